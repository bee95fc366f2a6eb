//! Box plots of the experiment (PNG bytes; the caller writes them): error at the occluded-wrist
//! truth and 95 % ellipsoid volume, one box per variant.
//!
//! Drawn with plotters into an in-memory bitmap and encoded with `png`. Text needs a TrueType
//! font, passed in as bytes (the CLI reads it; see `nomen_eval::plots::DEFAULT_FONT_PATHS`);
//! without one the plots are drawn without text. plotters keeps fonts in a process-wide table,
//! so the first font given is the one used.

use crate::error::{OcclusionError, Result};
use crate::experiment::{OcclusionReport, quantile};
use plotters::prelude::*;
use std::sync::OnceLock;

/// Font family name registered with plotters.
const FAMILY: &str = "nomen-occlusion-sans";

/// Box colours per variant, in report order.
const COLOURS: [RGBColor; 5] = [
    RGBColor(214, 39, 40),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(127, 127, 127),
    RGBColor(31, 119, 180),
];

/// One encoded plot.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedPlot {
    /// Suggested file name.
    pub file_name: String,
    /// PNG bytes.
    pub png: Vec<u8>,
}

fn register_font(font_ttf: Option<&[u8]>) -> bool {
    static HAS_FONT: OnceLock<bool> = OnceLock::new();
    *HAS_FONT.get_or_init(|| {
        font_ttf.is_some_and(|bytes| {
            // plotters needs `'static` bytes: the font lives for the process.
            let bytes: &'static [u8] = Box::leak(bytes.to_vec().into_boxed_slice());
            plotters::style::register_font(FAMILY, FontStyle::Normal, bytes).is_ok()
        })
    })
}

struct BoxStats {
    q1: f64,
    median: f64,
    q3: f64,
    low: f64,
    high: f64,
}

fn box_stats(samples: &[f64]) -> Option<BoxStats> {
    let (q1, median, q3) = (
        quantile(samples, 0.25)?,
        quantile(samples, 0.5)?,
        quantile(samples, 0.75)?,
    );
    let iqr = q3 - q1;
    let inside = samples
        .iter()
        .copied()
        .filter(|v| v.is_finite() && *v >= q1 - 1.5 * iqr && *v <= q3 + 1.5 * iqr);
    let low = inside.clone().fold(f64::INFINITY, f64::min);
    let high = inside.fold(f64::NEG_INFINITY, f64::max);
    Some(BoxStats {
        q1,
        median,
        q3,
        low,
        high,
    })
}

/// Draws `occlusion_error_boxplot.png` (cm) and `occlusion_volume_boxplot.png` (litres).
///
/// # Errors
/// [`OcclusionError::Plot`] if drawing or encoding fails.
pub fn render_boxplots(
    report: &OcclusionReport,
    font_ttf: Option<&[u8]>,
) -> Result<Vec<RenderedPlot>> {
    let has_text = register_font(font_ttf);
    let names: Vec<&str> = report.variants.iter().map(|v| v.name.as_str()).collect();
    let errors: Vec<Vec<f64>> = report
        .variants
        .iter()
        .map(|v| v.errors_m.iter().map(|e| e * 100.0).collect())
        .collect();
    let volumes: Vec<Vec<f64>> = report
        .variants
        .iter()
        .map(|v| v.volumes_m3.iter().map(|e| e * 1000.0).collect())
        .collect();
    Ok(vec![
        RenderedPlot {
            file_name: "occlusion_error_boxplot.png".into(),
            png: render_one(
                "occlusion_error_boxplot.png",
                "Occluded-wrist error per variant",
                "error [cm]",
                &names,
                &errors,
                has_text,
            )?,
        },
        RenderedPlot {
            file_name: "occlusion_volume_boxplot.png".into(),
            png: render_one(
                "occlusion_volume_boxplot.png",
                "95% ellipsoid volume per variant",
                "volume [litre]",
                &names,
                &volumes,
                has_text,
            )?,
        },
    ])
}

fn render_one(
    file_name: &str,
    title: &str,
    y_desc: &str,
    names: &[&str],
    samples: &[Vec<f64>],
    has_text: bool,
) -> Result<Vec<u8>> {
    let plot_error = |what: String| OcclusionError::Plot {
        name: file_name.to_owned(),
        what,
    };
    let (width, height) = (900u32, 600u32);
    let stats: Vec<Option<BoxStats>> = samples.iter().map(|s| box_stats(s)).collect();
    let y_max = stats
        .iter()
        .flatten()
        .map(|s| s.high)
        .fold(0.0_f64, f64::max);
    let y_max = if y_max > 0.0 { 1.1 * y_max } else { 1.0 };
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(e.to_string()))?;
        let draw = || -> std::result::Result<(), String> {
            let text = |size: u32| (FAMILY, size).into_font().color(&BLACK);
            let mut builder = ChartBuilder::on(&root);
            builder
                .margin(10)
                .margin_top(if has_text { 50 } else { 10 })
                .set_label_area_size(LabelAreaPosition::Left, if has_text { 70 } else { 10 })
                .set_label_area_size(LabelAreaPosition::Bottom, if has_text { 40 } else { 10 });
            if has_text {
                builder.caption(title, text(22));
            }
            let n = names.len() as f64;
            let mut chart = builder
                .build_cartesian_2d(-0.5..n - 0.5, 0.0..y_max)
                .map_err(|e| e.to_string())?;
            let mut mesh = chart.configure_mesh();
            mesh.disable_x_mesh().x_labels(0);
            if has_text {
                mesh.y_desc(y_desc).label_style(text(14));
            } else {
                mesh.y_labels(0);
            }
            mesh.draw().map_err(|e| e.to_string())?;
            for (i, s) in stats.iter().enumerate() {
                let Some(s) = s else { continue };
                let colour = COLOURS[i % COLOURS.len()];
                let x = i as f64;
                let half = 0.25;
                chart
                    .draw_series([
                        Rectangle::new(
                            [(x - half, s.q1), (x + half, s.q3)],
                            colour.mix(0.35).filled(),
                        ),
                        Rectangle::new(
                            [(x - half, s.q1), (x + half, s.q3)],
                            colour.stroke_width(2),
                        ),
                    ])
                    .map_err(|e| e.to_string())?;
                let segments = [
                    [(x - half, s.median), (x + half, s.median)],
                    [(x, s.q3), (x, s.high)],
                    [(x, s.q1), (x, s.low)],
                    [(x - half / 2.0, s.high), (x + half / 2.0, s.high)],
                    [(x - half / 2.0, s.low), (x + half / 2.0, s.low)],
                ];
                chart
                    .draw_series(
                        segments
                            .iter()
                            .map(|seg| PathElement::new(seg.to_vec(), colour.stroke_width(2))),
                    )
                    .map_err(|e| e.to_string())?;
                if has_text {
                    let (px, py) = chart.backend_coord(&(x, 0.0));
                    let label = format!("{} (median {:.3})", names[i], s.median);
                    let w = 6 * label.chars().count() as i32;
                    root.draw(&Text::new(label, (px - w / 2, py + 10), text(13)))
                        .map_err(|e| e.to_string())?;
                }
            }
            Ok(())
        };
        draw().map_err(plot_error)?;
        root.present().map_err(|e| plot_error(e.to_string()))?;
    }
    let mut png_bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut png_bytes, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder
        .write_header()
        .map_err(|e| plot_error(e.to_string()))?;
    writer
        .write_image_data(&rgb)
        .map_err(|e| plot_error(e.to_string()))?;
    writer.finish().map_err(|e| plot_error(e.to_string()))?;
    Ok(png_bytes)
}
