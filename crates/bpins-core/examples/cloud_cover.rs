//! The README's cloud-cover curve: the field estimator's heading RMS and the share of
//! frames within 2σ against cloud cover (0–90 % of the dome), for the samples' 8 mm
//! pinhole and the 2.2 mm fisheye at sun elevations 20°, 45° and 70°
//! (`field_conditions::cover_condition`: a broken sky of 12° features, cores 2×
//! brighter, depolarized to 15 %, E-vectors turned by ~17°).
//!
//! ```sh
//! cargo run --release -p bpins-core --example cloud_cover -- [FRAMES] [SEED] [SCALE] [OUT.svg]
//! ```
//! (defaults 12 frames per point, seed 2026, half resolution, `docs/cloud_cover.svg`;
//! about ten minutes on two cores). Prints the table as Markdown and writes the plot.

use bpins_core::internal::field_conditions::{cover_condition, score_field, Score};
use bpins_core::internal::heading::field::FieldOptions;
use bpins_core::internal::heading::Extractor;
use std::fmt::Write as _;

const COVERS: [f64; 7] = [0.0, 0.15, 0.3, 0.45, 0.6, 0.75, 0.9];
const SUNS_DEG: [f64; 3] = [20.0, 45.0, 70.0];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(12);
    let seed: u64 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(2026);
    let scale: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(2);
    let out = args.next().unwrap_or_else(|| "docs/cloud_cover.svg".into());
    println!("{frames} frames per point, seed {seed}, 1/{scale} resolution, sun_vector, field estimator\n");
    println!("| camera | sun (°) | cover (%) | RMS (°) | within 2σ | max \\|err\\|/σ | median 1σ (°) | no heading | median cloud fraction |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut curves: Vec<(String, Vec<(f64, Score)>)> = Vec::new();
    for fisheye in [false, true] {
        for sun in SUNS_DEG {
            let mut points = Vec::new();
            for cover in COVERS {
                let cond = cover_condition(fisheye, sun, cover, frames, scale, seed)?;
                let sim = cond.simulate(seed)?;
                let s = score_field(&sim, Extractor::SunVector, &FieldOptions::default())?;
                let camera = if fisheye { "fisheye" } else { "pinhole" };
                if s.with_heading == 0 {
                    println!(
                        "| {camera} | {sun:.0} | {:.0} | — | — | — | — | {} of {} | {:.0} % |",
                        100.0 * cover,
                        s.frames,
                        s.frames,
                        100.0 * s.median_cloud_fraction
                    );
                } else {
                    println!(
                        "| {camera} | {sun:.0} | {:.0} | {:.3} | {:.0} % | {:.1} | {:.3} | {} of {} | {:.0} % |",
                        100.0 * cover,
                        s.rms_error_deg,
                        100.0 * s.within_2sigma,
                        s.max_error_over_sigma,
                        s.median_sigma_deg,
                        s.frames - s.with_heading,
                        s.frames,
                        100.0 * s.median_cloud_fraction
                    );
                }
                points.push((cover, s));
            }
            curves.push((format!("{} sun {sun:.0}°", if fisheye { "fisheye" } else { "pinhole" }), points));
        }
    }
    std::fs::write(&out, svg(&curves))?;
    eprintln!("wrote {out}");
    Ok(())
}

/// Two panels side by side: heading RMS (°, log scale) and the share within 2σ (%),
/// against cover (%); one line per camera and sun.
fn svg(curves: &[(String, Vec<(f64, Score)>)]) -> String {
    let (pw, ph, m) = (360.0, 240.0, 50.0);
    let (w, h) = (2.0 * (pw + m) + 160.0, ph + 2.0 * m);
    let colours = ["#1b9e77", "#d95f02", "#7570b3"];
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" \
         font-size=\"11\" role=\"img\" aria-label=\"heading RMS and 2σ coverage against cloud cover\">\n\
         <rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>"
    );
    // y maps: RMS on log10 from 0.001° to 10°; coverage 0–100 %.
    let rms_y = |v: f64| {
        let l = v.max(1e-3).log10().clamp(-3.0, 1.0);
        m + ph * (1.0 - (l + 3.0) / 4.0)
    };
    let cov_y = |v: f64| m + ph * (1.0 - v);
    for (panel, title) in [(0.0, "heading RMS (°)"), (1.0, "frames within 2σ (%)")] {
        let x0 = m + panel * (pw + m);
        let _ = writeln!(
            s,
            "<rect x=\"{x0}\" y=\"{m}\" width=\"{pw}\" height=\"{ph}\" fill=\"none\" stroke=\"#888\"/>\n\
             <text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{title}</text>\n\
             <text x=\"{}\" y=\"{}\" text-anchor=\"middle\">cloud cover (% of the sky in view)</text>",
            x0 + pw / 2.0,
            m - 12.0,
            x0 + pw / 2.0,
            m + ph + 32.0
        );
        for c in [0.0, 0.3, 0.6, 0.9] {
            let x = x0 + pw * c / 0.9;
            let _ =
                writeln!(s, "<text x=\"{x}\" y=\"{}\" text-anchor=\"middle\">{:.0}</text>", m + ph + 14.0, 100.0 * c);
        }
        let ticks: Vec<(f64, String)> = if panel == 0.0 {
            [0.001, 0.01, 0.1, 1.0, 10.0].iter().map(|&v| (rms_y(v), format!("{v}"))).collect()
        } else {
            [0.0, 0.5, 0.9, 1.0].iter().map(|&v| (cov_y(v), format!("{:.0}", 100.0 * v))).collect()
        };
        for (y, label) in ticks {
            let _ = writeln!(
                s,
                "<line x1=\"{x0}\" x2=\"{}\" y1=\"{y}\" y2=\"{y}\" stroke=\"#eee\"/>\
                 <text x=\"{}\" y=\"{}\" text-anchor=\"end\">{label}</text>",
                x0 + pw,
                x0 - 4.0,
                y + 4.0
            );
        }
        // The targets: 0.1° where ≥ 30 % is clear (cover ≤ 70 %), 0.3° at 60 %; 90 % within 2σ.
        if panel == 0.0 {
            for (v, upto) in [(0.1f64, 0.7f64), (0.3, 0.9)] {
                let _ = writeln!(
                    s,
                    "<line x1=\"{x0}\" x2=\"{}\" y1=\"{y}\" y2=\"{y}\" stroke=\"#c00\" stroke-dasharray=\"4 3\"/>",
                    x0 + pw * upto.min(0.9) / 0.9,
                    y = rms_y(v)
                );
            }
        } else {
            let _ = writeln!(
                s,
                "<line x1=\"{x0}\" x2=\"{}\" y1=\"{y}\" y2=\"{y}\" stroke=\"#c00\" stroke-dasharray=\"4 3\"/>",
                x0 + pw,
                y = cov_y(0.9)
            );
        }
        for (k, (name, points)) in curves.iter().enumerate() {
            let dash = if name.starts_with("fisheye") { " stroke-dasharray=\"6 3\"" } else { "" };
            let pts: Vec<String> = points
                .iter()
                .filter(|(_, sc)| sc.with_heading > 0)
                .map(|(c, sc)| {
                    let y = if panel == 0.0 { rms_y(sc.rms_error_deg) } else { cov_y(sc.within_2sigma) };
                    format!("{:.1},{:.1}", x0 + pw * c / 0.9, y)
                })
                .collect();
            let _ = writeln!(
                s,
                "<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\"{dash}/>",
                pts.join(" "),
                colours[k % 3]
            );
        }
    }
    // Legend.
    let lx = 2.0 * (pw + m) + 20.0;
    for (k, (name, _)) in curves.iter().enumerate() {
        let y = m + 16.0 * k as f64;
        let dash = if name.starts_with("fisheye") { " stroke-dasharray=\"6 3\"" } else { "" };
        let _ = writeln!(
            s,
            "<line x1=\"{lx}\" x2=\"{}\" y1=\"{y}\" y2=\"{y}\" stroke=\"{}\" stroke-width=\"1.5\"{dash}/>\
             <text x=\"{}\" y=\"{}\">{name}</text>",
            lx + 24.0,
            colours[k % 3],
            lx + 30.0,
            y + 4.0
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{lx}\" y=\"{}\" fill=\"#c00\">dashed red: targets</text>\n</svg>",
        m + 16.0 * curves.len() as f64 + 8.0
    );
    s
}
