//! lincal-models tests: every derived model against the run-time engine and the direct forward
//! kinematics, insta snapshots of every spec's symbolic result, and a simulate → calibrate
//! round trip per robot.

mod equivalence;
mod recovery;
mod snapshots;
