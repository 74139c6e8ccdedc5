//! # `sky_neutral_points` — the sky's neutral points split (multiple scattering)
//!
//! ```text
//! ξ = (E + iN)/(1 + U)                 stereographic chart of a unit ENU direction
//! ξ_P = tan(θ_P/2)·e^{iA}              the four neutral points on the solar vertical:
//!   θ_P = θ_S ± s/2 (Babinet, Brewster), θ_S + π ± s/2 (Arago and the fourth),
//!   θ_S the sun's zenith angle, A = arg ξ_sun, s = separation
//! ω = −4 Π_P (ξ − ξ_P)/√(1 + |ξ_P|²) / (1 + |ξ|²)²
//! E-vector orientation in the chart χ = ½ arg(ω·e^{−2iA}),  DoLP = d_max·|ω|/(2 − |ω|)
//! radiance ½(1 + cos²γ) as Rayleigh (the model is about polarization only)
//! ```
//!
//! Source: M. V. Berry, M. R. Dennis, R. L. Lee, "Polarization singularities in the
//! clear sky", New J. Phys. 6, 162 (2004), eq. 4.2 (the quartic sky); EFFECTS.md for
//! the chart, orientation and DoLP mapping. At separation 0 the pairs merge and ω
//! is −4(ξ − ξ_S)²(ξ − ξ_A)²/…, |ω| = sin²γ: exactly the Rayleigh sky, which is then
//! evaluated by `sky_stokes` itself (so zero strength is bitwise the ideal chain;
//! continuity at small separations is tested). Each factor is evaluated as
//! ξ cos(θ_P/2) − sin(θ_P/2)·e^{iA} (the same value, finite when ξ_P is at infinity);
//! the chart is conformal, so χ is the angle on the sky from the chart's x (East)
//! direction toward its y (North) direction. Frame: ENU world for the chart, then
//! the ray's meridional frame (camera). Units: separation in degrees; per pixel on
//! both backends (`shaders/effects/sky_neutral_points.wgsl`), square roots only.
//!
//! | param            | unit | neutral | fit bounds | physical |
//! |------------------|------|---------|------------|----------|
//! | `separation_deg` | deg  | 0       | [0, 60]    | bounds   |
//!
//! Cannot: a separation that differs between the sun's and the anti-sun's pair, the
//! depolarization toward the horizon (that is partly `sky_depolarization`), or a sun
//! within half a separation of the zenith (a neutral point crosses the chart's pole
//! at the nadir there and the orientation jumps).

use super::{Apply, EffectDef, FrameContext, ParamSpec, SkyParams, Stage};
use crate::camera::{MeridionalBasis, RayGeometry};
use crate::stokes::Stokes;
use glam::{DMat3, DVec3};

pub const EFFECT: EffectDef = EffectDef {
    name: "sky_neutral_points",
    summary: "Berry-Dennis-Lee quartic sky: neutral points split by separation on the solar vertical",
    source: "Berry, Dennis & Lee, New J. Phys. 6, 162 (2004) eq. 4.2",
    stage: Stage::Sky,
    params: &[ParamSpec {
        name: "separation_deg",
        unit: "deg",
        neutral: 0.0,
        typical: 20.0,
        min: 0.0,
        max: 60.0,
        // The bounds are the physical range: the Babinet and Brewster points are seen some
        // 15–25° from the sun in clear air and farther in turbid air (Coulson 1988, ch. 5),
        // each half a separation away.
        physical: None,
        doc: "angular separation of each pair of neutral points",
    }],
    apply: Apply::Sky {
        params: |v| [[v[0], 0.0, 0.0, 0.0], [0.0; 4], [0.0; 4], [0.0; 4], [0.0; 4]],
        frame: Some(with_frame),
        pixel: sky_neutral_points,
    },
    wgsl: Some(include_str!("../../../../shaders/effects/sky_neutral_points.wgsl")),
    derivatives: &[],
    inseparable: None,
};

/// The vector completed with the frame's constants ([`NeutralPoints::to_params`]) from
/// the separation (degrees) in `p[0][0]` times the frame's multiple scattering (a
/// colour band's, `sky_neutral_spectrum`; 1 otherwise); left neutral (all zero) at
/// separation 0.
fn with_frame(p: SkyParams, c: &FrameContext) -> SkyParams {
    if p[0][0] == 0.0 {
        return p;
    }
    NeutralPoints::new(&c.world_from_cam, c.sun_cam, (p[0][0] * c.multiple_scattering).to_radians()).to_params()
}

/// The quartic sky along the ray `g` in place of the sky so far `s` where it is on
/// (`p[0][3]` = 1: a frame's [`NeutralPoints::to_params`]); `s` itself otherwise.
#[inline(always)]
pub fn sky_neutral_points(p: &SkyParams, sun: DVec3, dmax: f64, g: &RayGeometry, s: Stokes) -> Stokes {
    if p[0][3] == 0.0 {
        return s;
    }
    quartic_sky(&NeutralPoints::from_params(p), sun, dmax, g.d, &g.basis)
}

/// What the quartic sky needs per frame (host side): the world axes in the camera
/// frame, each neutral point's (cos θ_P/2, sin θ_P/2) and e^{iA}.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeutralPoints {
    pub east: DVec3,
    pub north: DVec3,
    pub up: DVec3,
    /// (cos θ_P/2, sin θ_P/2) of the four points: sun −, sun +, anti-sun −, anti-sun +.
    pub half_angles: [[f64; 2]; 4],
    /// (cos A, sin A).
    pub eia: [f64; 2],
}

impl NeutralPoints {
    /// For a camera whose axes in the world are the columns of `world_from_cam`, the
    /// sun at `sun_cam` (camera frame, unit), pairs `separation_rad` apart.
    pub fn new(world_from_cam: &DMat3, sun_cam: DVec3, separation_rad: f64) -> Self {
        let cam_from_world = world_from_cam.transpose();
        let (east, north, up) = (cam_from_world * DVec3::X, cam_from_world * DVec3::Y, cam_from_world * DVec3::Z);
        let (e, n, u) = (sun_cam.dot(east), sun_cam.dot(north), sun_cam.dot(up));
        let theta_s = u.clamp(-1.0, 1.0).acos();
        let a = n.atan2(e);
        let h = 0.5 * separation_rad;
        let half = |t: f64| {
            let (s, c) = (0.5 * t).sin_cos();
            [c, s]
        };
        let pi = std::f64::consts::PI;
        NeutralPoints {
            east,
            north,
            up,
            half_angles: [half(theta_s - h), half(theta_s + h), half(theta_s + pi - h), half(theta_s + pi + h)],
            eia: [a.cos(), a.sin()],
        }
    }
}

impl NeutralPoints {
    /// The frame vector: (East, 1), (North, cos A), (Up, sin A), the sun's pair's
    /// (cos, sin θ_P/2) twice, the anti-sun's pair's twice. The 1 marks it on.
    pub fn to_params(&self) -> SkyParams {
        let h = self.half_angles;
        let (e, n, u) = (self.east, self.north, self.up);
        [
            [e.x, e.y, e.z, 1.0],
            [n.x, n.y, n.z, self.eia[0]],
            [u.x, u.y, u.z, self.eia[1]],
            [h[0][0], h[0][1], h[1][0], h[1][1]],
            [h[2][0], h[2][1], h[3][0], h[3][1]],
        ]
    }

    /// The frame constants of [`NeutralPoints::to_params`]'s vector.
    #[inline(always)]
    pub fn from_params(p: &SkyParams) -> Self {
        NeutralPoints {
            east: DVec3::new(p[0][0], p[0][1], p[0][2]),
            north: DVec3::new(p[1][0], p[1][1], p[1][2]),
            up: DVec3::new(p[2][0], p[2][1], p[2][2]),
            half_angles: [[p[3][0], p[3][1]], [p[3][2], p[3][3]], [p[4][0], p[4][1]], [p[4][2], p[4][3]]],
            eia: [p[1][3], p[2][3]],
        }
    }
}

fn cmul(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]]
}

/// Skylight of the quartic sky along the unit camera-frame ray `view`, in its
/// meridional frame `basis` (as `sky_stokes`); `sun` the unit sun (camera frame).
#[inline]
pub fn quartic_sky(np: &NeutralPoints, sun: DVec3, dmax: f64, view: DVec3, basis: &MeridionalBasis) -> Stokes {
    // Radiance as Rayleigh.
    let cg = sun.dot(view);
    let radiance = 0.5 * (1.0 + cg * cg);
    // The ray in the stereographic chart of the ENU world.
    let (e, n, u) = (view.dot(np.east), view.dot(np.north), view.dot(np.up));
    let den = 1.0 + u;
    if den <= 1e-12 {
        return Stokes::new(radiance, 0.0, 0.0, 0.0); // the nadir: the chart's pole
    }
    let (x, y) = (e / den, n / den);
    let rho2 = x * x + y * y;
    // ω·e^{−2iA} = −4 Π (ξ c_P − s_P e^{iA}) e^{−2iA} / (1 + |ξ|²)².
    let mut w = [-4.0, 0.0];
    for [c, s] in np.half_angles {
        w = cmul(w, [x * c - s * np.eia[0], y * c - s * np.eia[1]]);
    }
    let e2 = [np.eia[0] * np.eia[0] - np.eia[1] * np.eia[1], 2.0 * np.eia[0] * np.eia[1]];
    w = cmul(w, [e2[0], -e2[1]]);
    let k = 1.0 / ((1.0 + rho2) * (1.0 + rho2));
    let w = [w[0] * k, w[1] * k];
    let mag = (w[0] * w[0] + w[1] * w[1]).sqrt();
    if mag == 0.0 {
        return Stokes::new(radiance, 0.0, 0.0, 0.0); // a neutral point
    }
    // cos 2χ, sin 2χ of the E-vector in the chart.
    let (c2, s2) = (w[0] / mag, w[1] / mag);
    // Unit tangents of the chart's x and y directions at ξ (ENU → camera frame).
    let q = 1.0 / (1.0 + rho2);
    let tx = (np.east * (1.0 - x * x + y * y) + np.north * (-2.0 * x * y) + np.up * (-2.0 * x)) * q;
    let ty = (np.east * (-2.0 * x * y) + np.north * (1.0 + x * x - y * y) + np.up * (-2.0 * y)) * q;
    let (a, b, c, d) = (tx.dot(basis.p), ty.dot(basis.p), tx.dot(basis.s), ty.dot(basis.s));
    // e = cos χ tx + sin χ ty: cos 2φ = (e·p)² − (e·s)², sin 2φ = −2 (e·p)(e·s).
    let cos2phi = 0.5 * ((a * a - c * c) + (b * b - d * d))
        + 0.5 * c2 * ((a * a - c * c) - (b * b - d * d))
        + s2 * (a * b - c * d);
    let sin2phi = -((a * c + b * d) + c2 * (a * c - b * d) + s2 * (a * d + b * c));
    // Polarized radiance I·DoLP, DoLP = d_max |ω|/(2 − |ω|).
    let pol = radiance * dmax * mag / (2.0 - mag);
    Stokes::new(radiance, pol * cos2phi, pol * sin2phi, 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use crate::conventions::{enu_from_az_el_deg, world_from_camera};
    use crate::sky::sky_stokes;

    fn setup(sep_deg: f64, sun_el: f64) -> (DMat3, DVec3, NeutralPoints) {
        let r = world_from_camera(30.0, 3.0, -2.0);
        let sun = r.transpose() * enu_from_az_el_deg(40.0, sun_el);
        (r, sun, NeutralPoints::new(&r, sun, sep_deg.to_radians()))
    }

    #[test]
    fn at_zero_separation_it_is_the_rayleigh_sky() {
        let (r, sun, np) = setup(0.0, 25.0);
        for (az, el) in [(40.0, 80.0), (100.0, 50.0), (220.0, 75.0), (300.0, 30.0), (10.0, 89.0)] {
            let v = r.transpose() * enu_from_az_el_deg(az, el);
            let b = meridional_basis(v);
            let (a, want) = (quartic_sky(&np, sun, 0.6, v, &b), sky_stokes(sun, 0.6, v, &b));
            assert!((a.i - want.i).abs() < 1e-12, "{az} {el}");
            assert!((a.q - want.q).abs() < 1e-12 && (a.u - want.u).abs() < 1e-12, "{az} {el}: {a:?} vs {want:?}");
        }
    }

    #[test]
    fn split_points_are_unpolarized_and_the_sun_no_longer_is_alone() {
        // Sun at 30° elevation, separation 20°: Babinet 10° above the sun, Brewster 10° below.
        let (r, sun, np) = setup(20.0, 30.0);
        for el in [40.0, 20.0] {
            let v = r.transpose() * enu_from_az_el_deg(40.0, el);
            let s = quartic_sky(&np, sun, 0.6, v, &meridional_basis(v));
            assert!(s.dolp() < 1e-9, "elevation {el}: DoLP {}", s.dolp());
        }
        // Between them (at the sun) the sky is now polarized; far away it is nearly Rayleigh.
        let v = r.transpose() * enu_from_az_el_deg(40.0, 30.5);
        assert!(quartic_sky(&np, sun, 0.6, v, &meridional_basis(v)).dolp() > 1e-4);
        let v = r.transpose() * enu_from_az_el_deg(130.0, 60.0);
        let b = meridional_basis(v);
        let (a, ray) = (quartic_sky(&np, sun, 0.6, v, &b), sky_stokes(sun, 0.6, v, &b));
        assert!((a.dolp() - ray.dolp()).abs() < 0.05 && (a.aop_rad() - ray.aop_rad()).abs() < 0.05);
    }

    #[test]
    fn small_separations_approach_rayleigh_continuously() {
        let (r, sun, np) = setup(1e-6, 25.0);
        let v = r.transpose() * enu_from_az_el_deg(100.0, 50.0);
        let b = meridional_basis(v);
        let (a, want) = (quartic_sky(&np, sun, 0.6, v, &b), sky_stokes(sun, 0.6, v, &b));
        assert!((a.q - want.q).abs() < 1e-9 && (a.u - want.u).abs() < 1e-9);
    }
}
