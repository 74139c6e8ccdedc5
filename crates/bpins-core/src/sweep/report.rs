//! `report.html`: one self-contained page (inline SVG, no script) with the rows, the
//! budget, σ of the heading error against the sun elevation per source (one plot per
//! extractor), and a histogram of every row's errors. The page is the template
//! `report.html` beside this file (minijinja, every value escaped); this module gives it
//! the numbers, formatted, and the figures' coordinates in px.

use super::spec::SweepSpec;
use super::stats::{Row, Summary};
use crate::error::Result;
use serde::Serialize;

const TEMPLATE: &str = include_str!("report.html");

const COLOURS: [&str; 8] = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"];

/// A colour sensor's band after its extractor (` · R`, ` · fused`); nothing on a
/// monochrome sensor.
fn band_label(b: &Option<String>) -> String {
    b.as_ref().map(|b| format!(" · {b}")).unwrap_or_default()
}

fn known_label(k: Option<bool>) -> &'static str {
    match k {
        Some(true) => " (known)",
        Some(false) => " (unknown)",
        None => "",
    }
}

/// What the template reads: every number already formatted as the page shows it.
#[derive(Serialize)]
struct Page {
    title: String,
    sweep: String,
    seed: u64,
    trials: String,
    width_px: String,
    height_px: String,
    layout: &'static str,
    elevations: String,
    /// Error sources: source, parameter, distribution, per, known.
    sources: Vec<[String; 5]>,
    plots: Vec<Plot>,
    /// Rows: source, extractor, then nine right-aligned cells.
    rows: Vec<Vec<String>>,
    /// Budget rows: extractor, elevation, known, shares, σ combined, √Σσ², in quadrature.
    budget: Vec<[String; 7]>,
    histograms: Vec<Histogram>,
}

/// σ against sun elevation for one extractor: tick positions and labels, series.
#[derive(Serialize)]
struct Plot {
    extractor: String,
    x_ticks: Vec<[String; 2]>,
    y_ticks: Vec<[String; 2]>,
    series: Vec<Series>,
}

#[derive(Serialize)]
struct Series {
    name: String,
    colour: &'static str,
    /// The polyline's points, `x,y` space-separated.
    points: String,
    circles: Vec<[String; 2]>,
    legend_y: String,
    legend_text_y: String,
}

#[derive(Serialize)]
struct Histogram {
    label: String,
    /// Bars: x, y, width, height.
    bars: Vec<[String; 4]>,
    low: Option<String>,
    high: Option<String>,
}

/// The report of `summary`, for `spec`.
pub fn html(spec: &SweepSpec, summary: &Summary) -> Result<String> {
    let title = if summary.title.is_empty() { summary.sweep.clone() } else { summary.title.clone() };
    let sources = spec
        .errors
        .iter()
        .map(|e| {
            [
                e.source.clone(),
                e.target.name(),
                e.distribution.describe(),
                match e.per {
                    super::spec::Per::Trial => "trial",
                    super::spec::Per::Pixel => "pixel",
                }
                .to_string(),
                match e.known {
                    super::spec::Known::No => "no",
                    super::spec::Known::Yes => "yes",
                    super::spec::Known::Both => "both (rows for each)",
                }
                .to_string(),
            ]
        })
        .collect();
    let known = |k: Option<bool>| k.map(|k| k.to_string()).unwrap_or_else(|| "—".into());
    let rows = summary
        .rows
        .iter()
        .map(|r| {
            vec![
                r.source.clone(),
                format!("{}{}", r.extractor, band_label(&r.band)),
                r.sun_elevation_deg.to_string(),
                known(r.known),
                format!("{:+.4} ± {:.4}", r.mean_deg, r.mean_sigma_deg),
                format!("{:.4}", r.std_deg),
                format!("{:.4}", r.rms_deg),
                format!("{:.4}", r.p95_deg),
                format!("{:.4}", r.max_abs_deg),
                r.trials.to_string(),
                r.failed.to_string(),
            ]
        })
        .collect();
    let budget = summary
        .budget
        .iter()
        .map(|b| {
            let shares: Vec<String> =
                b.shares.iter().map(|s| format!("{} {:.1} %", s.source, 100.0 * s.share_of_sum)).collect();
            [
                format!("{}{}", b.extractor, band_label(&b.band)),
                b.sun_elevation_deg.to_string(),
                known(b.known),
                shares.join("; "),
                format!("{:.4}", b.combined_std_deg),
                format!("{:.4}", b.root_sum_square_deg),
                if b.adds_in_quadrature { "yes" } else { "no" }.to_string(),
            ]
        })
        .collect();
    let page = Page {
        title,
        sweep: summary.sweep.clone(),
        seed: summary.seed,
        trials: summary.trials_per_source.to_string(),
        width_px: spec.sensor.geometry.width_px.to_string(),
        height_px: spec.sensor.geometry.height_px.to_string(),
        layout: match (&spec.sensor.layout, &spec.sensor.colour) {
            (crate::sensor::Layout::Dofp { .. }, None) => "DoFP",
            (crate::sensor::Layout::Dofp { .. }, Some(_)) => {
                "colour DoFP (each band from its own superpixels; fused: their inverse-variance mean)"
            }
            (crate::sensor::Layout::Colocated { .. }, _) => "colocated",
        },
        elevations: summary.sun_elevations_deg.iter().map(|e| e.to_string()).collect::<Vec<_>>().join(", "),
        sources,
        plots: spec.extractors.iter().map(|ex| elevation_plot(summary, ex.name())).collect(),
        rows,
        budget,
        histograms: summary.rows.iter().map(histogram).collect(),
    };
    crate::output::render_html("sweep/report.html", TEMPLATE, &page)
}

/// σ against sun elevation, one line per (source, known) for extractor `ex`; the
/// template's frame: 560 × 300 px, margins 60 (left), 40 (bottom), 20 (top), 170
/// (right, the legend).
fn elevation_plot(summary: &Summary, ex: &str) -> Plot {
    let (w, hgt, ml, mb, mt, mr) = (560.0, 300.0, 60.0, 40.0, 20.0, 170.0);
    let rows: Vec<&Row> = summary.rows.iter().filter(|r| r.extractor == ex && r.std_deg.is_finite()).collect();
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for r in &rows {
        let name = format!("{}{}{}", r.source, known_label(r.known), band_label(&r.band));
        match series.iter_mut().find(|(n, _)| *n == name) {
            Some((_, pts)) => pts.push((r.sun_elevation_deg, r.std_deg)),
            None => series.push((name, vec![(r.sun_elevation_deg, r.std_deg)])),
        }
    }
    let els = &summary.sun_elevations_deg;
    let (x0, x1) =
        (els.iter().copied().fold(f64::INFINITY, f64::min), els.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    let (x0, x1) = if x1 > x0 { (x0, x1) } else { (x0 - 1.0, x0 + 1.0) };
    let ymax = rows.iter().map(|r| r.std_deg).fold(0.0, f64::max).max(1e-6) * 1.1;
    let px = |x: f64| ml + (x - x0) / (x1 - x0) * (w - ml - mr);
    let py = |y: f64| hgt - mb - y / ymax * (hgt - mb - mt);
    Plot {
        extractor: ex.to_string(),
        x_ticks: els.iter().map(|&e| [format!("{:.1}", px(e)), e.to_string()]).collect(),
        y_ticks: (0..=4)
            .map(|k| {
                let y = ymax * k as f64 / 4.0;
                [format!("{:.1}", py(y) + 4.0), format!("{y:.3}")]
            })
            .collect(),
        series: series
            .iter()
            .enumerate()
            .map(|(i, (name, pts))| {
                let circles: Vec<[String; 2]> =
                    pts.iter().map(|&(x, y)| [format!("{:.1}", px(x)), format!("{:.1}", py(y))]).collect();
                let ly = mt + 14.0 * i as f64;
                Series {
                    name: name.clone(),
                    colour: COLOURS[i % COLOURS.len()],
                    points: circles.iter().map(|[x, y]| format!("{x},{y}")).collect::<Vec<_>>().join(" "),
                    circles,
                    legend_y: ly.to_string(),
                    legend_text_y: (ly + 4.0).to_string(),
                }
            })
            .collect(),
    }
}

/// A histogram of one row's errors (20 bins over its range), in the template's
/// 240 × 120 px frame with 20 px margins.
fn histogram(r: &Row) -> Histogram {
    let (w, hgt, m) = (240.0, 120.0, 20.0);
    let ok: Vec<f64> = r.errors_deg.iter().copied().filter(|v| v.is_finite()).collect();
    let label = format!(
        "{} · {}{}{} · sun {}°",
        r.source,
        r.extractor,
        band_label(&r.band),
        known_label(r.known),
        r.sun_elevation_deg
    );
    if ok.is_empty() {
        return Histogram { label, bars: Vec::new(), low: None, high: None };
    }
    let lo = ok.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = ok.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let span = if hi > lo { hi - lo } else { 1e-9 };
    let bins = 20;
    let mut count = vec![0usize; bins];
    for v in &ok {
        count[(((v - lo) / span * bins as f64) as usize).min(bins - 1)] += 1;
    }
    let cmax = *count.iter().max().unwrap_or(&1) as f64;
    let bw = (w - 2.0 * m) / bins as f64;
    let bars = count
        .iter()
        .enumerate()
        .map(|(i, &c)| {
            let bh = c as f64 / cmax * (hgt - 2.0 * m);
            [
                format!("{:.1}", m + i as f64 * bw),
                format!("{:.1}", hgt - m - bh),
                format!("{:.1}", bw - 1.0),
                format!("{bh:.1}"),
            ]
        })
        .collect();
    Histogram { label, bars, low: Some(format!("{lo:+.4}")), high: Some(format!("{hi:+.4}")) }
}
