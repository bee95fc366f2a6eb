//! The dense, row-major cost matrix with forbidden entries.

use crate::error::{AssignError, Result};

/// A dense `num_rows x num_cols` matrix of costs (or scores), row-major.
///
/// Rows are what gets a label (for nomen: anonymous camera skeletons), columns are the labels
/// (wearables). An entry that is `None`, NaN or infinite is a *forbidden* pair (gated out by an
/// upstream test); [`crate::solve`] never assigns it. `None` is stored as `+inf`; NaN is kept
/// as NaN so that [`crate::NanPolicy::Error`] can report it.
#[derive(Debug, Clone, PartialEq)]
pub struct CostMatrix {
    num_rows: usize,
    num_cols: usize,
    costs: Vec<f64>,
}

impl CostMatrix {
    /// Wraps a row-major buffer; entry `(i, j)` is `costs[i * num_cols + j]`.
    ///
    /// # Errors
    /// [`AssignError::ShapeMismatch`] if `costs.len() != num_rows * num_cols`.
    pub fn new(num_rows: usize, num_cols: usize, costs: Vec<f64>) -> Result<Self> {
        let expected = num_rows.checked_mul(num_cols);
        if expected != Some(costs.len()) {
            return Err(AssignError::ShapeMismatch {
                num_rows,
                num_cols,
                expected: num_rows.saturating_mul(num_cols),
                len: costs.len(),
            });
        }
        Ok(Self {
            num_rows,
            num_cols,
            costs,
        })
    }

    /// Builds a matrix from rows of costs (non-finite entries are forbidden).
    ///
    /// No rows gives a `0 x 0` matrix.
    ///
    /// # Errors
    /// [`AssignError::RaggedRows`] if the rows differ in length.
    pub fn from_rows<R: AsRef<[f64]>>(rows: &[R]) -> Result<Self> {
        let num_cols = rows.first().map_or(0, |r| r.as_ref().len());
        let mut costs = Vec::with_capacity(rows.len() * num_cols);
        for (row, r) in rows.iter().enumerate() {
            let r = r.as_ref();
            check_row_len(row, r.len(), num_cols)?;
            costs.extend_from_slice(r);
        }
        Self::new(rows.len(), num_cols, costs)
    }

    /// Builds a matrix from rows of optional costs; `None` is a forbidden pair.
    ///
    /// # Errors
    /// [`AssignError::RaggedRows`] if the rows differ in length.
    pub fn from_gated_rows<R: AsRef<[Option<f64>]>>(rows: &[R]) -> Result<Self> {
        let num_cols = rows.first().map_or(0, |r| r.as_ref().len());
        let mut costs = Vec::with_capacity(rows.len() * num_cols);
        for (row, r) in rows.iter().enumerate() {
            let r = r.as_ref();
            check_row_len(row, r.len(), num_cols)?;
            costs.extend(r.iter().map(|c| c.unwrap_or(f64::INFINITY)));
        }
        Self::new(rows.len(), num_cols, costs)
    }

    /// Number of rows.
    pub fn num_rows(&self) -> usize {
        self.num_rows
    }

    /// Number of columns.
    pub fn num_cols(&self) -> usize {
        self.num_cols
    }

    /// `true` if the matrix has no entries (zero rows or zero columns).
    pub fn is_empty(&self) -> bool {
        self.costs.is_empty()
    }

    /// The cost of pair `(row, col)`, `None` if it is forbidden (non-finite) or out of range.
    pub fn get(&self, row: usize, col: usize) -> Option<f64> {
        if row >= self.num_rows || col >= self.num_cols {
            return None;
        }
        self.costs
            .get(row * self.num_cols + col)
            .copied()
            .filter(|c| c.is_finite())
    }

    /// Forbids pair `(row, col)` (sets it to `+inf`); out-of-range indices are ignored.
    pub fn forbid(&mut self, row: usize, col: usize) {
        if row < self.num_rows
            && col < self.num_cols
            && let Some(c) = self.costs.get_mut(row * self.num_cols + col)
        {
            *c = f64::INFINITY;
        }
    }

    /// The raw row-major entries (forbidden ones are non-finite).
    pub fn as_slice(&self) -> &[f64] {
        &self.costs
    }
}

fn check_row_len(row: usize, len: usize, expected: usize) -> Result<()> {
    if len == expected {
        Ok(())
    } else {
        Err(AssignError::RaggedRows { row, len, expected })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ragged_rows_are_an_error_naming_the_row() {
        let rows = vec![vec![1.0, 2.0], vec![3.0, 4.0], vec![5.0]];
        assert_eq!(
            CostMatrix::from_rows(&rows),
            Err(AssignError::RaggedRows {
                row: 2,
                len: 1,
                expected: 2
            })
        );
    }

    #[test]
    fn flat_buffer_must_match_shape() {
        assert!(matches!(
            CostMatrix::new(2, 3, vec![0.0; 5]),
            Err(AssignError::ShapeMismatch { expected: 6, .. })
        ));
        assert!(matches!(
            CostMatrix::new(usize::MAX, 2, vec![]),
            Err(AssignError::ShapeMismatch { .. })
        ));
    }

    #[test]
    fn none_and_non_finite_read_back_as_forbidden() {
        let mut m =
            CostMatrix::from_gated_rows(&[[Some(1.0), None], [Some(f64::NAN), Some(2.0)]]).unwrap();
        assert_eq!(m.get(0, 0), Some(1.0));
        assert_eq!(m.get(0, 1), None);
        assert_eq!(m.get(1, 0), None);
        assert_eq!(m.get(5, 0), None);
        m.forbid(1, 1);
        assert_eq!(m.get(1, 1), None);
        let empty: [[f64; 0]; 0] = [];
        assert!(CostMatrix::from_rows(&empty).unwrap().is_empty());
    }
}
