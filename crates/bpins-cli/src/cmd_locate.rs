//! `bpins locate CAPTURE`: north, latitude and longitude from frames of one camera
//! over time, without GNSS (bpins_core::locate; docs/locate.md). Per frame the sky's
//! sun (bearing from the image top, elevation, 1σ), then the answer with its 1σ, or
//! why there is none yet (exit 2: too few frames with a sun, a 1σ over the bounds, or
//! frames in which the sun did not move, each the library's typed `LocateError`);
//! `--site-out` writes the site file that `bpins heading --site` and the Compass take
//! in place of a GNSS position.

use crate::{ensure_not_in_capture, write_json, write_output};
use anyhow::{bail, Context};
use bpins_core::compass::FieldOptions;
use bpins_core::conventions::wrap_deg_180;
use bpins_core::effects::EffectSet;
use bpins_core::tool::locate::SeriesTruth;
use bpins_core::Capture;
use bpins_core::{locate, measure, LocateOptions, Site, SunObs};
use serde_json::json;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Capture folder (bpins-capture/1) whose frames carry `time_utc` (with or without
    /// a place; a place given is not used) and, for a turning camera, `yaw_deg` or
    /// `heading_deg` changes.
    capture: PathBuf,
    /// A calibration file (bpins-calibration/1) to compensate.
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// A known calibration as effect.param=value (repeatable), on top of --calibration.
    #[arg(long = "effect", value_name = "EFFECT.PARAM=VALUE")]
    effects: Vec<String>,
    /// Field estimator: cell size in pixels (default: about 1/64 of the shorter side).
    #[arg(long)]
    cell_px: Option<usize>,
    /// The pole alone (north and latitude), even where the frames have stamps.
    #[arg(long, conflicts_with = "max_longitude_sigma_deg")]
    pole: bool,
    /// Refuse ("not yet") an answer whose north 1σ exceeds this, degrees.
    #[arg(long, default_value_t = LocateOptions::default().max_heading_sigma_deg)]
    max_heading_sigma_deg: f64,
    /// Refuse an answer whose latitude 1σ exceeds this, degrees.
    #[arg(long, default_value_t = LocateOptions::default().max_latitude_sigma_deg)]
    max_latitude_sigma_deg: f64,
    /// Refuse an answer whose longitude 1σ exceeds this, degrees.
    #[arg(long, default_value_t = LocateOptions::default().max_longitude_sigma_deg)]
    max_longitude_sigma_deg: f64,
    /// Write the site (bpins-site/1: place, north offset, 1σ) to this file.
    #[arg(long, value_name = "FILE")]
    site_out: Option<PathBuf>,
    /// Compare with a truth file (latitude_deg, longitude_deg, heading_deg), as
    /// `bpins simulate --every-min` writes beside the capture.
    #[arg(long, value_name = "FILE")]
    truth: Option<PathBuf>,
    /// Write the per-frame suns and the answer as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let cal = match &a.calibration {
        Some(p) => Some(bpins_core::calibration::Calibration::load(p)?),
        None => None,
    };
    if cal.as_ref().is_some_and(|c| c.pixels.is_some()) {
        bail!("--calibration: per-pixel maps are not applied by locate yet; use a calibration without them");
    }
    let mut known = cal.map(|c| c.effects).unwrap_or_else(EffectSet::new);
    for spec in &a.effects {
        known.parse_assignment(spec).with_context(|| format!("--effect {spec}"))?;
    }
    let known = known.model();
    if let Some(c) = a.cell_px.filter(|&c| c < 2) {
        bail!("--cell-px {c}: a cell must be at least 2 pixels (one DoFP tile)");
    }
    for p in [&a.site_out, &a.json].into_iter().flatten() {
        ensure_not_in_capture(p)?;
    }
    let truth = a.truth.as_deref().map(SeriesTruth::load).transpose()?;
    let opts = FieldOptions { cell_px: a.cell_px, ..FieldOptions::default() };
    let capture = Capture::load_unplaced(&a.capture)?;
    let pb = crate::progress::bar(capture.frames.len() as u64, "frames");
    let frames = measure(&capture, &known, &opts, |n| pb.set_position(n as u64))?;
    pb.finish_and_clear();
    out!(
        "{:<22} {:<22} {:>10} {:>12} {:>8} {:>14} {:>8}  or why no sun",
        "frame",
        "time (UTC)",
        "yaw (°)",
        "bearing (°)",
        "1σ (°)",
        "elevation (°)",
        "1σ (°)"
    );
    for f in &frames {
        let spec = &capture.frames[f.index];
        let time = spec.sun.source.time_utc().unwrap_or("—");
        match &f.sun {
            Ok(s) => out!(
                "{:<22} {:<22} {:>10.3} {:>12.4} {:>8.4} {:>14.4} {:>8.4}",
                spec.file.display(),
                time,
                f.yaw_deg,
                s.bearing_deg,
                s.bearing_sigma_deg,
                s.elevation_deg,
                s.elevation_sigma_deg
            ),
            Err(why) => out!("{:<22} {:<22} {:>10.3}  no sun: {why}", spec.file.display(), time, f.yaw_deg),
        }
    }
    let obs: Vec<SunObs> = frames.iter().filter_map(|f| f.obs()).collect();
    let lopts = LocateOptions {
        max_heading_sigma_deg: a.max_heading_sigma_deg,
        max_latitude_sigma_deg: a.max_latitude_sigma_deg,
        max_longitude_sigma_deg: a.max_longitude_sigma_deg,
        pole_only: a.pole,
    };
    let result = locate(&obs, &lopts).map_err(|e| match e {
        bpins_core::LocateError::TooFewFrames { usable, needed, .. } => {
            anyhow::anyhow!(
                "too few frames with a sun: {usable} of {} usable, {needed} needed (too cloudy, the sun out of range, \
                 or too few frames)",
                frames.len()
            )
        }
        e => anyhow::Error::new(e),
    });
    let first_time = frames
        .iter()
        .find(|f| f.sun.is_ok())
        .and_then(|f| capture.frames[f.index].sun.source.time_utc().map(str::to_string));
    let r = match result {
        Ok(r) => r,
        Err(e) => {
            if let Some(p) = &a.json {
                write_json(p, &json!({ "frames": frames_json(&frames), "error": e.to_string() }))?;
            }
            return Err(e.context(format!("{}: no answer", capture.dir.display())));
        }
    };
    out!(
        "route {}: {} frames{}, χ²/dof {:.2}",
        r.route.name(),
        r.frames_used,
        r.span_s.map(|s| format!(" over {:.0} min", s / 60.0)).unwrap_or_default(),
        r.chi2_per_dof
    );
    out!("north: the camera's heading at the first frame {:.4}° ± {:.4}° (1σ)", r.heading_deg, r.heading_sigma_deg);
    out!("latitude  {:.4}° ± {:.4}°", r.latitude_deg, r.latitude_sigma_deg);
    match (r.longitude_deg, r.longitude_sigma_deg) {
        (Some(l), Some(s)) => out!("longitude {l:.4}° ± {s:.4}°"),
        _ => out!("longitude: none (no clock: the pole route)"),
    }
    let mut errors = json!(null);
    if let Some(t) = &truth {
        let e_n = wrap_deg_180(r.heading_deg - t.heading_deg);
        let e_lat = r.latitude_deg - t.latitude_deg;
        let e_lon = r.longitude_deg.map(|l| wrap_deg_180(l - t.longitude_deg));
        out!(
            "against the truth: north {e_n:+.4}° ({:+.1}σ), latitude {e_lat:+.4}° ({:+.1}σ){}",
            e_n / r.heading_sigma_deg,
            e_lat / r.latitude_sigma_deg,
            match (e_lon, r.longitude_sigma_deg) {
                (Some(e), Some(s)) => format!(", longitude {e:+.4}° ({:+.1}σ)", e / s),
                _ => String::new(),
            }
        );
        errors = json!({ "heading_deg": e_n, "latitude_deg": e_lat, "longitude_deg": e_lon });
    }
    let site = Site::from_located(&r, first_time);
    if let Some(p) = &a.site_out {
        write_output(p, site.to_toml_string().as_bytes())?;
        say!("wrote the site to {}", p.display());
    }
    if let Some(p) = &a.json {
        write_json(p, &json!({ "frames": frames_json(&frames), "located": r, "errors": errors }))?;
        say!("wrote {}", p.display());
    }
    Ok(())
}

fn frames_json(frames: &[bpins_core::FrameSun]) -> serde_json::Value {
    frames
        .iter()
        .map(|f| match &f.sun {
            Ok(s) => json!({ "index": f.index, "time_unix_s": f.time_unix_s, "yaw_deg": f.yaw_deg, "sun": s }),
            Err(why) => json!({ "index": f.index, "time_unix_s": f.time_unix_s, "no_sun": why.to_string() }),
        })
        .collect()
}
