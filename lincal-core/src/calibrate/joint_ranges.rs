//! The joint ranges a calibration saw, and the poses that leave them.
//!
//! A calibration is least-squares over its poses: inside the box of joint readings they span
//! its prediction interpolates, beyond it extrapolates, and the weakest directions of the
//! fit (the ones the data barely see) grow with the distance. On FIGAROH's TIAGo
//! motion-capture data (docs/benchmarks/accuracy.md, session 42) the held-out error of the
//! postures with a joint beyond the training range is twice that of the others, for lincal
//! and FIGAROH alike. `calibrate` records each joint's range (JSON `joint_ranges`);
//! `predict`, `evaluate` and `compensate` say which of their poses leave it.
//!
//! Readings are compared as read, not modulo a turn: a joint with limits moves within them,
//! and a reading a turn away from the data is another cable wrap and another gear mesh.

use serde::{Deserialize, Serialize};

use crate::data::Poses;

/// How far a revolute reading may lie beyond the calibrated range before it counts as
/// outside (radians): 0.05 rad, about 3°, the margin of FIGAROH's held-out protocol.
pub const REVOLUTE_MARGIN: f64 = 0.05;
/// How far a prismatic reading may lie beyond the calibrated range before it counts as
/// outside (metres).
pub const PRISMATIC_MARGIN: f64 = 0.01;

/// The range of one joint's readings over the poses a calibration used (radians, or metres
/// for a prismatic joint).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct JointRange {
    /// The least reading.
    pub min: f64,
    /// The greatest reading.
    pub max: f64,
}

/// Each joint's range over `poses` (empty when there are none, or a reading is not finite:
/// then no pose is judged against it).
#[must_use]
pub fn joint_ranges(poses: &Poses) -> Vec<JointRange> {
    let width = poses.q.width();
    let mut ranges = vec![
        JointRange {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
        };
        width
    ];
    for q in poses.q.iter() {
        for (r, &v) in ranges.iter_mut().zip(q) {
            r.min = r.min.min(v);
            r.max = r.max.max(v);
        }
    }
    if poses.is_empty()
        || ranges
            .iter()
            .any(|r| !(r.min.is_finite() && r.max.is_finite()))
    {
        return Vec::new();
    }
    ranges
}

/// The pose that leaves the calibrated ranges farthest, in margins (see [`beyond_ranges`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FarthestPose {
    /// The pose (0-based, in the data as given).
    pub pose: usize,
    /// Its CSV line, when known.
    pub line: Option<usize>,
    /// Its data file, when the poses came from several.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// Whether the joint is prismatic (its reading in metres, else radians).
    pub prismatic: bool,
    /// The joint (1-based, `q1` first).
    pub joint: usize,
    /// Its reading.
    pub value: f64,
    /// The joint's calibrated range.
    pub range: JointRange,
}

/// The poses beyond the calibrated ranges (JSON `beyond_ranges` of `evaluate`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BeyondRanges {
    /// How many poses have a joint beyond its range by more than the margin
    /// ([`REVOLUTE_MARGIN`], [`PRISMATIC_MARGIN`]).
    pub poses: usize,
    /// Of how many.
    pub of: usize,
    /// The one farthest out, measured in margins.
    pub farthest: Option<FarthestPose>,
}

/// The poses of `poses` with a joint beyond `ranges` by more than its margin (`prismatic[i]`:
/// joint `i` is prismatic). `None` when `ranges` does not match the poses' joints (a result
/// without ranges, or of another spec) or is not a range (`min > max`, not finite: a
/// hand-written result), so that nothing is judged by it.
#[must_use]
pub fn beyond_ranges(
    ranges: &[JointRange],
    prismatic: &[bool],
    poses: &Poses,
) -> Option<BeyondRanges> {
    let valid = |r: &JointRange| r.min.is_finite() && r.max.is_finite() && r.min <= r.max;
    if ranges.is_empty()
        || ranges.len() != poses.q.width()
        || prismatic.len() != ranges.len()
        || !ranges.iter().all(valid)
    {
        return None;
    }
    let mut count = 0;
    let mut farthest: Option<(f64, FarthestPose)> = None;
    for (l, q) in poses.q.iter().enumerate() {
        let mut out = false;
        for (i, (&v, r)) in q.iter().zip(ranges).enumerate() {
            let margin = if prismatic[i] {
                PRISMATIC_MARGIN
            } else {
                REVOLUTE_MARGIN
            };
            // In margins beyond the range's nearer end (`> 1`: outside).
            let by = (r.min - v).max(v - r.max) / margin;
            if by > 1.0 {
                out = true;
                if farthest.as_ref().is_none_or(|(b, _)| by > *b) {
                    let pose = FarthestPose {
                        pose: l,
                        line: poses.line.get(l),
                        file: poses.files.name(l).map(str::to_string),
                        prismatic: prismatic[i],
                        joint: i + 1,
                        value: v,
                        range: *r,
                    };
                    farthest = Some((by, pose));
                }
            }
        }
        count += usize::from(out);
    }
    Some(BeyondRanges {
        poses: count,
        of: poses.len(),
        farthest: farthest.map(|(_, f)| f),
    })
}

/// A warning naming the poses beyond the calibrated ranges, or `None` when there are none.
#[must_use]
pub fn beyond_warning(beyond: &BeyondRanges) -> Option<String> {
    let f = beyond.farthest.as_ref()?;
    let mut at = format!("pose {}", f.pose);
    match (&f.file, f.line) {
        (Some(file), Some(line)) => at += &format!(" ({file}:{line})"),
        (None, Some(line)) => at += &format!(" (line {line})"),
        (Some(file), None) => at += &format!(" ({file})"),
        (None, None) => {}
    }
    let unit = if f.prismatic { "m" } else { "rad" };
    Some(format!(
        "{} of {} poses have a joint beyond the range the calibration's data span (by more \
         than {REVOLUTE_MARGIN} rad or {PRISMATIC_MARGIN} m), farthest {at}: q{} = {:.4} {unit} \
         against [{:.4}, {:.4}]; the calibration extrapolates there, and its error grows with \
         the distance",
        beyond.poses, beyond.of, f.joint, f.value, f.range.min, f.range.max
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Rows;

    fn poses(rows: &[&[f64]]) -> Poses {
        let mut q = Rows::new(rows[0].len());
        for r in rows {
            q.push(r);
        }
        Poses {
            q,
            ..Poses::default()
        }
    }

    #[test]
    fn the_ranges_are_each_joints_least_and_greatest_reading() {
        let p = poses(&[&[0.1, -1.0], &[0.3, 2.0], &[-0.2, 0.5]]);
        let r = joint_ranges(&p);
        assert_eq!(
            r,
            vec![
                JointRange {
                    min: -0.2,
                    max: 0.3
                },
                JointRange {
                    min: -1.0,
                    max: 2.0
                }
            ]
        );
    }

    #[test]
    fn a_pose_counts_as_outside_only_beyond_the_margin() {
        let ranges = [
            JointRange { min: 0.0, max: 1.0 },
            JointRange { min: 0.0, max: 0.2 },
        ];
        let prismatic = [false, true];
        // Within the margin on both joints; beyond on the revolute one; beyond on the
        // prismatic one, farther in margins (0.05 m is 5 of its margins).
        let p = poses(&[&[1.04, 0.205], &[1.2, 0.1], &[0.5, 0.25]]);
        let b = beyond_ranges(&ranges, &prismatic, &p).expect("matching ranges");
        assert_eq!((b.poses, b.of), (2, 3));
        let f = b.farthest.clone().expect("two poses outside");
        assert_eq!((f.pose, f.joint), (2, 2));
        assert!(beyond_warning(&b)
            .is_some_and(|w| w.contains("2 of 3 poses") && w.contains("q2 = 0.2500 m")));
        let inside = poses(&[&[0.5, 0.1]]);
        let none = beyond_ranges(&ranges, &prismatic, &inside).expect("matching ranges");
        assert_eq!(none.poses, 0);
        assert!(beyond_warning(&none).is_none());
        // Ranges of another spec (one joint) judge nothing, nor do ranges that are none.
        assert!(beyond_ranges(&ranges[..1], &prismatic[..1], &p).is_none());
        let inverted = [JointRange { min: 1.0, max: 0.0 }, ranges[1]];
        assert!(beyond_ranges(&inverted, &prismatic, &p).is_none());
        let infinite = [
            JointRange {
                min: f64::NEG_INFINITY,
                max: 1.0,
            },
            ranges[1],
        ];
        assert!(beyond_ranges(&infinite, &prismatic, &p).is_none());
    }
}
