//! Optimal assignment for identity decisions: rectangular linear-sum assignment with gating and rejection, and Belmonte-Hernández's conflict rules.
//!
//! Rows are the things to name (anonymous camera skeletons), columns the names (wearables).
//! [`solve`] takes a [`CostMatrix`] whose entries may be forbidden (`None`, NaN, `inf`: pairs
//! gated out upstream) and an [`AssignConfig`], and returns an [`Assignment`] with one
//! [`RowDecision`] per row:
//!
//! - the optimum is SciPy's `linear_sum_assignment` (through the `lsap` crate, a translation
//!   of SciPy's solver), minimising costs or maximising scores, on rectangular matrices;
//! - forbidden pairs are never assigned; a row that could only get one stays
//!   [`RowDecision::Gated`];
//! - a rejection threshold turns weak entries into forbidden ones, so a skeleton whose best
//!   evidence is too weak stays anonymous;
//! - the optional conflict rule, after Belmonte-Hernández et al.'s modified Hungarian
//!   assignment, defers a pair when two rows compete for one column, or one row's two best
//!   columns are, within a margin ([`AssignConfig::conflict_margin`]).
//!
//! The crate is sans-IO: no files, clocks, threads or printing.
//!
//! ```
//! use nomen_assign::{solve, AssignConfig, CostMatrix, Objective, RowDecision};
//!
//! // Two skeletons x three bands, correlation scores; skeleton 1 cannot wear band 2.
//! let scores = CostMatrix::from_gated_rows(&[
//!     [Some(0.9), Some(0.2), Some(0.1)],
//!     [Some(0.3), Some(0.15), None],
//! ])?;
//! let config = AssignConfig {
//!     objective: Objective::Maximize,
//!     rejection_threshold: Some(0.25),
//!     ..AssignConfig::default()
//! };
//! let a = solve(&scores, &config)?;
//! assert_eq!(a.rows[0], RowDecision::Assigned { col: 0, cost: 0.9 });
//! assert_eq!(a.rows[1], RowDecision::Gated); // its only good band is taken
//! # Ok::<(), nomen_assign::AssignError>(())
//! ```
#![warn(missing_docs)]

mod error;
mod matrix;
mod solve;

pub use error::{AssignError, Result};
pub use matrix::CostMatrix;
pub use solve::{AssignConfig, Assignment, NanPolicy, Objective, Pair, RowDecision, solve};
