//! PNG plots of an identity evaluation, as readers of the identity-association papers expect
//! them: an identity timeline per scene (rows = people, x = time, colour = correct / wrong
//! subject / anonymous), accuracy over time, and box plots of tag errors (raw vs corrected) and of
//! the time to identify.
//!
//! Plots are drawn with plotters into an in-memory RGB bitmap and encoded with the `png` crate
//! ([`render_plots`]); [`write_plots`] also writes them to a directory. Text uses plotters'
//! `ab_glyph` renderer with a TrueType font read at run time from the first readable path of
//! [`PlotConfig::font_paths`] (no fontconfig or freetype at build time). Without a readable font
//! the plots are drawn without any text rather than not at all. The font is registered once per
//! process (plotters keeps a global font table; its bytes stay alive for the process).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::error::{EvalError, Result};
use crate::identity::{BoxStats, EvalReport, LabelOutcome, Timeline};

/// Where fonts usually are on Debian and Ubuntu (`fonts-dejavu-core`, `fonts-liberation`).
pub const DEFAULT_FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/freefont/FreeSans.ttf",
];

/// The font family name the plots register and use.
const FAMILY: &str = "sans-serif";

/// Colour of correctly labelled observations.
const CORRECT: RGBColor = RGBColor(44, 160, 44);
/// Colour of observations labelled with a wrong subject.
const WRONG: RGBColor = RGBColor(214, 39, 40);
/// Colour of registered subjects left anonymous.
const ANONYMOUS: RGBColor = RGBColor(170, 170, 170);
/// Colour of raw tag errors.
const RAW: RGBColor = RGBColor(255, 127, 14);
/// Colour of corrected tag errors.
const CORRECTED: RGBColor = RGBColor(31, 119, 180);

/// Size and fonts of the plots.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotConfig {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels (the timeline grows with its number of rows).
    pub height_px: u32,
    /// TrueType fonts to try, in order; the first readable one is used. Only the first call in a
    /// process loads a font.
    pub font_paths: Vec<PathBuf>,
}

impl Default for PlotConfig {
    fn default() -> Self {
        Self {
            width_px: 1200,
            height_px: 600,
            font_paths: DEFAULT_FONT_PATHS.iter().map(PathBuf::from).collect(),
        }
    }
}

/// One encoded plot.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedPlot {
    /// Suggested file name, e.g. `identity_timeline_lab.png`.
    pub file_name: String,
    /// The PNG file's bytes.
    pub png: Vec<u8>,
}

/// Draws every plot the report has data for: `identity_timeline_<scene>.png` per scene with
/// observations, `accuracy_over_time.png`, `confidence_reliability.png` (if some result line
/// joined a truth frame), `tag_error_boxplot.png` (if tags were evaluated) and
/// `time_to_identify_boxplot.png` (if some appearance was identified).
///
/// # Errors
/// [`EvalError::Plot`] if drawing or encoding fails.
pub fn render_plots(report: &EvalReport, config: &PlotConfig) -> Result<Vec<RenderedPlot>> {
    let has_text = register_font(&config.font_paths);
    let mut plots = Vec::new();
    let (w, h) = (config.width_px.max(200), config.height_px.max(150));
    for (scene, s) in &report.per_scene {
        if s.timelines.iter().all(|t| t.segments.is_empty()) {
            continue;
        }
        let rows = s.timelines.len() as u32;
        let height = h.max(120 + 28 * rows);
        let file_name = format!("identity_timeline_{}.png", file_stem(scene));
        let png = render(&file_name, w, height, |root| {
            draw_timeline(root, scene, &s.timelines, has_text)
        })?;
        plots.push(RenderedPlot { file_name, png });
    }
    if !report.overall.over_time.is_empty() {
        let file_name = "accuracy_over_time.png".to_owned();
        let png = render(&file_name, w, h, |root| {
            draw_accuracy_over_time(root, report, has_text)
        })?;
        plots.push(RenderedPlot { file_name, png });
    }
    if report.overall.confidence.num_frames > 0 {
        let file_name = "confidence_reliability.png".to_owned();
        let png = render(&file_name, w, h, |root| {
            draw_reliability(root, report, has_text)
        })?;
        plots.push(RenderedPlot { file_name, png });
    }
    let tags = &report.overall.tags;
    if tags.pooled.num_samples > 0 {
        let mut groups = vec![BoxGroup {
            name: "all tags".into(),
            boxes: vec![
                (
                    tags.pooled.raw_m.clone(),
                    tags.pooled.raw_errors_m.clone(),
                    RAW,
                ),
                (
                    tags.pooled.corrected_m.clone(),
                    tags.pooled.corrected_errors_m.clone(),
                    CORRECTED,
                ),
            ],
        }];
        if tags.per_tag.len() > 1 {
            groups.extend(tags.per_tag.iter().map(|(tag, t)| BoxGroup {
                name: tag.clone(),
                boxes: vec![
                    (t.raw_m.clone(), t.raw_errors_m.clone(), RAW),
                    (
                        t.corrected_m.clone(),
                        t.corrected_errors_m.clone(),
                        CORRECTED,
                    ),
                ],
            }));
        }
        let file_name = "tag_error_boxplot.png".to_owned();
        let legend = [("raw", RAW), ("corrected", CORRECTED)];
        let png = render(&file_name, w, h, |root| {
            draw_boxes(
                root,
                "Tag position error: raw vs corrected",
                "error (m)",
                &groups,
                &legend,
                has_text,
            )
        })?;
        plots.push(RenderedPlot { file_name, png });
    }
    if report.overall.time_to_identify.box_s.is_some() {
        let samples =
            |scene: &crate::identity::SceneReport| -> Vec<f64> { s_times(&scene.appearances) };
        let mut groups = Vec::new();
        let all: Vec<f64> = report.per_scene.values().flat_map(samples).collect();
        let never = report.overall.time_to_identify.num_never_identified;
        groups.push(BoxGroup {
            name: format!("all (n = {}, {never} never)", all.len()),
            boxes: vec![(BoxStats::from_samples(&all), all, CORRECT)],
        });
        if report.per_scene.len() > 1 {
            for (scene, s) in &report.per_scene {
                let times = samples(s);
                let never = s.metrics.time_to_identify.num_never_identified;
                groups.push(BoxGroup {
                    name: format!("{scene} (n = {}, {never} never)", times.len()),
                    boxes: vec![(BoxStats::from_samples(&times), times, CORRECT)],
                });
            }
        }
        let file_name = "time_to_identify_boxplot.png".to_owned();
        let png = render(&file_name, w, h, |root| {
            draw_boxes(
                root,
                "Time to identify after an appearance",
                "time (s)",
                &groups,
                &[],
                has_text,
            )
        })?;
        plots.push(RenderedPlot { file_name, png });
    }
    Ok(plots)
}

/// One line of a [`CurvePanel`]: a name for the legend and its points `(x, y)`, in x order.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// Legend entry.
    pub name: String,
    /// The points, `(x, y)`.
    pub points: Vec<(f64, f64)>,
}

/// One panel of [`render_curves`]: a y axis and the curves drawn against it.
#[derive(Debug, Clone, PartialEq)]
pub struct CurvePanel {
    /// Description of the y axis.
    pub y_desc: String,
    /// The curves.
    pub curves: Vec<Curve>,
}

/// Colours of the curves of a panel, in order (matplotlib's first four).
const CURVE_COLOURS: [RGBColor; 4] = [CORRECTED, RAW, CORRECT, WRONG];

/// Draws `panels` one above the other, sharing the x axis `x_desc`, under `caption`: a metric
/// against the level of something (a fault, a noise), one line with dots per curve. Each y axis
/// runs from 0 to its largest value (at least 1e-3) with 5 % head room; from just below its
/// smallest value when that is above half the largest (accuracies near 100 %).
///
/// # Errors
/// [`EvalError::Plot`] if drawing or encoding fails.
pub fn render_curves(
    file_name: &str,
    caption: &str,
    x_desc: &str,
    panels: &[CurvePanel],
    config: &PlotConfig,
) -> Result<RenderedPlot> {
    let has_text = register_font(&config.font_paths);
    let num_panels = panels.len().max(1) as u32;
    let (w, h) = (
        config.width_px.max(200),
        config.height_px.max(150).max(220 * num_panels),
    );
    let png = render(file_name, w, h, |root| {
        let (top, body) = root.split_vertically(if has_text { 40 } else { 5 });
        if has_text {
            top.draw(&Text::new(caption.to_owned(), (10, 10), text(22)))
                .map_err(err)?;
        }
        let areas = body.split_evenly((panels.len().max(1), 1));
        let points = panels
            .iter()
            .flat_map(|p| &p.curves)
            .flat_map(|c| &c.points);
        let (x0, x1) = points.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (x, _)| {
            (lo.min(*x), hi.max(*x))
        });
        let (x0, x1) = if x0.is_finite() && x1 > x0 {
            (x0, x1)
        } else if x0.is_finite() {
            (x0 - 1.0, x0 + 1.0)
        } else {
            (0.0, 1.0)
        };
        let pad = 0.03 * (x1 - x0);
        for (panel, area) in panels.iter().zip(&areas) {
            let ys = || {
                panel
                    .curves
                    .iter()
                    .flat_map(|c| &c.points)
                    .map(|(_, y)| *y)
                    .filter(|y| y.is_finite())
            };
            let y_max = ys().fold(1e-3, f64::max);
            let y_min = ys().fold(f64::INFINITY, f64::min);
            let y_lo = if y_min >= 0.5 * y_max {
                (y_min - 0.1 * (y_max - y_min) - 0.01 * y_max).max(0.0)
            } else {
                0.0
            };
            let (area, legend) = area.split_vertically(area.dim_in_pixel().1 as i32 - 24);
            let mut chart = xy_chart(
                &area,
                "",
                (
                    (x0 - pad)..(x1 + pad),
                    y_lo..(y_max + 0.05 * (y_max - y_lo)),
                ),
                (x_desc, &panel.y_desc),
                has_text,
            )?;
            let mut entries = Vec::new();
            for (curve, colour) in panel.curves.iter().zip(CURVE_COLOURS.iter().cycle()) {
                let finite: Vec<(f64, f64)> = curve
                    .points
                    .iter()
                    .copied()
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .collect();
                chart
                    .draw_series(LineSeries::new(
                        finite.iter().copied(),
                        colour.stroke_width(2),
                    ))
                    .map_err(err)?;
                chart
                    .draw_series(finite.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                    .map_err(err)?;
                entries.push((curve.name.as_str(), *colour));
            }
            if has_text {
                draw_legend(&legend, &entries, 70, 4)?;
            }
        }
        Ok(())
    })?;
    Ok(RenderedPlot {
        file_name: file_name.to_owned(),
        png,
    })
}

/// [`render_plots`], then writes every plot into `dir` (created if missing). Returns the paths
/// written.
///
/// # Errors
/// [`EvalError::Plot`] if drawing fails, [`EvalError::PlotIo`] if the directory or a file cannot
/// be written.
pub fn write_plots(report: &EvalReport, dir: &Path, config: &PlotConfig) -> Result<Vec<PathBuf>> {
    let plots = render_plots(report, config)?;
    std::fs::create_dir_all(dir).map_err(|e| io_error(dir, &e))?;
    let mut paths = Vec::with_capacity(plots.len());
    for plot in plots {
        let path = dir.join(&plot.file_name);
        std::fs::write(&path, &plot.png).map_err(|e| io_error(&path, &e))?;
        paths.push(path);
    }
    Ok(paths)
}

fn io_error(path: &Path, e: &std::io::Error) -> EvalError {
    EvalError::PlotIo {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

fn s_times(appearances: &[crate::identity::Appearance]) -> Vec<f64> {
    appearances
        .iter()
        .filter_map(|a| a.time_to_identify_s)
        .collect()
}

/// Registers the first readable font once per process; returns whether text can be drawn.
fn register_font(paths: &[PathBuf]) -> bool {
    static HAS_FONT: OnceLock<bool> = OnceLock::new();
    *HAS_FONT.get_or_init(|| {
        paths.iter().any(|path| {
            let Ok(bytes) = std::fs::read(path) else {
                return false;
            };
            // plotters' font table needs `'static` bytes: the font lives for the process.
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            plotters::style::register_font(FAMILY, FontStyle::Normal, bytes).is_ok()
        })
    })
}

/// A file-name-safe version of a scene name.
fn file_stem(name: &str) -> String {
    let stem: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if stem.is_empty() {
        "scene".into()
    } else {
        stem
    }
}

/// Draws into an RGB buffer with `draw` and encodes it as PNG.
fn render(
    plot: &str,
    width: u32,
    height: u32,
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> std::result::Result<(), String>,
) -> Result<Vec<u8>> {
    let plot_error = |message: String| EvalError::Plot {
        plot: plot.to_owned(),
        message,
    };
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(e.to_string()))?;
        draw(&root).map_err(plot_error)?;
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

fn text(size: u32) -> TextStyle<'static> {
    (FAMILY, size).into_font().color(&BLACK)
}

/// Stringifies any drawing error.
fn err<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

fn draw_legend(
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    entries: &[(&str, RGBColor)],
    x0: i32,
    y: i32,
) -> std::result::Result<(), String> {
    let (width, _) = root.dim_in_pixel();
    let total: i32 = entries
        .iter()
        .map(|(name, _)| 30 + 10 * name.chars().count() as i32)
        .sum();
    let mut x = x0.min(width as i32 - total - 10);
    for (name, colour) in entries {
        root.draw(&Rectangle::new([(x, y), (x + 16, y + 14)], colour.filled()))
            .map_err(err)?;
        root.draw(&Text::new(name.to_string(), (x + 22, y), text(16)))
            .map_err(err)?;
        x += 30 + 10 * name.chars().count() as i32;
    }
    Ok(())
}

fn draw_timeline(
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    scene: &str,
    timelines: &[Timeline],
    has_text: bool,
) -> std::result::Result<(), String> {
    let (t0, t1) = timelines
        .iter()
        .flat_map(|t| &t.segments)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), s| {
            (a.min(s.start_s), b.max(s.end_s))
        });
    let t1 = if t1 > t0 { t1 } else { t0 + 1.0 };
    let num_rows = timelines.len();
    let several_cameras = timelines
        .iter()
        .any(|t| timelines.first().is_some_and(|f| f.camera != t.camera));
    let mut builder = ChartBuilder::on(root);
    builder
        .margin(10)
        .margin_right(30)
        .margin_top(if has_text { 50 } else { 10 })
        .set_label_area_size(LabelAreaPosition::Left, if has_text { 180 } else { 10 })
        .set_label_area_size(LabelAreaPosition::Bottom, if has_text { 40 } else { 10 });
    if has_text {
        builder.caption(format!("Identity over time: {scene}"), text(22));
    }
    let mut chart = builder
        .build_cartesian_2d(t0..t1, 0.0..num_rows as f64)
        .map_err(err)?;
    let mut mesh = chart.configure_mesh();
    mesh.disable_y_mesh().y_labels(0);
    if has_text {
        mesh.x_desc("session time (s)").label_style(text(14));
    } else {
        mesh.x_labels(0);
    }
    mesh.draw().map_err(err)?;

    for (i, timeline) in timelines.iter().enumerate() {
        // Row 0 at the top.
        let y = (num_rows - 1 - i) as f64;
        chart
            .draw_series(timeline.segments.iter().map(|s| {
                let colour = match s.outcome {
                    LabelOutcome::Correct => CORRECT,
                    LabelOutcome::WrongSubject => WRONG,
                    LabelOutcome::Anonymous => ANONYMOUS,
                };
                Rectangle::new(
                    [(s.start_s, y + 0.15), (s.end_s, y + 0.85)],
                    colour.filled(),
                )
            }))
            .map_err(err)?;
        if has_text {
            let mut name = timeline.person.clone();
            if timeline.subject.is_none() {
                name.push_str(" (wears nothing)");
            } else if timeline.subject.as_deref() != Some(timeline.person.as_str()) {
                name = format!("{name} = {}", timeline.subject.as_deref().unwrap_or(""));
            }
            if several_cameras {
                name = format!("{name} @ {}", timeline.camera);
            }
            let (_, py) = chart.backend_coord(&(t0, y + 0.5));
            root.draw(&Text::new(name, (12, py - 8), text(14)))
                .map_err(err)?;
        }
    }
    if has_text {
        draw_legend(
            root,
            &[
                ("correct", CORRECT),
                ("wrong subject", WRONG),
                ("anonymous", ANONYMOUS),
            ],
            i32::MAX,
            12,
        )?;
    }
    Ok(())
}

/// A chart of `ranges` (x, y) on `root` with its mesh drawn: the caption and the axis
/// descriptions `axes` (x, y) when text can be drawn, bare axes otherwise.
fn xy_chart<'a, 'b>(
    root: &'a DrawingArea<BitMapBackend<'b>, Shift>,
    caption: &str,
    ranges: (std::ops::Range<f64>, std::ops::Range<f64>),
    axes: (&str, &str),
    has_text: bool,
) -> std::result::Result<
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    String,
> {
    let mut builder = ChartBuilder::on(root);
    builder
        .margin(10)
        .margin_right(30)
        .set_label_area_size(LabelAreaPosition::Left, if has_text { 60 } else { 10 })
        .set_label_area_size(LabelAreaPosition::Bottom, if has_text { 40 } else { 10 });
    if has_text && !caption.is_empty() {
        builder.caption(caption, text(22));
    }
    let mut chart = builder
        .build_cartesian_2d(ranges.0, ranges.1)
        .map_err(err)?;
    let mut mesh = chart.configure_mesh();
    if has_text {
        mesh.x_desc(axes.0).y_desc(axes.1).label_style(text(14));
    } else {
        mesh.x_labels(0).y_labels(0);
    }
    mesh.draw().map_err(err)?;
    Ok(chart)
}

fn draw_accuracy_over_time(
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    report: &EvalReport,
    has_text: bool,
) -> std::result::Result<(), String> {
    let bins = &report.overall.over_time;
    let t0 = bins.first().map_or(0.0, |b| b.start_s);
    let t1 = bins.last().map_or(1.0, |b| b.end_s);
    let caption = format!(
        "Identification accuracy per {} s bin (all scenes)",
        report.config.time_bin_s
    );
    let axes = ("session time (s)", "accuracy");
    let mut chart = xy_chart(root, &caption, (t0..t1, 0.0..1.05), axes, has_text)?;
    let points: Vec<(f64, f64)> = bins
        .iter()
        .filter_map(|b| b.accuracy.map(|a| (0.5 * (b.start_s + b.end_s), a)))
        .collect();
    chart
        .draw_series(LineSeries::new(
            points.iter().copied(),
            CORRECTED.stroke_width(2),
        ))
        .map_err(err)?;
    chart
        .draw_series(
            points
                .iter()
                .map(|&p| Circle::new(p, 3, CORRECTED.filled())),
        )
        .map_err(err)?;
    Ok(())
}

/// The reliability diagram of the confidences (all scenes): each confidence bin's accuracy
/// against its mean confidence, a dot whose area grows with the bin's frames, over the diagonal
/// of perfect calibration.
fn draw_reliability(
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    report: &EvalReport,
    has_text: bool,
) -> std::result::Result<(), String> {
    let confidence = &report.overall.confidence;
    let fmt = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.3}"));
    let caption = format!(
        "Confidence reliability (all scenes): ECE {}, Brier {}",
        fmt(confidence.ece),
        fmt(confidence.brier)
    );
    let axes = ("mean confidence of the bin", "fraction right");
    let mut chart = xy_chart(root, &caption, (0.0..1.0, 0.0..1.05), axes, has_text)?;
    chart
        .draw_series(LineSeries::new(
            [(0.0, 0.0), (1.0, 1.0)],
            ANONYMOUS.stroke_width(1),
        ))
        .map_err(err)?;
    let points: Vec<((f64, f64), u64)> = confidence
        .bins
        .iter()
        .filter_map(|b| Some(((b.mean_confidence?, b.accuracy?), b.num_frames)))
        .collect();
    let most = points.iter().map(|(_, n)| *n).max().unwrap_or(1).max(1) as f64;
    chart
        .draw_series(points.iter().map(|&(p, n)| {
            // Radius 3 to 12 px, the area in proportion to the frames.
            let radius = 3.0 + 9.0 * (n as f64 / most).sqrt();
            Circle::new(p, radius.round() as i32, CORRECTED.filled())
        }))
        .map_err(err)?;
    Ok(())
}

/// Up to this many samples, a box plot also shows every sample as a dot.
const MAX_SAMPLES_SHOWN: usize = 50;

/// A labelled group of boxes drawn side by side: (summary, samples for outliers, colour).
struct BoxGroup {
    name: String,
    boxes: Vec<(Option<BoxStats>, Vec<f64>, RGBColor)>,
}

fn draw_boxes(
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    title: &str,
    y_desc: &str,
    groups: &[BoxGroup],
    legend: &[(&str, RGBColor)],
    has_text: bool,
) -> std::result::Result<(), String> {
    let y_max = groups
        .iter()
        .flat_map(|g| &g.boxes)
        .filter_map(|(b, _, _)| b.as_ref().map(|b| b.max))
        .fold(0.0_f64, f64::max);
    let y_max = if y_max > 0.0 { 1.08 * y_max } else { 1.0 };
    let mut builder = ChartBuilder::on(root);
    builder
        .margin(10)
        .margin_top(if has_text { 50 } else { 10 })
        .set_label_area_size(LabelAreaPosition::Left, if has_text { 70 } else { 10 })
        .set_label_area_size(LabelAreaPosition::Bottom, if has_text { 40 } else { 10 });
    if has_text {
        builder.caption(title, text(22));
    }
    let n = groups.len() as f64;
    let mut chart = builder
        .build_cartesian_2d(-0.5..n - 0.5, 0.0..y_max)
        .map_err(err)?;
    let mut mesh = chart.configure_mesh();
    mesh.disable_x_mesh().x_labels(0);
    if has_text {
        mesh.y_desc(y_desc).label_style(text(14));
    } else {
        mesh.y_labels(0);
    }
    mesh.draw().map_err(err)?;

    for (g, group) in groups.iter().enumerate() {
        let k = group.boxes.len().max(1) as f64;
        let slot = 0.8 / k;
        for (b, (stats, samples, colour)) in group.boxes.iter().enumerate() {
            let Some(s) = stats else { continue };
            let x = g as f64 - 0.4 + slot * (b as f64 + 0.5);
            let half = (0.35 * slot).min(0.12);
            let line = colour.stroke_width(2);
            let fill = colour.mix(0.35).filled();
            chart
                .draw_series([
                    Rectangle::new([(x - half, s.q1), (x + half, s.q3)], fill),
                    Rectangle::new([(x - half, s.q1), (x + half, s.q3)], line),
                ])
                .map_err(err)?;
            let segments = [
                [(x - half, s.median), (x + half, s.median)],
                [(x, s.q3), (x, s.whisker_high)],
                [(x, s.q1), (x, s.whisker_low)],
                [
                    (x - half / 2.0, s.whisker_high),
                    (x + half / 2.0, s.whisker_high),
                ],
                [
                    (x - half / 2.0, s.whisker_low),
                    (x + half / 2.0, s.whisker_low),
                ],
            ];
            chart
                .draw_series(
                    segments
                        .iter()
                        .map(|seg| PathElement::new(seg.to_vec(), line)),
                )
                .map_err(err)?;
            // Few samples: show them all beside the box; many: only the outliers on it.
            let (dots, dot_x): (Vec<f64>, f64) = if samples.len() <= MAX_SAMPLES_SHOWN {
                (samples.clone(), x + 1.6 * half)
            } else {
                let outliers = samples
                    .iter()
                    .copied()
                    .filter(|&v| v < s.whisker_low || v > s.whisker_high)
                    .collect();
                (outliers, x)
            };
            chart
                .draw_series(
                    dots.iter()
                        .map(|&v| Circle::new((dot_x, v), 3, colour.stroke_width(1))),
                )
                .map_err(err)?;
        }
        if has_text {
            let (px, py) = chart.backend_coord(&(g as f64, 0.0));
            let width = 7 * group.name.chars().count() as i32;
            root.draw(&Text::new(
                group.name.clone(),
                (px - width / 2, py + 10),
                text(15),
            ))
            .map_err(err)?;
        }
    }
    if has_text && !legend.is_empty() {
        draw_legend(root, legend, i32::MAX, 12)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_names_become_safe_file_stems() {
        assert_eq!(file_stem("lab/day 1"), "lab_day_1");
        assert_eq!(file_stem(""), "scene");
    }
}
