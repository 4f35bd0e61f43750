//! Calibration data: poses read from CSV (see `shared/interface.md`, "Data (CSV)").
//! (Loader being written.)

/// The poses of one data set.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Poses {
    /// Joint readings, one `Vec` of `n` values per pose.
    pub q: Vec<Vec<f64>>,
    /// Measured tips (`x, y(, z)`), one per pose, for `measured` constraints.
    pub measured: Option<Vec<Vec<f64>>>,
    /// The constraint each pose lies on (index into the spec's list; all 0 for one constraint).
    pub constraint: Vec<usize>,
    /// 1-based line of each pose in its file, for messages.
    pub line: Vec<usize>,
}

impl Poses {
    /// Number of poses.
    #[must_use]
    pub fn len(&self) -> usize {
        self.q.len()
    }

    /// Whether there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }
}
