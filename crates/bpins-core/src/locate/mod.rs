//! North and position from the sky alone: for a robot whose GNSS receiver has gone
//! dark (issue 33).
//!
//! The sky's pattern turns with the sun about the celestial pole. Frames of one
//! camera over time give, per frame, the sun's bearing from the image top and its
//! elevation, each with 1σ ([`crate::heading::field::sky_sun`]). From them:
//!
//! * **stamped route** (every usable frame has `time_utc`; `solve.rs`): unknowns the
//!   camera's heading at the first frame ψ₀ (its true-north offset), the latitude φ
//!   and the longitude λ; model (`model.rs`) the apparent sun (A, h)(φ, λ, tᵢ) by NREL
//!   SPA, the bearing `bᵢ = A − ψ₀ − Δyawᵢ` and the elevation `hᵢ`; weighted least
//!   squares by Levenberg–Marquardt from the best cells of a 5° × 10° grid of (φ, λ),
//!   ψ₀ solved in closed form on the grid (the weighted circular mean); covariance
//!   (JᵀJ)⁻¹ of the whitened residuals, times χ²/dof where it exceeds 1.
//! * **pole route** (no usable stamps, three frames or more; `pole.rs`): the sun's unit
//!   vectors in the first frame's level axes lie on a cone about the celestial pole
//!   (the declination barely moves in a day): fit the cone's axis and half-angle; the
//!   axis's elevation is the latitude, its bearing gives north; the sense in which the
//!   sun turns (westward, clockwise about the north pole) tells the north pole from
//!   the south. No longitude without a clock.
//!
//! The relative yaw Δyawᵢ between frames comes from the capture: `yaw_deg` (a gyro,
//! with `yaw_sigma_deg`) where every frame has it, else `heading_deg` changes where
//! every frame has one (only changes are used), else the camera is taken as static.
//! Its 1σ joins the bearing's, frame by frame (a gyro's drift is correlated across
//! frames; taking it as independent understates its effect when it dominates).
//!
//! Honest answers: a sequence with too few usable frames, or whose 1σ exceeds the
//! asked bounds (too short a span, too cloudy), is a typed [`LocateError`], never an
//! answer; so are frames in which the sun cannot be seen to move (`motion.rs`, refused
//! before any fit, whose 1σ would not see it): suns given by hand, the same for every
//! frame ([`LocateError::SunGiven`]), one stamp on every frame
//! ([`LocateError::OneInstant`]), stamps whose span lets the sun move less than 5× the
//! 1σ of its travel ([`LocateError::SpanTooShort`]) and suns that, the camera's turns
//! taken out, span less than that ([`LocateError::SunStill`]); where the frames' sky is not Rayleigh's (its neutral points split by more
//! than 5° and twice their 1σ, by the frames' median: `sky_sun`'s step 5), the
//! refusal says so ([`LocateError::NotRayleigh`]). Frame: ENU and CONVENTIONS.md's azimuths (from North toward East); the
//! heading is the image top's azimuth at the first frame.
//!
//! Cannot: use frames whose sun is below the horizon or within 1° of the zenith;
//! separate a mount tilt (an elevation bias shared by all frames) from the latitude;
//! model the declination's change over a day on the pole route (≤ 0.4° per day, so
//! spans of a few hours); locate from a single frame.

mod capture;
mod model;
mod motion;
mod pole;
mod series;
mod site;
mod solve;

pub use capture::{measure, measure_data, relative_yaw, FrameSun};
pub use model::SunModel;
pub use motion::MIN_TRAVEL_SIGMAS;
pub use series::{with_reference_tilts, Series, SeriesTruth};
pub use site::Site;

/// How a [`locate`] answer was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Route {
    /// UTC stamps: north, latitude and longitude.
    Stamped,
    /// No stamps: the pole alone (north and latitude).
    Pole,
}

impl Route {
    pub fn name(self) -> &'static str {
        match self {
            Route::Stamped => "stamped",
            Route::Pole => "pole",
        }
    }
}

/// One frame's measurement for [`locate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunObs {
    /// UTC stamp, seconds since 1970-01-01T00:00:00Z (None: no usable stamp).
    pub time_unix_s: Option<f64>,
    /// The camera's turn since the first frame, degrees (heading sense), and its 1σ.
    pub yaw_deg: f64,
    pub yaw_sigma_deg: f64,
    /// The sun's bearing from the image top and its elevation, degrees, with 1σ.
    pub bearing_deg: f64,
    pub bearing_sigma_deg: f64,
    pub elevation_deg: f64,
    pub elevation_sigma_deg: f64,
    /// What the sky's unknown neutral-point separation adds to the elevation's 1σ,
    /// degrees: the same sky for every frame, so a bias shared by all of them.
    pub elevation_nuisance_sigma_deg: f64,
    /// The sky's neutral-point separation the frame's fit found and its 1σ, degrees
    /// (0 for Rayleigh's sky; [`crate::heading::field::SkySun`]).
    pub separation_deg: f64,
    pub separation_sigma_deg: f64,
    /// The sun's azimuth and elevation the capture gives this frame by hand
    /// (`sun_azimuth_deg`, `sun_elevation_deg`), degrees; `None` where it gives a stamp
    /// or nothing. No answer is read from it, but frames that all share one are refused:
    /// the capture says the sun stood still ([`LocateError::SunGiven`]).
    pub given_sun_deg: Option<[f64; 2]>,
}

/// Bounds on the answer's 1σ past which [`locate`] says "not yet" instead.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocateOptions {
    pub max_heading_sigma_deg: f64,
    pub max_latitude_sigma_deg: f64,
    pub max_longitude_sigma_deg: f64,
    /// Force the pole route even where the frames have stamps.
    pub pole_only: bool,
}

impl Default for LocateOptions {
    fn default() -> Self {
        LocateOptions {
            max_heading_sigma_deg: 2.0,
            max_latitude_sigma_deg: 2.0,
            max_longitude_sigma_deg: 3.0,
            pole_only: false,
        }
    }
}

/// Where the camera is and where it points, with 1σ.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Located {
    pub route: Route,
    /// The camera's heading (image top's azimuth) at the first usable frame, [0°, 360°).
    pub heading_deg: f64,
    pub heading_sigma_deg: f64,
    pub latitude_deg: f64,
    pub latitude_sigma_deg: f64,
    /// Only on the stamped route.
    pub longitude_deg: Option<f64>,
    pub longitude_sigma_deg: Option<f64>,
    /// Frames the answer rests on, and the span they cover (stamped route), seconds.
    pub frames_used: usize,
    pub span_s: Option<f64>,
    /// χ² per degree of freedom of the fit (the 1σ are inflated by it where > 1).
    pub chi2_per_dof: f64,
}

/// Why there is no answer (yet).
#[derive(Debug, thiserror::Error)]
pub enum LocateError {
    #[error(
        "too few frames with a sun: {usable} of {total} usable, {needed} needed (too cloudy, the sun out of \
         range, or too few frames){}", if reasons.is_empty() { String::new() } else { format!("; {reasons}") }
    )]
    TooFewFrames { usable: usize, total: usize, needed: usize, reasons: String },
    #[error(
        "not yet: the {what}'s 1σ is {sigma_deg:.2}°, more than the {limit_deg:.2}° asked, from {frames} frames \
         (the sequence is too short or too cloudy: take frames over a longer span)"
    )]
    TooUncertain { what: &'static str, sigma_deg: f64, limit_deg: f64, frames: usize },
    #[error(
        "not yet: the sky's polarization is not Rayleigh's (its neutral points {separation_deg:.0}° ± \
         {separation_sigma_deg:.0}° apart, by the frames' median): the sun's elevation is weak in this view, and \
         the {what}'s 1σ is {sigma_deg:.2}°, more than the {limit_deg:.2}° asked, from {frames} frames (take \
         frames over a longer span, or with a wider view)"
    )]
    NotRayleigh {
        separation_deg: f64,
        separation_sigma_deg: f64,
        what: &'static str,
        sigma_deg: f64,
        limit_deg: f64,
        frames: usize,
    },
    #[error(
        "not yet: the sun did not move between frames: the capture gives all {frames} frames the same sun by hand \
         (azimuth {azimuth_deg}°, elevation {elevation_deg}°), as under a turntable, so they hold no pole, north or \
         latitude; locate needs frames of one camera over time in which the sun moves: each with its time_utc, or \
         without stamps at least 3 frames over an hour or more"
    )]
    SunGiven { azimuth_deg: f64, elevation_deg: f64, frames: usize },
    #[error(
        "not yet: every frame carries the same stamp ({time_utc}): {frames} frames of one instant see the sun in one \
         place, and the place is read from its motion; give each frame the time it was taken (time_utc), the frames \
         spread over an hour or more"
    )]
    OneInstant { time_utc: String, frames: usize },
    #[error(
        "not yet: the frames' stamps span {:.1} min, in which the sun moves at least {travel_deg:.3}°, not over {} × \
         the {sigma_deg:.3}° 1σ of that travel as {frames} frames measure it: {}", span_s / 60.0, MIN_TRAVEL_SIGMAS,
         needed(*needed_s)
    )]
    SpanTooShort { span_s: f64, travel_deg: f64, sigma_deg: f64, needed_s: Option<f64>, frames: usize },
    #[error(
        "not yet: the sun did not move between frames: its direction, the camera's turns taken out, spans \
         {travel_deg:.3}° over {frames} frames, not over {} × the {sigma_deg:.3}° 1σ of that travel (a turntable \
         under a fixed sun, one frame repeated, or frames too close in time): {}", MIN_TRAVEL_SIGMAS,
         needed(*needed_s)
    )]
    SunStill { travel_deg: f64, sigma_deg: f64, needed_s: Option<f64>, frames: usize },
    #[error("the fit did not converge: {0}")]
    Solver(String),
    #[error("relative yaw: {0}")]
    Yaw(String),
    #[error(transparent)]
    Core(#[from] crate::Error),
}

/// What a motion refusal asks for: the shortest span over which the sun moves enough.
fn needed(needed_s: Option<f64>) -> String {
    match needed_s {
        Some(s) => format!("take frames over at least {:.0} min (the sun moves at least 13.8°/h)", (s / 60.0).ceil()),
        None => "no span is enough at this 1σ (too cloudy, or a sun too poorly seen)".into(),
    }
}

/// North, latitude and (with stamps) longitude from `obs` (see the module doc).
pub fn locate(obs: &[SunObs], opts: &LocateOptions) -> Result<Located, LocateError> {
    let stamped = !opts.pole_only && obs.iter().all(|o| o.time_unix_s.is_some());
    let needed = 3;
    if obs.len() < needed {
        return Err(LocateError::TooFewFrames { usable: obs.len(), total: obs.len(), needed, reasons: String::new() });
    }
    motion::check(obs, stamped)?;
    let r = if stamped { solve::solve_stamped(obs)? } else { pole::solve_pole(obs)? };
    let checks = [
        ("heading", Some(r.heading_sigma_deg), opts.max_heading_sigma_deg),
        ("latitude", Some(r.latitude_sigma_deg), opts.max_latitude_sigma_deg),
        ("longitude", r.longitude_sigma_deg, opts.max_longitude_sigma_deg),
    ];
    for (what, sigma, limit) in checks {
        if let Some(s) = sigma {
            #[allow(clippy::neg_cmp_op_on_partial_ord)] // a NaN 1σ must be refused too
            if !(s <= limit) {
                let frames = obs.len();
                return Err(match non_rayleigh(obs) {
                    Some((separation_deg, separation_sigma_deg)) => LocateError::NotRayleigh {
                        separation_deg,
                        separation_sigma_deg,
                        what,
                        sigma_deg: s,
                        limit_deg: limit,
                        frames,
                    },
                    None => LocateError::TooUncertain { what, sigma_deg: s, limit_deg: limit, frames },
                });
            }
        }
    }
    Ok(r)
}

/// The frames' median neutral-point separation and median 1σ where the sky is not
/// Rayleigh's: the median |separation| over 5° and over twice its 1σ.
fn non_rayleigh(obs: &[SunObs]) -> Option<(f64, f64)> {
    let sep = crate::stats::median(obs.iter().map(|o| o.separation_deg).collect())?;
    let sigma = crate::stats::median(obs.iter().map(|o| o.separation_sigma_deg).collect())?;
    (sep.abs() > NON_RAYLEIGH_DEG && sep.abs() > 2.0 * sigma).then_some((sep, sigma))
}

/// A frame's share of the elevation bias every frame may carry alike, degrees: its
/// 1σ with what the sky's unknown neutral-point separation adds (the same sky for
/// every frame; `sky_sun`'s step 5).
pub(crate) fn shared_elevation_sigma(o: &SunObs) -> f64 {
    o.elevation_sigma_deg.hypot(o.elevation_nuisance_sigma_deg)
}

/// A neutral-point separation past which a refusal names the sky, degrees.
const NON_RAYLEIGH_DEG: f64 = 5.0;

/// The Levenberg–Marquardt search of both routes ([`crate::lsq`]), with the central-
/// difference steps of (ψ₀ or β_p, φ or e_p, λ or c): up to 100 Jacobians of 12 damping
/// tries each, until a step lowers χ² by less than 10⁻¹⁰ of it.
pub(crate) fn lm(step: [f64; 3]) -> crate::lsq::Lm<3> {
    crate::lsq::Lm { step, iterations: 100, tries: 12, rel_tol: 1e-10, ridge: 1e-12 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An hour of exact suns at 45° N every 5 min, each with a 1° elevation 1σ and the
    /// given neutral-point separation.
    fn hour(separation_deg: f64) -> Vec<SunObs> {
        (0..13)
            .filter_map(|i| {
                let t = 1_778_400_000.0 + 300.0 * i as f64;
                let (a, h) = SunModel::sun(t, 45.0, 15.0)?;
                Some(SunObs {
                    time_unix_s: Some(t),
                    yaw_deg: 0.0,
                    yaw_sigma_deg: 0.0,
                    bearing_deg: crate::conventions::wrap_deg_360(a - 30.0),
                    bearing_sigma_deg: 0.05,
                    elevation_deg: h,
                    elevation_sigma_deg: 1.0,
                    elevation_nuisance_sigma_deg: 0.5,
                    separation_deg,
                    separation_sigma_deg: 2.0,
                    given_sun_deg: None,
                })
            })
            .collect()
    }

    /// A 1σ over the bounds is refused as too short a span on a Rayleigh sky, and as
    /// a sky that is not Rayleigh's where the frames' neutral points are split.
    #[test]
    fn a_refusal_names_a_sky_that_is_not_rayleighs() {
        let strict = LocateOptions { max_latitude_sigma_deg: 0.01, ..LocateOptions::default() };
        let e = locate(&hour(0.0), &strict).unwrap_err();
        assert!(matches!(e, LocateError::TooUncertain { what: "latitude", .. }), "{e}");
        let e = locate(&hour(28.0), &strict).unwrap_err();
        assert!(matches!(e, LocateError::NotRayleigh { what: "latitude", .. }), "{e}");
        assert!(e.to_string().contains("not Rayleigh's (its neutral points 28° ± 2° apart"), "{e}");
        // Within the bounds, the answer stands whatever the sky.
        assert!(locate(&hour(28.0), &LocateOptions::default()).is_ok());
    }
}
