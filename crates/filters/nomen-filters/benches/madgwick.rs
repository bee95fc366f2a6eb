//! Madgwick per-sample cost against Python `ahrs` (the reference the golden test matches to
//! 1e-15): `cargo bench -p nomen-filters --bench madgwick`.
//!
//! Both sides run the IMU-only update on the same synthetic 100 Hz stream (a slow wobble plus a
//! fixed pseudo-random jitter). The Python side is timed only if `python3` with `ahrs` and
//! `numpy` is on the PATH; the ratio is printed from one run of each.
#![allow(
    missing_docs,
    clippy::print_stdout,
    clippy::unwrap_used,
    clippy::expect_used
)]

use nalgebra::{UnitQuaternion, Vector3};
use nomen_filters::orientation::{Madgwick, MadgwickConfig};
use std::hint::black_box;
use std::process::Command;
use std::time::Instant;

const NUM_SAMPLES: usize = 1_000_000;
const NUM_PYTHON_SAMPLES: usize = 20_000;

fn sample(k: usize) -> (Vector3<f64>, Vector3<f64>) {
    let t = k as f64 * 0.01;
    let jitter = ((k * 7919) as f64 * 0.618_033_988_75).fract() - 0.5;
    let gyro = Vector3::new(0.3 * t.sin(), 0.2 * (0.7 * t).cos(), 0.1 + 0.01 * jitter);
    let accel = Vector3::new(0.5 * (0.3 * t).sin(), 0.4 * jitter, 9.81);
    (gyro, accel)
}

fn main() {
    let samples: Vec<_> = (0..NUM_SAMPLES).map(sample).collect();
    let mut filter = Madgwick::new(MadgwickConfig::default(), UnitQuaternion::identity()).unwrap();
    let start = Instant::now();
    for (g, a) in &samples {
        black_box(filter.update_imu(black_box(g), black_box(a), 0.01));
    }
    let rust_ns = start.elapsed().as_secs_f64() * 1e9 / NUM_SAMPLES as f64;
    println!("nomen Madgwick::update_imu: {rust_ns:.1} ns per sample ({NUM_SAMPLES} samples)");

    let script = format!(
        r#"
import time, math, numpy as np
from ahrs.filters import Madgwick
n = {NUM_PYTHON_SAMPLES}
g = []; a = []
for k in range(n):
    t = k * 0.01
    j = ((k * 7919) * 0.61803398875) % 1.0 - 0.5
    g.append(np.array([0.3 * math.sin(t), 0.2 * math.cos(0.7 * t), 0.1 + 0.01 * j]))
    a.append(np.array([0.5 * math.sin(0.3 * t), 0.4 * j, 9.81]))
f = Madgwick(frequency=100.0)
q = np.array([1.0, 0.0, 0.0, 0.0])
s = time.perf_counter()
for k in range(n):
    q = f.updateIMU(q, gyr=g[k], acc=a[k])
print((time.perf_counter() - s) * 1e9 / n)
"#
    );
    match Command::new("python3").arg("-c").arg(&script).output() {
        Ok(out) if out.status.success() => {
            let text = String::from_utf8_lossy(&out.stdout);
            match text.trim().parse::<f64>() {
                Ok(py_ns) => println!(
                    "python ahrs Madgwick.updateIMU: {py_ns:.0} ns per sample ({NUM_PYTHON_SAMPLES} samples); nomen is {:.0}× faster",
                    py_ns / rust_ns
                ),
                Err(_) => println!("skipping python: unexpected output {text:?}"),
            }
        }
        Ok(out) => println!(
            "skipping python: ahrs not available ({})",
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .last()
                .unwrap_or("")
        ),
        Err(e) => println!("skipping python: {e}"),
    }
}
