//! Residual profiles on disk: `profiles.csv` (the numbers, one row per bin) and
//! `profiles.svg` (one panel per axis, three to a row — scattering angle, radius, image azimuth,
//! mosaic position, channel, model DoLP, and a colour sensor's colour band — each with three strips: raw-DN χ² per sample − 1,
//! AoP residual and DoLP residual against that axis, each strip on its own symmetric
//! scale, zero dashed). A missing effect shows as a trend along its own axis.

use bpins_core::{Profile, ProfileBin};
use std::fmt::Write as _;
use std::path::Path;

/// Writes `dir/profiles.csv` and `dir/profiles.svg`; returns the SVG's file name.
pub fn write(dir: &Path, profiles: &[Profile]) -> anyhow::Result<String> {
    let mut csv =
        String::from("axis,lo,hi,dn_samples,chi2_per_sample,mean_z_sigma,pol_samples,aop_residual_deg,dolp_residual\n");
    for p in profiles {
        for b in &p.bins {
            writeln!(
                csv,
                "{},{},{},{},{},{},{},{},{}",
                p.axis.name(),
                b.lo,
                b.hi,
                b.dn_samples,
                b.chi2_per_sample,
                b.mean_z,
                b.pol_samples,
                b.aop_deg,
                b.dolp
            )?;
        }
    }
    let path = dir.join("profiles.csv");
    crate::write_output(&path, csv.as_bytes())?;
    crate::write_output(&dir.join("profiles.svg"), svg(profiles).as_bytes())?;
    Ok("profiles.svg".into())
}

// Panels in a grid of `COLUMNS`, each wide enough to read at the report's width
// (1280 px: three panels of ~420 px) without zooming.
const COLUMNS: usize = 3;
const PANEL_W: f64 = 430.0;
const STRIP_H: f64 = 76.0;
const TOP: f64 = 22.0;
const PANEL_H: f64 = TOP + STRIP_H * 3.0 + 34.0;

/// One strip of a panel: its label, its unit, its value in a bin.
type Strip = (&'static str, &'static str, fn(&ProfileBin) -> f64);

/// The profiles as one SVG, a panel per axis, [`COLUMNS`] to a row.
fn svg(profiles: &[Profile]) -> String {
    let strips: [Strip; 3] =
        [("χ²/sample − 1", "", |b| b.chi2_per_sample - 1.0), ("AoP", "°", |b| b.aop_deg), ("DoLP", "", |b| b.dolp)];
    let rows = profiles.len().div_ceil(COLUMNS).max(1);
    let (w, h) = (PANEL_W * COLUMNS.min(profiles.len().max(1)) as f64, PANEL_H * rows as f64);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"sans-serif\" font-size=\"13\">\n<rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>\n"
    );
    for (i, p) in profiles.iter().enumerate() {
        let x0 = PANEL_W * (i % COLUMNS) as f64 + 10.0;
        let top = PANEL_H * (i / COLUMNS) as f64;
        let pw = PANEL_W - 20.0;
        let _ = writeln!(s, "<text x=\"{}\" y=\"{}\" font-weight=\"bold\">{}</text>", x0, top + 15.0, p.axis.title());
        let (lo, hi) = match (p.bins.first(), p.bins.last()) {
            (Some(a), Some(b)) => (a.lo, b.hi),
            _ => continue,
        };
        for (j, (name, unit, get)) in strips.iter().enumerate() {
            let y0 = top + TOP + STRIP_H * j as f64;
            let vals: Vec<(f64, f64)> =
                p.bins.iter().map(|b| (0.5 * (b.lo + b.hi), get(b))).filter(|(_, v)| v.is_finite()).collect();
            let scale = vals.iter().fold(0.0f64, |m, (_, v)| m.max(v.abs())).max(1e-300);
            let px = |x: f64| x0 + (x - lo) / (hi - lo) * pw;
            // Data below the strip's label: centre at 58 % of its height, ±30 %.
            let py = |v: f64| y0 + STRIP_H * 0.58 - v / scale * (STRIP_H * 0.3);
            let range = if vals.is_empty() { ": none".to_string() } else { format!(" ±{}{unit}", short(scale)) };
            let _ = writeln!(
                s,
                "<rect x=\"{x0}\" y=\"{y0}\" width=\"{pw}\" height=\"{}\" fill=\"none\" stroke=\"#ccc\"/>\n<line x1=\"{x0}\" x2=\"{}\" y1=\"{}\" y2=\"{}\" stroke=\"#999\" stroke-dasharray=\"3,3\"/>\n<text x=\"{}\" y=\"{}\" fill=\"#555\">{name}{range}</text>",
                STRIP_H - 4.0,
                x0 + pw,
                py(0.0),
                py(0.0),
                x0 + 3.0,
                y0 + 13.0,
            );
            let pts: Vec<String> = vals.iter().map(|&(x, v)| format!("{:.1},{:.1}", px(x), py(v))).collect();
            let colour = ["#222", "#c33", "#33c"][j];
            if pts.len() > 1 {
                let _ = writeln!(
                    s,
                    "<polyline points=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\"/>",
                    pts.join(" ")
                );
            }
            for pt in &pts {
                let (x, y) = pt.split_once(',').unwrap_or(("0", "0"));
                let _ = writeln!(s, "<circle cx=\"{x}\" cy=\"{y}\" r=\"2.5\" fill=\"{colour}\"/>");
            }
        }
        let yb = top + TOP + STRIP_H * 3.0 + 6.0;
        let _ = writeln!(
            s,
            "<text x=\"{x0}\" y=\"{}\">{}</text><text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text>",
            yb + 10.0,
            short(lo),
            x0 + pw,
            yb + 10.0,
            short(hi)
        );
    }
    s += "</svg>\n";
    s
}

/// A number in three significant digits.
fn short(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let digits = (2 - x.abs().log10().floor() as i32).max(0) as usize;
    format!("{x:.digits$}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use bpins_core::Axis;

    #[test]
    fn the_svg_has_a_panel_per_axis_and_a_line_per_strip() {
        let bin = |lo: f64, v: f64| ProfileBin {
            lo,
            hi: lo + 10.0,
            dn_samples: 5,
            chi2_per_sample: 1.0 + v,
            mean_z: 0.0,
            pol_samples: 2,
            aop_deg: -v,
            dolp: f64::NAN,
        };
        let p = Profile { axis: Axis::ScatteringAngle, bins: vec![bin(0.0, 0.1), bin(10.0, 0.3), bin(20.0, -0.2)] };
        let s = svg(&[p.clone(), Profile { axis: Axis::Radius, ..p }]);
        assert_eq!(s.matches("font-weight=\"bold\"").count(), 2);
        // χ² and AoP have a line in each panel; DoLP (all NaN) has none.
        assert_eq!(s.matches("<polyline").count(), 4);
        assert!(s.contains("χ²/sample − 1 ±0.300") && s.contains("scattering angle (°)"), "{s}");
        assert_eq!(short(0.0123456), "0.0123");
        assert_eq!(short(123.4), "123");
    }
}
