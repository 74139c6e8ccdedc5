//! `report.html`: one self-contained page (inline SVG, no script) with the rows, the
//! budget, σ of the heading error against the sun elevation per source (one plot per
//! extractor), and a histogram of every row's errors.

use std::fmt::Write;

use super::spec::SweepSpec;
use super::stats::{Row, Summary};
use crate::output::escape_html as esc;

const COLOURS: [&str; 8] = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"];

fn known_label(k: Option<bool>) -> &'static str {
    match k {
        Some(true) => " (known)",
        Some(false) => " (unknown)",
        None => "",
    }
}

/// The report of `summary`, for `spec`.
pub fn html(spec: &SweepSpec, summary: &Summary) -> String {
    let mut h = String::new();
    let title = if summary.title.is_empty() { summary.sweep.clone() } else { summary.title.clone() };
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>bpins sweep: {t}</title>\n\
         <style>body{{font-family:sans-serif;margin:2em;max-width:1100px}}table{{border-collapse:collapse;font-size:13px}}\
         td,th{{border:1px solid #ccc;padding:2px 6px;text-align:right}}th{{background:#eee}}td.l{{text-align:left}}\
         figure{{display:inline-block;margin:4px}}figcaption{{font-size:12px}}</style></head><body>\n\
         <h1>Heading error budget: {t}</h1>\n<p>Sweep <code>{f}</code>, seed {seed}, {n} trials per source and sun \
         elevation; sensor {w} × {hh} px, {layout}; sun elevations {els} °. Errors in degrees of heading.</p>\n",
        t = esc(&title),
        f = esc(&summary.sweep),
        seed = summary.seed,
        n = summary.trials_per_source,
        w = spec.sensor.geometry.width_px,
        hh = spec.sensor.geometry.height_px,
        layout = match spec.sensor.layout {
            crate::sensor::Layout::Dofp { .. } => "DoFP",
            crate::sensor::Layout::Colocated { .. } => "colocated",
        },
        els = summary.sun_elevations_deg.iter().map(|e| e.to_string()).collect::<Vec<_>>().join(", "),
    );
    h += "<h2>Error sources</h2>\n<table><tr><th>source</th><th>parameter</th><th>distribution</th><th>per</th><th>known</th></tr>\n";
    for e in &spec.errors {
        let _ = writeln!(
            h,
            "<tr><td class=l>{}</td><td class=l>{}</td><td class=l>{}</td><td class=l>{}</td><td class=l>{}</td></tr>",
            esc(&e.source),
            esc(&e.target.name()),
            esc(&e.distribution.describe()),
            match e.per {
                super::spec::Per::Trial => "trial",
                super::spec::Per::Pixel => "pixel",
            },
            match e.known {
                super::spec::Known::No => "no",
                super::spec::Known::Yes => "yes",
                super::spec::Known::Both => "both (rows for each)",
            }
        );
    }
    h += "</table>\n";

    h += "<h2>σ of the heading error against the sun elevation</h2>\n";
    for ex in &spec.extractors {
        h += &elevation_plot(summary, ex.name());
    }

    h += "<h2>Rows</h2>\n<table><tr><th>source</th><th>extractor</th><th>sun elevation (°)</th><th>known</th>\
          <th>mean (°)</th><th>σ (°)</th><th>RMS (°)</th><th>p95 |err| (°)</th><th>max |err| (°)</th><th>trials</th><th>failed</th></tr>\n";
    for r in &summary.rows {
        let _ = writeln!(
            h,
            "<tr><td class=l>{}</td><td class=l>{}</td><td>{}</td><td>{}</td><td>{:+.4}</td><td>{:.4}</td><td>{:.4}</td><td>{:.4}</td><td>{:.4}</td><td>{}</td><td>{}</td></tr>",
            esc(&r.source),
            esc(&r.extractor),
            r.sun_elevation_deg,
            r.known.map(|k| k.to_string()).unwrap_or_else(|| "—".into()),
            r.mean_deg,
            r.std_deg,
            r.rms_deg,
            r.p95_deg,
            r.max_abs_deg,
            r.trials,
            r.failed
        );
    }
    h += "</table>\n";

    if !summary.budget.is_empty() {
        h += "<h2>Error budget</h2>\n<p>Each source's share of the combined row's variance; independent sources add in \
              quadrature when √Σσ² ≈ σ<sub>combined</sub> (within two standard errors of σ).</p>\n<table><tr><th>extractor</th>\
              <th>sun elevation (°)</th><th>known</th><th>shares of combined variance</th><th>σ combined (°)</th><th>√Σσ² (°)</th><th>in quadrature</th></tr>\n";
        for b in &summary.budget {
            let shares: Vec<String> =
                b.shares.iter().map(|s| format!("{} {:.1} %", esc(&s.source), 100.0 * s.share_of_combined)).collect();
            let _ = writeln!(
                h,
                "<tr><td class=l>{}</td><td>{}</td><td>{}</td><td class=l>{}</td><td>{:.4}</td><td>{:.4}</td><td>{}</td></tr>",
                esc(&b.extractor),
                b.sun_elevation_deg,
                b.known.map(|k| k.to_string()).unwrap_or_else(|| "—".into()),
                shares.join("; "),
                b.combined_std_deg,
                b.root_sum_square_deg,
                if b.adds_in_quadrature { "yes" } else { "no" }
            );
        }
        h += "</table>\n";
    }

    h += "<h2>Histograms of the heading error</h2>\n";
    for r in &summary.rows {
        h += &histogram(r);
    }
    h += "</body></html>\n";
    h
}

/// σ against sun elevation, one line per (source, known) for extractor `ex`.
fn elevation_plot(summary: &Summary, ex: &str) -> String {
    let (w, hgt, ml, mb, mt, mr) = (560.0, 300.0, 60.0, 40.0, 20.0, 170.0);
    let rows: Vec<&Row> = summary.rows.iter().filter(|r| r.extractor == ex && r.std_deg.is_finite()).collect();
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for r in &rows {
        let name = format!("{}{}", r.source, known_label(r.known));
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
    let mut s = format!(
        "<figure><svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{hgt}\" role=\"img\" aria-label=\"σ against sun elevation, {ex}\">\n\
         <rect x=\"0\" y=\"0\" width=\"{w}\" height=\"{hgt}\" fill=\"white\"/>\n\
         <line x1=\"{ml}\" y1=\"{b}\" x2=\"{r}\" y2=\"{b}\" stroke=\"black\"/><line x1=\"{ml}\" y1=\"{mt}\" x2=\"{ml}\" y2=\"{b}\" stroke=\"black\"/>\n",
        ex = esc(ex),
        b = hgt - mb,
        r = w - mr
    );
    for &e in els {
        let _ = writeln!(
            s,
            "<text x=\"{:.1}\" y=\"{}\" font-size=\"11\" text-anchor=\"middle\">{e}</text>",
            px(e),
            hgt - mb + 14.0
        );
    }
    for k in 0..=4 {
        let y = ymax * k as f64 / 4.0;
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{:.1}\" font-size=\"11\" text-anchor=\"end\">{y:.3}</text>",
            ml - 4.0,
            py(y) + 4.0
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{}\" font-size=\"12\" text-anchor=\"middle\">sun elevation (°)</text>",
        (ml + w - mr) / 2.0,
        hgt - 6.0
    );
    let _ = writeln!(s, "<text x=\"14\" y=\"{:.1}\" font-size=\"12\" transform=\"rotate(-90 14 {:.1})\" text-anchor=\"middle\">σ of heading error (°)</text>", hgt / 2.0, hgt / 2.0);
    for (i, (name, pts)) in series.iter().enumerate() {
        let c = COLOURS[i % COLOURS.len()];
        let d: Vec<String> = pts.iter().map(|&(x, y)| format!("{:.1},{:.1}", px(x), py(y))).collect();
        let _ = writeln!(s, "<polyline fill=\"none\" stroke=\"{c}\" stroke-width=\"2\" points=\"{}\"/>", d.join(" "));
        for &(x, y) in pts {
            let _ = writeln!(s, "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"3\" fill=\"{c}\"/>", px(x), py(y));
        }
        let ly = mt + 14.0 * i as f64;
        let _ = writeln!(
            s,
            "<line x1=\"{}\" y1=\"{ly}\" x2=\"{}\" y2=\"{ly}\" stroke=\"{c}\" stroke-width=\"2\"/><text x=\"{}\" y=\"{}\" font-size=\"11\">{}</text>",
            w - mr + 8.0,
            w - mr + 24.0,
            w - mr + 28.0,
            ly + 4.0,
            esc(name)
        );
    }
    s += &format!("</svg><figcaption>{}</figcaption></figure>\n", esc(ex));
    s
}

/// A histogram of one row's errors (20 bins over its range).
fn histogram(r: &Row) -> String {
    let (w, hgt, m) = (240.0, 120.0, 20.0);
    let ok: Vec<f64> = r.errors_deg.iter().copied().filter(|v| v.is_finite()).collect();
    let label = format!("{} · {}{} · sun {}°", r.source, r.extractor, known_label(r.known), r.sun_elevation_deg);
    let mut s = format!(
        "<figure><svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{hgt}\" role=\"img\" aria-label=\"histogram {}\">\n<rect x=\"0\" y=\"0\" width=\"{w}\" height=\"{hgt}\" fill=\"white\" stroke=\"#ccc\"/>\n",
        esc(&label)
    );
    if !ok.is_empty() {
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
        for (i, &c) in count.iter().enumerate() {
            let bh = c as f64 / cmax * (hgt - 2.0 * m);
            let _ = writeln!(
                s,
                "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"#1f77b4\"/>",
                m + i as f64 * bw,
                hgt - m - bh,
                bw - 1.0,
                bh
            );
        }
        let _ = writeln!(s, "<text x=\"{m}\" y=\"{}\" font-size=\"10\">{lo:+.4}°</text>", hgt - 6.0);
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" font-size=\"10\" text-anchor=\"end\">{hi:+.4}°</text>",
            w - m,
            hgt - 6.0
        );
    }
    s += &format!("</svg><figcaption>{}</figcaption></figure>\n", esc(&label));
    s
}
