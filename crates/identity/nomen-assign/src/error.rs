//! The crate's error type.

/// What can go wrong when building a cost matrix or solving an assignment.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AssignError {
    /// The flat cost buffer does not hold `num_rows * num_cols` entries.
    #[error("cost matrix of {num_rows}x{num_cols} needs {expected} entries, got {len}")]
    ShapeMismatch {
        /// Rows claimed.
        num_rows: usize,
        /// Columns claimed.
        num_cols: usize,
        /// `num_rows * num_cols` (saturating).
        expected: usize,
        /// Entries given.
        len: usize,
    },
    /// A row of a row-by-row matrix is not as long as the first row.
    #[error("cost matrix row {row} has {len} entries, row 0 has {expected}")]
    RaggedRows {
        /// Index of the offending row.
        row: usize,
        /// Its length.
        len: usize,
        /// The first row's length.
        expected: usize,
    },
    /// A NaN cost while [`crate::NanPolicy::Error`] is in force.
    #[error("cost at row {row}, column {col} is NaN")]
    NanCost {
        /// Row of the NaN.
        row: usize,
        /// Column of the NaN.
        col: usize,
    },
    /// A configuration value is out of range (NaN threshold, negative or NaN margin).
    #[error("invalid assignment config: {0}")]
    InvalidConfig(&'static str),
    /// The finite costs span so wide a range that no finite gate cost exceeds them
    /// (|cost| near `f64::MAX / min(num_rows, num_cols)`).
    #[error("finite costs span [{lo}, {hi}]: too wide to gate forbidden pairs with a finite cost")]
    CostRange {
        /// Lowest allowed cost (in minimisation sense).
        lo: f64,
        /// Highest allowed cost (in minimisation sense).
        hi: f64,
    },
    /// The underlying solver refused the (finite) problem; not expected to happen.
    #[error("linear-sum assignment solver failed: {0}")]
    Solver(String),
}

/// `Result` with [`AssignError`].
pub type Result<T> = std::result::Result<T, AssignError>;
