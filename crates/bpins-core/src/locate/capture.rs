//! From a capture to [`SunObs`]: each frame's cells, its sky's sun
//! ([`crate::heading::field::sky_sun`]), its stamp and its turn since the first frame.
//!
//! A colour-polarization capture (`colour_tiles`) is read through its green band: the
//! cells of the G tiles alone, with the frame's red-to-blue ratio for the colour cloud
//! test, at the colour compass's cell size (`fit::input::masks::green_cells`, the
//! fit's sky masks' cells). G has two tiles of four (the most cells and signal) and is
//! the band model's reference band. The three bands' suns are not fused: most of each
//! sun's 1σ is shared by the bands (the reference tilt, the sky model's misfit, the
//! neutral points' nuisance σ_n that `locate` carries as one bias for all frames) and
//! [`SkySun`] does not keep it apart from the independent noise, so an inverse-variance
//! mean would average the shared part down as if it were independent.

use super::{LocateError, SunObs};
use crate::capture::{Capture, FrameData};
use crate::effects::Model;
use crate::heading::field::{sky_sun, FieldOptions, FieldScratch, NoHeading, SkySun};
use crate::pipeline::{field_context, frame_cells};
use crate::sky::sun::{parse_time_utc, SunSource};

/// One frame of a capture as `locate` reads it.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameSun {
    pub index: usize,
    /// The frame's UTC stamp, seconds since 1970 (None: the frame has none).
    pub time_unix_s: Option<f64>,
    /// Turn since the first frame and its 1σ, degrees ([`relative_yaw`]).
    pub yaw_deg: f64,
    pub yaw_sigma_deg: f64,
    /// The sky's sun, or why the frame has none.
    pub sun: Result<SkySun, NoHeading>,
    /// The sun's azimuth and elevation the capture gives the frame by hand, degrees
    /// (None: a stamp, or nothing); [`SunObs::given_sun_deg`].
    pub given_sun_deg: Option<[f64; 2]>,
}

impl FrameSun {
    /// The measurement for [`super::locate`], where the frame has a sun.
    pub fn obs(&self) -> Option<SunObs> {
        let s = self.sun.as_ref().ok()?;
        Some(SunObs {
            time_unix_s: self.time_unix_s,
            yaw_deg: self.yaw_deg,
            yaw_sigma_deg: self.yaw_sigma_deg,
            bearing_deg: s.bearing_deg,
            bearing_sigma_deg: s.bearing_sigma_deg,
            elevation_deg: s.elevation_deg,
            elevation_sigma_deg: s.elevation_sigma_deg,
            elevation_nuisance_sigma_deg: s.elevation_nuisance_sigma_deg,
            separation_deg: s.separation_deg,
            separation_sigma_deg: s.separation_sigma_deg,
            given_sun_deg: self.given_sun_deg,
        })
    }
}

/// Each frame's turn since the first, and its 1σ, degrees: from `yaw_deg` (with
/// `yaw_sigma_deg`, default 0) where every frame has it, else from `heading_deg`
/// changes where every frame has one (1σ 0), else 0 (a static camera). Frames that
/// mix the two, or give them to some frames only, are refused naming the first
/// frame without.
pub fn relative_yaw(c: &Capture) -> Result<Vec<(f64, f64)>, LocateError> {
    let pick = |get: &dyn Fn(usize) -> Option<f64>, key: &str| -> Result<Option<Vec<f64>>, LocateError> {
        let have: Vec<Option<f64>> = (0..c.frames.len()).map(get).collect();
        match (have.iter().all(Option::is_some), have.iter().position(Option::is_none)) {
            (true, _) => Ok(Some(have.into_iter().flatten().collect())),
            (false, Some(i)) if have.iter().any(Option::is_some) => Err(LocateError::Yaw(format!(
                "frames[{i}] ({}) has no {key} while other frames have one: give it to every frame or to none",
                c.frames[i].file.display()
            ))),
            _ => Ok(None),
        }
    };
    if let Some(y) = pick(&|i| c.frames[i].yaw_deg, "yaw_deg")? {
        return Ok(c.frames.iter().zip(&y).map(|(f, v)| (v - y[0], f.yaw_sigma_deg.unwrap_or(0.0))).collect());
    }
    if let Some(h) = pick(&|i| c.frames[i].heading_deg, "heading_deg")? {
        return Ok(h.iter().map(|v| (v - h[0], 0.0)).collect());
    }
    Ok(vec![(0.0, 0.0); c.frames.len()])
}

/// Every frame of `c` read for `locate` (frames are read one by one; `progress` is
/// called after each); `known` is the sensor's calibration.
pub fn measure(
    c: &Capture,
    known: &Model,
    opts: &FieldOptions,
    mut progress: impl FnMut(usize),
) -> Result<Vec<FrameSun>, LocateError> {
    measure_with(c, known, opts, |i| c.read_frame(i), &mut progress)
}

/// [`measure`] of frames already in memory (`data[i]` the pixels of `c.frames[i]`).
pub fn measure_data(
    c: &Capture,
    data: &[FrameData],
    known: &Model,
    opts: &FieldOptions,
) -> Result<Vec<FrameSun>, LocateError> {
    if data.len() != c.frames.len() {
        return Err(LocateError::Core(crate::Error::FrameMismatch(format!(
            "{} frames of data for {} frames",
            data.len(),
            c.frames.len()
        ))));
    }
    measure_with(c, known, opts, |i| Ok(data[i].clone()), &mut |_| {})
}

fn measure_with(
    c: &Capture,
    known: &Model,
    opts: &FieldOptions,
    read: impl Fn(usize) -> crate::Result<FrameData>,
    progress: &mut dyn FnMut(usize),
) -> Result<Vec<FrameSun>, LocateError> {
    let yaw = relative_yaw(c)?;
    let mut scratch = FieldScratch::default();
    let mut out = Vec::with_capacity(c.frames.len());
    for (i, f) in c.frames.iter().enumerate() {
        let time_unix_s = match f.sun.source.time_utc() {
            Some(t) => {
                let t = parse_time_utc(t)?;
                Some(t.timestamp() as f64 + f64::from(t.timestamp_subsec_nanos()) * 1e-9)
            }
            None => None,
        };
        let data = read(i)?;
        // A colour capture's sun is its green band's (module doc).
        let cells = match crate::fit::input::masks::green_cells(c, &data, known, opts.cell_px)? {
            Some(green) => green,
            None => frame_cells(c, &data, known, opts.cell_px)?,
        };
        let ctx = field_context(c, f, known);
        let sun = sky_sun(&cells, &ctx, opts, &mut scratch);
        let given_sun_deg =
            matches!(f.sun.source, SunSource::Given).then_some([f.sun.azimuth_deg, f.sun.elevation_deg]);
        out.push(FrameSun { index: i, time_unix_s, yaw_deg: yaw[i].0, yaw_sigma_deg: yaw[i].1, sun, given_sun_deg });
        progress(i + 1);
    }
    Ok(out)
}
