//! The HTML report of a lab calibration: a self-contained page beside the maps
//! (`report.html`, images from `png/`), like `bpins diagnose`'s. The page is the
//! template `report.html` beside this file (minijinja, every value escaped); this
//! module gives it the numbers, formatted with their precision and units. Once loaded
//! the page marks `<body data-images-ok="decoded/all">` so that a headless browser can
//! check that every map was found and decoded (tests/report_render.rs).

use super::output::MapFile;
use super::LabCalibration;
use crate::error::Result;
use serde::Serialize;

const TEMPLATE: &str = include_str!("report.html");

/// What the template reads: every number already formatted.
#[derive(Serialize)]
struct Page<'a> {
    source: &'a str,
    width_px: usize,
    height_px: usize,
    offset_source: &'a str,
    /// Per channel and quantity: the table's eight cells.
    summary: Vec<[String; 8]>,
    /// The sensor table's rows: quantity, value ± 1σ, unit.
    sensor: Vec<[String; 3]>,
    /// What the capture could not determine: quantity, why.
    left_out: Vec<[&'a str; 2]>,
    maps: Vec<Map<'a>>,
}

#[derive(Serialize)]
struct Map<'a> {
    png: &'a str,
    name: &'a str,
    /// Low … high value and unit.
    range: String,
}

fn row(quantity: impl Into<String>, value: String, unit: &str) -> [String; 3] {
    [quantity.into(), value, unit.to_string()]
}

/// The page for `cal` of the capture `source`, with the written `maps`.
pub fn report_html(cal: &LabCalibration, source: &str, maps: &[MapFile]) -> Result<String> {
    let summary = cal
        .summary
        .iter()
        .map(|s| {
            [
                s.quantity.clone(),
                s.channel_deg.to_string(),
                format!("{:.5} ± {:.5}", s.mean, s.mean_sigma),
                format!("{:.5}", s.spread),
                format!("{:+.5} ± {:.5}", s.gradient_x, s.gradient_x_sigma),
                format!("{:+.5} ± {:.5}", s.gradient_y, s.gradient_y_sigma),
                s.pixel_sigma_rms.map_or("—".into(), |x| format!("{x:.5}")),
                s.unit.clone(),
            ]
        })
        .collect();
    let mut sensor = Vec::new();
    if let Some(d) = &cal.dark {
        sensor.push(row(format!("mean offset ({} dark frame(s))", d.frames), format!("{:.3}", d.mean_offset_dn), "DN"));
        sensor.push(row(
            "DSNU (offset spread, read noise included with 1 dark frame)",
            format!("{:.3}", d.dsnu_dn),
            "DN",
        ));
    }
    if let Some(p) = &cal.photon_transfer {
        sensor.push(row(
            "conversion gain K",
            format!("{:.5} ± {:.5}", p.conversion_gain_dn_per_e, p.conversion_gain_sigma),
            "DN/e⁻",
        ));
        sensor.push(row("read noise", format!("{:.3} ± {:.3}", p.read_noise_dn, p.read_noise_sigma_dn), "DN"));
        if let Some(le) = p.linearity_error_pct {
            sensor.push(row("linearity error", format!("{le:.4}"), "%"));
        }
        for q in &p.points {
            sensor.push(row(format!("mean signal at exposure {}×", q.exposure_rel), format!("{:.2}", q.mean_dn), "DN"));
        }
    }
    if let Some(f) = &cal.flat {
        sensor.push(row("vignetting v2 (r in focal lengths)", format!("{:.5} ± {:.5}", f.v2, f.v2_sigma), "1"));
        sensor.push(row("vignetting v4", format!("{:.5} ± {:.5}", f.v4, f.v4_sigma), "1"));
        sensor.push(row("PRNU (after falloff and channel means)", format!("{:.4}", f.prnu_pct), "%"));
    }
    if let Some(r) = &cal.malus_residual_dn {
        sensor.push(row(
            "Malus fit residual per channel (0°, 45°, 90°, 135°)",
            format!("{:.3}, {:.3}, {:.3}, {:.3}", r[0], r[1], r[2], r[3]),
            "DN",
        ));
    }
    let page = Page {
        source,
        width_px: cal.maps.width_px,
        height_px: cal.maps.height_px,
        offset_source: &cal.offset_source,
        summary,
        sensor,
        left_out: cal.left_out.iter().map(|l| [l.quantity.as_str(), l.reason.as_str()]).collect(),
        maps: maps
            .iter()
            .map(|f| Map { png: &f.png, name: &f.name, range: format!("{:.4} … {:.4} {}", f.low, f.high, f.unit) })
            .collect(),
    };
    crate::output::render_html("lab/report.html", TEMPLATE, &page)
}
