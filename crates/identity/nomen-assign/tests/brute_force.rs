//! nomen-assign against exhaustive search on small matrices with forbidden entries,
//! rejection thresholds, both objectives and the conflict rule (seeded, so reproducible).

use nomen_assign::{AssignConfig, CostMatrix, NanPolicy, Objective, RowDecision, solve};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const SEED: u64 = 0x006e_6f6d_656e;
const NUM_CASES: usize = 4000;
const MAX_SIDE: usize = 5;

/// Best `(number of pairs, total)` over all partial assignments using only acceptable entries,
/// more pairs first, then lower total (`acc` is in minimisation space).
fn brute_force(acc: &[Option<f64>], num_rows: usize, num_cols: usize) -> (usize, f64) {
    struct Search<'a> {
        acc: &'a [Option<f64>],
        num_rows: usize,
        num_cols: usize,
        used: Vec<bool>,
        best: (usize, f64),
    }
    impl Search<'_> {
        fn go(&mut self, row: usize, count: usize, total: f64) {
            if row == self.num_rows {
                if count > self.best.0 || (count == self.best.0 && total < self.best.1) {
                    self.best = (count, total);
                }
                return;
            }
            self.go(row + 1, count, total);
            for j in 0..self.num_cols {
                if let Some(c) = self.acc[row * self.num_cols + j]
                    && !self.used[j]
                {
                    self.used[j] = true;
                    self.go(row + 1, count + 1, total + c);
                    self.used[j] = false;
                }
            }
        }
    }
    let mut s = Search {
        acc,
        num_rows,
        num_cols,
        used: vec![false; num_cols],
        best: (0, 0.0),
    };
    s.go(0, 0, 0.0);
    s.best
}

fn random_entry(rng: &mut ChaCha8Rng, p_forbidden: f64, is_int: bool) -> f64 {
    if rng.random_bool(p_forbidden) {
        return match rng.random_range(0..3) {
            0 => f64::NAN,
            1 => f64::INFINITY,
            _ => f64::NEG_INFINITY,
        };
    }
    if is_int {
        f64::from(rng.random_range(-2..3))
    } else {
        rng.random_range(-10.0..10.0)
    }
}

#[test]
fn optimum_equals_exhaustive_search_and_never_uses_forbidden_pairs() {
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    for case in 0..NUM_CASES {
        let num_rows = rng.random_range(0..=MAX_SIDE);
        let num_cols = rng.random_range(0..=MAX_SIDE);
        let p_forbidden = [0.0, 0.2, 0.5, 0.9][case % 4];
        let is_int = rng.random_bool(0.5);
        let costs: Vec<f64> = (0..num_rows * num_cols)
            .map(|_| random_entry(&mut rng, p_forbidden, is_int))
            .collect();
        let objective = if rng.random_bool(0.5) {
            Objective::Maximize
        } else {
            Objective::Minimize
        };
        let rejection_threshold = rng
            .random_bool(0.3)
            .then(|| f64::from(rng.random_range(-5..5)));
        let config = AssignConfig {
            objective,
            nan_policy: NanPolicy::Forbidden,
            rejection_threshold,
            conflict_margin: None,
        };
        let sign = if objective == Objective::Maximize {
            -1.0
        } else {
            1.0
        };
        let acc: Vec<Option<f64>> = costs
            .iter()
            .map(|&c| {
                let c = sign * c;
                (c.is_finite() && rejection_threshold.is_none_or(|t| c <= sign * t)).then_some(c)
            })
            .collect();

        let matrix = CostMatrix::new(num_rows, num_cols, costs.clone()).unwrap();
        let ours = solve(&matrix, &config).unwrap();
        let (best_count, best_total) = brute_force(&acc, num_rows, num_cols);
        let ctx = format!("case {case}: {num_rows}x{num_cols} {costs:?} {config:?}");

        assert_eq!(ours.num_assigned(), best_count, "{ctx}");
        assert!(
            (sign * ours.total_cost() - best_total).abs() <= 1e-9 * (1.0 + best_total.abs()),
            "{ctx}: total {} vs brute force {best_total}",
            sign * ours.total_cost()
        );
        // Every kept pair is acceptable, columns are distinct, and the views agree.
        assert_eq!(ours.rows.len(), num_rows);
        let mut seen = vec![false; num_cols];
        for p in &ours.pairs {
            assert!(
                acc[p.row * num_cols + p.col].is_some(),
                "{ctx}: forbidden pair kept"
            );
            assert!(!seen[p.col], "{ctx}: column used twice");
            seen[p.col] = true;
            assert_eq!(ours.row_for_col(p.col), Some(p.row));
            assert_eq!(ours.col_for_row(p.row), Some(p.col));
        }
        assert!(ours.pairs.windows(2).all(|w| w[0].row < w[1].row));
    }
}

#[test]
fn conflict_rule_defers_exactly_the_pairs_that_do_not_win_by_the_margin() {
    let mut rng = ChaCha8Rng::seed_from_u64(SEED + 1);
    for case in 0..NUM_CASES / 2 {
        let num_rows = rng.random_range(1..=MAX_SIDE);
        let num_cols = rng.random_range(1..=MAX_SIDE);
        let is_int = rng.random_bool(0.3);
        let costs: Vec<f64> = (0..num_rows * num_cols)
            .map(|_| random_entry(&mut rng, 0.25, is_int))
            .collect();
        let objective = if case % 2 == 0 {
            Objective::Maximize
        } else {
            Objective::Minimize
        };
        let margin = rng.random_range(0.0..4.0);
        let matrix = CostMatrix::new(num_rows, num_cols, costs.clone()).unwrap();
        let plain = AssignConfig {
            objective,
            ..AssignConfig::default()
        };
        let with_rule = AssignConfig {
            conflict_margin: Some(margin),
            ..plain
        };
        let base = solve(&matrix, &plain).unwrap();
        let ruled = solve(&matrix, &with_rule).unwrap();
        let sign = if objective == Objective::Maximize {
            -1.0
        } else {
            1.0
        };
        let get = |i: usize, j: usize| matrix.get(i, j).map(|c| sign * c);
        for (i, (b, r)) in base.rows.iter().zip(&ruled.rows).enumerate() {
            let ctx = format!("case {case} row {i}: {costs:?} margin {margin}");
            match (*b, *r) {
                (RowDecision::Assigned { col, .. }, after) => {
                    let c = get(i, col).unwrap();
                    let row_m = (0..num_cols)
                        .filter(|&j| j != col)
                        .filter_map(|j| get(i, j))
                        .fold(f64::INFINITY, f64::min)
                        - c;
                    let col_m = (0..num_rows)
                        .filter(|&ii| ii != i)
                        .filter_map(|ii| get(ii, col))
                        .fold(f64::INFINITY, f64::min)
                        - c;
                    let wins = row_m >= margin && col_m >= margin;
                    match after {
                        RowDecision::Assigned { col: c2, .. } => {
                            assert!(wins && c2 == col, "{ctx}")
                        }
                        RowDecision::Deferred {
                            col: c2,
                            row_margin,
                            col_margin,
                        } => {
                            assert!(!wins && c2 == col, "{ctx}");
                            assert_eq!((row_margin, col_margin), (row_m, col_m), "{ctx}");
                        }
                        other => panic!("{ctx}: {other:?}"),
                    }
                }
                (b, r) => assert_eq!(b, r, "{ctx}"),
            }
        }
    }
}
