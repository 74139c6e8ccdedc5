//! The HTML report of a lab calibration: a self-contained page beside the maps
//! (`report.html`, images from `png/`), like `bpins diagnose`'s. Once loaded it marks
//! `<body data-images-ok="decoded/all">` so that a headless browser can check that
//! every map was found and decoded (crates/bpins-cli/tests/report_render.rs).

use super::output::MapFile;
use super::LabCalibration;
use crate::output::escape_html as esc;

/// The page for `cal` of the capture `source`, with the written `maps`.
pub fn report_html(cal: &LabCalibration, source: &str, maps: &[MapFile]) -> String {
    let m = &cal.maps;
    let mut h = String::new();
    h += "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>bpins lab calibration</title>\n";
    h += "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;color:#222}table{border-collapse:collapse;margin:1em 0;display:block;overflow-x:auto}td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}td:first-child,th:first-child{text-align:left}.no{color:#a00}</style></head><body>\n";
    h += &format!("<h1>Lab calibration of <code>{}</code></h1>\n", esc(source));
    h += &format!(
        "<p>Sensor {} × {} px; offsets: {}. Every number with its 1σ from the noise.</p>\n",
        m.width_px,
        m.height_px,
        esc(&cal.offset_source)
    );
    h += "<h2>Per channel: mean, white spread, gradient across the die</h2>\n";
    h += "<p>Each map fitted per channel by a plane, value = mean + g<sub>x</sub>·(x/W − ½) + g<sub>y</sub>·(y/H − ½); the spread is the standard deviation about it (measured: flaw and noise together); the last column is the RMS of each pixel's own 1σ (what the photon count allows).</p>\n";
    h += "<table><tr><th>quantity</th><th>channel (°)</th><th>mean ± 1σ</th><th>spread</th><th>g<sub>x</sub> ± 1σ</th><th>g<sub>y</sub> ± 1σ</th><th>pixel 1σ (RMS)</th><th>unit</th></tr>\n";
    for s in &cal.summary {
        h += &format!(
            "<tr><td>{}</td><td>{}</td><td>{:.5} ± {:.5}</td><td>{:.5}</td><td>{:+.5} ± {:.5}</td><td>{:+.5} ± {:.5}</td><td>{}</td><td>{}</td></tr>\n",
            esc(&s.quantity),
            s.channel_deg,
            s.mean,
            s.mean_sigma,
            s.spread,
            s.gradient_x,
            s.gradient_x_sigma,
            s.gradient_y,
            s.gradient_y_sigma,
            s.pixel_sigma_rms.map_or("—".into(), |x| format!("{x:.5}")),
            esc(&s.unit)
        );
    }
    h += "</table>\n<h2>Sensor (EMVA 1288)</h2>\n<table><tr><th>quantity</th><th>value ± 1σ</th><th>unit</th></tr>\n";
    if let Some(d) = &cal.dark {
        h += &format!(
            "<tr><td>mean offset ({} dark frame(s))</td><td>{:.3}</td><td>DN</td></tr>\n",
            d.frames, d.mean_offset_dn
        );
        h += &format!(
            "<tr><td>DSNU (offset spread, read noise included with 1 dark frame)</td><td>{:.3}</td><td>DN</td></tr>\n",
            d.dsnu_dn
        );
    }
    if let Some(p) = &cal.photon_transfer {
        h += &format!(
            "<tr><td>conversion gain K</td><td>{:.5} ± {:.5}</td><td>DN/e⁻</td></tr>\n",
            p.conversion_gain_dn_per_e, p.conversion_gain_sigma
        );
        h += &format!(
            "<tr><td>read noise</td><td>{:.3} ± {:.3}</td><td>DN</td></tr>\n",
            p.read_noise_dn, p.read_noise_sigma_dn
        );
        if let Some(le) = p.linearity_error_pct {
            h += &format!("<tr><td>linearity error</td><td>{le:.4}</td><td>%</td></tr>\n");
        }
        for q in &p.points {
            h += &format!(
                "<tr><td>mean signal at exposure {}×</td><td>{:.2}</td><td>DN</td></tr>\n",
                q.exposure_rel, q.mean_dn
            );
        }
    }
    if let Some(f) = &cal.flat {
        h += &format!(
            "<tr><td>vignetting v2 (r in focal lengths)</td><td>{:.5} ± {:.5}</td><td>1</td></tr>\n",
            f.v2, f.v2_sigma
        );
        h += &format!("<tr><td>vignetting v4</td><td>{:.5} ± {:.5}</td><td>1</td></tr>\n", f.v4, f.v4_sigma);
        h += &format!("<tr><td>PRNU (after falloff and channel means)</td><td>{:.4}</td><td>%</td></tr>\n", f.prnu_pct);
    }
    if let Some(r) = &cal.malus_residual_dn {
        h += &format!(
            "<tr><td>Malus fit residual per channel (0°, 45°, 90°, 135°)</td><td>{:.3}, {:.3}, {:.3}, {:.3}</td><td>DN</td></tr>\n",
            r[0], r[1], r[2], r[3]
        );
    }
    h += "</table>\n<h2>Not determined</h2>\n";
    if cal.left_out.is_empty() {
        h += "<p>Everything was determined.</p>\n";
    } else {
        h += "<table><tr><th>quantity</th><th>why</th></tr>\n";
        for l in &cal.left_out {
            h += &format!(
                "<tr><td class=\"no\">{}</td><td style=\"text-align:left\">{}</td></tr>\n",
                esc(&l.quantity),
                esc(&l.reason)
            );
        }
        h += "</table>\n";
    }
    h += "<h2>Maps</h2>\n<p>Grey from the low to the high value given (0.5 … 99.5 % of the pixels); full precision in <code>maps.exr</code>.</p>\n<table><tr>";
    for (k, f) in maps.iter().enumerate() {
        if k > 0 && k % 4 == 0 {
            h += "</tr><tr>";
        }
        h += &format!(
            "<td><img src=\"{}\" alt=\"{}\" style=\"width:12em;image-rendering:pixelated\"><br>{} ({:.4} … {:.4} {})</td>",
            esc(&f.png),
            esc(&f.name),
            esc(&f.name),
            f.low,
            f.high,
            esc(&f.unit)
        );
    }
    h += "</tr></table>\n";
    h += "<script>addEventListener(\"load\",()=>{const i=[...document.images];document.body.dataset.imagesOk=i.filter(x=>x.complete&&x.naturalWidth>0).length+\"/\"+i.length})</script>\n";
    h += "</body></html>\n";
    h
}
