//! Measured poses that repeat an earlier one exactly: a copy, not a measurement.
//!
//! A laser tracker never reads the same point twice to the last digit, so a measured pose
//! whose joints, measured values and constraint all equal an earlier pose's bit for bit is a
//! row copied (a file concatenated with itself, a log written twice). Each copy counts as new
//! information: the standard deviations shrink as if it were (by `√2` when every row is
//! doubled), and nothing else in the fit shows it. Poses without measured values are not
//! judged: an arm driven to one commanded posture can read the same encoder counts twice.

use std::collections::hash_map::{DefaultHasher, Entry};
use std::collections::HashMap;
use std::hash::{Hash, Hasher};

use super::checks::and_more;
use crate::data::Poses;

/// The poses searched for copies at most (the first ones): a table of this many hashes is
/// 2-3 MB, and a million measured poses must fit in 100 MB whole.
pub(super) const COPIES_SEARCHED: usize = 100_000;

/// How many copies a warning names.
const COPIES_SHOWN: usize = 3;

/// The warning naming measured poses (of the first [`COPIES_SEARCHED`]) that repeat an
/// earlier pose exactly, with their pose numbers `id(l)` and places; `None` without copies or
/// without measured values.
pub(super) fn copies_warning(poses: &Poses, id: &dyn Fn(usize) -> usize) -> Option<String> {
    let measured = poses.measured.as_ref()?;
    let n = poses.len().min(COPIES_SEARCHED);
    let row = |l: usize| (poses.q.get(l), measured.get(l), poses.constraint.at(l));
    let hash = |l: usize| {
        let mut h = DefaultHasher::new();
        let (q, m, c) = row(l);
        for v in q.into_iter().flatten().chain(m.into_iter().flatten()) {
            v.to_bits().hash(&mut h);
        }
        c.hash(&mut h);
        h.finish()
    };
    // A hash per pose (not the rows): a hit is then compared exactly.
    let same = |a: usize, b: usize| {
        let ((qa, ma, ca), (qb, mb, cb)) = (row(a), row(b));
        let bits = |r: Option<&[f64]>| r.map(|r| r.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
        ca == cb && bits(qa) == bits(qb) && bits(ma) == bits(mb)
    };
    let mut first: HashMap<u64, usize> = HashMap::with_capacity(n);
    let mut copies = Vec::new();
    for l in 0..n {
        match first.entry(hash(l)) {
            Entry::Occupied(e) if same(*e.get(), l) => copies.push((l, *e.get())),
            Entry::Occupied(_) => {}
            Entry::Vacant(e) => {
                e.insert(l);
            }
        }
    }
    if copies.is_empty() {
        return None;
    }
    let shown: Vec<String> = copies
        .iter()
        .take(COPIES_SHOWN)
        .map(|&(l, e)| {
            format!(
                "pose {} ({}) repeats pose {} ({})",
                id(l),
                poses.place(l),
                id(e),
                poses.place(e)
            )
        })
        .collect();
    let searched = if poses.len() > n {
        format!(" (of the first {n})")
    } else {
        String::new()
    };
    Some(format!(
        "{} measured pose(s){searched} repeat an earlier one exactly, joints and measured \
         values to the last digit: a copied row (a file given twice, a log written twice), not \
         a new measurement, yet each counts as one and the standard deviations shrink as if \
         it were; remove the copies: {}",
        copies.len(),
        and_more(&shown, copies.len())
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Rows;

    fn poses(q: &[[f64; 2]], m: Option<&[[f64; 2]]>) -> Poses {
        let rows = |r: &[[f64; 2]]| Rows::from_vec(2, r.iter().flatten().copied().collect());
        Poses {
            q: rows(q).unwrap(),
            measured: m.map(|m| rows(m).unwrap()),
            constraint: crate::data::PoseColumn::labels_from(vec![0; q.len()]),
            line: crate::data::PoseColumn::counting_from((0..q.len()).map(|l| l + 2)),
            ..Poses::default()
        }
    }

    #[test]
    fn names_measured_copies_and_nothing_else() {
        let q = [[0.1, 0.2], [0.3, 0.4], [0.1, 0.2], [0.3, 0.4]];
        let id = |l: usize| l;
        // Every measured row twice: two copies, each naming its original.
        let m = [[1.0, 2.0], [3.0, 4.0], [1.0, 2.0], [3.0, 4.0]];
        let w = copies_warning(&poses(&q, Some(&m)), &id).unwrap();
        assert!(w.starts_with("2 measured pose(s) repeat"), "{w}");
        assert!(w.contains("pose 2 (line 4) repeats pose 0 (line 2)"), "{w}");
        // The same joints measured anew (another reading): no copy.
        let m2 = [[1.0, 2.0], [3.0, 4.0], [1.0, 2.000_001], [3.0, 4.0]];
        let w = copies_warning(&poses(&q, Some(&m2)), &id).unwrap();
        assert!(w.starts_with("1 measured pose(s)"), "{w}");
        // Without measured values, repeated joints are no copy.
        assert!(copies_warning(&poses(&q, None), &id).is_none());
    }
}
