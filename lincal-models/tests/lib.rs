//! lincal-models tests: every derived model against the run-time engine and the direct forward
//! kinematics, and insta snapshots of every spec's symbolic result.

mod equivalence;
mod snapshots;
