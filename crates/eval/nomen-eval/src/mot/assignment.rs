//! Minimum-cost assignment with forbidden pairs, as py-motmetrics solves it with SciPy.

/// Solves the rectangular assignment problem on the row-major `num_rows x num_cols` matrix
/// `costs`, where non-finite entries are forbidden pairs, and returns the assigned
/// `(row, column)` pairs at finite cost in increasing row order.
///
/// This mirrors `motmetrics.lap.lsa_solve_scipy`: forbidden entries are replaced by the
/// constant `2 r c + 1` (`r = min(num_rows, num_cols)`, `c = max |finite cost| + 1`), which is
/// larger than any assignment using only allowed pairs could cost, the problem is solved with
/// SciPy's shortest-augmenting-path algorithm (the `lsap` crate is its translation, so ties
/// break the same way), and pairs landing on a forbidden entry are dropped.
///
/// # Errors
/// The solver's message if it rejects the matrix (it cannot for the finite matrix built here).
pub(crate) fn solve_gated(
    num_rows: usize,
    num_cols: usize,
    costs: &[f64],
) -> Result<Vec<(usize, usize)>, String> {
    if num_rows == 0 || num_cols == 0 {
        return Ok(Vec::new());
    }
    let max_abs = costs
        .iter()
        .filter(|c| c.is_finite())
        .map(|c| c.abs())
        .fold(None, |acc: Option<f64>, c| {
            Some(acc.map_or(c, |a| a.max(c)))
        });
    // No allowed pair at all: py-motmetrics solves an all-zero problem and drops every pair.
    let Some(max_abs) = max_abs else {
        return Ok(Vec::new());
    };
    let large_cost = 2.0 * num_rows.min(num_cols) as f64 * (max_abs + 1.0) + 1.0;
    let finite_costs: Vec<f64> = costs
        .iter()
        .map(|&c| if c.is_finite() { c } else { large_cost })
        .collect();
    let (rows, cols) =
        lsap::solve(num_rows, num_cols, &finite_costs, false).map_err(|e| format!("{e:?}"))?;
    Ok(rows
        .into_iter()
        .zip(cols)
        .filter(|&(i, j)| costs.get(i * num_cols + j).is_some_and(|c| c.is_finite()))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forbidden_pairs_are_never_assigned() {
        let nan = f64::NAN;
        // Row 0 may only take column 1; row 1 may take either.
        let costs = [nan, 5.0, 0.0, 1.0];
        assert_eq!(solve_gated(2, 2, &costs), Ok(vec![(0, 1), (1, 0)]));
        assert_eq!(solve_gated(2, 2, &[nan; 4]), Ok(vec![]));
        assert_eq!(solve_gated(0, 3, &[]), Ok(vec![]));
    }

    #[test]
    fn tall_problems_come_back_in_row_order() {
        // 3 rows, 2 columns: row 2 is cheapest for column 0, row 0 for column 1.
        let costs = [5.0, 0.1, 5.0, 5.0, 0.2, 5.0];
        assert_eq!(solve_gated(3, 2, &costs), Ok(vec![(0, 1), (2, 0)]));
    }
}
