//! `bpins calibrate LAB --out DIR`: a DoFP sensor calibrated from a lab capture
//! (`kind = "lab"`, CAPTURE.md) per pixel (`bpins_core::lab`). Writes
//! DIR/calibration.toml with DIR/pixels.exr beside it (for `heading`, `fit`,
//! `diagnose --calibration` and the library's Compass), every map as
//! DIR/maps.exr and DIR/png/*.png, DIR/summary.json and DIR/report.html. A colour
//! sensor (`colour_tiles`) is calibrated band by band: its calibration.toml holds
//! effects (`lab/bands.rs`: what `fit` and `diagnose` take), and
//! DIR/calibration-pixels.toml with DIR/pixels.exr its per-pixel maps, which the
//! compass (`heading`) applies band by band and `fit` and `diagnose` pixel by pixel.

use crate::{ensure_not_in_capture, write_json, write_output};
use anyhow::Context;
use bpins_core::calibrate;
use bpins_core::calibration::Calibration;
use bpins_core::tool::lab::{report_html, write_maps};
use bpins_core::LabCapture;
use serde_json::json;
use std::path::PathBuf;
use std::sync::Arc;

/// A colour sensor's per-pixel calibration file, beside calibration.toml (its effects).
const COLOUR_PIXELS_FILE: &str = "calibration-pixels.toml";

#[derive(clap::Args)]
pub struct Args {
    /// The lab capture folder (bpins-capture/1, kind = "lab").
    lab: PathBuf,
    /// Output folder (never inside the capture).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    ensure_not_in_capture(&a.out)?;
    let t0 = std::time::Instant::now();
    let lab = LabCapture::load(&a.lab)?;
    let g = &lab.sensor.geometry;
    say!("bpins calibrate: {} frames of {} ({} × {} px)", lab.frames.len(), a.lab.display(), g.width_px, g.height_px);
    let pb = crate::progress::bar(lab.frames.len() as u64, "frames");
    let cal = calibrate(&lab, &|done, _| pb.set_position(done as u64)).context("calibrating")?;
    pb.finish_and_clear();
    let t_fit = t0.elapsed().as_secs_f64();

    out!("offsets: {}", cal.offset_source);
    out!(
        "{:<24} {:>8} {:>22} {:>11} {:>22} {:>22} {:>12}  unit",
        "quantity",
        "channel",
        "mean ± 1σ",
        "spread",
        "gradient x ± 1σ",
        "gradient y ± 1σ",
        "pixel 1σ"
    );
    for s in &cal.summary {
        out!(
            "{:<24} {:>7}° {:>11.5} ± {:<8.5} {:>11.5} {:>+11.5} ± {:<8.5} {:>+11.5} ± {:<8.5} {:>12}  {}",
            s.quantity,
            s.channel_deg,
            s.mean,
            s.mean_sigma,
            s.spread,
            s.gradient_x,
            s.gradient_x_sigma,
            s.gradient_y,
            s.gradient_y_sigma,
            s.pixel_sigma_rms.map_or("—".into(), |x| format!("{x:.5}")),
            s.unit
        );
    }
    if let Some(p) = &cal.photon_transfer {
        out!(
            "photon transfer: K {:.5} ± {:.5} DN/e⁻, read noise {:.3} ± {:.3} DN, linearity error {}",
            p.conversion_gain_dn_per_e,
            p.conversion_gain_sigma,
            p.read_noise_dn,
            p.read_noise_sigma_dn,
            p.linearity_error_pct.map_or("—".into(), |x| format!("{x:.4} %"))
        );
    }
    if let Some(d) = &cal.dark {
        out!("dark: mean offset {:.3} DN, DSNU {:.3} DN over {} dark frame(s)", d.mean_offset_dn, d.dsnu_dn, d.frames);
    }
    if let Some(f) = &cal.flat {
        out!(
            "flat field: vignetting v2 {:.5} ± {:.5}, v4 {:.5} ± {:.5} (r in focal lengths), PRNU {:.3} %",
            f.v2,
            f.v2_sigma,
            f.v4,
            f.v4_sigma,
            f.prnu_pct
        );
    }
    for b in cal.bands.iter().flatten() {
        out!(
            "band {} ({:.0} nm, {} px): gain {:.4} ± {:.4} of green's, ε 0°/45°/90°/135° {}, PRNU {:.3} %{}",
            b.band,
            b.centre_nm,
            b.pixels,
            b.qe,
            b.qe_sigma,
            (0..4)
                .map(|c| format!("{:.5} ± {:.5}", b.eps_by_channel[c], b.eps_sigma_by_channel[c]))
                .collect::<Vec<_>>()
                .join(" / "),
            b.prnu_pct,
            b.photon_transfer.as_ref().map_or(String::new(), |p| format!(
                ", K {:.5} ± {:.5} DN/e⁻, read noise {:.3} DN",
                p.conversion_gain_dn_per_e, p.conversion_gain_sigma, p.read_noise_dn
            ))
        );
    }
    for l in &cal.left_out {
        out!("not determined: {}: {}", l.quantity, l.reason);
    }

    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let maps = write_maps(&cal, &a.out).context("writing the maps")?;
    let source = format!("bpins calibrate {}", a.lab.display());
    // A colour sensor's per-pixel maps are each pixel's total (its band's ε and gain
    // included), so they go in a file of their own: calibration.toml is the effects each
    // band's means give (every route), calibration-pixels.toml the maps (every route).
    // Together they would count the band twice (`Calibration::pixels_conflict`).
    let calibration = match &cal.bands {
        Some(bands) => {
            let (effects, sigmas) =
                bpins_core::tool::lab::bands::effects(bands).context("the colour sensor's calibration effects")?;
            let px =
                Calibration { source: source.clone(), pixels: Some(Arc::new(cal.maps.clone())), ..Default::default() };
            px.write_pixels(&a.out).context("writing pixels.exr")?;
            write_output(&a.out.join(COLOUR_PIXELS_FILE), px.to_toml().as_bytes())?;
            say!(
                "colour sensor: calibration.toml holds effects (analyzer_angles, extinction_ratio, band_response, \
                 channel_response: heading, fit, diagnose); {COLOUR_PIXELS_FILE} the per-pixel maps (pixels.exr: \
                 heading applies them band by band, fit and diagnose pixel by pixel)"
            );
            Calibration { source, effects, sigmas, ..Default::default() }
        }
        None => {
            let c = Calibration { source, pixels: Some(Arc::new(cal.maps.clone())), ..Default::default() };
            c.write_pixels(&a.out).context("writing pixels.exr")?;
            c
        }
    };
    let cal_path = a.out.join("calibration.toml");
    write_output(&cal_path, calibration.to_toml().as_bytes())?;
    let mut summary = json!({
        "lab": a.lab.display().to_string(),
        "width_px": g.width_px, "height_px": g.height_px,
        "offset_source": cal.offset_source,
        "channels": cal.summary,
        "photon_transfer": cal.photon_transfer,
        "dark": cal.dark.as_ref().map(|d| json!({"frames": d.frames, "mean_offset_dn": d.mean_offset_dn, "dsnu_dn": d.dsnu_dn})),
        "flat_field": cal.flat,
        "malus_residual_dn": cal.malus_residual_dn,
        "left_out": cal.left_out,
        "maps": maps,
    });
    if let Some(bands) = &cal.bands {
        summary["bands"] = json!(bands);
    }
    write_json(&a.out.join("summary.json"), &summary)?;
    write_output(&a.out.join("report.html"), report_html(&cal, &a.lab.display().to_string(), &maps)?.as_bytes())?;
    let t_all = t0.elapsed().as_secs_f64();
    let pixels_note = if cal.bands.is_some() { " (+ calibration-pixels.toml, pixels.exr)" } else { " (+ pixels.exr)" };
    say!(
        "wrote {}{pixels_note}, maps.exr, png/, summary.json, report.html to {} in {t_all:.1} s \
         (reading and fitting {t_fit:.1} s, writing {:.1} s)",
        cal_path.display(),
        a.out.display(),
        t_all - t_fit
    );
    Ok(())
}
