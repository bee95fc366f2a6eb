//! Butterworth low-pass against SciPy golden values.
//!
//! Fixtures come from `tests/fixtures/make_scipy_golden.py` (SciPy 1.17.1, NumPy 2.4.6):
//! `butter(4, 3, fs=100, output='sos')`, `sosfilt` (zero initial state) and `sosfiltfilt` with
//! its defaults — odd padding of 3·(2·2+1) = 15 samples at each end and `sosfilt_zi`-scaled
//! initial conditions for both passes, which `ZeroPhaseLowpass` reproduces.
//! Regenerate with `python3 tests/fixtures/make_scipy_golden.py` from the crate directory.

use nomen_filters::FilterError;
use nomen_filters::lowpass::{
    ButterworthConfig, Lowpass, ZeroPhaseLowpass, butterworth_lowpass_sections,
};

fn read_rows(name: &str) -> Vec<Vec<f64>> {
    let path = format!("{}/tests/fixtures/{name}", env!("CARGO_MANIFEST_DIR"));
    let Ok(text) = std::fs::read_to_string(&path) else {
        panic!("cannot read {path}");
    };
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            l.split(',')
                .map(|v| match v.trim().parse::<f64>() {
                    Ok(x) => x,
                    Err(e) => panic!("{path}: bad number {v:?}: {e}"),
                })
                .collect()
        })
        .collect()
}

fn config() -> ButterworthConfig {
    ButterworthConfig::de_marchi_accelerometer(100.0)
}

fn column(rows: &[Vec<f64>], c: usize) -> Vec<f64> {
    rows.iter().map(|r| r[c]).collect()
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn three_hz_butterworth_sections_equal_scipy_butter() {
    let want = read_rows("scipy_butter4_3hz_100hz_sos.csv");
    let got = butterworth_lowpass_sections(&config()).unwrap();
    assert_eq!(got.len(), want.len());
    let mut worst = 0.0_f64;
    for (g, w) in got.iter().zip(&want) {
        for (a, b) in g.as_sos_row().iter().zip(w) {
            worst = worst.max((a - b).abs() / b.abs().max(1e-6));
        }
    }
    println!("sos max relative difference vs SciPy: {worst:.3e}");
    assert!(worst < 1e-12, "{worst}");
}

#[test]
fn three_hz_lowpass_matches_scipy_sosfilt() {
    let rows = read_rows("scipy_butter4_3hz_100hz_signal.csv");
    let x = column(&rows, 1);
    let want = column(&rows, 2);
    let mut f = Lowpass::new(&config()).unwrap();
    let got: Vec<f64> = x.iter().map(|&v| f.process(v).unwrap()).collect();
    let err = max_abs_diff(&got, &want);
    println!(
        "causal max |Δ| vs sosfilt over {} samples: {err:.3e}",
        x.len()
    );
    assert!(err < 1e-12, "{err}");
}

#[test]
fn three_hz_lowpass_matches_scipy_sosfiltfilt() {
    let rows = read_rows("scipy_butter4_3hz_100hz_signal.csv");
    let x = column(&rows, 1);
    let want = column(&rows, 3);
    let mut f = ZeroPhaseLowpass::new(&config()).unwrap();
    assert_eq!(f.pad_len(), 15);
    let mut got = vec![0.0; x.len()];
    f.filter(&x, &mut got).unwrap();
    let err = max_abs_diff(&got, &want);
    println!(
        "zero-phase max |Δ| vs sosfiltfilt over {} samples: {err:.3e}",
        x.len()
    );
    assert!(err < 1e-9, "{err}");
    // Reusing the filter on the same window gives the same answer (no state leaks between windows).
    let mut again = vec![0.0; x.len()];
    f.filter(&x, &mut again).unwrap();
    assert_eq!(got, again);
}

#[test]
fn zero_phase_lowpass_does_not_delay_a_slow_movement_but_causal_does() {
    // 0.5 Hz movement at 100 Hz through a 3 Hz filter: the causal filter lags, the zero-phase does not.
    let fs = 100.0;
    let x: Vec<f64> = (0..600)
        .map(|i| (2.0 * std::f64::consts::PI * 0.5 * i as f64 / fs).sin())
        .collect();
    let mut zp = ZeroPhaseLowpass::new(&config()).unwrap();
    let mut y = vec![0.0; x.len()];
    zp.filter(&x, &mut y).unwrap();
    let mut causal = Lowpass::new(&config()).unwrap();
    let yc: Vec<f64> = x.iter().map(|&v| causal.process(v).unwrap()).collect();
    let argmax = |s: &[f64]| {
        (200..400)
            .max_by(|&a, &b| s[a].total_cmp(&s[b]))
            .unwrap_or(0)
    };
    assert_eq!(argmax(&y), argmax(&x));
    assert!(argmax(&yc) > argmax(&x) + 5, "causal peak should lag");
}

#[test]
fn window_shorter_than_the_padding_is_an_error_not_a_panic() {
    let mut f = ZeroPhaseLowpass::new(&config()).unwrap();
    let x = [1.0; 15];
    let mut y = [0.0; 15];
    assert!(matches!(
        f.filter(&x, &mut y),
        Err(FilterError::WindowTooShort {
            needed: 15,
            got: 15,
            ..
        })
    ));
    let mut x = [1.0; 40];
    x[7] = f64::NAN;
    let mut y = [0.0; 40];
    assert!(matches!(
        f.filter(&x, &mut y),
        Err(FilterError::NonFinite { index: 7, .. })
    ));
    let mut short_out = [0.0; 39];
    assert!(f.filter(&[1.0; 40], &mut short_out).is_err());
}
