//! One frame source for `bpins heading` (issue 50 item 1): a capture folder, a ROS 2
//! bag and a live ROS 2 graph (`bpins node`) each hand the same [`SourceFrame`] (pixels,
//! where it came from, the sun and the reference tilt with their 1σ, the reference
//! heading where known) to one compass loop ([`read_frames`]), whose results are one
//! serde type ([`Row`]) for the table, `--json` and the output bag. The same pixels
//! with the same sun and tilt therefore give the same heading, 1σ and JSON row by
//! every route, bit for bit; only the fields naming the frame's origin differ (a
//! capture's `file`, a bag's `message_index`, `stamp`, `stamp_ns`, `frame_id`).

use anyhow::Context;
use bpins_core::compass::{Attitude, Compass, Extractor, FieldHeading, RawImage, SigmaParts, Sun};
use bpins_core::conventions::wrap_deg_180;
use bpins_core::{FrameData, SunSource};
use bpins_ros::rep103;
use serde::Serialize;
use serde_json::json;

/// A frame's origin, as the JSON names it (each route fills its own fields).
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameId {
    /// A capture's frame file, as `capture.toml` names it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// A bag's image message: its index on the image topic.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub message_index: Option<u64>,
    /// The image header's stamp.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stamp: Option<Stamp>,
    /// The same stamp, nanoseconds since the Unix epoch.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stamp_ns: Option<i64>,
    /// The image header's frame_id.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frame_id: Option<String>,
}

impl FrameId {
    /// The table's first column: the file, or the message index.
    fn label(&self) -> String {
        match (&self.file, self.message_index) {
            (Some(f), _) => f.clone(),
            (None, Some(i)) => format!("message {i}"),
            (None, None) => "—".into(),
        }
    }
}

/// A ROS 2 stamp (builtin_interfaces/Time).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Stamp {
    pub sec: i32,
    pub nanosec: u32,
}

/// A frame's pixels as its source holds them: a capture's (DoFP mosaic or colocated
/// planes, in DN as f32), or a bag's raw mono8/mono16 rows (any stride).
pub enum Pixels<'a> {
    Capture(&'a FrameData),
    Dn8(RawImage<'a, u8>),
    Dn16(RawImage<'a, u16>),
}

/// The sun a frame is read under, degrees, and where it came from.
#[derive(Clone, Debug)]
pub struct FrameSun {
    pub azimuth_deg: f64,
    pub elevation_deg: f64,
    /// 1σ of each angle, degrees (`None`: taken as exact).
    pub sigma_deg: Option<f64>,
    /// Where it came from, for the table and the JSON's `sun`.
    pub source: String,
    /// A mixed twilight's clock and place ([`Sun::mixed_twilight`]): the compass reads
    /// the frame with both sources; `None`: the angles above.
    pub mixed: Option<Sun>,
}

impl FrameSun {
    /// A frame's sun as the compass reads it: a twilight lit by both the sun and the
    /// moon with both sources ([`Sun::mixed_twilight`]), a dark night refused with
    /// the reason ([`bpins_core::tool::sun::dark_night`]), otherwise the angles.
    /// `sigma_deg`: each angle's 1σ, degrees (`None`: exact); `source`: for the table.
    pub fn of(sun: &bpins_core::SunPosition, sigma_deg: Option<f64>, source: String) -> Result<FrameSun, String> {
        let mixed = Sun::mixed_twilight(sun, sigma_deg.unwrap_or(0.0));
        match (&mixed, bpins_core::tool::sun::dark_night(sun)) {
            (None, Some(why)) => Err(why),
            _ => Ok(FrameSun {
                azimuth_deg: sun.azimuth_deg,
                elevation_deg: sun.elevation_deg,
                sigma_deg,
                source,
                mixed,
            }),
        }
    }

    /// `az/el [± 1σ], source`, four decimals.
    pub fn text(&self) -> String {
        let (az, el) = (self.azimuth_deg, self.elevation_deg);
        match self.sigma_deg {
            Some(s) => format!("{az:.4}/{el:.4} ± {s:.4}, {}", self.source),
            None => format!("{az:.4}/{el:.4}, {}", self.source),
        }
    }
}

/// Where a sun came from, for [`FrameSun::source`]: the source's own words, or for
/// a sun through NREL SPA the time, the place and where its 1σ came from (`sigma_from`,
/// where it has one).
pub fn sun_source(source: &SunSource, sigma_from: Option<&str>) -> String {
    match (source, sigma_from) {
        (SunSource::Spa { time_utc, latitude_deg, longitude_deg }, Some(what)) => {
            let ns = if *latitude_deg < 0.0 { 'S' } else { 'N' };
            let ew = if *longitude_deg < 0.0 { 'W' } else { 'E' };
            format!(
                "NREL SPA from {time_utc} at {:.4}°{ns} {:.4}°{ew}, 1σ {what}",
                latitude_deg.abs(),
                longitude_deg.abs()
            )
        }
        (other, _) => other.describe(),
    }
}

/// The reference tilt a frame is read at, degrees, with its 1σ; the roll and pitch
/// variances are what an output bag's Imu carries (REP 145).
#[derive(Clone, Copy, Debug)]
pub struct FrameTilt {
    pub tilt_x_deg: f64,
    pub tilt_y_deg: f64,
    /// 1σ of each tilt angle, degrees, as the compass takes it.
    pub sigma_deg: f64,
    pub roll_var_rad2: f64,
    pub pitch_var_rad2: f64,
}

/// One frame from any source.
pub struct SourceFrame<'a> {
    pub id: FrameId,
    pub pixels: Pixels<'a>,
    /// The sun, or why there is none at this frame (no fix near its stamp, …).
    pub sun: Result<FrameSun, String>,
    /// The reference tilt, or why there is none (no IMU sample near its stamp, NaN, …).
    pub tilt: Result<FrameTilt, String>,
    /// The true heading where the source knows it (a capture's `heading_deg`), degrees.
    pub reference_heading_deg: Option<f64>,
}

/// Where frames come from. A source walks its frames in order and hands each to
/// `visit`; it stops at the first error either side returns.
pub trait FrameSource {
    /// How many frames there are, for the progress bar.
    fn len(&self) -> u64;
    /// Walks the frames.
    fn each(&mut self, visit: &mut dyn FnMut(SourceFrame<'_>) -> anyhow::Result<()>) -> anyhow::Result<()>;
}

/// One extractor's result on one frame: a line of the table, a row of `--json`.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    #[serde(flatten)]
    pub id: FrameId,
    pub extractor: &'static str,
    /// A colour-polarization sensor's band (`R`, `G`, `B`), or `fused` for the bands'
    /// inverse-variance heading; absent for a monochrome sensor.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub band: Option<&'static str>,
    pub heading_deg: Option<f64>,
    /// The heading's 1σ, degrees (the parts' root sum of squares).
    pub sigma_deg: Option<f64>,
    pub reference_heading_deg: Option<f64>,
    /// Heading less reference, wrapped to (−180°, 180°].
    pub error_deg: Option<f64>,
    /// The heading as an ENU yaw (REP 103): 90° − heading, wrapped.
    pub yaw_enu_deg: Option<f64>,
    pub yaw_variance_rad2: Option<f64>,
    pub sigma_parts_deg: Option<SigmaParts>,
    pub tilt_x_deg: Option<f64>,
    pub tilt_y_deg: Option<f64>,
    pub tilt_sigma_deg: Option<f64>,
    pub sun_azimuth_deg: Option<f64>,
    pub sun_elevation_deg: Option<f64>,
    pub sun_sigma_deg: Option<f64>,
    /// The sun as the table says it (az/el ± 1σ, where it came from), or why none.
    pub sun: String,
    pub cells_total: Option<usize>,
    pub cells_valid: Option<usize>,
    pub cells_used: Option<usize>,
    pub used_fraction: Option<f64>,
    pub cloud_fraction: Option<f64>,
    pub residual_rms_deg: Option<f64>,
    pub misfit_deg: Option<f64>,
    pub iterations: Option<usize>,
    pub sun_elevation_offset_deg: Option<f64>,
    /// A mixed twilight read with both sources (docs/night.md "Twilight"): the sun's
    /// share of the two skies' polarized radiance as the fit found it, and its 1σ
    /// (`FieldHeading::fitted_sun_share`); absent for a one-source sky.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fitted_sun_share: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fitted_sun_share_sigma: Option<f64>,
    /// The plain estimator's sample count (`--estimator plain`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samples: Option<usize>,
    pub no_heading_reason: Option<String>,
}

impl Row {
    /// A row of frame `f` with no result yet: its origin, sun and tilt.
    pub fn of(f: &SourceFrame<'_>, extractor: Extractor) -> Row {
        let sun = f.sun.as_ref().ok();
        let tilt = f.tilt.as_ref().ok();
        Row {
            id: f.id.clone(),
            extractor: extractor.name(),
            band: None,
            heading_deg: None,
            sigma_deg: None,
            reference_heading_deg: f.reference_heading_deg,
            error_deg: None,
            yaw_enu_deg: None,
            yaw_variance_rad2: None,
            sigma_parts_deg: None,
            tilt_x_deg: tilt.map(|t| t.tilt_x_deg),
            tilt_y_deg: tilt.map(|t| t.tilt_y_deg),
            tilt_sigma_deg: tilt.map(|t| t.sigma_deg),
            sun_azimuth_deg: sun.map(|s| s.azimuth_deg),
            sun_elevation_deg: sun.map(|s| s.elevation_deg),
            sun_sigma_deg: sun.and_then(|s| s.sigma_deg),
            sun: match &f.sun {
                Ok(s) => s.text(),
                Err(why) => why.clone(),
            },
            cells_total: None,
            cells_valid: None,
            cells_used: None,
            used_fraction: None,
            cloud_fraction: None,
            residual_rms_deg: None,
            misfit_deg: None,
            iterations: None,
            sun_elevation_offset_deg: None,
            fitted_sun_share: None,
            fitted_sun_share_sigma: None,
            samples: None,
            no_heading_reason: None,
        }
    }

    /// Sets the heading and its 1σ, and what follows from them.
    pub fn set_heading(&mut self, heading_deg: f64, sigma_deg: f64) {
        self.heading_deg = Some(heading_deg);
        self.sigma_deg = Some(sigma_deg);
        self.error_deg = self.reference_heading_deg.map(|r| wrap_deg_180(heading_deg - r));
        self.yaw_enu_deg = Some(rep103::yaw_deg(rep103::enu_quaternion(heading_deg, 0.0, 0.0)));
        self.yaw_variance_rad2 = Some(sigma_deg.to_radians().powi(2));
    }

    /// The field estimator's result.
    fn set_field(&mut self, h: &FieldHeading) {
        let q = &h.quality;
        self.cells_total = Some(q.cells_total);
        self.cells_valid = Some(q.cells_valid);
        self.cells_used = Some(q.cells_used);
        self.used_fraction = Some(q.used_fraction);
        self.cloud_fraction = Some(q.cloud_fraction);
        self.residual_rms_deg = finite(q.residual_rms_deg);
        self.misfit_deg = finite(q.misfit_deg);
        self.iterations = Some(q.iterations);
        self.sun_elevation_offset_deg = finite(q.sun_elevation_offset_deg);
        self.fitted_sun_share = h.fitted_sun_share();
        self.fitted_sun_share_sigma = h.fitted_sun_share_sigma();
        match &h.result {
            Ok((heading, parts)) => {
                self.set_heading(*heading, parts.total_deg());
                self.sigma_parts_deg = Some(*parts);
            }
            Err(why) => self.no_heading_reason = Some(why.to_string()),
        }
    }

    /// The table's line.
    pub fn line(&self) -> String {
        let opt = |x: Option<f64>, f: &dyn Fn(f64) -> String| x.map(f).unwrap_or_else(|| "—".into());
        let tilt = match (self.tilt_x_deg, self.tilt_y_deg) {
            (Some(x), Some(y)) => format!("{x:+.2}/{y:+.2}"),
            _ => "—".into(),
        };
        format!(
            "{:<22} {:<20} {:>12} {:>9} {:>14} {:>10} {:>8} {:>9} {:>9} {:>10} {:>13}  {}",
            self.id.label(),
            match self.band {
                Some(b) => format!("{} {b}", self.extractor),
                None => self.extractor.to_string(),
            },
            opt(self.heading_deg, &|x| format!("{x:.4}")),
            opt(self.sigma_deg, &|x| format!("{x:.4}")),
            opt(self.reference_heading_deg, &|x| format!("{x:.4}")),
            opt(self.error_deg, &|x| format!("{x:+.4}")),
            opt(self.error_deg.zip(self.sigma_deg).map(|(e, s)| e / s), &|x| format!("{x:+.1}")),
            opt(self.used_fraction, &|x| format!("{:.1}", 100.0 * x)),
            opt(self.cloud_fraction, &|x| format!("{:.1}", 100.0 * x)),
            opt(self.residual_rms_deg, &|x| format!("{x:.3}")),
            tilt,
            match (&self.no_heading_reason, self.fitted_sun_share.zip(self.fitted_sun_share_sigma)) {
                (Some(w), _) => format!("no heading: {w}"),
                (None, Some((p, sd))) => format!("{}; the sun's polarized share fitted {p:.3} ± {sd:.3}", self.sun),
                (None, None) => self.sun.clone(),
            }
        )
    }
}

/// The table's header.
pub fn header_line() -> String {
    format!(
        "{:<22} {:<20} {:>12} {:>9} {:>14} {:>10} {:>8} {:>9} {:>9} {:>10} {:>13}  sun az/el (°) [± its 1σ], source; or why no heading",
        "frame",
        "extractor",
        "heading (°)",
        "1σ (°)",
        "reference (°)",
        "error (°)",
        "err/1σ",
        "used (%)",
        "cloud (%)",
        "resid (°)",
        "tilt x/y (°)"
    )
}

/// The compass over every frame of `source` with each of `extractors`: a frame's rows
/// go to the table as it is read (the header with the first, so that a frame that
/// cannot be read ends the command before any table), then to `after` (an output
/// bag's messages), and are returned for `--json` and the summary. A frame without a
/// sun or a tilt has rows saying why; a frame the compass refuses (the wrong size)
/// ends the run with the frame named.
pub fn read_frames(
    source: &mut dyn FrameSource,
    compass: &mut Compass,
    extractors: &[Extractor],
    after: &mut dyn FnMut(&SourceFrame<'_>, &[Row]) -> anyhow::Result<()>,
) -> anyhow::Result<Vec<Row>> {
    let pb = crate::progress::bar(source.len(), "frames");
    let mut rows: Vec<Row> = Vec::new();
    let mut header = true;
    source.each(&mut |f| {
        let frame_rows = frame_rows(compass, extractors, &f)?;
        pb.inc(1);
        pb.suspend(|| -> anyhow::Result<()> {
            if std::mem::take(&mut header) {
                out!("{}", header_line());
            }
            for r in &frame_rows {
                out!("{}", r.line());
            }
            Ok(())
        })?;
        after(&f, &frame_rows)?;
        rows.extend(frame_rows);
        Ok(())
    })?;
    pb.finish_and_clear();
    Ok(rows)
}

/// One frame's rows, one per extractor (and per band of a colour sensor): the
/// compass's heading, or why there is none (no sun, no tilt, the fit's reason). Every
/// route's frames go through it (capture, bag, live node). An error is a frame the
/// compass refuses (the wrong size), named by its label.
pub fn frame_rows(compass: &mut Compass, extractors: &[Extractor], f: &SourceFrame<'_>) -> anyhow::Result<Vec<Row>> {
    let mut frame_rows: Vec<Row> = Vec::new();
    match (&f.sun, &f.tilt) {
        (Ok(sun), Ok(tilt)) => {
            let sun_arg = sun.mixed.unwrap_or(Sun::Angles {
                azimuth_deg: sun.azimuth_deg,
                elevation_deg: sun.elevation_deg,
                sigma_deg: sun.sigma_deg.unwrap_or(0.0),
            });
            let att = Attitude { tilt_x_deg: tilt.tilt_x_deg, tilt_y_deg: tilt.tilt_y_deg, sigma_deg: tilt.sigma_deg };
            // Per band (a colour sensor: the fused heading first, then each band's),
            // each extractor's heading.
            let sets: Vec<(Option<&'static str>, Vec<FieldHeading>)> = if compass.is_colour() {
                let fix = match &f.pixels {
                    Pixels::Capture(data) => compass.capture_colour_headings(data, sun_arg, att, extractors),
                    Pixels::Dn8(r) => compass.colour_headings(*r, sun_arg, att, extractors),
                    Pixels::Dn16(r) => compass.colour_headings(*r, sun_arg, att, extractors),
                }
                .with_context(|| f.id.label())?;
                std::iter::once((Some("fused"), fix.fused))
                    .chain(fix.bands.into_iter().map(|(b, hs)| (Some(b.name()), hs)))
                    .collect()
            } else {
                let hs = match &f.pixels {
                    Pixels::Capture(data) => compass.capture_headings(data, sun_arg, att, extractors),
                    Pixels::Dn8(r) => compass.headings(*r, sun_arg, att, extractors),
                    Pixels::Dn16(r) => compass.headings(*r, sun_arg, att, extractors),
                }
                .with_context(|| f.id.label())?;
                vec![(None, hs)]
            };
            for (band, hs) in sets {
                for h in &hs {
                    let mut row = Row::of(&f, h.extractor);
                    row.band = band;
                    row.set_field(h);
                    frame_rows.push(row);
                }
            }
        }
        (Err(why), _) | (_, Err(why)) => {
            for &e in extractors {
                let mut row = Row::of(&f, e);
                row.band = compass.is_colour().then_some("fused");
                row.no_heading_reason = Some(why.clone());
                frame_rows.push(row);
            }
        }
    }
    Ok(frame_rows)
}

/// Per extractor: frames, frames without a heading, and against the reference where
/// there is one the RMS and largest error and the share within 2σ. Printed as a line
/// each; returned for the JSON's `summary`.
pub fn summary(rows: &[Row], extractors: &[Extractor]) -> anyhow::Result<Vec<serde_json::Value>> {
    let mut summary = Vec::new();
    let mut bands: Vec<Option<&'static str>> = Vec::new();
    for r in rows {
        if !bands.contains(&r.band) {
            bands.push(r.band);
        }
    }
    if bands.is_empty() {
        bands.push(None);
    }
    for e in extractors {
        for &band in &bands {
            let mine: Vec<&Row> = rows.iter().filter(|r| r.extractor == e.name() && r.band == band).collect();
            let errs: Vec<(f64, f64)> = mine.iter().filter_map(|r| Some((r.error_deg?, r.sigma_deg?))).collect();
            let none = mine.iter().filter(|r| r.heading_deg.is_none()).count();
            let name = match band {
                Some(b) => format!("{} {b}", e.name()),
                None => e.name().to_string(),
            };
            let mut line = format!("{name}: {} frame(s) with a heading, {none} without", mine.len() - none);
            let mut s = json!({"extractor": e.name(), "frames": mine.len(), "frames_without_heading": none});
            if let Some(b) = band {
                s["band"] = json!(b);
            }
            if !errs.is_empty() {
                let n = errs.len() as f64;
                let rms = (errs.iter().map(|x| x.0 * x.0).sum::<f64>() / n).sqrt();
                let max = errs.iter().fold(0f64, |m, x| m.max(x.0.abs()));
                let z: Vec<f64> = errs.iter().map(|(x, s)| (x / s).abs()).collect();
                let within = z.iter().filter(|&&z| z <= 2.0).count() as f64 / n;
                let zmax = z.iter().fold(0f64, |m, &x| m.max(x));
                line += &format!(
                    "; RMS error {rms:.4}°, largest |error| {max:.4}° over {} frames; {:.0} % within 2σ, largest |error|/σ {zmax:.1}",
                    errs.len(),
                    100.0 * within
                );
                s["rms_error_deg"] = json!(rms);
                s["max_abs_error_deg"] = json!(max);
                s["within_2sigma_fraction"] = json!(within);
                s["max_abs_error_over_sigma"] = json!(zmax);
            } else {
                line += "; no reference headings to compare";
            }
            out!("{line}");
            summary.push(s);
        }
    }
    Ok(summary)
}

/// JSON has no NaN: `None` instead.
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}
