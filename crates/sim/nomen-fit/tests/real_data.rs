//! Facts about the shared real recordings (`../shared/data`), which are not in the repository:
//! each test prints "skipping" and passes when the data is absent.

use nomen_fit::dataset::static_world_from_body;
use nomen_fit::load::{
    ImuCsvFormat, QuatConvention, RssiCsvFormat, UwbCsvFormat, parse_mocap_csv, parse_uwb_csv,
};
use nomen_fit::uwb::{check_quat_convention, range_errors_mocap};
use nomen_fit::{
    FitAllConfig, ImuFitConfig, PathLossConfig, UwbFitConfig, UwbSetup, fit_all, fit_imu_file,
    fit_rssi_files, fit_uwb_errors, fit_uwb_static_file,
};
use std::path::{Path, PathBuf};

const DATA_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../../shared/data");

/// The data directory, or `None` (after saying so) when it is not there.
fn data(sub: &str) -> Option<PathBuf> {
    let p = Path::new(DATA_DIR).join(sub);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("skipping: {} not found", p.display());
        None
    }
}

#[test]
fn broad_gyro_at_rest_is_quiet_and_accel_norm_is_gravity() {
    let Some(dir) = data("imu/broad") else { return };
    for trial in [
        "07_undisturbed_fast_rotation_B",
        "15_undisturbed_fast_translation_A",
        "24_disturbed_tapping_A",
        "32_disturbed_attached_magnet_1cm",
    ] {
        let fit = fit_imu_file(
            &dir.join(format!("{trial}.csv")),
            &ImuCsvFormat::broad(),
            &ImuFitConfig::default(),
        )
        .unwrap();
        // Rest phases at both ends of every trial.
        assert_eq!(fit.still_segments_s.len(), 2, "{trial}");
        assert!(fit.still_duration_s > 40.0, "{trial}");
        for axis in &fit.gyro.axes {
            assert!(
                axis.white_noise_std < 0.01,
                "{trial}: {}",
                axis.white_noise_std
            );
            // The quantisation step of this gyroscope is 1.07e-3 rad/s: noise is above it.
            assert!(axis.white_noise_std > 5e-4, "{trial}");
        }
        let rel = fit.accel_norm_bias_mps2 / 9.81;
        assert!(
            rel.abs() < 0.01,
            "{trial}: accel norm {}",
            fit.accel_norm_at_rest_mps2
        );
        // 40 s of rest cannot show a bias random walk.
        assert!(fit.gyro.axes.iter().all(|a| a.bias_random_walk.is_none()));
        // White noise dominates at short τ: ADEV(1 s) ≈ noise density within a factor 2.
        for axis in &fit.gyro.axes {
            let n = axis.random_walk_adev_1s.unwrap();
            assert!((0.5..2.0).contains(&(n / axis.noise_density)), "{trial}");
        }
    }
}

#[test]
fn xio_still_start_is_detected_from_the_data() {
    let Some(dir) = data("imu/xio") else { return };
    let fit = fit_imu_file(
        &dir.join("sensor_data.csv"),
        &ImuCsvFormat::xio(),
        &ImuFitConfig::default(),
    )
    .unwrap();
    let first = fit.still_segments_s[0];
    assert!(first[0] < 0.5 && first[1] - first[0] > 5.0, "{first:?}");
    assert!((95.0..105.0).contains(&fit.rate_hz));
    for axis in &fit.gyro.axes {
        assert!(axis.white_noise_std < 0.01);
    }
    assert!((fit.accel_norm_bias_mps2 / 9.81).abs() < 0.01);
}

#[test]
fn lias_quaternion_is_a_pure_yaw_and_ranges_read_long() {
    let Some(dir) = data("uwb/lias/Dynamic") else {
        return;
    };
    let read = |f: &str| std::fs::read_to_string(dir.join(f)).unwrap();
    let uwb = parse_uwb_csv(
        &read("UWB_dynamic_exp_mid.csv"),
        "mid",
        &UwbCsvFormat::lias(),
    )
    .unwrap();
    let mocap = parse_mocap_csv(&read("motion_capture_dynamic_exp_mid.csv"), "mocap").unwrap();
    let setup = UwbSetup::lias_2022_08_14();
    let check = check_quat_convention(&uwb, &mocap, &setup, 0.05).unwrap();
    // The documented reading mirrors the tag triangle: clearly worse than the chosen one and
    // even worse than ignoring rotation.
    let score = |label: &str| {
        check
            .scores
            .iter()
            .find(|s| s.label == label)
            .map(|s| s.robust_std_m)
            .unwrap()
    };
    let chosen = score(&check.chosen.label());
    assert!(score(&QuatConvention::documented().label()) > 3.0 * chosen);
    assert!(score("no rotation (tags at the body origin)") > 2.0 * chosen);
    assert!(check.median_tilt_rad.to_degrees() < 2.0);
    let errors = range_errors_mocap(&uwb, &mocap, &setup, check.chosen, 0.05).unwrap();
    let fit = fit_uwb_errors(&errors, &UwbFitConfig::default()).unwrap();
    // README: "Ranges read about 0.1–0.2 m long".
    assert!((0.05..0.3).contains(&fit.bias_m), "bias {}", fit.bias_m);
    for b in &fit.bias_per_anchor_m {
        assert!((0.05..0.3).contains(b), "anchor bias {b}");
    }
    // Outliers are long (non-line-of-sight adds delay, never removes it).
    assert!(fit.outlier_positive_fraction > 0.9);
    assert!(fit.outlier_rate > fit.gaussian_outlier_rate);
}

#[test]
fn kolakowski_path_loss_exponent_is_physical() {
    let Some(dir) = data("ble/kolakowski") else {
        return;
    };
    let fit = fit_rssi_files(
        &dir.join("calibration/calibration_df.csv"),
        &dir.join("anchors.csv"),
        Some(&dir.join("tests/test_robot_df.csv")),
        &RssiCsvFormat::kolakowski(),
        &PathLossConfig::default(),
    )
    .unwrap();
    assert_eq!(fit.num_rows, 4104);
    assert!(
        (1.5..4.0).contains(&fit.pooled.n),
        "pooled n {}",
        fit.pooled.n
    );
    for a in &fit.per_anchor {
        assert!(
            (1.0..4.5).contains(&a.model.n),
            "anchor {} n {}",
            a.anchor,
            a.model.n
        );
        assert!((-70.0..-30.0).contains(&a.model.p1_dbm));
    }
    assert!((3.0..10.0).contains(&fit.pooled.shadowing_std_db));
    let v = fit.validation.unwrap();
    assert_eq!(v.source.rsplit('/').next(), Some("test_robot_df.csv"));
    // Held-out residuals are no wider than 1.5× the calibration shadowing, and unbiased.
    assert!(v.residual_std_db < 1.5 * fit.pooled.shadowing_std_db);
    assert!(v.residual_mean_db.abs() < 2.0);
}

#[test]
fn lias_static_ranges_read_long_with_a_tight_spread() {
    let Some(dir) = data("uwb/lias/Static/8.14") else {
        return;
    };
    let setup = UwbSetup::lias_2022_08_14();
    // Static/README.md, 2022/8/14, pose 5 at 0°: yaw 0.233°, x −0.0475, y −0.0122; the body
    // height is the dynamic mocap's (≈0.97 m).
    let pose = static_world_from_body(0.233f64.to_radians(), -0.0475, -0.0122, 0.97);
    let errors = fit_uwb_static_file(
        &dir.join("UWB_static_exp_8_14_pos5_deg_0.csv"),
        &UwbCsvFormat::lias(),
        &setup,
        &pose,
    )
    .unwrap();
    let fit = fit_uwb_errors(&errors, &UwbFitConfig::default()).unwrap();
    assert!((0.05..0.3).contains(&fit.bias_m), "bias {}", fit.bias_m);
    // Standing still, each pair's noise is a few centimetres.
    assert!(fit.robust_std_after_pair_bias_m < 0.06);
}

/// `cargo test -p nomen-fit --release -- --ignored --nocapture print_fitted_models` prints the
/// report that `docs/sensor-models.md` quotes.
#[test]
#[ignore = "runs every fit (about 50 s in a debug build); run with --release -- --ignored"]
fn print_fitted_models() {
    let Some(dir) = data("") else { return };
    let models = fit_all(&dir, &FitAllConfig::default()).unwrap();
    let json = serde_json::to_string(&models).unwrap();
    let back: nomen_fit::FittedModels = serde_json::from_str(&json).unwrap();
    assert_eq!(back.uwb.len(), 3);
    assert_eq!(models.uwb_time_offset_s.map(|o| o.abs() < 0.05), Some(true));
    #[allow(clippy::print_stdout)]
    {
        println!("{models}");
    }
}
