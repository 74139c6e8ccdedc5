//! Time series to locate from (what `bpins simulate --every-min` writes): a site, a
//! start time, a frame every N seconds over a span, the sun by NREL SPA, the camera
//! turning by a fixed step per frame, and its gyro's yaw written with a seeded error.
//!
//! ```text
//! tₖ = t₀ + k·every,  k = 0 … ⌊span/every⌋
//! true heading ψₖ = ψ₀ + k·step                               rendered
//! written yaw  yₖ = k·step + σ_yaw·nₖ (k > 0), y₀ = 0         yaw_deg, yaw_sigma_deg = σ_yaw
//! ```
//!
//! The written frames carry `time_utc` alone (no place, no heading): the place and
//! ψ₀ are the truth ([`SeriesTruth`]), written beside the capture. With
//! `yaw_step_deg` = 0 and no `yaw_sigma_deg`, no yaw is written (a static camera).

use crate::capture::{Capture, FrameData, FrameSpec};
use crate::effects::Model;
use crate::error::{Error, Result};
use crate::pipeline::{simulate_capture, SimSensor};
use crate::scene::Draws;
use crate::scene::{FieldAttitude, FieldScene};
use crate::sky::sun::{parse_time_utc, sun_from_unix_time, SunPosition};
use chrono::SecondsFormat;

/// The trial word of the gyro's draws (apart from the scene's and the attitude's).
const YAW_TRIAL: u32 = 0x9a70_0001;

/// A time series of one camera at one site.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    /// RFC 3339 time of the first frame.
    pub start_utc: String,
    pub every_s: f64,
    pub span_s: f64,
    /// The camera's true heading at the first frame, degrees.
    pub heading_deg: f64,
    /// The camera's turn from frame to frame, degrees.
    pub yaw_step_deg: f64,
    /// 1σ of the written yaw (a gyro), degrees.
    pub yaw_sigma_deg: Option<f64>,
    pub seed: u64,
}

/// What a located series should find (`truth.toml` beside a simulated series).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeriesTruth {
    pub latitude_deg: f64,
    pub longitude_deg: f64,
    /// The camera's heading at the first frame.
    pub heading_deg: f64,
}

impl SeriesTruth {
    /// The text of `truth.toml`.
    pub fn to_toml_string(&self) -> String {
        let body = toml::to_string(self).expect("a truth serialises");
        format!("# the truth of a series simulated for `bpins locate` (capture readers ignore this file)\n{body}")
    }

    /// Reads a `truth.toml`; errors name the file and the key.
    pub fn load(path: &std::path::Path) -> Result<SeriesTruth> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::Io { path: path.to_path_buf(), source: e })?;
        toml::from_str(&text)
            .map_err(|e| Error::Capture { path: path.to_path_buf(), message: crate::capture::clean_toml_error(e) })
    }
}

impl Series {
    pub fn truth(&self) -> SeriesTruth {
        SeriesTruth {
            latitude_deg: self.latitude_deg,
            longitude_deg: self.longitude_deg,
            heading_deg: self.heading_deg,
        }
    }

    /// The frames to render (true sun and heading) and to write (stamp, yaw), files
    /// `frames/fNNN.<ext>`. Errors on a bad time, place, step or span.
    pub fn frames(&self, ext: &str) -> Result<(Vec<FrameSpec>, Vec<FrameSpec>)> {
        if !(self.every_s > 0.0 && self.every_s.is_finite() && self.span_s >= 0.0 && self.span_s.is_finite()) {
            return Err(Error::OutOfRange {
                what: "a series' frame interval and span".into(),
                value: format!("every {} s over {} s", self.every_s, self.span_s),
                range: "an interval > 0 s and a span ≥ 0 s".into(),
            });
        }
        let n = (self.span_s / self.every_s + 1e-9).floor() as usize + 1;
        if n > 10_000 {
            return Err(Error::OutOfRange {
                what: "a series' frame count".into(),
                value: n.to_string(),
                range: "[1, 10000]".into(),
            });
        }
        if let Some(s) = self.yaw_sigma_deg.filter(|s| !(s.is_finite() && (0.0..=45.0).contains(s))) {
            return Err(Error::OutOfRange {
                what: "yaw 1σ".into(), value: format!("{s}°"), range: "[0°, 45°]".into()
            });
        }
        let t0 = parse_time_utc(&self.start_utc)?;
        let t0_s = t0.timestamp() as f64 + f64::from(t0.timestamp_subsec_nanos()) * 1e-9;
        let write_yaw = self.yaw_step_deg != 0.0 || self.yaw_sigma_deg.is_some();
        let (mut truth, mut written) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for k in 0..n {
            let t = t0_s + k as f64 * self.every_s;
            let sun = sun_from_unix_time(t, self.latitude_deg, self.longitude_deg)?;
            let turn = k as f64 * self.yaw_step_deg;
            let noise = if k == 0 {
                0.0
            } else {
                self.yaw_sigma_deg.unwrap_or(0.0) * Draws::keyed(self.seed, YAW_TRIAL, k as u32).normal(0)
            };
            let time = chrono::DateTime::from_timestamp(t.floor() as i64, ((t - t.floor()) * 1e9) as u32)
                .ok_or_else(|| Error::Time { time: format!("time {t} s"), message: "not representable".into() })?
                .to_rfc3339_opts(SecondsFormat::AutoSi, true);
            let frame = FrameSpec {
                heading_deg: Some(self.heading_deg + turn),
                ..FrameSpec::new(format!("frames/f{k:03}.{ext}"), sun)
            };
            written.push(FrameSpec {
                sun: SunPosition::unplaced(&time)?,
                heading_deg: None,
                yaw_deg: write_yaw.then_some(turn + noise),
                yaw_sigma_deg: if write_yaw { self.yaw_sigma_deg } else { None },
                ..frame.clone()
            });
            truth.push(frame);
        }
        Ok((truth, written))
    }

    /// The series rendered in memory on `base`'s sensor and lens under `model`, the
    /// scene `field` and the `attitude` draws (random tilt, IMU): the capture as a
    /// user holds it (stamps, yaw, reference tilts) and its frames.
    pub fn simulate(
        &self,
        base: &Capture,
        model: &Model,
        field: Option<&FieldScene>,
        attitude: &FieldAttitude,
        sim: &SimSensor,
    ) -> Result<(Capture, Vec<FrameData>)> {
        let ext = base.frames.first().and_then(|f| f.file.extension()).and_then(|e| e.to_str()).unwrap_or("png");
        let (truth, written) = self.frames(ext)?;
        let (truth, reference) = attitude.draw(&truth)?;
        let render = Capture { frames: truth, ..base.clone() };
        let (_, data) = simulate_capture(&render, model, sim, field)?;
        Ok((Capture { frames: with_reference_tilts(written, reference), ..base.clone() }, data))
    }
}

/// The written frames of a series with the reference tilts (and their 1σ) of the
/// attitude draws' `reference` frames.
pub fn with_reference_tilts(written: Vec<FrameSpec>, reference: Vec<FrameSpec>) -> Vec<FrameSpec> {
    written
        .into_iter()
        .zip(reference)
        .map(|(w, r)| FrameSpec {
            tilt_x_deg: r.tilt_x_deg,
            tilt_y_deg: r.tilt_y_deg,
            tilt_sigma_deg: r.tilt_sigma_deg,
            ..w
        })
        .collect()
}
