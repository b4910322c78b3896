//! PNG pictures of analyses (plotters, bitmap backend, bundled DejaVu Sans): a recording's
//! spectrogram with its modes and (f, d) plane, an estimate's features against the Rayleigh
//! curve with the two loudness images the metric compares, and any signal's spectrogram.
//!
//! An edge crate like `resound-io`: it writes files (atomically). It sits above the numeric
//! crates and below the facade, so the CLI, the demo and other front ends draw the same pictures.
#![warn(missing_docs)]

use plotters::prelude::*;
use resound_core::DampedMode;
use resound_estimate::image::{LoudnessImage, BANDS};
use resound_io::atomic::write_atomic;
use resound_signal::stft::Spectrogram;
use resound_signal::Analysis;
use std::path::Path;

/// Why a picture could not be drawn or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// Drawing failed.
    #[error("plot: {0}")]
    Draw(String),
    /// Writing failed.
    #[error(transparent)]
    Io(#[from] resound_io::IoError),
    /// The temporary PNG encoding file failed.
    #[error("plot: {0}")]
    Temp(#[from] std::io::Error),
}

/// `Result` with [`PlotError`].
pub type Result<T> = std::result::Result<T, PlotError>;

fn draw_err(e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw(e.to_string())
}

static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The bundled font is valid; a failure would only lose the labels.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Perceptual-ish colour map from dark blue through orange to yellow; `v` in [0, 1].
fn colour(v: f64) -> RGBColor {
    let v = v.clamp(0.0, 1.0);
    let stops = [
        (10.0, 10.0, 40.0),
        (90.0, 30.0, 120.0),
        (200.0, 60.0, 60.0),
        (250.0, 160.0, 30.0),
        (252.0, 250.0, 160.0),
    ];
    let x = v * (stops.len() - 1) as f64;
    let i = (x.floor() as usize).min(stops.len() - 2);
    let t = x - i as f64;
    let (a, b) = (stops[i], stops[i + 1]);
    RGBColor(
        (a.0 + t * (b.0 - a.0)) as u8,
        (a.1 + t * (b.1 - a.1)) as u8,
        (a.2 + t * (b.2 - a.2)) as u8,
    )
}

/// Spectrogram of the analysed segment (onset-aligned) with the modes marked, and the (f, d)
/// feature plane (Ren 2013 Fig. 3 and 6), written atomically to `path`.
///
/// # Errors
/// [`PlotError`] when drawing or writing fails.
pub fn analysis_png(path: &Path, res: &Analysis, title: &str) -> Result<()> {
    let seg = &res.segment;
    register_font();
    let (w, h) = (1400u32, 620u32);
    let mut pixels = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let (left, right) = root.split_horizontally(820);
        draw_spectrogram(&left, seg, res, title).map_err(draw_err)?;
        draw_features(&right, res).map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    let img = image_png(&pixels, w, h)?;
    write_atomic(path, |out| out.write_all(&img))?;
    Ok(())
}

/// Encodes RGB pixels as PNG through plotters' bitmap encoder (via a temporary file).
fn image_png(pixels: &[u8], w: u32, h: u32) -> Result<Vec<u8>> {
    let dir = tempfile::tempdir()?;
    let p = dir.path().join("plot.png");
    {
        let root = BitMapBackend::new(&p, (w, h)).into_drawing_area();
        let src = BitMapElement::with_owned_buffer((0, 0), (w, h), pixels.to_vec())
            .ok_or_else(|| PlotError::Draw("plot buffer has the wrong size".into()))?;
        root.draw(&src).map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    Ok(std::fs::read(&p)?)
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// A title for a caption: a path becomes its file name, and a long one is cut with "…" (the
/// full path was cut off at the image's edge).
pub fn short_title(title: &str) -> String {
    let name = std::path::Path::new(title)
        .file_name()
        .map_or_else(|| title.to_string(), |n| n.to_string_lossy().into_owned());
    if name.chars().count() > 48 {
        let head: String = name.chars().take(47).collect();
        format!("{head}…")
    } else {
        name
    }
}

/// Tick labels of a log axis at 1, 2 and 5 × 10^k (the axis asks for every 1–9 × 10^k: with
/// plotters' default a decade-wide axis had one label).
fn log_label(v: f64) -> String {
    if !(v > 0.0) {
        return String::new();
    }
    let e = v.log10().floor();
    let mantissa = (v / 10f64.powf(e)).round();
    if ![1.0, 2.0, 5.0].contains(&mantissa) || ((v / 10f64.powf(e)) - mantissa).abs() > 0.05 {
        return String::new();
    }
    if v >= 1.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.prec$}", prec = (-e) as usize)
    }
}

/// The power of ten at or below `v` (plotters labels a log axis only from its first power of
/// ten on).
fn decade_below(v: f64) -> f64 {
    10f64.powf(v.log10().floor())
}

/// Labels requested on a log axis so that plotters places 1–9 × 10^k.
const LOG_LABELS: usize = 60;

/// A vertical colour bar for `colour` from `lo` to `hi` (labelled in `unit`).
fn draw_colour_bar(
    area: &Area<'_>,
    lo: f64,
    hi: f64,
    unit: &str,
    map: &dyn Fn(f64) -> f64,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let mut chart = ChartBuilder::on(area)
        .margin_top(38)
        .margin_bottom(50)
        .margin_right(6)
        .y_label_area_size(46)
        .build_cartesian_2d(0.0..1.0, lo..hi)?;
    chart
        .configure_mesh()
        .disable_x_axis()
        .disable_mesh()
        .y_labels(6)
        .y_label_formatter(&|v| format!("{v:.0}"))
        .y_label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 13))
        .y_desc(unit)
        .draw()?;
    let n = 100;
    chart.draw_series((0..n).map(|i| {
        let a = lo + (hi - lo) * i as f64 / n as f64;
        let b = lo + (hi - lo) * (i + 1) as f64 / n as f64;
        Rectangle::new([(0.0, a), (1.0, b)], colour(map(0.5 * (a + b))).filled())
    }))?;
    Ok(())
}

/// Spectrogram of a signal, written atomically to `path`.
pub fn spectrogram_png(path: &Path, x: &[f64], sample_rate_hz: f64, title: &str) -> Result<()> {
    spectrograms_png(path, &[(title, x)], sample_rate_hz, &[])
}

/// Spectrograms of several channels (each `(title, samples)`), one above the other on one
/// time axis, with `marks_s` (event times, s: a scene's impacts) marked on each, written
/// atomically to `path`.
pub fn spectrograms_png(
    path: &Path,
    channels: &[(&str, &[f64])],
    sample_rate_hz: f64,
    marks_s: &[f64],
) -> Result<()> {
    register_font();
    let rows = channels.len().max(1) as u32;
    let (w, h) = (1000u32, 60 + 440 * rows);
    let mut pixels = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let areas = root.split_evenly((channels.len().max(1), 1));
        for ((title, x), area) in channels.iter().zip(&areas) {
            draw_spectrogram_of(
                area,
                x,
                sample_rate_hz,
                &[],
                title,
                Some(x.len() as f64 / sample_rate_hz),
                marks_s,
            )
            .map_err(draw_err)?;
        }
        root.present().map_err(draw_err)?;
    }
    let img = image_png(&pixels, w, h)?;
    write_atomic(path, |out| out.write_all(&img))?;
    Ok(())
}

fn draw_spectrogram(
    area: &Area<'_>,
    seg: &[f64],
    res: &Analysis,
    title: &str,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    draw_spectrogram_of(area, seg, res.sample_rate_hz, &res.modes, title, None, &[])
}

fn draw_spectrogram_of(
    area: &Area<'_>,
    seg: &[f64],
    fs: f64,
    modes: &[DampedMode],
    title: &str,
    span_s: Option<f64>,
    marks_s: &[f64],
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    struct Res<'a> {
        modes: &'a [DampedMode],
    }
    let res = Res { modes };
    let window = if seg.len() >= 4096 {
        2048
    } else {
        (seg.len() / 2).next_power_of_two().max(64) / 2
    };
    let Some(spec) = Spectrogram::compute(seg, fs, window) else {
        return Ok(());
    };
    let f_top = if res.modes.is_empty() {
        0.5 * fs
    } else {
        res.modes
            .iter()
            .map(|m| m.freq_hz)
            .fold(0.0, f64::max)
            .mul_add(1.25, 200.0)
            .min(0.5 * fs)
    };
    // The whole segment analysed (a shorter view hid most of what was fitted).
    let t_end = span_s.unwrap_or(seg.len() as f64 / fs).max(1e-3);
    let (area, bar) = area.split_horizontally(area.dim_in_pixel().0.saturating_sub(100));
    let title = short_title(title);
    let mut chart = ChartBuilder::on(&area)
        .caption(
            if !marks_s.is_empty() {
                format!("{title}: spectrogram, impacts marked")
            } else if res.modes.is_empty() {
                format!("{title}: spectrogram")
            } else {
                format!("{title}: spectrogram, modes marked")
            },
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_end, 0.0..f_top)?;
    chart
        .configure_mesh()
        .x_desc(if span_s.is_some() {
            "time (s)"
        } else {
            "time after onset (s)"
        })
        .y_desc("frequency (Hz)")
        .y_label_formatter(&|v| format!("{v:.0}"))
        .disable_mesh()
        .draw()?;
    let db: Vec<f64> = spec
        .data
        .iter()
        .map(|c| 10.0 * (c.norm_sqr() + 1e-30).log10())
        .collect();
    // The colour range from the data: from the peak down to the 5th percentile of the bins
    // shown (the noise floor), 30–90 dB, so a decay spans the colours instead of one hue.
    let top = db.iter().copied().fold(f64::MIN, f64::max);
    let k_top = ((f_top / spec.bin_width_hz()).ceil() as usize).clamp(1, spec.bins);
    let m_top = (((t_end * fs) / spec.hop as f64).ceil() as usize).clamp(1, spec.frames);
    let shown: Vec<f64> = (0..m_top)
        .flat_map(|m| db[m * spec.bins..m * spec.bins + k_top].iter().copied())
        .collect();
    let range = colour_range_db(shown, top);
    let floor = top - range;
    draw_colour_bar(&bar, -range, 0.0, "dB re peak", &|v| (v + range) / range)?;
    let plot = chart.plotting_area();
    let (px_w, px_h) = plot.dim_in_pixel();
    for py in 0..px_h {
        let f = f_top * (1.0 - (py as f64 + 0.5) / px_h as f64);
        let k = ((f / spec.bin_width_hz()).round() as usize).min(spec.bins - 1);
        for px in 0..px_w {
            let t = t_end * (px as f64 + 0.5) / px_w as f64;
            let m = ((t * fs - 0.5 * window as f64) / spec.hop as f64)
                .round()
                .clamp(0.0, (spec.frames - 1) as f64) as usize;
            let v = (db[m * spec.bins + k] - floor) / (top - floor);
            plot.draw_pixel((t, f), &colour(v))?;
        }
    }
    let strongest = res.modes.iter().map(|m| m.amplitude).fold(0.0, f64::max);
    chart.draw_series(res.modes.iter().map(|m| {
        // A mode is marked from its onset to where it has decayed by 60 dB.
        let t60 = (3.0 * std::f64::consts::LN_10 / m.damping_per_s).min(t_end);
        let level = 20.0 * (m.amplitude / strongest).log10();
        let (c, w) = if level > -20.0 { (CYAN, 3) } else { (WHITE, 2) };
        PathElement::new(vec![(0.0, m.freq_hz), (t60, m.freq_hz)], c.stroke_width(w))
    }))?;
    // Event marks: a green tick down from the top at each time.
    chart.draw_series(
        marks_s
            .iter()
            .filter(|&&t| (0.0..=t_end).contains(&t))
            .map(|&t| PathElement::new(vec![(t, f_top), (t, 0.9 * f_top)], GREEN.stroke_width(2))),
    )?;
    Ok(())
}

/// The dB range a spectrogram's colours span below its peak `top`: down to the 5th
/// percentile of the `shown` bins' levels (the noise floor, or the end of a decay), rounded up
/// and held within 30–90 dB.
fn colour_range_db(mut shown: Vec<f64>, top: f64) -> f64 {
    shown.sort_by(f64::total_cmp);
    let p5 = shown.get(shown.len() / 20).copied().unwrap_or(top - 90.0);
    (top - p5).clamp(30.0, 90.0).ceil()
}

/// Log–log axes of frequency and damping spanning `modes` (from a decade boundary).
struct FdRange {
    f_min: f64,
    f_max: f64,
    d_min: f64,
    d_max: f64,
}

impl FdRange {
    fn of<'m>(modes: impl Iterator<Item = &'m DampedMode> + Clone) -> Self {
        let f_max = modes.clone().map(|m| m.freq_hz).fold(100.0, f64::max) * 1.3;
        let f_min = modes
            .clone()
            .map(|m| m.freq_hz)
            .fold(f64::INFINITY, f64::min)
            .min(f_max / 10.0)
            * 0.7;
        let d_max = modes.clone().map(|m| m.damping_per_s).fold(1.0, f64::max) * 2.0;
        let d_min = modes
            .map(|m| m.damping_per_s)
            .fold(f64::INFINITY, f64::min)
            .min(d_max / 100.0)
            * 0.5;
        Self {
            f_min: decade_below(f_min),
            f_max,
            d_min: decade_below(d_min),
            d_max,
        }
    }
}

type FdChart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    plotters::coord::cartesian::Cartesian2d<
        plotters::coord::combinators::LogCoord<f64>,
        plotters::coord::combinators::LogCoord<f64>,
    >,
>;

/// The (f, d) chart with its labelled log axes, `caption` on top.
fn fd_chart<'a, 'b>(
    area: &'a Area<'b>,
    caption: &str,
    caption_size: u32,
    r: &FdRange,
) -> std::result::Result<FdChart<'a, 'b>, Box<dyn std::error::Error>> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", caption_size))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(
            (r.f_min..r.f_max).log_scale(),
            (r.d_min..r.d_max).log_scale(),
        )?;
    chart
        .configure_mesh()
        .x_labels(LOG_LABELS)
        .y_labels(LOG_LABELS)
        .x_label_formatter(&|v| log_label(*v))
        .y_label_formatter(&|v| log_label(*v))
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(200, 200, 200))
        .x_desc("frequency (Hz)")
        .y_desc("damping (1/s)")
        .draw()?;
    Ok(chart)
}

fn draw_features(
    area: &Area<'_>,
    res: &Analysis,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let r = FdRange::of(res.modes.iter());
    let mut chart = fd_chart(area, "features (f, d) with ±σ; size = level", 18, &r)?;
    let strongest = res.modes.iter().map(|m| m.amplitude).fold(0.0, f64::max);
    // Each mode's σ of f and d (the analysis's Cramér–Rao bound) as a cross, clipped to the
    // axes: a mode whose damping is not determined shows a bar across the plot.
    let bar = RGBColor(90, 90, 90).stroke_width(1);
    chart.draw_series(res.modes.iter().zip(&res.sigma).flat_map(|(m, s)| {
        let Some(s) = *s else {
            return Vec::new();
        };
        let (f, d) = (m.freq_hz, m.damping_per_s);
        let d_lo = (d - s.damping_per_s).max(r.d_min);
        let d_hi = (d + s.damping_per_s).min(r.d_max);
        let f_lo = (f - s.freq_hz).max(r.f_min);
        let f_hi = (f + s.freq_hz).min(r.f_max);
        vec![
            PathElement::new(vec![(f, d_lo), (f, d_hi)], bar),
            PathElement::new(vec![(f_lo, d), (f_hi, d)], bar),
        ]
    }))?;
    chart.draw_series(res.modes.iter().map(|m| {
        let level = 20.0 * (m.amplitude / strongest).log10();
        let r = (3.0 + (level + 60.0).max(0.0) / 6.0) as i32;
        Circle::new((m.freq_hz, m.damping_per_s), r, RED.mix(0.7).filled())
    }))?;
    Ok(())
}

/// What `estimate --plot` draws: reference and estimated features with the estimated Rayleigh
/// curve (Ren 2013 Fig. 11), and the two loudness images compared by the metric.
pub struct EstimatePlot<'a> {
    /// Recording name for the titles.
    pub title: &'a str,
    /// The recording's modes.
    pub reference: &'a [DampedMode],
    /// The estimated material's modes on the object.
    pub estimated: &'a [DampedMode],
    /// Estimated Rayleigh α (1/s).
    pub alpha: f64,
    /// Estimated Rayleigh β (s).
    pub beta: f64,
    /// Loudness image of the recording.
    pub reference_image: &'a LoudnessImage,
    /// Loudness image of the estimated modes.
    pub estimated_image: &'a LoudnessImage,
}

/// Draws an [`EstimatePlot`] to `path` (PNG, written atomically).
pub fn estimate_png(path: &Path, p: &EstimatePlot<'_>) -> Result<()> {
    register_font();
    let (w, h) = (1400u32, 1000u32);
    let mut pixels = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        let (top, bottom) = root.split_vertically(500);
        draw_estimate_features(&top, p).map_err(draw_err)?;
        let (l, r) = bottom.split_horizontally(700);
        let vmax = p
            .reference_image
            .data
            .iter()
            .chain(&p.estimated_image.data)
            .copied()
            .fold(1e-9, f64::max);
        draw_loudness(&l, p.reference_image, vmax, "recording: loudness (sone)")
            .map_err(draw_err)?;
        draw_loudness(&r, p.estimated_image, vmax, "estimate: loudness (sone)")
            .map_err(draw_err)?;
        root.present().map_err(draw_err)?;
    }
    let img = image_png(&pixels, w, h)?;
    write_atomic(path, |out| out.write_all(&img))?;
    Ok(())
}

fn draw_estimate_features(
    area: &Area<'_>,
    p: &EstimatePlot<'_>,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let r = FdRange::of(p.reference.iter().chain(p.estimated));
    let (f_min, f_max, d_min, d_max) = (r.f_min, r.f_max, r.d_min, r.d_max);
    let caption = format!(
        "{}: recorded (red) vs estimated (blue) features; Rayleigh curve α = {:.3} 1/s, β = {:.3e} s",
        short_title(p.title),
        p.alpha,
        p.beta
    );
    let mut chart = fd_chart(area, &caption, 17, &r)?;
    // d = (α + βλ)/2 and f = √(λ − d²)/2π along λ.
    let curve: Vec<(f64, f64)> = (0..400)
        .filter_map(|i| {
            let f = f_min * (f_max / f_min).powf(i as f64 / 399.0);
            let lambda = (std::f64::consts::TAU * f).powi(2);
            let mut l = lambda;
            for _ in 0..30 {
                let d = 0.5 * (p.alpha + p.beta * l);
                l = lambda + d * d;
            }
            let d = 0.5 * (p.alpha + p.beta * l);
            (d > d_min && d < d_max && d * d < l).then_some((f, d))
        })
        .collect();
    chart.draw_series(LineSeries::new(curve, BLACK.stroke_width(2)))?;
    let level = |m: &DampedMode| resound_signal::mode_level(m, resound_signal::LEVEL_WINDOW_S);
    // Each set sized relative to its own strongest mode (their scales need not agree).
    let strongest = |set: &[DampedMode]| set.iter().map(level).fold(1e-300, f64::max);
    let (ref_top, est_top) = (strongest(p.reference), strongest(p.estimated));
    let radius = |m: &DampedMode, top: f64| {
        let db = 20.0 * (level(m) / top).log10();
        (3.0 + (db + 60.0).max(0.0) / 6.0) as i32
    };
    chart.draw_series(p.reference.iter().map(|m| {
        Circle::new(
            (m.freq_hz, m.damping_per_s),
            radius(m, ref_top),
            RED.mix(0.6).filled(),
        )
    }))?;
    chart.draw_series(p.estimated.iter().map(|m| {
        Circle::new(
            (m.freq_hz, m.damping_per_s),
            radius(m, est_top),
            BLUE.stroke_width(2),
        )
    }))?;
    Ok(())
}

fn draw_loudness(
    area: &Area<'_>,
    image: &LoudnessImage,
    vmax: f64,
    title: &str,
) -> std::result::Result<(), Box<dyn std::error::Error>> {
    let g = &image.grid;
    let frames = g.frames.max(1);
    let t_end = (frames * g.hop) as f64 / g.sample_rate_hz;
    let (area, bar) = area.split_horizontally(area.dim_in_pixel().0.saturating_sub(100));
    draw_colour_bar(&bar, 0.0, vmax, "sone", &|v| (v / vmax).sqrt())?;
    let mut chart = ChartBuilder::on(&area)
        .caption(title, ("sans-serif", 17))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..t_end, 0.0..BANDS as f64)?;
    chart
        .configure_mesh()
        .x_desc("time after onset (s)")
        .y_desc("critical band (Bark)")
        .disable_mesh()
        .draw()?;
    let plot = chart.plotting_area();
    let (px_w, px_h) = plot.dim_in_pixel();
    for py in 0..px_h {
        let z = BANDS as f64 * (1.0 - (py as f64 + 0.5) / px_h as f64);
        let b = (z as usize).min(BANDS - 1);
        for px in 0..px_w {
            let t = t_end * (px as f64 + 0.5) / px_w as f64;
            let m = ((t * g.sample_rate_hz / g.hop as f64) as usize).min(frames - 1);
            let v = image.data.get(m * BANDS + b).copied().unwrap_or(0.0);
            plot.draw_pixel((t, z), &colour((v / vmax).sqrt()))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 37: the analysis spectrogram was near-uniform orange (a fixed 90 dB range over a
    /// strike whose bins span 40 dB). The range follows the data: a 60 dB decay spans the
    /// colours, a noisy 40 dB recording gets 40 dB, never under 30 or over 90.
    #[test]
    fn the_colour_range_follows_the_levels_shown() {
        let decay: Vec<f64> = (0..1000).map(|i| -60.0 * f64::from(i) / 1000.0).collect();
        assert_eq!(colour_range_db(decay, 0.0), 57.0);
        let noisy: Vec<f64> = (0..1000)
            .map(|i| -40.0 * f64::from(i % 100) / 100.0)
            .collect();
        assert_eq!(colour_range_db(noisy, 0.0), 38.0);
        let flat = vec![-1.0; 100];
        assert_eq!(colour_range_db(flat, 0.0), 30.0);
        let silence: Vec<f64> = (0..100)
            .map(|i| if i < 50 { 0.0 } else { -300.0 })
            .collect();
        assert_eq!(colour_range_db(silence, 0.0), 90.0);
    }

    /// The scene picture: every channel drawn, one above the other (it showed the left one).
    #[test]
    fn several_channels_make_one_row_each() {
        let dir = tempfile::tempdir().unwrap();
        let x: Vec<f64> = (0..48_000)
            .map(|i| (f64::from(i) * 0.1).sin() * (-f64::from(i) / 4800.0).exp())
            .collect();
        let one = dir.path().join("one.png");
        let two = dir.path().join("two.png");
        spectrograms_png(&one, &[("a", &x)], 48_000.0, &[0.1]).unwrap();
        spectrograms_png(&two, &[("a", &x), ("b", &x)], 48_000.0, &[0.1]).unwrap();
        // A PNG's height is bytes 20–23 of its IHDR chunk.
        let height = |p: &Path| {
            let b = std::fs::read(p).unwrap();
            u32::from_be_bytes([b[20], b[21], b[22], b[23]])
        };
        assert_eq!(height(&one), 500);
        assert_eq!(height(&two), 940);
    }
}
