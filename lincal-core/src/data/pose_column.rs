//! [`PoseColumn`]: one non-negative integer per pose (a constraint index, a line number),
//! stored as runs; takes values one pose at a time, gives them back by pose or in order.

/// One non-negative integer per pose (the constraint it lies on, or its line in its file),
/// stored as runs: within a run the value at pose `l` is `first + step·(l − start)`, with
/// `step` 0 for labels and 1 for line numbers. Data as files have them (one constraint, or
/// files one after the other; consecutive lines) take one run for any number of poses, so a
/// million poses do not carry 16 MB of bookkeeping beside their readings. The worst case (a
/// new run at every pose) costs 16 bytes a pose. Runs are kept maximal, so equal columns of
/// the same kind compare equal (a labels column never equals a counting one).
///
/// ```
/// use lincal_core::data::PoseColumn;
/// let mut lines = PoseColumn::counting();
/// for l in [2, 3, 4, 7, 8] {
///     lines.push(l);
/// }
/// assert_eq!((lines.len(), lines.runs(), lines.get(3)), (5, 2, Some(7)));
/// assert_eq!(lines.to_vec(), vec![2, 3, 4, 7, 8]);
/// let labels = PoseColumn::labels_from([0, 0, 1]);
/// assert_eq!((labels.get(2), labels.get(3)), (Some(1), None));
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PoseColumn {
    /// 0 (labels) or 1 (counting).
    step: usize,
    /// `(start, first)` of every run, by ascending `start`; the first run starts at 0.
    runs: Vec<(usize, usize)>,
    len: usize,
}

impl Default for PoseColumn {
    /// An empty column of labels.
    fn default() -> Self {
        Self::labels()
    }
}

impl PoseColumn {
    /// An empty column of labels (runs of equal values): constraint indices.
    #[must_use]
    pub fn labels() -> Self {
        PoseColumn {
            step: 0,
            runs: Vec::new(),
            len: 0,
        }
    }

    /// An empty column of counts (runs of consecutive values): line numbers.
    #[must_use]
    pub fn counting() -> Self {
        PoseColumn {
            step: 1,
            ..Self::labels()
        }
    }

    /// A column of labels holding `values`.
    #[must_use]
    pub fn labels_from(values: impl IntoIterator<Item = usize>) -> Self {
        let mut c = Self::labels();
        c.extend(values);
        c
    }

    /// A counting column holding `values`.
    #[must_use]
    pub fn counting_from(values: impl IntoIterator<Item = usize>) -> Self {
        let mut c = Self::counting();
        c.extend(values);
        c
    }

    /// Appends the next pose's value.
    pub fn push(&mut self, value: usize) {
        let follows = self.runs.last().is_some_and(|&(start, first)| {
            first.checked_add(self.step * (self.len - start)) == Some(value)
        });
        if !follows {
            self.runs.push((self.len, value));
        }
        self.len += 1;
    }

    /// Appends every value of `values`.
    pub fn extend(&mut self, values: impl IntoIterator<Item = usize>) {
        for v in values {
            self.push(v);
        }
    }

    /// The value at pose `l`, `None` past the end.
    #[must_use]
    pub fn get(&self, l: usize) -> Option<usize> {
        if l >= self.len {
            return None;
        }
        let (start, first) = match self.runs.as_slice() {
            [one] => *one,
            runs => runs[runs.partition_point(|&(s, _)| s <= l) - 1],
        };
        Some(first + self.step * (l - start))
    }

    /// The value at pose `l`, 0 past the end (for loops over `0..len()`).
    #[must_use]
    pub fn at(&self, l: usize) -> usize {
        self.get(l).unwrap_or(0)
    }

    /// Number of poses.
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Number of runs (what the column's memory grows with).
    #[must_use]
    pub fn runs(&self) -> usize {
        self.runs.len()
    }

    /// Every value, in pose order.
    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        self.runs
            .iter()
            .enumerate()
            .flat_map(move |(i, &(start, first))| {
                let end = self.runs.get(i + 1).map_or(self.len, |r| r.0);
                (0..end - start).map(move |k| first + self.step * k)
            })
    }

    /// Every value, in pose order, as a vector.
    #[must_use]
    pub fn to_vec(&self) -> Vec<usize> {
        self.iter().collect()
    }
}
