//! [`FittedModels`]: every fitted parameter in one serialisable bundle, with a markdown report.

use crate::imu::{ImuNoiseFit, ImuNoiseSummary, SensorNoise};
use crate::rssi::PathLossFit;
use crate::uwb::{ConventionCheck, UwbRangeFit};
use serde::{Deserialize, Serialize};
use std::fmt::{self, Display, Formatter, Write as _};

/// The surveyed pose used as truth for one static UWB file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StaticPoseTruth {
    /// File name.
    pub file: String,
    /// Yaw from the README, degrees.
    pub yaw_deg: f64,
    /// Body origin, m (z from the dynamic mocap).
    pub position_m: [f64; 3],
}

/// Every fitted sensor model; the simulator takes its defaults from these numbers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FittedModels {
    /// IMU noise per recording (four BROAD trials, then x-io).
    pub imu: Vec<ImuNoiseFit>,
    /// Simulator defaults per IMU: BROAD (median over its four trials), x-io.
    pub imu_summary: Vec<ImuNoiseSummary>,
    /// How the LIAS mocap quaternion convention was decided.
    pub uwb_convention: ConventionCheck,
    /// UWB-to-mocap clock offset that best aligns the fast dynamic run, s (`None` = not scanned).
    pub uwb_time_offset_s: Option<f64>,
    /// Truth poses of the static UWB files.
    pub uwb_static_poses: Vec<StaticPoseTruth>,
    /// UWB ranging error: dynamic fast, dynamic mid, static (three files pooled).
    pub uwb: Vec<UwbRangeFit>,
    /// BLE path loss (Kolakowski), with validation on the robot test run.
    pub rssi: PathLossFit,
}

fn opt(v: Option<f64>, scale: f64, digits: usize) -> String {
    v.map_or_else(|| "—".to_owned(), |x| format!("{:.*}", digits, x * scale))
}

fn axes3(values: [f64; 3], scale: f64, digits: usize) -> String {
    values
        .map(|v| format!("{:.*}", digits, v * scale))
        .join(" / ")
}

fn sensor_rows(
    out: &mut String,
    label: &str,
    s: &SensorNoise,
    unit: &str,
    scale: f64,
) -> fmt::Result {
    let a = &s.axes;
    let pick = |f: &dyn Fn(&crate::imu::AxisNoise) -> Option<f64>| {
        [0, 1, 2].map(|i| opt(f(&a[i]), scale, 3)).join(" / ")
    };
    writeln!(
        out,
        "| {label} white-noise σ ({unit}) | {} |",
        axes3(a.clone().map(|x| x.white_noise_std), scale, 3)
    )?;
    writeln!(
        out,
        "| {label} noise density ({unit}/√Hz) | {} |",
        axes3(a.clone().map(|x| x.noise_density), scale, 4)
    )?;
    writeln!(
        out,
        "| {label} random walk, ADEV(1 s) ({unit}/√Hz) | {} |",
        pick(&|x| x.random_walk_adev_1s)
    )?;
    writeln!(
        out,
        "| {label} bias instability ({unit}; ≤ = curve still falling) | {} |",
        [0, 1, 2]
            .map(|i| {
                let bound = if a[i].is_bias_instability_upper_bound {
                    "≤"
                } else {
                    ""
                };
                format!("{bound}{}", opt(a[i].bias_instability, scale, 3))
            })
            .join(" / ")
    )?;
    writeln!(
        out,
        "| {label} τ at ADEV minimum (s) | {} |",
        [0, 1, 2]
            .map(|i| opt(a[i].adev_min_tau_s, 1.0, 2))
            .join(" / ")
    )?;
    writeln!(
        out,
        "| {label} bias random walk | {} |",
        s.bias_random_walk_note
    )
}

impl FittedModels {
    /// The markdown report (also what `Display` prints).
    pub fn to_markdown(&self) -> String {
        let mut out = String::new();
        // Writing to a String cannot fail.
        let _ = self.write_markdown(&mut out);
        out
    }

    fn write_markdown(&self, out: &mut String) -> fmt::Result {
        writeln!(out, "# Fitted sensor models\n")?;
        writeln!(out, "## IMU noise at rest\n")?;
        writeln!(
            out,
            "Simulator defaults (medians over recordings × axes):\n"
        )?;
        writeln!(
            out,
            "| IMU | rate (Hz) | gyro σ (rad/s) | gyro ARW (rad/s/√Hz) | gyro bias instab. (rad/s) | max abs gyro bias (rad/s) | accel σ (m/s²) | accel VRW (m/s²/√Hz) | accel bias instab. (m/s²) | max abs(‖a‖ − g) (m/s²) |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
        )?;
        for s in &self.imu_summary {
            writeln!(
                out,
                "| {} ({} rec.) | {:.1} | {:.2e} | {:.2e} | ≤ {:.2e} | {:.2e} | {:.2e} | {:.2e} | ≤ {:.2e} | {:.3} |",
                s.label,
                s.num_recordings,
                s.rate_hz,
                s.gyro_white_noise_std_radps,
                s.gyro_noise_density_radps_per_sqrt_hz,
                s.gyro_bias_instability_radps,
                s.gyro_bias_max_abs_radps,
                s.accel_white_noise_std_mps2,
                s.accel_noise_density_mps2_per_sqrt_hz,
                s.accel_bias_instability_mps2,
                s.accel_norm_bias_max_abs_mps2
            )?;
        }
        writeln!(out)?;
        writeln!(
            out,
            "Gyroscope in mrad/s, accelerometer in mm/s² (x / y / z).\n"
        )?;
        for f in &self.imu {
            writeln!(out, "### {}\n", f.source)?;
            writeln!(out, "| quantity | value |\n| --- | --- |")?;
            writeln!(out, "| rate (Hz) | {:.3} |", f.rate_hz)?;
            writeln!(out, "| stillness rule | {} |", f.stillness_rule)?;
            let segs: Vec<String> = f
                .still_segments_s
                .iter()
                .map(|s| format!("{:.1}–{:.1} s", s[0], s[1]))
                .collect();
            writeln!(
                out,
                "| still segments | {} (total {:.1} s) |",
                segs.join(", "),
                f.still_duration_s
            )?;
            sensor_rows(out, "gyro", &f.gyro, "mrad/s", 1e3)?;
            writeln!(
                out,
                "| gyro bias (mrad/s) | {} |",
                axes3(f.gyro_bias_radps, 1e3, 3)
            )?;
            sensor_rows(out, "accel", &f.accel, "mm/s²", 1e3)?;
            writeln!(
                out,
                "| accel norm at rest (m/s²) | {:.4} (vs {:.2}: {:+.4}, {:+.2} %) |\n",
                f.accel_norm_at_rest_mps2,
                f.gravity_reference_mps2,
                f.accel_norm_bias_mps2,
                100.0 * f.accel_norm_bias_mps2 / f.gravity_reference_mps2
            )?;
        }

        writeln!(out, "## UWB ranging (LIAS)\n")?;
        writeln!(
            out,
            "Quaternion convention check (robust σ of range error after removing each anchor-tag pair's median):\n"
        )?;
        writeln!(out, "| candidate | robust σ (m) |\n| --- | --- |")?;
        for s in &self.uwb_convention.scores {
            writeln!(out, "| {} | {:.4} |", s.label, s.robust_std_m)?;
        }
        writeln!(
            out,
            "\nChosen: **{}** (median tilt of the tag plane {:.2}°).",
            self.uwb_convention.chosen.label(),
            self.uwb_convention.median_tilt_rad.to_degrees()
        )?;
        if let Some(o) = self.uwb_time_offset_s {
            writeln!(
                out,
                "Best UWB-to-mocap clock offset (fast run, ±0.2 s scan, 10 ms steps): {o:+.2} s.\n"
            )?;
        }
        writeln!(
            out,
            "| quantity | {} |",
            self.uwb
                .iter()
                .map(|u| short_name(&u.source))
                .collect::<Vec<_>>()
                .join(" | ")
        )?;
        writeln!(out, "| --- |{}", " --- |".repeat(self.uwb.len()))?;
        let row = |out: &mut String, label: &str, f: &dyn Fn(&UwbRangeFit) -> String| {
            writeln!(
                out,
                "| {label} | {} |",
                self.uwb.iter().map(f).collect::<Vec<_>>().join(" | ")
            )
        };
        row(out, "ranges", &|u| u.num_ranges.to_string())?;
        row(out, "bias = median error (m)", &|u| {
            format!("{:+.3}", u.bias_m)
        })?;
        row(out, "mean error (m)", &|u| format!("{:+.3}", u.mean_m))?;
        row(out, "σ (m)", &|u| format!("{:.3}", u.std_m))?;
        row(out, "robust σ, 1.4826·MAD (m)", &|u| {
            format!("{:.3}", u.robust_std_m)
        })?;
        row(out, "robust σ after per-pair bias (m)", &|u| {
            format!("{:.3}", u.robust_std_after_pair_bias_m)
        })?;
        row(out, "outlier rate, k = 3 (Gaussian 0.27 %)", &|u| {
            format!("{:.2} %", 100.0 * u.outlier_rate)
        })?;
        row(out, "outliers that read long", &|u| {
            format!("{:.0} %", 100.0 * u.outlier_positive_fraction)
        })?;
        for (label, pick) in [
            (
                "raw",
                (|u: &UwbRangeFit| &u.distribution)
                    as fn(&UwbRangeFit) -> &crate::uwb::ErrorDistributionFits,
            ),
            ("after per-pair bias", |u: &UwbRangeFit| {
                &u.distribution_after_pair_bias
            }),
        ] {
            row(out, &format!("Student-t ν ({label})"), &|u| {
                format!("{:.1}", pick(u).student_t.nu)
            })?;
            row(
                out,
                &format!("Student-t location / scale, m ({label})"),
                &|u| {
                    let t = &pick(u).student_t;
                    format!("{:+.3} / {:.3}", t.location, t.scale)
                },
            )?;
            row(
                out,
                &format!("Gauss+exp μ / σ / tail weight / tail mean, m ({label})"),
                &|u| {
                    let m = &pick(u).gauss_exp;
                    format!(
                        "{:+.3} / {:.3} / {:.3} / {:.3}",
                        m.mean, m.std, m.tail_weight, m.tail_mean_excess
                    )
                },
            )?;
            row(
                out,
                &format!("ln L gain over Gaussian t / mix, nats/range ({label})"),
                &|u| {
                    let g = pick(u).gain_over_gaussian_nats;
                    format!("{:.3} / {:.3}", g[0], g[1])
                },
            )?;
            row(out, &format!("preferred by AIC ({label})"), &|u| {
                pick(u).preferred.clone()
            })?;
        }
        row(out, "dropout rate (0.0 entries)", &|u| {
            format!("{:.2} %", 100.0 * u.dropout_rate)
        })?;
        row(out, "misaligned rows skipped", &|u| {
            format!("{:.2} %", 100.0 * u.skipped_row_rate)
        })?;
        row(out, "bias spread between anchors, σ (m)", &|u| {
            format!("{:.3}", u.bias_spread_between_anchors_m)
        })?;
        row(out, "bias per anchor a0…a7 (m)", &|u| {
            u.bias_per_anchor_m
                .iter()
                .map(|b| format!("{b:+.2}"))
                .collect::<Vec<_>>()
                .join(" ")
        })?;
        row(out, "error-vs-range slope (m/m, Huber)", &|u| {
            format!(
                "{:+.4} ± {:.4}",
                u.error_vs_distance.slope, u.error_vs_distance.slope_std_err
            )
        })?;
        writeln!(
            out,
            "\nMedian error (robust σ) per true-range bin, m:\n\n| range (m) | {} |\n| --- |{}",
            self.uwb
                .iter()
                .map(|u| short_name(&u.source))
                .collect::<Vec<_>>()
                .join(" | "),
            " --- |".repeat(self.uwb.len())
        )?;
        let max_bin = self
            .uwb
            .iter()
            .flat_map(|u| u.distance_bins.iter().map(|b| b.to_m))
            .fold(0.0, f64::max);
        let mut from = 0.0;
        while from < max_bin {
            let cells: Vec<String> = self
                .uwb
                .iter()
                .map(|u| {
                    u.distance_bins
                        .iter()
                        .find(|b| (b.from_m - from).abs() < 1e-9)
                        .map_or_else(
                            || "—".to_owned(),
                            |b| format!("{:+.3} ({:.3})", b.median_error_m, b.robust_std_m),
                        )
                })
                .collect();
            let width = self
                .uwb
                .first()
                .and_then(|u| u.distance_bins.first())
                .map_or(1.0, |b| b.to_m - b.from_m);
            writeln!(
                out,
                "| {:.0}–{:.0} | {} |",
                from,
                from + width,
                cells.join(" | ")
            )?;
            from += width;
        }
        writeln!(out)?;

        let r = &self.rssi;
        writeln!(out, "## BLE RSSI path loss (Kolakowski)\n")?;
        writeln!(
            out,
            "`P(d) = P1 − 10·n·log10(d)`, Huber IRLS, 3D distance, tag at 1.3 m; {} rows of `{}`.\n",
            r.num_rows,
            short_name(&r.source)
        )?;
        writeln!(
            out,
            "| anchor | P1 (dBm) | n | σ shadowing (dB) | robust σ (dB) | reads | d range (m) |\n| --- | --- | --- | --- | --- | --- | --- |"
        )?;
        let model_row =
            |out: &mut String, id: &str, m: &crate::rssi::PathLossModel, range: String| {
                writeln!(
                    out,
                    "| {id} | {:.1} | {:.2} ± {:.2} | {:.1} | {:.1} | {} | {range} |",
                    m.p1_dbm,
                    m.n,
                    m.n_std_err,
                    m.shadowing_std_db,
                    m.shadowing_robust_std_db,
                    m.num_reads
                )
            };
        for a in &r.per_anchor {
            model_row(
                out,
                &a.anchor,
                &a.model,
                format!("{:.1}–{:.1}", a.distance_range_m[0], a.distance_range_m[1]),
            )?;
        }
        model_row(out, "pooled", &r.pooled, String::new())?;
        writeln!(
            out,
            "\nRead rate (reads / rows) against distance, overall {:.1} %:\n",
            100.0 * r.overall_read_rate
        )?;
        writeln!(
            out,
            "| distance (m) | rows | read rate |\n| --- | --- | --- |"
        )?;
        for b in &r.read_rate {
            writeln!(
                out,
                "| {:.0}–{:.0} | {} | {:.1} % |",
                b.from_m,
                b.to_m,
                b.num_slots,
                100.0 * b.read_rate
            )?;
        }
        if let Some(v) = &r.validation {
            writeln!(
                out,
                "\nValidation on `{}` ({} reads, per-anchor models): residual mean {:+.2} dB, σ {:.2} dB, robust σ {:.2} dB; \
                 inverting the model gives a median |distance error| of {:.2} m (median true distance {:.2} m; per anchor {}).",
                short_name(&v.source),
                v.num_reads,
                v.residual_mean_db,
                v.residual_std_db,
                v.residual_robust_std_db,
                v.median_abs_distance_error_m,
                v.median_true_distance_m,
                v.median_abs_distance_error_per_anchor_m
                    .iter()
                    .map(|e| format!("{e:.2}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            )?;
        }
        Ok(())
    }
}

fn short_name(path: &str) -> String {
    path.split(" + ")
        .map(|p| p.rsplit('/').next().unwrap_or(p))
        .collect::<Vec<_>>()
        .join(" + ")
}

impl Display for FittedModels {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_markdown())
    }
}
