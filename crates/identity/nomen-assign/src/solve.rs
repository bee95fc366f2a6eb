//! Gated rectangular linear-sum assignment with rejection and conflict deferral.

use serde::{Deserialize, Serialize};

use crate::error::{AssignError, Result};
use crate::matrix::CostMatrix;

/// Whether the matrix holds costs to minimise or scores to maximise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Objective {
    /// Entries are costs (distances, negative log-likelihoods): lower is better.
    #[default]
    Minimize,
    /// Entries are scores (correlations, likelihoods): higher is better.
    Maximize,
}

/// What a NaN entry means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NanPolicy {
    /// NaN is missing evidence: the pair is forbidden, like `None` or `inf`.
    #[default]
    Forbidden,
    /// NaN is a bug upstream: [`solve`] returns [`AssignError::NanCost`].
    Error,
}

/// How [`solve`] decides. Plain data; loadable from TOML (all fields optional).
///
/// Thresholds and margins are in the matrix's own units (cost or score).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AssignConfig {
    /// Minimise costs or maximise scores.
    pub objective: Objective,
    /// Meaning of NaN entries.
    pub nan_policy: NanPolicy,
    /// Rejection threshold: a pair whose cost is above it (minimising), or whose score is below
    /// it (maximising), is treated as forbidden *before* solving, so a row whose every
    /// acceptable column is too weak stays unassigned (for nomen: the skeleton stays
    /// anonymous) and its column stays free for others. A value equal to the threshold is
    /// accepted. `None`: no threshold. No default value: it depends on the evidence model.
    pub rejection_threshold: Option<f64>,
    /// Belmonte-Hernández-style conflict deferral: the minimum margin (≥ 0) by which an
    /// assigned pair must beat every other acceptable entry in its row *and* in its column;
    /// otherwise the pair is deferred (not assigned), see [`RowDecision::Deferred`].
    /// `None`: no deferral.
    pub conflict_margin: Option<f64>,
}

impl AssignConfig {
    fn validate(&self) -> Result<()> {
        if self.rejection_threshold.is_some_and(f64::is_nan) {
            return Err(AssignError::InvalidConfig("rejection_threshold is NaN"));
        }
        if let Some(m) = self.conflict_margin
            && (m.is_nan() || m < 0.0)
        {
            return Err(AssignError::InvalidConfig(
                "conflict_margin must be a number >= 0",
            ));
        }
        Ok(())
    }
}

/// One assigned `(row, column)` pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pair {
    /// Row index.
    pub row: usize,
    /// Column index.
    pub col: usize,
    /// The matrix entry (cost or score, as given).
    pub cost: f64,
}

/// What [`solve`] decided for one row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RowDecision {
    /// The row got this column.
    Assigned {
        /// Column index.
        col: usize,
        /// The matrix entry (cost or score, as given).
        cost: f64,
    },
    /// More rows than columns and the optimum left this row out.
    Unmatched,
    /// Every column this row could have taken (once the others were assigned) was forbidden
    /// or beyond the rejection threshold.
    Gated,
    /// The optimal column was found, but the pair is within `conflict_margin` of a competitor:
    /// another acceptable column of this row (`row_margin`) or another acceptable row for this
    /// column (`col_margin`). Margins are "competitor minus this pair" for costs and "this
    /// pair minus competitor" for scores, `+inf` without competitor; at least one is below the
    /// configured margin. A negative margin means the row or column prefers another partner
    /// that the global optimum gave away.
    Deferred {
        /// The column the optimum proposed.
        col: usize,
        /// Advantage over the best other acceptable column in the row.
        row_margin: f64,
        /// Advantage over the best other acceptable row in the column.
        col_margin: f64,
    },
}

/// The result of [`solve`]: kept pairs plus a decision for every row.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Assignment {
    /// Kept pairs, in increasing row order.
    pub pairs: Vec<Pair>,
    /// One decision per row of the matrix.
    pub rows: Vec<RowDecision>,
    /// For each column, the row it was assigned to.
    pub col_to_row: Vec<Option<usize>>,
}

impl Assignment {
    /// Sum of the kept pairs' entries, in row order.
    pub fn total_cost(&self) -> f64 {
        self.pairs.iter().map(|p| p.cost).sum()
    }

    /// Number of kept pairs.
    pub fn num_assigned(&self) -> usize {
        self.pairs.len()
    }

    /// The column assigned to `row`, if any.
    pub fn col_for_row(&self, row: usize) -> Option<usize> {
        match self.rows.get(row) {
            Some(RowDecision::Assigned { col, .. }) => Some(*col),
            _ => None,
        }
    }

    /// The row assigned to `col`, if any.
    pub fn row_for_col(&self, col: usize) -> Option<usize> {
        self.col_to_row.get(col).copied().flatten()
    }
}

/// Optimal rectangular linear-sum assignment with forbidden pairs, rejection and optional
/// conflict deferral.
///
/// Semantics, in order:
/// 1. An entry is *acceptable* if it is finite (NaN per [`AssignConfig::nan_policy`]) and not
///    beyond [`AssignConfig::rejection_threshold`].
/// 2. Among assignments that use only acceptable pairs, the solver finds one with the most
///    pairs and, among those, the lowest total cost (highest total score). This is done as
///    py-motmetrics does with SciPy: unacceptable entries get a finite gate cost larger than
///    any difference acceptable entries can make, SciPy's shortest-augmenting-path algorithm
///    (the `lsap` crate) solves the dense problem, and pairs landing on a gate are dropped
///    (their rows become [`RowDecision::Gated`]). A forbidden pair is never assigned.
/// 3. If [`AssignConfig::conflict_margin`] is set, each kept pair is checked against its row
///    and column competitors and deferred if it does not win by the margin. Deferred pairs are
///    not re-solved: their rows and columns stay free for this decision.
///
/// Ties: when no entry is unacceptable the matrix goes to the solver unchanged, so the result
/// is exactly SciPy's `linear_sum_assignment` on the same matrix, including which of several
/// optimal assignments is returned; the solve is deterministic in every case.
///
/// An empty matrix (no rows or no columns) gives an empty assignment.
///
/// # Errors
/// [`AssignError::InvalidConfig`], [`AssignError::NanCost`] (with [`NanPolicy::Error`]),
/// [`AssignError::CostRange`] if acceptable costs are within a factor `min(rows, cols)` of
/// `f64::MAX` and forbidden entries must be gated.
pub fn solve(cost: &CostMatrix, config: &AssignConfig) -> Result<Assignment> {
    config.validate()?;
    let (num_rows, num_cols) = (cost.num_rows(), cost.num_cols());
    let costs = cost.as_slice();
    if config.nan_policy == NanPolicy::Error
        && let Some(k) = costs.iter().position(|c| c.is_nan())
    {
        return Err(AssignError::NanCost {
            row: k / num_cols.max(1),
            col: k % num_cols.max(1),
        });
    }
    let mut out = Assignment {
        pairs: Vec::new(),
        rows: vec![RowDecision::Unmatched; num_rows],
        col_to_row: vec![None; num_cols],
    };
    if num_rows == 0 || num_cols == 0 {
        return Ok(out);
    }

    // Work in minimisation space: c' = c (minimise) or -c (maximise); SciPy's own `maximize`
    // negates the same way, so ties break identically.
    let sign = match config.objective {
        Objective::Minimize => 1.0,
        Objective::Maximize => -1.0,
    };
    let threshold = config.rejection_threshold.map(|t| sign * t);
    let acceptable = |c: f64| -> Option<f64> {
        let c = sign * c;
        (c.is_finite() && threshold.is_none_or(|t| c <= t)).then_some(c)
    };
    let work: Vec<Option<f64>> = costs.iter().map(|&c| acceptable(c)).collect();

    let mut range: Option<(f64, f64)> = None;
    for c in work.iter().flatten() {
        range = Some(range.map_or((*c, *c), |(lo, hi)| (lo.min(*c), hi.max(*c))));
    }
    let Some((lo, hi)) = range else {
        // Nothing acceptable: every row is gated.
        out.rows.fill(RowDecision::Gated);
        return Ok(out);
    };
    let has_gated = work.iter().any(Option::is_none);
    let dense: Vec<f64> = if has_gated {
        let gate = gate_cost(lo, hi, num_rows.min(num_cols))?;
        work.iter().map(|c| c.unwrap_or(gate)).collect()
    } else {
        work.iter().flatten().copied().collect()
    };

    let (sol_rows, sol_cols) = lsap::solve(num_rows, num_cols, &dense, false)
        .map_err(|e| AssignError::Solver(format!("{e:?}")))?;

    for (&i, &j) in sol_rows.iter().zip(&sol_cols) {
        let Some(Some(c)) = work.get(i * num_cols + j).copied() else {
            if let Some(d) = out.rows.get_mut(i) {
                *d = RowDecision::Gated;
            }
            continue;
        };
        let decision = match config.conflict_margin {
            Some(m) => {
                let (row_margin, col_margin) = margins(&work, num_rows, num_cols, i, j, c);
                if row_margin < m || col_margin < m {
                    RowDecision::Deferred {
                        col: j,
                        row_margin,
                        col_margin,
                    }
                } else {
                    RowDecision::Assigned { col: j, cost: 0.0 }
                }
            }
            None => RowDecision::Assigned { col: j, cost: 0.0 },
        };
        if let RowDecision::Assigned { .. } = decision {
            let original = sign * c;
            out.pairs.push(Pair {
                row: i,
                col: j,
                cost: original,
            });
            if let Some(slot) = out.col_to_row.get_mut(j) {
                *slot = Some(i);
            }
            if let Some(d) = out.rows.get_mut(i) {
                *d = RowDecision::Assigned {
                    col: j,
                    cost: original,
                };
            }
        } else if let Some(d) = out.rows.get_mut(i) {
            *d = decision;
        }
    }
    out.pairs.sort_by_key(|p| p.row);
    Ok(out)
}

/// A finite cost `G` for unacceptable pairs such that trading one gated pair for any number of
/// acceptable ones always lowers the total.
///
/// Any complete assignment has `r = min(rows, cols)` pairs. With acceptable costs in
/// `[lo, hi]`, one with `k` gated pairs costs at most `k G + (r - k) hi` and one with `k + 1`
/// at least `(k + 1) G + (r - k - 1) lo`; the first is strictly cheaper when
/// `G > hi + (r - 1)(hi - lo)`. We add `(r + 1)(hi - lo + s)`, `s = max(|lo|, |hi|, 1)`,
/// which keeps the inequality strict after rounding.
fn gate_cost(lo: f64, hi: f64, r: usize) -> Result<f64> {
    let s = lo.abs().max(hi.abs()).max(1.0);
    let gate = hi + (r as f64 + 1.0) * ((hi - lo) + s);
    if gate.is_finite() {
        Ok(gate)
    } else {
        Err(AssignError::CostRange { lo, hi })
    }
}

/// Margins of the kept pair `(i, j)` with cost `c` (minimisation space) over the best other
/// acceptable entry in row `i` and in column `j` (`+inf` when there is none).
fn margins(
    work: &[Option<f64>],
    num_rows: usize,
    num_cols: usize,
    i: usize,
    j: usize,
    c: f64,
) -> (f64, f64) {
    let row_best_other = work
        .iter()
        .skip(i * num_cols)
        .take(num_cols)
        .enumerate()
        .filter(|&(jj, _)| jj != j)
        .filter_map(|(_, c)| *c)
        .fold(f64::INFINITY, f64::min);
    let col_best_other = (0..num_rows)
        .filter(|&ii| ii != i)
        .filter_map(|ii| work.get(ii * num_cols + j).copied().flatten())
        .fold(f64::INFINITY, f64::min);
    (row_best_other - c, col_best_other - c)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(rows: &[&[f64]]) -> CostMatrix {
        CostMatrix::from_rows(rows).unwrap()
    }

    const INF: f64 = f64::INFINITY;

    #[test]
    fn forbidden_pair_is_never_assigned_even_when_forced() {
        // Both rows can only take column 0: one of them must stay unassigned.
        let c = m(&[&[1.0, INF], &[2.0, INF]]);
        let a = solve(&c, &AssignConfig::default()).unwrap();
        assert_eq!(a.rows[0], RowDecision::Assigned { col: 0, cost: 1.0 });
        assert_eq!(a.rows[1], RowDecision::Gated);
        assert_eq!(a.col_to_row, vec![Some(0), None]);
    }

    #[test]
    fn gating_maximises_the_number_of_pairs_first() {
        // Row 1 may only take column 0; giving column 0 to row 0 (cost 1) would strand it.
        let c = m(&[&[1.0, 100.0], &[1.0, f64::NAN]]);
        let a = solve(&c, &AssignConfig::default()).unwrap();
        assert_eq!(a.col_for_row(0), Some(1));
        assert_eq!(a.col_for_row(1), Some(0));
        assert_eq!(a.total_cost(), 101.0);
    }

    #[test]
    fn weak_skeleton_stays_anonymous_and_frees_its_band() {
        // Scores: skeleton 0 matches band 0 weakly (0.2), skeleton 1 matches band 0 well.
        let c = m(&[&[0.2, 0.1], &[0.9, 0.3]]);
        let cfg = AssignConfig {
            objective: Objective::Maximize,
            rejection_threshold: Some(0.25),
            ..AssignConfig::default()
        };
        let a = solve(&c, &cfg).unwrap();
        assert_eq!(a.rows[0], RowDecision::Gated);
        assert_eq!(a.rows[1], RowDecision::Assigned { col: 0, cost: 0.9 });
        // Without the threshold, the optimum gives skeleton 0 band 1.
        let a = solve(
            &c,
            &AssignConfig {
                objective: Objective::Maximize,
                ..AssignConfig::default()
            },
        )
        .unwrap();
        assert_eq!(a.col_for_row(0), Some(1));
    }

    #[test]
    fn two_skeletons_competing_for_one_band_are_both_deferred() {
        // Skeletons 0 and 1 both fit band 0 almost equally; skeleton 2 clearly owns band 1.
        let c = m(&[&[1.0, 9.0], &[1.1, 9.0], &[9.0, 1.0]]);
        let cfg = AssignConfig {
            conflict_margin: Some(0.5),
            ..AssignConfig::default()
        };
        let a = solve(&c, &cfg).unwrap();
        assert!(matches!(a.rows[0], RowDecision::Deferred { col: 0, .. }));
        assert_eq!(a.rows[1], RowDecision::Unmatched);
        assert_eq!(a.rows[2], RowDecision::Assigned { col: 1, cost: 1.0 });
        if let RowDecision::Deferred { col_margin, .. } = a.rows[0] {
            approx::assert_relative_eq!(col_margin, 0.1, epsilon = 1e-12);
        }
    }

    #[test]
    fn skeleton_with_two_close_bands_is_deferred() {
        let c = m(&[&[1.0, 1.2], &[5.0, 5.0]]);
        let cfg = AssignConfig {
            conflict_margin: Some(0.5),
            ..AssignConfig::default()
        };
        let a = solve(&c, &cfg).unwrap();
        // The optimum is (0,0),(1,1); row 0's margin over band 1 is 0.2 < 0.5.
        assert!(matches!(
            a.rows[0],
            RowDecision::Deferred { col: 0, row_margin, .. } if (row_margin - 0.2).abs() < 1e-12
        ));
        // Row 1 takes band 1 at 5 though band 0 also costs 5: a zero row margin is deferred.
        assert!(matches!(a.rows[1], RowDecision::Deferred { col: 1, .. }));
        assert!(a.pairs.is_empty());
    }

    #[test]
    fn clear_winners_survive_the_conflict_rule_and_gated_entries_do_not_compete() {
        let c = m(&[&[1.0, INF], &[INF, 2.0]]);
        let cfg = AssignConfig {
            conflict_margin: Some(10.0),
            ..AssignConfig::default()
        };
        let a = solve(&c, &cfg).unwrap();
        assert_eq!(a.num_assigned(), 2);
    }

    #[test]
    fn nan_policy_error_names_the_entry() {
        let c = m(&[&[1.0, 2.0], &[3.0, f64::NAN]]);
        let cfg = AssignConfig {
            nan_policy: NanPolicy::Error,
            ..AssignConfig::default()
        };
        assert_eq!(
            solve(&c, &cfg),
            Err(AssignError::NanCost { row: 1, col: 1 })
        );
        assert_eq!(
            solve(&c, &AssignConfig::default()).unwrap().num_assigned(),
            2
        );
    }

    #[test]
    fn empty_and_all_forbidden_give_empty_assignments() {
        let a = solve(
            &CostMatrix::new(0, 4, vec![]).unwrap(),
            &AssignConfig::default(),
        )
        .unwrap();
        assert_eq!(
            (a.rows.len(), a.col_to_row.len(), a.num_assigned()),
            (0, 4, 0)
        );
        let a = solve(
            &CostMatrix::new(3, 0, vec![]).unwrap(),
            &AssignConfig::default(),
        )
        .unwrap();
        assert_eq!(a.rows, vec![RowDecision::Unmatched; 3]);
        let a = solve(&m(&[&[INF, f64::NAN]]), &AssignConfig::default()).unwrap();
        assert_eq!(a.rows, vec![RowDecision::Gated]);
    }

    #[test]
    fn bad_config_is_rejected() {
        let c = m(&[&[1.0]]);
        for cfg in [
            AssignConfig {
                rejection_threshold: Some(f64::NAN),
                ..AssignConfig::default()
            },
            AssignConfig {
                conflict_margin: Some(-1.0),
                ..AssignConfig::default()
            },
        ] {
            assert!(matches!(
                solve(&c, &cfg),
                Err(AssignError::InvalidConfig(_))
            ));
        }
    }

    #[test]
    fn costs_near_f64_max_cannot_be_gated() {
        let c = m(&[&[1e308, INF], &[-1e308, 0.0]]);
        assert!(matches!(
            solve(&c, &AssignConfig::default()),
            Err(AssignError::CostRange { .. })
        ));
    }

    #[test]
    fn config_reads_from_toml_like_data() {
        // Round-trips through serde's data model (TOML loading uses the same derive).
        let cfg = AssignConfig {
            objective: Objective::Maximize,
            nan_policy: NanPolicy::Error,
            rejection_threshold: Some(0.3),
            conflict_margin: Some(0.05),
        };
        let json = serde_json::to_string(&cfg).unwrap();
        assert!(json.contains("\"maximize\""));
        assert_eq!(serde_json::from_str::<AssignConfig>(&json).unwrap(), cfg);
        assert_eq!(
            serde_json::from_str::<AssignConfig>("{}").unwrap(),
            AssignConfig::default()
        );
    }
}
