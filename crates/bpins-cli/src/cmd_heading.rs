//! `bpins heading CAPTURE`: per frame the heading, its 1σ, the reference and the error.

use crate::{ensure_not_in_capture, write_json};
use anyhow::{bail, Context};
use bpins_core::capture::Capture;
use bpins_core::conventions::wrap_deg_180;
use bpins_core::effects::EffectSet;
use bpins_core::heading::Extractor;
use bpins_core::pipeline::{frame_headings, ReconMode};
use serde_json::json;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Capture folder holding capture.toml (bpins-capture/1).
    capture: PathBuf,
    /// Heading extractor: sun_vector, meridian_line, or all.
    #[arg(long, default_value = "sun_vector")]
    extractor: String,
    /// How DoFP mosaics become Stokes samples.
    #[arg(long, value_enum, default_value_t = Recon::Demosaic)]
    recon: Recon,
    /// A known calibration to compensate, as effect.param=value (repeatable),
    /// e.g. --effect array_rotation.dtheta_deg=0.3.
    #[arg(long = "effect", value_name = "EFFECT.PARAM=VALUE")]
    effects: Vec<String>,
    /// Write the per-frame results as JSON to this file (never inside the capture).
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum Recon {
    /// Bilinear demosaicing: every pixel its own ray (default; most accurate).
    Demosaic,
    /// 2×2 superpixels at the tile centres (faster; biased by ~0.05° on gradients).
    Superpixel,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let extractors: Vec<Extractor> = if a.extractor == "all" {
        Extractor::ALL.to_vec()
    } else {
        match Extractor::from_name(&a.extractor) {
            Some(e) => vec![e],
            None => bail!(
                "unknown extractor `{}`; use one of: {}, all",
                a.extractor,
                Extractor::ALL.map(|e| e.name()).join(", ")
            ),
        }
    };
    let mut known = EffectSet::new();
    for spec in &a.effects {
        known.parse_assignment(spec).with_context(|| format!("--effect {spec}"))?;
    }
    let known = known.model();
    let mode = match a.recon {
        Recon::Demosaic => ReconMode::Demosaic,
        Recon::Superpixel => ReconMode::Superpixel,
    };
    let capture = Capture::load(&a.capture)?;
    if let Some(p) = &a.json {
        ensure_not_in_capture(p)?;
    }
    println!(
        "{:<22} {:<14} {:>12} {:>9} {:>14} {:>10}  sun az/el (°), source",
        "frame", "extractor", "heading (°)", "1σ (°)", "reference (°)", "error (°)"
    );
    let pb = crate::progress::bar(capture.frames.len() as u64, "frames");
    let mut frames_json = Vec::new();
    let mut errors: Vec<(Extractor, f64)> = Vec::new();
    let mut failures = 0;
    for (i, f) in capture.frames.iter().enumerate() {
        let results = frame_headings(&capture, i, &known, mode, &extractors)?;
        pb.inc(1);
        for (e, r) in results {
            let file = f.file.display().to_string();
            let sun = format!("{:.4}/{:.4}, {}", f.sun.azimuth_deg, f.sun.elevation_deg, f.sun.source.describe());
            match r {
                Ok(est) => {
                    let err = f.heading_deg.map(|h| wrap_deg_180(est.heading_deg - h));
                    if let Some(x) = err {
                        errors.push((e, x));
                    }
                    pb.suspend(|| {
                        println!(
                            "{:<22} {:<14} {:>12.4} {:>9.4} {:>14} {:>10}  {}",
                            file,
                            e.name(),
                            est.heading_deg,
                            est.sigma_deg,
                            f.heading_deg.map(|h| format!("{h:.4}")).unwrap_or_else(|| "—".into()),
                            err.map(|x| format!("{x:+.4}")).unwrap_or_else(|| "—".into()),
                            sun
                        )
                    });
                    frames_json.push(json!({
                        "file": file, "extractor": e.name(), "heading_deg": est.heading_deg, "sigma_deg": est.sigma_deg,
                        "reference_heading_deg": f.heading_deg, "error_deg": err, "samples": est.samples,
                        "sun_azimuth_deg": f.sun.azimuth_deg, "sun_elevation_deg": f.sun.elevation_deg, "sun_source": f.sun.source.describe(),
                    }));
                }
                Err(err) => {
                    failures += 1;
                    pb.suspend(|| println!("{:<22} {:<14} failed: {err}", file, e.name()));
                    frames_json.push(json!({
                        "file": file, "extractor": e.name(), "heading_deg": null, "sigma_deg": null,
                        "reference_heading_deg": f.heading_deg, "error_deg": null, "error": err.to_string(),
                    }));
                }
            }
        }
    }
    pb.finish_and_clear();
    let mut summary = Vec::new();
    for e in &extractors {
        let errs: Vec<f64> = errors.iter().filter(|(x, _)| x == e).map(|(_, v)| *v).collect();
        if !errs.is_empty() {
            let rms = (errs.iter().map(|x| x * x).sum::<f64>() / errs.len() as f64).sqrt();
            let max = errs.iter().fold(0f64, |m, x| m.max(x.abs()));
            println!("{}: RMS error {rms:.4}°, largest |error| {max:.4}° over {} frames", e.name(), errs.len());
            summary.push(
                json!({"extractor": e.name(), "rms_error_deg": rms, "max_abs_error_deg": max, "frames": errs.len()}),
            );
        }
    }
    if let Some(p) = &a.json {
        let v = json!({
            "capture": capture.dir.display().to_string(),
            "recon": mode.name(),
            "compensated_effects": a.effects,
            "frames": frames_json,
            "summary": summary,
        });
        write_json(p, &v)?;
        eprintln!("wrote {}", p.display());
    }
    if failures > 0 {
        bail!("{failures} heading extraction(s) failed");
    }
    Ok(())
}
