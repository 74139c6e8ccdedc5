//! Frames that cannot show the sun's motion (issue 49): refused before any fit.
//!
//! Both routes read the place from the sun's motion across the frames: the pole route
//! from the cone its directions trace, the stamped route from how its direction
//! changes with the stamps. Frames in which the sun did not move hold neither, yet a
//! fit through them still returns numbers with a small 1σ: the cone fit, handed a
//! cluster of suns, passes a tiny circle through their noise (its axis the sun
//! itself, so "latitude" is minus the sun's elevation) and its covariance sees
//! nothing wrong. So before fitting, in this order:
//!
//! 1. **A sun given by hand, the same for every frame** (`sun_azimuth_deg`,
//!    `sun_elevation_deg`; [`SunObs::given_sun_deg`]): the capture itself says the sun
//!    stood still (a turntable under a fixed sun): [`LocateError::SunGiven`].
//! 2. **Stamped route: one instant** (every stamp the same): the frames are one
//!    sun: [`LocateError::OneInstant`]. Two distinct instants are enough in
//!    principle (two directions of the sun, known on the celestial sphere by the
//!    ephemeris, fix the rotation from the sky to the camera: ψ₀, φ, λ).
//! 3. **Stamped route: a span too short for the 1σ**: the sun's least travel over the
//!    stamps, whatever the place and day (below), must clear the bar:
//!    [`LocateError::SpanTooShort`].
//! 4. **Both routes: the sun did not move** as measured: the arc its direction spans
//!    in the first frame's level axes (the camera's turns taken out) must clear the
//!    bar: [`LocateError::SunStill`].
//!
//! ```text
//! σ_dir,i  = √((σ_b,i cos hᵢ)² + σ_h,i²)        one frame's sun, on the sky (σ_b with the yaw's)
//! σ_T      = √2 · median σ_dir,i                a travel between two frames
//! T_meas   = maxᵢ ∠(s₀, sᵢ)                     sᵢ = (βᵢ = b̂ᵢ + Δyawᵢ, hᵢ) as unit vectors
//! T_least  = maxᵢ 2 asin(cos ε · |sin(π (tᵢ − t_min)/day)|),  ε = 23.44°
//! refuse where T < k σ_T,  k = 5
//! ```
//!
//! The least travel: two suns at one declination δ an hour angle H apart are
//! 2 asin(cos δ sin(H/2)) apart on the sky; H = 360° (Δt / 86 400 s) and |δ| ≤ ε, so
//! cos ε is the slowest case (13.8°/h for short spans; the declination's own drift,
//! ≤ 0.4°/day, is 0 at the solstices and is not counted).
//!
//! The bar k = 5 (in units of σ_T): where the sun stood still, each sᵢ − s₀ is noise
//! of 1σ σ_dir per axis, so ∠(s₀, sᵢ) is Rayleigh-distributed with RMS σ_T and
//! P(∠ > k σ_T) = e^(−k²); the largest of N − 1 exceeds k σ_T with probability
//! ≤ (N − 1) e^(−k²) = (N − 1)·1.4·10⁻¹¹, under 10⁻⁶ for every capture up to the
//! 10 000 frames a series may hold. So noise alone never passes, and a sun that did
//! move passes as soon as its travel is resolved; what the travel then fixes (a short
//! arc leaves the cone's curvature loose) is the fit's 1σ against the asked bounds
//! ([`LocateError::TooUncertain`]). The shared elevation bias (`shared_elevation_sigma`)
//! is left out of σ_dir: it moves every frame alike and cancels in a travel. Real
//! series clear the bar by far: an hour is ≥ 13.8° of travel against σ_T of 0.1°–2°.

use super::model::bearing_sigma;
use super::{LocateError, SunObs};
use crate::conventions::enu_from_az_el_deg;

/// The bar: a travel must exceed this many of its 1σ (module doc).
pub const MIN_TRAVEL_SIGMAS: f64 = 5.0;

/// The largest |declination| of the sun, the obliquity of the ecliptic, degrees.
const OBLIQUITY_DEG: f64 = 23.44;

/// A mean solar day, seconds: the sun's hour angle turns 360° in it.
const SOLAR_DAY_S: f64 = 86_400.0;

/// Suns given by hand closer than this are the same sun, degrees (the same numbers
/// written in a file, up to rounding).
const SAME_GIVEN_SUN_DEG: f64 = 1e-6;

/// One frame's sun direction 1σ on the sky, degrees: the bearing's (with the yaw's)
/// across, shrunk by cos h, and the elevation's; not the shared elevation bias.
pub(crate) fn direction_sigma_deg(o: &SunObs) -> f64 {
    (bearing_sigma(o) * o.elevation_deg.to_radians().cos()).hypot(o.elevation_sigma_deg)
}

/// The 1σ of a travel between two frames, degrees: √2 × the median frame's.
pub(crate) fn travel_sigma_deg(obs: &[SunObs]) -> f64 {
    let median = crate::stats::median(obs.iter().map(direction_sigma_deg).collect());
    std::f64::consts::SQRT_2 * median.unwrap_or(f64::NAN)
}

/// The sun's least travel on the sky in `dt_s` seconds, whatever the place and the
/// day, degrees (module doc).
pub(crate) fn least_travel_deg(dt_s: f64) -> f64 {
    let half_h = std::f64::consts::PI * dt_s / SOLAR_DAY_S;
    let x = OBLIQUITY_DEG.to_radians().cos() * half_h.sin().abs();
    2.0 * x.min(1.0).asin().to_degrees()
}

/// The shortest span over which the sun travels at least `travel_deg` whatever the
/// place and day, seconds; `None` where no span does (a travel over 180° − 2ε).
pub(crate) fn span_for_travel_s(travel_deg: f64) -> Option<f64> {
    let x = (travel_deg / 2.0).to_radians().sin() / OBLIQUITY_DEG.to_radians().cos();
    (travel_deg >= 0.0 && x <= 1.0).then(|| x.asin() * SOLAR_DAY_S / std::f64::consts::PI)
}

/// The arc the frames' suns span from the first, degrees, in the first frame's level
/// axes with the camera's turns taken out (the pole route's sᵢ).
pub(crate) fn measured_travel_deg(obs: &[SunObs]) -> f64 {
    let s: Vec<_> = obs.iter().map(|o| enu_from_az_el_deg(o.bearing_deg + o.yaw_deg, o.elevation_deg)).collect();
    s.iter().map(|v| s[0].angle_between(*v).to_degrees()).fold(0.0, f64::max)
}

/// Refuses frames that cannot show the sun's motion (module doc); `stamped`: the
/// route the frames take. `obs` holds at least one frame.
pub(crate) fn check(obs: &[SunObs], stamped: bool) -> Result<(), LocateError> {
    let frames = obs.len();
    // 1. The capture says the sun stood still.
    if let Some([az, el]) = obs[0].given_sun_deg {
        let first = enu_from_az_el_deg(az, el);
        let same = |o: &SunObs| {
            o.given_sun_deg
                .is_some_and(|[a, e]| first.angle_between(enu_from_az_el_deg(a, e)).to_degrees() < SAME_GIVEN_SUN_DEG)
        };
        if obs.iter().all(same) {
            return Err(LocateError::SunGiven { azimuth_deg: az, elevation_deg: el, frames });
        }
    }
    let sigma_deg = travel_sigma_deg(obs);
    let bar = MIN_TRAVEL_SIGMAS * sigma_deg;
    let needed_s = span_for_travel_s(bar);
    if stamped {
        let mut t: Vec<f64> = obs.iter().filter_map(|o| o.time_unix_s).collect();
        t.sort_by(f64::total_cmp);
        t.dedup();
        // 2. One instant: the sun in one place.
        if t.len() < 2 {
            return Err(LocateError::OneInstant { time_utc: rfc3339(t.first().copied()), frames });
        }
        // 3. The sun's least travel over the stamps.
        let travel_deg = t.iter().map(|ti| least_travel_deg(ti - t[0])).fold(0.0, f64::max);
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // a NaN 1σ must be refused too
        if !(travel_deg > bar) {
            let span_s = t[t.len() - 1] - t[0];
            return Err(LocateError::SpanTooShort { span_s, travel_deg, sigma_deg, needed_s, frames });
        }
    }
    // 4. The sun's travel as the frames measure it.
    let travel_deg = measured_travel_deg(obs);
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(travel_deg > bar) {
        return Err(LocateError::SunStill { travel_deg, sigma_deg, needed_s, frames });
    }
    Ok(())
}

/// A stamp as RFC 3339 UTC, for a message.
fn rfc3339(t: Option<f64>) -> String {
    t.and_then(|t| chrono::DateTime::from_timestamp(t.floor() as i64, ((t - t.floor()) * 1e9) as u32))
        .map(|d| d.to_rfc3339_opts(chrono::SecondsFormat::AutoSi, true))
        .unwrap_or_else(|| "no stamp".into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conventions::wrap_deg_360;
    use crate::locate::{locate, LocateOptions, SunModel};

    /// Suns from SPA at 45° N, 10° E from `t0` every `every_s` for `n` frames, a
    /// camera facing 30° and turning 5° a frame (its gyro exact), with 1σ `sigma_deg`
    /// on the bearing and the elevation; stamped or not.
    fn suns(t0: f64, every_s: f64, n: usize, sigma_deg: f64, stamped: bool) -> Vec<SunObs> {
        (0..n)
            .map(|i| {
                let t = t0 + every_s * i as f64;
                let (a, h) = SunModel::sun(t, 45.0, 10.0).unwrap();
                SunObs {
                    time_unix_s: stamped.then_some(t),
                    yaw_deg: 5.0 * i as f64,
                    yaw_sigma_deg: 0.0,
                    bearing_deg: wrap_deg_360(a - 30.0 - 5.0 * i as f64),
                    bearing_sigma_deg: sigma_deg,
                    elevation_deg: h,
                    elevation_sigma_deg: sigma_deg,
                    elevation_nuisance_sigma_deg: 0.0,
                    separation_deg: 0.0,
                    separation_sigma_deg: 1.0,
                    given_sun_deg: None,
                }
            })
            .collect()
    }

    /// 2026-05-10T08:20:00Z: mid-morning at 10° E.
    const T0: f64 = 1_778_401_200.0;

    /// Wide bounds: only the refusals of this module can stop an answer.
    fn wide(pole_only: bool) -> LocateOptions {
        LocateOptions {
            max_heading_sigma_deg: 90.0,
            max_latitude_sigma_deg: 90.0,
            max_longitude_sigma_deg: 180.0,
            pole_only,
        }
    }

    /// The least travel: 13.8°/h for short spans (15°/h × cos 23.44°), 0 after a whole
    /// day, and the span that gives a travel inverts it.
    #[test]
    fn the_least_travel_is_the_slowest_sun() {
        assert!((least_travel_deg(3600.0) - 15.0 * OBLIQUITY_DEG.to_radians().cos()).abs() < 0.02);
        assert!(least_travel_deg(SOLAR_DAY_S) < 1e-9);
        assert_eq!(least_travel_deg(0.0), 0.0);
        for s in [60.0, 3600.0, 20_000.0] {
            assert!((span_for_travel_s(least_travel_deg(s)).unwrap() - s).abs() < 1e-6, "{s}");
        }
        assert_eq!(span_for_travel_s(170.0), None);
    }

    /// A turntable under a fixed sun, no stamps (what `samples/clean` is): the suns
    /// are one point after the turns are taken out, plus noise; the pole route would
    /// pass a tiny circle through the noise. Refused as the sun not moving, with the
    /// bar in the message; the same frames with the sun given by hand are refused as
    /// the capture saying so.
    #[test]
    fn a_sun_that_did_not_move_is_refused() {
        let d = crate::scene::Draws::keyed(7, 0x49, 0);
        let obs: Vec<SunObs> = (0..8)
            .map(|i| {
                let heading = 45.0 * i as f64;
                SunObs {
                    time_unix_s: None,
                    yaw_deg: heading,
                    yaw_sigma_deg: 0.0,
                    bearing_deg: wrap_deg_360(40.0 - heading + 0.05 * d.normal(2 * i)),
                    bearing_sigma_deg: 0.05,
                    elevation_deg: 25.0 + 0.05 * d.normal(2 * i + 1),
                    elevation_sigma_deg: 0.05,
                    elevation_nuisance_sigma_deg: 0.0,
                    separation_deg: 0.0,
                    separation_sigma_deg: 1.0,
                    given_sun_deg: None,
                }
            })
            .collect();
        let e = locate(&obs, &wide(false)).unwrap_err();
        assert!(matches!(e, LocateError::SunStill { frames: 8, .. }), "{e}");
        assert!(e.to_string().starts_with("not yet: the sun did not move between frames"), "{e}");
        let LocateError::SunStill { travel_deg, sigma_deg, needed_s, .. } = e else { unreachable!() };
        assert!(travel_deg < MIN_TRAVEL_SIGMAS * sigma_deg && sigma_deg > 0.05, "{travel_deg} {sigma_deg}");
        assert!(needed_s.is_some_and(|s| s > 60.0 && s < 600.0), "{needed_s:?}");
        let given: Vec<SunObs> = obs.iter().map(|o| SunObs { given_sun_deg: Some([40.0, 25.0]), ..*o }).collect();
        let e = locate(&given, &wide(false)).unwrap_err();
        assert!(matches!(e, LocateError::SunGiven { frames: 8, .. }), "{e}");
        assert!(e.to_string().contains("the same sun by hand (azimuth 40°, elevation 25°)"), "{e}");
        // Suns given by hand that differ are no such statement: the measured travel
        // decides (here still too small).
        let mut moved = given.clone();
        moved[3].given_sun_deg = Some([41.0, 25.5]);
        assert!(matches!(locate(&moved, &wide(false)), Err(LocateError::SunStill { .. })));
    }

    /// One stamp on every frame: the frames are one instant, refused on the stamped
    /// route; the pole route refuses them as a sun that did not move.
    #[test]
    fn one_stamp_repeated_is_refused() {
        let mut obs = suns(T0, 300.0, 13, 0.05, true);
        for o in &mut obs {
            o.time_unix_s = Some(T0);
        }
        let e = locate(&obs, &wide(false)).unwrap_err();
        assert!(matches!(e, LocateError::OneInstant { frames: 13, .. }), "{e}");
        assert!(e.to_string().contains("the same stamp (2026-05-10T08:20:00Z)"), "{e}");
        // Truly one instant (the same sun in every frame, the camera turning), --pole:
        let still: Vec<SunObs> = (0..13)
            .map(|i| SunObs { bearing_deg: wrap_deg_360(obs[0].bearing_deg - 5.0 * i as f64), ..obs[0] })
            .map(|o| SunObs { yaw_deg: wrap_deg_360(obs[0].bearing_deg - o.bearing_deg), ..o })
            .collect();
        let e = locate(&still, &wide(true)).unwrap_err();
        assert!(matches!(e, LocateError::SunStill { .. }), "{e}");
        // Two distinct instants an hour apart are enough (module doc, step 2): six
        // frames at the first, seven at the second, the camera turning 5° a frame.
        let two: Vec<SunObs> = (0..13)
            .map(|i| {
                let o = suns(T0 + if i < 6 { 0.0 } else { 3600.0 }, 1.0, 1, 0.05, true).remove(0);
                SunObs { yaw_deg: 5.0 * i as f64, bearing_deg: wrap_deg_360(o.bearing_deg - 5.0 * i as f64), ..o }
            })
            .collect();
        let r = locate(&two, &LocateOptions::default()).unwrap();
        assert!((r.latitude_deg - 45.0).abs() < 0.1 && (r.longitude_deg.unwrap() - 10.0).abs() < 0.1, "{r:?}");
    }

    /// A span whose least travel does not clear the bar: stamps a minute apart under
    /// a 1σ of 0.5° (the sun moves ≥ 0.23°, against a bar of 5 × 0.71°), refused with
    /// the span needed (≈ 15 min); the same 1σ over an hour is answered.
    #[test]
    fn a_span_shorter_than_the_sigma_allows_is_refused() {
        let obs = suns(T0, 20.0, 4, 0.5, true);
        let e = locate(&obs, &wide(false)).unwrap_err();
        assert!(matches!(e, LocateError::SpanTooShort { frames: 4, .. }), "{e}");
        let LocateError::SpanTooShort { span_s, travel_deg, sigma_deg, needed_s, .. } = e else { unreachable!() };
        assert_eq!(span_s, 60.0);
        assert!((travel_deg - least_travel_deg(60.0)).abs() < 1e-12);
        // √2 × √((0.5° cos h)² + 0.5²), h ≈ 40°–50°.
        assert!(sigma_deg > 0.8 && sigma_deg < 0.95, "{sigma_deg}");
        let need = needed_s.unwrap();
        assert!((least_travel_deg(need) - MIN_TRAVEL_SIGMAS * sigma_deg).abs() < 1e-9 && need > 600.0, "{need}");
        assert!(locate(&suns(T0, 300.0, 13, 0.5, true), &wide(false)).is_ok());
        // Stamps that span enough while the suns measured did not move (a frozen
        // camera repeating one frame): the measured travel refuses them.
        let frozen: Vec<SunObs> = suns(T0, 300.0, 13, 0.05, true)
            .into_iter()
            .map(|o| SunObs { yaw_deg: 0.0, bearing_deg: 100.0, elevation_deg: 30.0, ..o })
            .collect();
        assert!(matches!(locate(&frozen, &wide(false)), Err(LocateError::SunStill { .. })));
    }

    /// Real series clear the bar: an hour on the stamped route, three hours on the
    /// pole route, even at a 1σ of 1° a frame.
    #[test]
    fn real_series_are_not_refused() {
        assert!(check(&suns(T0, 300.0, 13, 1.0, true), true).is_ok());
        assert!(check(&suns(T0, 900.0, 13, 1.0, false), false).is_ok());
        assert!(locate(&suns(T0, 900.0, 13, 0.05, false), &wide(true)).is_ok());
    }
}
