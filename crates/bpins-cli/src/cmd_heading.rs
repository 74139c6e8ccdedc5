//! `bpins heading CAPTURE`: per frame the heading, its 1σ, the reference and the error;
//! with the field estimator (the default) also how much of the image it used, how well
//! the used sky fits, and the reason for any frame without a heading.

use crate::frames::{self, FrameId, FrameSource, FrameSun, FrameTilt, Pixels, Row, SourceFrame};
use crate::{ensure_not_in_capture, write_json};
use anyhow::{bail, Context};
use bpins_core::calibration::Calibration;
use bpins_core::compass::Compass;
use bpins_core::compass::Extractor;
use bpins_core::compass::FieldOptions;
use bpins_core::sensor::Band;
use bpins_core::tool::pipeline::{apply_pixel_maps, colour_frame_headings_of, frame_headings_of, ReconMode};
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
    /// Heading extractor (`all`: each in turn, on one robust fit; not with --bag-out,
    /// which writes one heading per frame).
    #[arg(long, value_enum, default_value = "sun_vector")]
    extractor: ExtractorArg,
    /// Estimator: `field` (robust to clouds, trees, the sun in view, tilt; a 1σ that
    /// includes the reference tilt's and the sun's errors) or `plain` (every pixel, no
    /// masks, statistical 1σ only: the seed paper's extractors as they are, the 1σ of
    /// demosaiced samples widened for their interpolation, docs/honesty.md).
    #[arg(long, value_enum, default_value_t = Estimator::Field)]
    estimator: Estimator,
    /// Field estimator: cell size in pixels (default: about 1/64 of the shorter side).
    #[arg(long, conflicts_with = "recon")]
    cell_px: Option<usize>,
    /// Plain estimator: how DoFP mosaics become Stokes samples: `demosaic` (bilinear,
    /// every pixel its own ray) or `superpixel` (2×2 tiles at their centres, each
    /// channel moved there by its gradient across the tiles beside it: as accurate,
    /// docs/honesty.md). Default: demosaic, its 1σ × 8/3 (√ of the design effect 64/9:
    /// each raw DN enters nine pixels' samples). A colour capture: each band from its
    /// own tiles, demosaic's samples the tile means.
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
        if self.extractor == ExtractorArg::All && self.bag_out.is_some() {
            return pair("--extractor all", "--bag-out <DIR>");
        }
        None
    }
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let extractors: Vec<Extractor> = match a.extractor {
        ExtractorArg::All => Extractor::ALL.to_vec(),
        ExtractorArg::One(e) => vec![e],
    };
    let mut calibration = match &a.calibration {
        Some(p) => Calibration::load(p)?,
        None => Calibration::default(),
    };
    for spec in &a.effects {
        calibration.effects.parse_assignment(spec).with_context(|| format!("--effect {spec}"))?;
    }
    let known = calibration.effects.model();
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
    let mut source = CaptureSource { capture: &capture, from_site };
    let rows = if field {
        // The field estimator reads every frame through the compass, as a robot does:
        // the calibration whole (its effects and its per-pixel maps, read per cell),
        // as the bag route and the live node read theirs.
        let mut compass =
            Compass::for_capture(&capture, calibration.clone(), opts, extractors[0]).with_context(|| {
                match &a.calibration {
                    Some(c) => format!("{} with --calibration {}", capture.toml_path().display(), c.display()),
                    None => capture.toml_path().display().to_string(),
                }
            })?;
        frames::read_frames(&mut source, &mut compass, &extractors, &mut |_, _| Ok(()))
            .with_context(|| capture.toml_path().display().to_string())?
    } else {
        plain_rows(&mut source, &known, mode, calibration.pixels.as_deref(), a.calibration.as_deref(), &extractors)?
    };
    let summary = frames::summary(&rows, &extractors)?;
    if let Some(p) = &a.json {
        let v = json!({
            "capture": capture.dir.display().to_string(),
            "estimator": if field { "field" } else { "plain" },
            "recon": if field { "cells" } else { mode.name() },
            "compensated_effects": a.effects,
            "calibration": a.calibration.as_ref().map(|p| p.display().to_string()),
            "frames": rows,
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

/// A capture's frames as a frame source: each frame's pixels as `read_frame` gives
/// them, its sun and reference tilt (level where it has no tilt keys) with their 1σ
/// from its `[[frames]]` entry, its reference heading.
struct CaptureSource<'c> {
    capture: &'c Capture,
    /// Which frames took their sun (and its 1σ) from --site.
    from_site: Vec<bool>,
}

impl FrameSource for CaptureSource<'_> {
    fn len(&self) -> u64 {
        self.capture.frames.len() as u64
    }

    fn each(&mut self, visit: &mut dyn FnMut(SourceFrame<'_>) -> anyhow::Result<()>) -> anyhow::Result<()> {
        for (i, f) in self.capture.frames.iter().enumerate() {
            let data = self.capture.read_frame(i)?;
            let sigma_from = match (f.sun_sigma_deg, self.from_site[i]) {
                (None, _) => None,
                (Some(_), true) => Some("the located site's latitude and longitude 1σ propagated (--site)"),
                (Some(_), false) => Some("sun_sigma_deg"),
            };
            let tilt_sigma_deg = f.tilt_sigma_deg.unwrap_or(0.0);
            let var_rad2 = tilt_sigma_deg.to_radians().powi(2);
            visit(SourceFrame {
                id: FrameId { file: Some(f.file.display().to_string()), ..FrameId::default() },
                pixels: Pixels::Capture(&data),
                sun: FrameSun::of(&f.sun, f.sun_sigma_deg, frames::sun_source(&f.sun.source, sigma_from)),
                tilt: Ok(FrameTilt {
                    tilt_x_deg: f.tilt_x_deg.unwrap_or(0.0),
                    tilt_y_deg: f.tilt_y_deg.unwrap_or(0.0),
                    sigma_deg: tilt_sigma_deg,
                    roll_var_rad2: var_rad2,
                    pitch_var_rad2: var_rad2,
                }),
                reference_heading_deg: f.heading_deg,
            })?;
        }
        Ok(())
    }
}

/// `--estimator plain`: every sample of each frame, least squares, statistical 1σ (the
/// Monte Carlo's extractors), a calibration's per-pixel maps applied to the mosaic
/// first (per tile: the plain reconstruction reads nominal analyzers). Rows as the
/// compass loop's, printed as it goes.
fn plain_rows(
    source: &mut CaptureSource<'_>,
    known: &bpins_core::effects::Model,
    mode: ReconMode,
    pixels: Option<&bpins_core::PixelMaps>,
    calibration: Option<&std::path::Path>,
    extractors: &[Extractor],
) -> anyhow::Result<Vec<Row>> {
    let capture = source.capture;
    let pb = crate::progress::bar(source.len(), "frames");
    let mut rows = Vec::new();
    let mut i = 0;
    source.each(&mut |f| {
        let Pixels::Capture(data) = &f.pixels else { unreachable!("a capture's frames") };
        let mapped;
        let data = match pixels {
            Some(m) => {
                mapped = apply_pixel_maps(capture, (*data).clone(), m).with_context(|| {
                    format!("--calibration {}", calibration.map(|p| p.display().to_string()).unwrap_or_default())
                })?;
                &mapped
            }
            None => *data,
        };
        let frame_rows = if capture.sensor.colour.is_some() {
            colour_rows(&f, capture, i, data, known, mode, extractors)?
        } else {
            let hs = frame_headings_of(capture, i, data, known, mode, extractors)?;
            hs.into_iter().map(|(e, r)| plain_row(&f, e, r.map_err(|err| err.to_string()))).collect()
        };
        i += 1;
        pb.inc(1);
        pb.suspend(|| -> anyhow::Result<()> {
            if i == 1 {
                out!("{}", frames::header_line());
            }
            for r in &frame_rows {
                out!("{}", r.line());
            }
            Ok(())
        })?;
        rows.extend(frame_rows);
        Ok(())
    })?;
    pb.finish_and_clear();
    Ok(rows)
}

/// A colour-polarization frame's plain rows (`colour_frame_headings_of`: each band's
/// own 2 × 2 tiles, least squares, statistical 1σ), as the field route orders them:
/// the fused heading with each extractor (the bands' inverse-variance mean, its 1σ
/// statistical only, what the bands share not in it), then each band's.
fn colour_rows(
    f: &SourceFrame<'_>,
    capture: &Capture,
    index: usize,
    data: &bpins_core::FrameData,
    known: &bpins_core::effects::Model,
    mode: ReconMode,
    extractors: &[Extractor],
) -> anyhow::Result<Vec<Row>> {
    let per = colour_frame_headings_of(capture, index, data, known, mode, extractors)?;
    let mut rows: Vec<Row> = per
        .iter()
        .map(|c| {
            let fused = c.fused.ok_or_else(|| {
                let why: Vec<String> = c
                    .bands
                    .iter()
                    .filter_map(|(b, r)| r.as_ref().err().map(|e| format!("{}: {e}", b.name())))
                    .collect();
                format!("no band has a heading ({})", why.join("; "))
            });
            Row { band: Some("fused"), ..plain_row(f, c.extractor, fused) }
        })
        .collect();
    let bands: Vec<Band> = per.first().map(|c| c.bands.iter().map(|(b, _)| *b).collect()).unwrap_or_default();
    for (k, b) in bands.iter().enumerate() {
        for c in &per {
            let r = c.bands[k].1.as_ref().copied().map_err(ToString::to_string);
            rows.push(Row { band: Some(b.name()), ..plain_row(f, c.extractor, r) });
        }
    }
    Ok(rows)
}

/// A plain estimate's row: the heading, its 1σ and sample count, or why none.
fn plain_row(f: &SourceFrame<'_>, e: Extractor, r: Result<bpins_core::HeadingEstimate, String>) -> Row {
    let mut row = Row::of(f, e);
    match r {
        Ok(est) => {
            row.set_heading(est.heading_deg, est.sigma_deg);
            row.samples = Some(est.samples);
        }
        Err(why) => row.no_heading_reason = Some(why),
    }
    row
}

/// `--bag`: the front door over a ROS 2 bag (cmd_heading_bag.rs).
fn run_bag(a: &Args, extractors: &[Extractor], opts: FieldOptions) -> anyhow::Result<()> {
    if extractors.len() > 1 && a.bag_out.is_some() {
        bail!("--bag-out writes one heading per frame: --extractor sun_vector or meridian_line, not all");
    }
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
        compensated_effects: &a.effects,
        calibration: a.calibration.as_deref(),
    };
    crate::cmd_heading_bag::run(&a.bag, extractors, calibration, opts, out)
}
