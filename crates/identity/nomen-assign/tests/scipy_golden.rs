//! nomen-assign against SciPy's `scipy.optimize.linear_sum_assignment`.
//!
//! Golden values: `tests/fixtures/lsap_golden.json`, made by
//! `tests/fixtures/make_lsap_golden.py` (SciPy and NumPy versions are recorded in the file;
//! regenerate with `python3 make_lsap_golden.py > lsap_golden.json` in that folder).
//! Forbidden entries are `null` there and `+inf` for SciPy.

use nomen_assign::{AssignConfig, CostMatrix, Objective, solve};
use serde_json::Value;

const GOLDEN: &str = include_str!("fixtures/lsap_golden.json");
/// Totals must agree to this, relative to the sum of |entries| SciPy assigned (at least 1).
const REL_TOL: f64 = 1e-9;

#[test]
fn totals_and_unique_optima_match_scipy() {
    let usizes = |v: &Value| -> Vec<usize> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap() as usize)
            .collect()
    };
    let golden: Value = serde_json::from_str(GOLDEN).unwrap();
    let cases = golden["cases"].as_array().unwrap();
    assert!(cases.len() >= 100);
    let (mut num_unique, mut num_identical, mut max_rel_diff) = (0, 0, 0.0_f64);
    for case in cases {
        let name = case["name"].as_str().unwrap();
        let num_rows = case["num_rows"].as_u64().unwrap() as usize;
        let num_cols = case["num_cols"].as_u64().unwrap() as usize;
        let costs: Vec<f64> = case["costs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap_or(f64::INFINITY))
            .collect();
        let has_forbidden = costs.iter().any(|c| !c.is_finite());
        let matrix = CostMatrix::new(num_rows, num_cols, costs.clone()).unwrap();
        let config = AssignConfig {
            objective: if case["maximize"].as_bool().unwrap() {
                Objective::Maximize
            } else {
                Objective::Minimize
            },
            ..AssignConfig::default()
        };
        let ours = solve(&matrix, &config).unwrap();

        let scipy_pairs: Vec<(usize, usize)> = usizes(&case["rows"])
            .into_iter()
            .zip(usizes(&case["cols"]))
            .collect();
        let our_pairs: Vec<(usize, usize)> = ours.pairs.iter().map(|p| (p.row, p.col)).collect();
        assert_eq!(
            our_pairs.len(),
            scipy_pairs.len(),
            "{name}: number of pairs"
        );

        let scipy_total = case["total"].as_f64().unwrap();
        let scale = scipy_pairs
            .iter()
            .map(|&(i, j)| costs[i * num_cols + j].abs())
            .sum::<f64>()
            .max(1.0);
        let rel_diff = (ours.total_cost() - scipy_total).abs() / scale;
        assert!(
            rel_diff <= REL_TOL,
            "{name}: total {} vs SciPy {scipy_total} (relative {rel_diff:e})",
            ours.total_cost()
        );
        max_rel_diff = max_rel_diff.max(rel_diff);

        if case["unique"].as_bool().unwrap() {
            num_unique += 1;
            assert_eq!(our_pairs, scipy_pairs, "{name}: unique optimum differs");
        }
        if our_pairs == scipy_pairs {
            num_identical += 1;
        } else {
            // The dense matrix goes to the solver unchanged: SciPy's tie-breaking must hold.
            assert!(
                has_forbidden,
                "{name}: same matrix, different optimum chosen"
            );
        }
    }
    println!(
        "{} SciPy cases: {num_unique} unique optima matched, {num_identical} identical \
         assignments, max relative total difference {max_rel_diff:e}",
        cases.len()
    );
}
