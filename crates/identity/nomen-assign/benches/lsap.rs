//! Time per solve of a dense random square problem: nomen-assign vs SciPy in the same run.
//!
//! `cargo bench -p nomen-assign --bench lsap`. The matrix is written to a temporary file as
//! little-endian f64 and SciPy's `linear_sum_assignment` is timed on it by `python3 -c`; without
//! python3/SciPy the comparison is skipped with a message. Both sides report the median of
//! `NUM_REPS` solves (solve only: no I/O or matrix construction in the timed region).
#![allow(clippy::print_stdout)]

use std::error::Error;
use std::io::Write;
use std::process::Command;
use std::time::{Duration, Instant};

use nomen_assign::{AssignConfig, CostMatrix, solve};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Side of the square workload.
const SIZE: usize = 1000;
/// Solves timed per side (the median is reported).
const NUM_REPS: usize = 7;
const SEED: u64 = 7;

const SCIPY_SCRIPT: &str = r#"
import sys, time
import numpy as np
from scipy.optimize import linear_sum_assignment
path, n, reps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
c = np.fromfile(path, dtype="<f8").reshape(n, n)
ts = []
for _ in range(reps):
    t = time.perf_counter()
    r, k = linear_sum_assignment(c)
    ts.append(time.perf_counter() - t)
ts.sort()
print(repr(ts[len(ts) // 2]), repr(float(c[r, k].sum())))
"#;

fn median(mut ts: Vec<Duration>) -> Duration {
    ts.sort();
    ts.get(ts.len() / 2).copied().unwrap_or_default()
}

/// `Ok(None)` when python3 or SciPy is unavailable.
fn scipy_median_s(costs: &[f64]) -> Result<Option<(f64, f64)>, Box<dyn Error>> {
    let path = std::env::temp_dir().join(format!("nomen_assign_bench_{}.f64", std::process::id()));
    {
        let mut f = std::fs::File::create(&path)?;
        let bytes: Vec<u8> = costs.iter().flat_map(|c| c.to_le_bytes()).collect();
        f.write_all(&bytes)?;
    }
    let out = Command::new("python3")
        .arg("-c")
        .arg(SCIPY_SCRIPT)
        .arg(&path)
        .arg(SIZE.to_string())
        .arg(NUM_REPS.to_string())
        .output();
    let _ = std::fs::remove_file(&path);
    let out = match out {
        Ok(o) if o.status.success() => o,
        Ok(o) => {
            println!(
                "skipping SciPy comparison: python3 failed: {}",
                String::from_utf8_lossy(&o.stderr)
                    .lines()
                    .last()
                    .unwrap_or("")
            );
            return Ok(None);
        }
        Err(e) => {
            println!("skipping SciPy comparison: cannot run python3: {e}");
            return Ok(None);
        }
    };
    let text = String::from_utf8(out.stdout)?;
    let mut fields = text.split_whitespace().map(str::parse::<f64>);
    match (fields.next(), fields.next()) {
        (Some(Ok(t)), Some(Ok(total))) => Ok(Some((t, total))),
        _ => Err(format!("unexpected SciPy output: {text:?}").into()),
    }
}

fn main() -> Result<(), Box<dyn Error>> {
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let costs: Vec<f64> = (0..SIZE * SIZE).map(|_| rng.random::<f64>()).collect();
    let matrix = CostMatrix::new(SIZE, SIZE, costs.clone())?;
    let config = AssignConfig::default();

    let mut ours = Vec::with_capacity(NUM_REPS);
    let mut total = 0.0;
    for _ in 0..NUM_REPS {
        let t = Instant::now();
        let a = solve(&matrix, &config)?;
        ours.push(t.elapsed());
        total = std::hint::black_box(a).total_cost();
    }
    let ours_s = median(ours).as_secs_f64();
    println!("{SIZE}x{SIZE} uniform random costs, median of {NUM_REPS} solves");
    println!(
        "  nomen-assign solve: {:9.2} ms  (total {total:.9})",
        ours_s * 1e3
    );

    match scipy_median_s(&costs)? {
        Some((scipy_s, scipy_total)) => {
            println!(
                "  SciPy linear_sum_assignment: {:9.2} ms  (total {scipy_total:.9})",
                scipy_s * 1e3
            );
            println!(
                "  ratio nomen-assign / SciPy: {:.2} (totals differ by {:.1e})",
                ours_s / scipy_s,
                (total - scipy_total).abs()
            );
        }
        None => println!("  SciPy: skipped"),
    }
    Ok(())
}
