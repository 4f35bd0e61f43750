//! Validation of a plane written by normal and offset (`plane: {normal: [..], offset: d}`).

use super::{Param, Slot};

/// Why the normal `n` of `n·x = d` is zero at its nominal, if it is: a known zero normal
/// describes no plane (`0·x = d`), and an unknown one needs a nonzero nominal because its
/// scale is a gauge direction fixed by holding its largest nominal entry (see
/// `symbolic::priority`); a held zero would make every plane with a nonzero entry there
/// unreachable. `None` when some entry is nonzero, or names a parameter missing from `params`
/// (reported on its own). Validation reports it at `….plane.normal`.
pub(crate) fn zero_normal(n: &[Slot], params: &[Param]) -> Option<&'static str> {
    let nominal = |s: &Slot| match s {
        Slot::Const(e) => Some((e.to_f64(), true)),
        Slot::Param(name) => params
            .iter()
            .find(|p| &p.name == name)
            .map(|p| (p.nominal.to_f64(), p.known)),
    };
    let entries: Vec<Option<(f64, bool)>> = n.iter().map(nominal).collect();
    if entries.iter().any(Option::is_none) || entries.iter().flatten().any(|e| e.0 != 0.0) {
        return None;
    }
    Some(if entries.iter().flatten().all(|e| e.1) {
        "the normal is known and zero: `0·x = d` describes no plane (any nonzero normal is \
         accepted; its length need not be 1)"
    } else {
        "the normal's nominal is zero: give the unknown normal a nonzero nominal (say \
         [0, 0, 1]); its scale is a gauge direction, fixed by holding its largest nominal \
         entry, so a zero nominal would leave no plane reachable"
    })
}
