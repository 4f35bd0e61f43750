//! [`Rows`]: rows of one width in one flat vector (the joint readings, the measured tips);
//! takes rows one at a time or a flat vector whole, gives them back by index or in order.

/// Rows of one width in one flat vector: a million poses are one allocation, not a million
/// (and about half the memory). A row may be empty (a measured tip left blank on a constraint
/// that is not measured); `rows[l]` is then `&[]`.
///
/// ```
/// use lincal_core::data::Rows;
/// let mut r = Rows::new(2);
/// r.push(&[1.0, 2.0]);
/// r.push(&[]);
/// assert_eq!((r.len(), &r[0], r.get(1)), (2, &[1.0, 2.0][..], Some(&[][..])));
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rows {
    width: usize,
    /// Row after row, `width` values each (an empty row stored as zeros).
    data: Vec<f64>,
    /// Which rows are empty; shorter than `len()` (even empty) while the rest are not.
    empty: Vec<bool>,
}

impl Rows {
    /// No rows yet, each to hold `width` values.
    #[must_use]
    pub fn new(width: usize) -> Self {
        Rows {
            width,
            ..Rows::default()
        }
    }

    /// Rows taken over from one flat vector, `width` values each, row after row, with no
    /// copy (how a caller that already holds the readings contiguously, such as a numpy
    /// array, hands them over). `None` when `data.len()` is not a multiple of `width`, or
    /// `width` is 0 and `data` is not empty.
    ///
    /// ```
    /// use lincal_core::data::Rows;
    /// let r = Rows::from_vec(2, vec![1.0, 2.0, 3.0, 4.0]).unwrap();
    /// assert_eq!((r.len(), &r[1]), (2, &[3.0, 4.0][..]));
    /// assert!(Rows::from_vec(2, vec![1.0]).is_none());
    /// ```
    #[must_use]
    pub fn from_vec(width: usize, data: Vec<f64>) -> Option<Self> {
        let fits = if width == 0 {
            data.is_empty()
        } else {
            data.len().is_multiple_of(width)
        };
        fits.then(|| Rows {
            width,
            data,
            empty: Vec::new(),
        })
    }

    /// The values per row.
    #[must_use]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows.
    #[must_use]
    pub fn len(&self) -> usize {
        self.data
            .len()
            .checked_div(self.width)
            .unwrap_or(self.empty.len())
    }

    /// Whether there are no rows.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Appends a row of `width` values, or an empty row (`&[]`). The first row of a
    /// collection made with width 0 (`Rows::default()`) sets the width.
    ///
    /// # Panics
    /// If `row` has another length (a programming error: readers check their input).
    pub fn push(&mut self, row: &[f64]) {
        let l = self.len();
        if l == 0 && self.width == 0 {
            // A default (width 0) collection takes the width of its first row.
            self.width = row.len();
        }
        if row.is_empty() && self.width > 0 {
            self.empty.resize(l, false);
            self.empty.push(true);
            self.data.resize(self.data.len() + self.width, 0.0);
            return;
        }
        assert_eq!(row.len(), self.width, "a row of {} values", self.width);
        if self.width == 0 {
            self.empty.push(false);
        } else if !self.empty.is_empty() {
            self.empty.resize(l, false);
            self.empty.push(false);
        }
        self.data.extend_from_slice(row);
    }

    /// Row `l`, if there is one.
    #[must_use]
    pub fn get(&self, l: usize) -> Option<&[f64]> {
        if l >= self.len() {
            return None;
        }
        if self.empty.get(l).copied().unwrap_or(false) {
            return Some(&[]);
        }
        Some(&self.data[l * self.width..(l + 1) * self.width])
    }

    /// Room for `additional` more rows, if the allocator grants it (a hint: nothing fails).
    pub fn reserve(&mut self, additional: usize) {
        let _ = self.data.try_reserve(additional.saturating_mul(self.width));
    }

    /// The first row.
    #[must_use]
    pub fn first(&self) -> Option<&[f64]> {
        self.get(0)
    }

    /// The rows in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = &[f64]> + '_ {
        (0..self.len()).map(move |l| &self[l])
    }

    /// The rows in order, mutable (an empty row as `&mut []`).
    pub fn iter_mut(&mut self) -> impl Iterator<Item = &mut [f64]> + '_ {
        let empty = &self.empty;
        self.data
            .chunks_exact_mut(self.width.max(1))
            .enumerate()
            .map(move |(l, row)| {
                if empty.get(l).copied().unwrap_or(false) {
                    &mut row[..0]
                } else {
                    row
                }
            })
    }
}

impl std::ops::IndexMut<usize> for Rows {
    fn index_mut(&mut self, l: usize) -> &mut [f64] {
        let n = self.len();
        assert!(l < n, "row {l} of {n}");
        if self.empty.get(l).copied().unwrap_or(false) {
            return &mut [];
        }
        &mut self.data[l * self.width..(l + 1) * self.width]
    }
}

impl std::ops::Index<usize> for Rows {
    type Output = [f64];
    fn index(&self, l: usize) -> &[f64] {
        match self.get(l) {
            Some(r) => r,
            None => panic!("row {l} of {}", self.len()),
        }
    }
}

impl<'a> IntoIterator for &'a Rows {
    type Item = &'a [f64];
    type IntoIter = Box<dyn Iterator<Item = &'a [f64]> + 'a>;
    fn into_iter(self) -> Self::IntoIter {
        Box::new(self.iter())
    }
}

impl From<Vec<Vec<f64>>> for Rows {
    /// Rows from nested vectors; the width is the first non-empty row's.
    ///
    /// # Panics
    /// If two non-empty rows differ in length.
    fn from(rows: Vec<Vec<f64>>) -> Self {
        let width = rows.iter().map(Vec::len).find(|&n| n > 0).unwrap_or(0);
        let mut r = Rows::new(width);
        for row in &rows {
            r.push(row);
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_default_collection_takes_the_first_rows_width() {
        let mut r = Rows::default();
        r.push(&[1.0, 2.0]);
        r.push(&[3.0, 4.0]);
        assert_eq!((r.width(), r.len()), (2, 2));
    }
}
