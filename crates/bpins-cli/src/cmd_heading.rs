//! `bpins heading CAPTURE`: per frame the heading, its 1σ, the reference and the error;
//! with the field estimator (the default) also how much of the image it used, how well
//! the used sky fits, and the reason for any frame without a heading.

use crate::{ensure_not_in_capture, write_json};
use anyhow::{bail, Context};
use bpins_core::calibration::Calibration;
use bpins_core::compass::Compass;
use bpins_core::compass::Extractor;
use bpins_core::compass::FieldOptions;
use bpins_core::conventions::wrap_deg_180;
use bpins_core::effects::EffectSet;
use bpins_core::tool::pipeline::{apply_pixel_maps, frame_headings_of, ReconMode};
use bpins_core::Capture;
use serde_json::json;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Capture folder holding capture.toml (bpins-capture/1); or --bag. The bag's
    /// flags but --tilt-sigma-deg are refused with it (clap does not check their
    /// `requires = "bag"` against an argument that conflicts with --bag).
    #[arg(
        required_unless_present = "bag",
        conflicts_with_all = [
            "bag", "image_topic", "camera_info_topic", "imu_topic", "fix_topic", "sensor", "mosaic_deg",
            "bit_depth", "black_level_dn", "sun_azimuth_deg", "sun_elevation_deg", "sun_sigma_deg", "imu_match",
            "imu_max_gap_s", "fix_max_age_s",
        ]
    )]
    capture: Option<PathBuf>,
    #[command(flatten)]
    bag: crate::bag::BagArgs,
    /// With --bag: write a new ROS 2 bag (MCAP) to this folder (which must not
    /// exist): per frame a sensor_msgs/Imu with the heading (REP 103, REP 145), or a
    /// diagnostic_msgs/DiagnosticArray saying why there is none.
    #[arg(long, value_name = "DIR", requires = "bag")]
    bag_out: Option<PathBuf>,
    /// With --bag-out: the topic of the sensor_msgs/Imu headings.
    #[arg(long, default_value = "/bpins/heading", value_name = "TOPIC", requires = "bag_out")]
    heading_topic: String,
    /// With --bag-out: the topic of the diagnostic_msgs/DiagnosticArray of frames
    /// without a heading.
    #[arg(long, default_value = "/diagnostics", value_name = "TOPIC", requires = "bag_out")]
    diagnostics_topic: String,
    /// With --bag-out: the frame_id of the Imu headings (default: the image's). The
    /// orientation is that of bpins' body frame (x the image top, z the optical
    /// axis: docs/ros2.md); name a TF frame that is it.
    #[arg(long, value_name = "FRAME", requires = "bag_out")]
    heading_frame_id: Option<String>,
    /// Heading extractor (`all`: each in turn; a capture only, --bag reads one).
    #[arg(long, value_enum, default_value = "sun_vector")]
    extractor: ExtractorArg,
    /// Estimator: `field` (robust to clouds, trees, the sun in view, tilt; a 1σ that
    /// includes the reference tilt's and the sun's errors) or `plain` (every pixel, no
    /// masks, statistical 1σ only: the seed paper's extractors as they are).
    #[arg(long, value_enum, default_value_t = Estimator::Field)]
    estimator: Estimator,
    /// Field estimator: cell size in pixels (default: about 1/64 of the shorter side).
    #[arg(long, conflicts_with = "recon")]
    cell_px: Option<usize>,
    /// Plain estimator: how DoFP mosaics become Stokes samples: `demosaic` (bilinear,
    /// every pixel its own ray; most accurate) or `superpixel` (2×2 tiles at their
    /// centres; faster, biased by ~0.05° on gradients). Default: demosaic.
    #[arg(long, value_parser = crate::names::by_name(&ReconMode::ALL, ReconMode::name), conflicts_with = "bag")]
    recon: Option<ReconMode>,
    /// A known calibration to compensate, as effect.param=value (repeatable),
    /// e.g. --effect array_rotation.dtheta_deg=0.3.
    #[arg(long = "effect", value_name = "EFFECT.PARAM=VALUE")]
    effects: Vec<String>,
    /// A calibration file (bpins-calibration/1, as `bpins fit` or `bpins calibrate`
    /// writes it) to compensate, its per-pixel maps included; `--effect`
    /// assignments apply on top of it.
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// Write the per-frame results as JSON to this file (never inside the capture).
    #[arg(long)]
    json: Option<PathBuf>,
    /// A site located by `bpins locate` (bpins-site/1) in place of a GNSS position:
    /// frames stamped with `time_utc` alone get the sun at this site, its 1σ the
    /// site's propagated. A capture only (a bag's suns come from its fixes or --sun-*).
    #[arg(long, value_name = "FILE", conflicts_with = "bag")]
    site: Option<PathBuf>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq)]
enum Estimator {
    /// Cells, masks, robust reweighting, jackknife 1σ (bpins_core::compass).
    Field,
    /// Every sample, least squares, statistical 1σ (the Monte Carlo's extractors).
    Plain,
}

/// `--extractor`: one of the library's extractors, or `all`.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ExtractorArg {
    One(Extractor),
    All,
}

impl clap::ValueEnum for ExtractorArg {
    fn value_variants<'a>() -> &'a [Self] {
        static VARIANTS: std::sync::LazyLock<Vec<ExtractorArg>> = std::sync::LazyLock::new(|| {
            Extractor::ALL.into_iter().map(ExtractorArg::One).chain([ExtractorArg::All]).collect()
        });
        &VARIANTS
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(match self {
            ExtractorArg::One(e) => clap::builder::PossibleValue::new(e.name()).help(e.describe()),
            ExtractorArg::All => clap::builder::PossibleValue::new("all").help("every extractor, each in turn"),
        })
    }
}

impl Args {
    /// A combination of flags clap cannot see (it turns on a flag's value): the two
    /// flags as a clap conflict names them, for `main` to refuse as clap does.
    pub fn refused(&self) -> Option<(String, String)> {
        let plain = self.estimator == Estimator::Plain;
        let pair = |a: &str, b: &str| Some((a.to_string(), b.to_string()));
        if plain {
            if self.bag.bag.is_some() {
                return pair("--estimator plain", "--bag <DIR>");
            }
            if self.cell_px.is_some() {
                return pair("--cell-px <CELL_PX>", "--estimator plain");
            }
            if self.bag.tilt_sigma_deg.is_some() {
                return pair("--tilt-sigma-deg <TILT_SIGMA_DEG>", "--estimator plain");
            }
        } else if self.recon.is_some() {
            return pair("--recon <RECON>", "--estimator field (the default)");
        }
        if self.extractor == ExtractorArg::All && self.bag.bag.is_some() {
            return pair("--extractor all", "--bag <DIR>");
        }
        None
    }
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let extractors: Vec<Extractor> = match a.extractor {
        ExtractorArg::All => Extractor::ALL.to_vec(),
        ExtractorArg::One(e) => vec![e],
    };
    let cal = match &a.calibration {
        Some(p) => Some(Calibration::load(p)?),
        None => None,
    };
    let pixels = cal.as_ref().and_then(|c| c.pixels.clone());
    let mut known_set = cal.map(|c| c.effects).unwrap_or_else(EffectSet::new);
    for spec in &a.effects {
        known_set.parse_assignment(spec).with_context(|| format!("--effect {spec}"))?;
    }
    let known = known_set.model();
    let mode = a.recon.unwrap_or(ReconMode::Demosaic);
    if let Some(c) = a.cell_px {
        if c < 2 {
            bail!("--cell-px {c}: a cell must be at least 2 pixels (one DoFP tile)");
        }
    }
    let opts = FieldOptions { cell_px: a.cell_px, ..FieldOptions::default() };
    let Some(capture_dir) = &a.capture else {
        return run_bag(&a, &extractors, opts);
    };
    // Which frames take their sun (and its 1σ) from --site.
    let (mut capture, from_site) = match &a.site {
        None => {
            let c = Capture::load(capture_dir)?;
            let n = c.frames.len();
            (c, vec![false; n])
        }
        Some(p) => {
            let site = bpins_core::Site::load(p)?;
            let mut c = Capture::load_unplaced(capture_dir)?;
            let unplaced: Vec<bool> = c.frames.iter().map(|f| !f.sun.is_known()).collect();
            let n = site.place(&mut c).with_context(|| format!("--site {}", p.display()))?;
            say!(
                "--site {}: the sun of {n} frame(s) stamped without a place from the located site, its 1σ the \
                 site's latitude and longitude 1σ propagated through SPA",
                p.display()
            );
            (c, unplaced)
        }
    };
    if let Some(p) = &a.json {
        ensure_not_in_capture(p)?;
    }
    // --tilt-sigma-deg: every frame's reference tilt 1σ, as the bag route takes it in
    // place of the IMU's covariance; a frame without tilt keys is level ± it (as a bag
    // without an IMU is), so both routes give one heading and 1σ on the same frames.
    if let Some(s) = a.bag.tilt_sigma_deg {
        let level = capture.frames.iter().filter(|f| f.tilt_x_deg.is_none() && f.tilt_y_deg.is_none()).count();
        for f in &mut capture.frames {
            f.tilt_sigma_deg = Some(s);
        }
        say!(
            "--tilt-sigma-deg {s}: every frame's reference tilt 1σ ({level} frame(s) without tilt keys taken as level \
             ± {s}°)"
        );
    }
    let field = a.estimator == Estimator::Field;
    // The field estimator reads every frame through the compass, as a robot does (the
    // calibration's per-pixel maps applied to each frame first, below).
    let mut compass = if field {
        let effects_only = Calibration { effects: known_set, ..Calibration::default() };
        let c = Compass::for_capture(&capture, effects_only, opts, extractors[0])
            .with_context(|| format!("{}", capture.toml_path().display()))?;
        Some(c)
    } else {
        None
    };
    // The header goes out with the first frame's rows: a frame that cannot be read
    // (truncated, the wrong size) ends the command before any table.
    let mut header = true;
    let pb = crate::progress::bar(capture.frames.len() as u64, "frames");
    let mut rows: Vec<Row> = Vec::new();
    for (i, f) in capture.frames.iter().enumerate() {
        let file = f.file.display().to_string();
        let sun = sun_text(f, from_site[i]);
        let mut frame_rows: Vec<Row> = Vec::new();
        let mut data = capture.read_frame(i)?;
        if let Some(m) = &pixels {
            data = apply_pixel_maps(&capture, data, m)
                .with_context(|| format!("--calibration {}", a.calibration.as_ref().unwrap().display()))?;
        }
        if let Some(compass) = &mut compass {
            let headings = compass
                .capture_frame(&data, f, &extractors)
                .with_context(|| format!("{}: frame {}", capture.toml_path().display(), f.file.display()))?;
            for h in headings {
                let q = h.quality;
                let (heading, parts, why) = match &h.result {
                    Ok((hd, p)) => (Some(*hd), Some(*p), None),
                    Err(r) => (None, None, Some(r.to_string())),
                };
                frame_rows.push(Row {
                    file: file.clone(),
                    extractor: h.extractor,
                    heading_deg: heading,
                    sigma_deg: parts.map(|p| p.total_deg()),
                    reference_deg: f.heading_deg,
                    why,
                    extra: json!({
                        "sigma_parts_deg": parts,
                        "cells_total": q.cells_total, "cells_valid": q.cells_valid, "cells_used": q.cells_used,
                        "used_fraction": q.used_fraction, "cloud_fraction": q.cloud_fraction,
                        "residual_rms_deg": finite(q.residual_rms_deg),
                        "misfit_deg": finite(q.misfit_deg), "iterations": q.iterations,
                        "sun_elevation_offset_deg": finite(q.sun_elevation_offset_deg),
                    }),
                    used_fraction: Some(q.used_fraction),
                    cloud_fraction: Some(q.cloud_fraction),
                    residual_deg: Some(q.residual_rms_deg),
                    sun: sun.clone(),
                    sun_sigma_deg: f.sun_sigma_deg,
                });
            }
        } else {
            for (e, r) in frame_headings_of(&capture, i, &data, &known, mode, &extractors)? {
                let (heading, sigma, samples, why) = match r {
                    Ok(est) => (Some(est.heading_deg), Some(est.sigma_deg), Some(est.samples), None),
                    Err(err) => (None, None, None, Some(err.to_string())),
                };
                frame_rows.push(Row {
                    file: file.clone(),
                    extractor: e,
                    heading_deg: heading,
                    sigma_deg: sigma,
                    reference_deg: f.heading_deg,
                    why,
                    extra: json!({ "samples": samples }),
                    used_fraction: None,
                    cloud_fraction: None,
                    residual_deg: None,
                    sun: sun.clone(),
                    sun_sigma_deg: f.sun_sigma_deg,
                });
            }
        }
        pb.inc(1);
        pb.suspend(|| -> anyhow::Result<()> {
            if std::mem::take(&mut header) {
                print_header()?;
            }
            frame_rows.iter().try_for_each(Row::print)
        })?;
        rows.extend(frame_rows);
    }
    pb.finish_and_clear();
    let mut summary = Vec::new();
    for e in &extractors {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.extractor == *e).collect();
        let errs: Vec<(f64, f64)> = mine.iter().filter_map(|r| Some((r.error_deg()?, r.sigma_deg?))).collect();
        let none = mine.iter().filter(|r| r.heading_deg.is_none()).count();
        let mut line = format!("{}: ", e.name());
        let mut s = json!({"extractor": e.name(), "frames": mine.len(), "frames_without_heading": none});
        if !errs.is_empty() {
            let n = errs.len() as f64;
            let rms = (errs.iter().map(|x| x.0 * x.0).sum::<f64>() / n).sqrt();
            let max = errs.iter().fold(0f64, |m, x| m.max(x.0.abs()));
            let z: Vec<f64> = errs.iter().map(|(x, s)| (x / s).abs()).collect();
            let within = z.iter().filter(|&&z| z <= 2.0).count() as f64 / n;
            let zmax = z.iter().fold(0f64, |m, &x| m.max(x));
            line += &format!(
                "RMS error {rms:.4}°, largest |error| {max:.4}° over {} frames; {:.0} % within 2σ, largest |error|/σ {zmax:.1}",
                errs.len(),
                100.0 * within
            );
            s["rms_error_deg"] = json!(rms);
            s["max_abs_error_deg"] = json!(max);
            s["within_2sigma_fraction"] = json!(within);
            s["max_abs_error_over_sigma"] = json!(zmax);
        } else {
            line += "no reference headings to compare";
        }
        if none > 0 {
            line += &format!("; {none} frame(s) without a heading");
        }
        out!("{line}");
        summary.push(s);
    }
    if let Some(p) = &a.json {
        let v = json!({
            "capture": capture.dir.display().to_string(),
            "estimator": if field { "field" } else { "plain" },
            "recon": if field { "cells" } else { mode.name() },
            "compensated_effects": a.effects,
            "calibration": a.calibration.as_ref().map(|p| p.display().to_string()),
            "frames": rows.iter().map(Row::to_json).collect::<Vec<_>>(),
            "summary": summary,
        });
        write_json(p, &v)?;
        say!("wrote {}", p.display());
    }
    let failed = rows.iter().filter(|r| r.heading_deg.is_none()).count();
    if !field && failed > 0 {
        bail!("{failed} heading extraction(s) failed");
    }
    Ok(())
}

/// The table's header.
fn print_header() -> anyhow::Result<()> {
    out!(
        "{:<22} {:<14} {:>12} {:>9} {:>14} {:>10} {:>8} {:>9} {:>9} {:>10}  sun az/el (°) [± its 1σ], source; or why no heading",
        "frame",
        "extractor",
        "heading (°)",
        "1σ (°)",
        "reference (°)",
        "error (°)",
        "err/1σ",
        "used (%)",
        "cloud (%)",
        "resid (°)"
    );
    Ok(())
}

/// The sun of frame `f` as the heading uses it: azimuth/elevation, the 1σ it carries
/// into the heading where it has one (`sun_sigma_deg`, or the site's propagated where
/// `from_site`), and where it came from.
fn sun_text(f: &bpins_core::FrameSpec, from_site: bool) -> String {
    use bpins_core::SunSource;
    let (az, el) = (f.sun.azimuth_deg, f.sun.elevation_deg);
    let Some(sigma) = f.sun_sigma_deg else {
        return format!("{az:.4}/{el:.4}, {}", f.sun.source.describe());
    };
    let source = match &f.sun.source {
        SunSource::Spa { time_utc, latitude_deg, longitude_deg } => {
            let ns = if *latitude_deg < 0.0 { 'S' } else { 'N' };
            let ew = if *longitude_deg < 0.0 { 'W' } else { 'E' };
            let place = format!("{:.4}°{ns} {:.4}°{ew}", latitude_deg.abs(), longitude_deg.abs());
            if from_site {
                format!("NREL SPA from {time_utc} at the located site {place} (--site), 1σ its place's propagated")
            } else {
                format!("NREL SPA from {time_utc} at {place}, 1σ sun_sigma_deg")
            }
        }
        other => other.describe(),
    };
    format!("{az:.4}/{el:.4} ± {sigma:.4}, {source}")
}

/// `--bag`: the front door over a ROS 2 bag (cmd_heading_bag.rs).
fn run_bag(a: &Args, extractors: &[Extractor], opts: FieldOptions) -> anyhow::Result<()> {
    let [extractor] = extractors else {
        bail!("--bag reads one extractor per run: --extractor sun_vector or meridian_line, not all");
    };
    if a.estimator != Estimator::Field {
        bail!("--bag reads through the field estimator (the compass): --estimator plain is for captures");
    }
    let mut calibration = match &a.calibration {
        Some(p) => Calibration::load(p)?,
        None => Calibration::default(),
    };
    for spec in &a.effects {
        calibration.effects.parse_assignment(spec).with_context(|| format!("--effect {spec}"))?;
    }
    let out = crate::cmd_heading_bag::BagOut {
        json: a.json.as_deref(),
        bag_out: a.bag_out.as_ref(),
        heading_topic: &a.heading_topic,
        diagnostics_topic: &a.diagnostics_topic,
        heading_frame_id: a.heading_frame_id.as_deref(),
    };
    crate::cmd_heading_bag::run(&a.bag, *extractor, calibration, opts, out)
}

/// One extractor's result on one frame.
struct Row {
    file: String,
    extractor: Extractor,
    heading_deg: Option<f64>,
    sigma_deg: Option<f64>,
    reference_deg: Option<f64>,
    /// Why there is no heading.
    why: Option<String>,
    extra: serde_json::Value,
    used_fraction: Option<f64>,
    /// Fraction of the observed sky taken for cloud (field estimator).
    cloud_fraction: Option<f64>,
    residual_deg: Option<f64>,
    sun: String,
    /// The sun's 1σ the heading carries, degrees (`None`: taken as exact).
    sun_sigma_deg: Option<f64>,
}

impl Row {
    fn error_deg(&self) -> Option<f64> {
        Some(wrap_deg_180(self.heading_deg? - self.reference_deg?))
    }

    fn print(&self) -> anyhow::Result<()> {
        let opt = |x: Option<f64>, f: &dyn Fn(f64) -> String| x.map(f).unwrap_or_else(|| "—".into());
        let err = self.error_deg();
        out!(
            "{:<22} {:<14} {:>12} {:>9} {:>14} {:>10} {:>8} {:>9} {:>9} {:>10}  {}",
            self.file,
            self.extractor.name(),
            opt(self.heading_deg, &|x| format!("{x:.4}")),
            opt(self.sigma_deg, &|x| format!("{x:.4}")),
            opt(self.reference_deg, &|x| format!("{x:.4}")),
            opt(err, &|x| format!("{x:+.4}")),
            opt(err.zip(self.sigma_deg).map(|(e, s)| e / s), &|x| format!("{x:+.1}")),
            opt(self.used_fraction, &|x| format!("{:.1}", 100.0 * x)),
            opt(self.cloud_fraction, &|x| format!("{:.1}", 100.0 * x)),
            opt(self.residual_deg.filter(|x| x.is_finite()), &|x| format!("{x:.3}")),
            match &self.why {
                Some(w) => format!("no heading: {w}"),
                None => self.sun.clone(),
            }
        );
        Ok(())
    }

    fn to_json(&self) -> serde_json::Value {
        let mut v = json!({
            "file": self.file, "extractor": self.extractor.name(), "heading_deg": self.heading_deg,
            "sigma_deg": self.sigma_deg, "reference_heading_deg": self.reference_deg, "error_deg": self.error_deg(),
            "no_heading_reason": self.why, "sun": self.sun, "sun_sigma_deg": self.sun_sigma_deg,
        });
        if let (Some(o), Some(extra)) = (v.as_object_mut(), self.extra.as_object()) {
            o.extend(extra.clone());
        }
        v
    }
}

/// JSON has no NaN: `null` instead.
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}
