//! # `skyline` — trees, buildings and the ground
//!
//! ```text
//! h(A)   skyline elevation at world azimuth A: the highest of low hills and the
//!        objects drawn around the horizon (seeded, fixed in the world):
//!        building  flat top at H·U(0.25, 1) over U(4°, 25°) of azimuth
//!        tree      crown H_t·√(1 − x²)·(1 + 0.15·j(A)), H_t = H·U(0.35, 1), over a width
//!                  of H_t·U(0.8, 1.6) (at least 3°): x ∈ [−1, 1] across the crown,
//!                  j ∈ [−1, 1] jagged noise (0.4°, 0.15°)
//!        gap       U(2°, 20°) of open horizon; a stretch is an object with
//!                  probability `coverage`, a tree with probability `tree_fraction`
//! view elevation e ≥ h(A):   the sky, untouched
//! 0 ≤ e < h(A):              object: I = ρ_o·L_z·(1 + ½n₁), DoLP = p_o·(½ + ½n₂),
//!                            E-vector at χ = π·n₃ from the local vertical
//! e < 0:                     ground: I = albedo·L_z·(1 + 0.3·n₄), unpolarized
//! ```
//!
//! n₁…n₄ ∈ [−1, 1] are seeded value noise on the world direction (`texture.rs`), so a
//! wall or a crown looks the same in every frame; L_z is the Rayleigh sky's zenith
//! radiance of the frame. Leaves and walls reflect mostly diffusely: a few percent
//! of polarization at no particular angle (G. Horváth, D. Varjú, *Polarized Light in
//! Animal Vision: Polarization Patterns in Nature*, Springer 2004); a canopy's radiance is a
//! small fraction of the sky's; ground albedo ~0.1–0.3 (soil, grass, asphalt).
//!
//! Source: as cited for the radiances; the skyline itself is a seeded procedural
//! model. Units: elevations in degrees, radiances relative to L_z, DoLP and albedo
//! dimensionless. Frame: world ENU (azimuth from North toward East, elevation above
//! the horizon); the Stokes vector in the ray's meridional frame. Only a fisheye or
//! a tilted camera sees it: a level ±46° lens looks no lower than 44°.
//!
//! | param               | unit | default | range     |
//! |---------------------|------|---------|-----------|
//! | `max_elevation_deg` | deg  | 20      | [0, 60]   |
//! | `coverage`          | 1    | 0.7     | [0, 1]    |
//! | `tree_fraction`     | 1    | 0.5     | [0, 1]    |
//! | `object_radiance`   | 1    | 0.15    | [0, 2]    |
//! | `object_dolp`       | 1    | 0.04    | [0, 0.3]  |
//! | `ground_albedo`     | 1    | 0.2     | [0, 1]    |
//!
//! Cannot: parallax (the skyline is at infinity, the camera at its centre), shadows
//! and sunlit faces, specular glints (windows, water, wet roads: strongly polarized),
//! the sky reflected by the ground, the horizon dip of a raised camera, and azimuth
//! detail finer than 0.05° (the profile is tabulated).

use super::frame::element_index;
use super::texture::Texture;
use super::{linear_stokes, Draws, ElementDef, FieldElement, FieldRay, Layer, ParamSpec};
use crate::stokes::Stokes;
use glam::DVec3;
use std::sync::Arc;

/// Azimuth bins of the tabulated skyline (0.05° each).
const BINS: usize = 7200;

pub const ELEMENT: ElementDef = ElementDef {
    name: "skyline",
    summary: "trees and buildings on a seeded jagged skyline, dark and nearly unpolarized; the ground below",
    source: "procedural skyline; radiances after Horvath & Varju 2004",
    params: &[
        ParamSpec::shape("max_elevation_deg", "deg", 20.0, 0.0, 60.0, "highest object top above the horizon"),
        ParamSpec::shape("coverage", "1", 0.7, 0.0, 1.0, "probability that a stretch of horizon holds an object"),
        ParamSpec::shape("tree_fraction", "1", 0.5, 0.0, 1.0, "probability that an object is a tree (else a building)"),
        ParamSpec::shape(
            "object_radiance",
            "1",
            0.15,
            0.0,
            2.0,
            "objects' mean radiance over the sky's zenith radiance",
        ),
        ParamSpec::shape("object_dolp", "1", 0.04, 0.0, 0.3, "objects' largest DoLP"),
        ParamSpec::shape("ground_albedo", "1", 0.2, 0.0, 1.0, "ground radiance over the sky's zenith radiance"),
    ],
    layer: Layer::Foreground,
    prepare: |v, cx| Arc::new(Skyline::new(v, cx.seed, cx.zenith_radiance)),
};

/// The skyline of one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Skyline {
    /// sin of the skyline's elevation in each 0.05° azimuth bin (bin i at azimuth
    /// 0.05°·i from North toward East).
    pub sin_elevation: Vec<f64>,
    /// sin of the highest top: rays above it are sky.
    pub sin_max: f64,
    /// ρ_o·L_z, p_o, albedo·L_z.
    pub object_radiance: f64,
    pub object_dolp: f64,
    pub ground_radiance: f64,
    /// Noise fields n₁ … n₄.
    textures: [Texture; 4],
}

impl Skyline {
    /// From the values in [`ELEMENT`]'s parameter order, under `seed`, for a frame
    /// whose zenith sky radiance is `zenith_radiance`.
    pub fn new(v: &[f64], seed: u64, zenith_radiance: f64) -> Self {
        let elevation_deg = profile_deg(v[0], v[1], v[2], seed);
        let sin_elevation: Vec<f64> = elevation_deg.iter().map(|e| e.to_radians().sin()).collect();
        let el = element_index(&ELEMENT);
        Skyline {
            sin_max: sin_elevation.iter().copied().fold(0.0, f64::max),
            sin_elevation,
            object_radiance: v[3] * zenith_radiance,
            object_dolp: v[4],
            ground_radiance: v[5] * zenith_radiance,
            textures: [0, 1, 2, 3].map(|salt| Texture::new(seed, el, salt)),
        }
    }

    /// sin of the skyline's elevation toward the world azimuth of the ENU ray `d`.
    #[inline]
    pub fn sin_top(&self, d: DVec3) -> f64 {
        let t = (d.x.atan2(d.y) * (BINS as f64 / std::f64::consts::TAU)).rem_euclid(BINS as f64);
        let i = (t.floor() as usize).min(BINS - 1);
        let f = t - i as f64;
        let (a, b) = (self.sin_elevation[i], self.sin_elevation[(i + 1) % BINS]);
        a + (b - a) * f
    }
}

/// The skyline's elevation in degrees in each azimuth bin: hills and objects.
fn profile_deg(max_deg: f64, coverage: f64, tree_fraction: f64, seed: u64) -> Vec<f64> {
    let draws = Draws::world(seed, &ELEMENT);
    let bin_deg = 360.0 / BINS as f64;
    // Smooth noise in azimuth, knots every `step_deg` (`salt` keeps fields apart), in [0, 1).
    let smooth = |az_deg: f64, step_deg: f64, salt: u32| {
        let t = az_deg.rem_euclid(360.0) / step_deg;
        let n = (360.0 / step_deg).round() as u32;
        let k = t.floor() as u32;
        let f = t - k as f64;
        let knot = |k: u32| draws.uniform(salt + k % n);
        knot(k) + (knot(k + 1) - knot(k)) * f
    };
    // Distant low hills: up to a tenth of the highest top.
    let mut el: Vec<f64> = (0..BINS).map(|i| 0.1 * max_deg * smooth(i as f64 * bin_deg, 9.0, 1 << 24)).collect();
    let mut k = 0u32;
    let mut next = || {
        k += 1;
        draws.uniform(k)
    };
    let mut az = 360.0 * next();
    let end = az + 360.0;
    while az < end {
        let object = next() < coverage;
        let tree = next() < tree_fraction;
        let (w, h) = match (object, tree) {
            (false, _) => (2.0 + 18.0 * next(), 0.0),
            (true, true) => {
                let h = max_deg * (0.35 + 0.65 * next());
                ((h * (0.8 + 0.8 * next())).max(3.0), h)
            }
            (true, false) => (4.0 + 21.0 * next(), max_deg * (0.25 + 0.75 * next())),
        };
        if object {
            let (first, n) = ((az / bin_deg).ceil() as i64, (w / bin_deg) as i64);
            for b in first..first + n {
                let a = b as f64 * bin_deg;
                let top = if tree {
                    // A rounded crown, jagged by leaves and branches.
                    let x = (2.0 * (a - az) / w - 1.0).clamp(-1.0, 1.0);
                    let jag = 2.0 * (0.6 * smooth(a, 0.4, 1 << 25) + 0.4 * smooth(a, 0.15, 1 << 26)) - 1.0;
                    h * (1.0 - x * x).sqrt() * (1.0 + 0.15 * jag)
                } else {
                    h
                };
                let slot = &mut el[b.rem_euclid(BINS as i64) as usize];
                *slot = slot.max(top.min(max_deg));
            }
        }
        az += w;
    }
    el
}

impl FieldElement for Skyline {
    /// What the ray sees: the sky `s` (meridional frame), an object or the ground.
    #[inline]
    fn apply(&self, ray: &FieldRay, s: Stokes) -> Stokes {
        let d = ray.d_world;
        if d.z >= self.sin_max {
            return s;
        }
        if d.z < 0.0 {
            // The ground: diffuse, unpolarized, textured.
            let n = self.textures[3].fbm(d * 60.0, 2);
            return Stokes::new(self.ground_radiance * (1.0 + 0.3 * n), 0.0, 0.0, 0.0);
        }
        if d.z >= self.sin_top(d) {
            return s;
        }
        // A tree or a building: dark, textured, a few percent polarized at no
        // particular angle (χ from the local vertical, fixed in the world).
        let i = self.object_radiance * (1.0 + 0.5 * self.textures[0].fbm(d * 120.0, 2));
        let dolp = self.object_dolp * (0.5 + 0.5 * self.textures[1].fbm(d * 40.0, 2));
        let chi = std::f64::consts::PI * self.textures[2].fbm(d * 40.0, 2);
        let up = (DVec3::Z - d * d.z).normalize();
        let e = up * chi.cos() + d.cross(up) * chi.sin();
        linear_stokes(i, dolp, e, ray)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use crate::conventions::enu_from_az_el_deg;
    use glam::DMat3;

    const SKY: Stokes = Stokes::new(0.8, 0.25, -0.15, 0.0);

    fn skyline(max: f64, coverage: f64, trees: f64, seed: u64) -> Skyline {
        Skyline::new(&[max, coverage, trees, 0.15, 0.04, 0.2], seed, 0.6)
    }

    fn seen(s: &Skyline, az: f64, el: f64) -> Stokes {
        let d = enu_from_az_el_deg(az, el);
        let b = meridional_basis(d);
        s.apply(
            &FieldRay { d_cam: d, d_world: d, basis: &b, cam_from_world: &DMat3::IDENTITY, white_over_sky: 1.0 },
            SKY,
        )
    }

    fn top_deg(s: &Skyline, az: f64) -> f64 {
        s.sin_top(enu_from_az_el_deg(az, 0.0)).asin().to_degrees()
    }

    #[test]
    fn above_the_skyline_the_sky_is_untouched_and_below_the_horizon_is_unpolarized_ground() {
        let s = skyline(20.0, 0.7, 0.5, 3);
        assert!(s.sin_max <= 20f64.to_radians().sin() + 1e-12);
        for i in 0..720 {
            let az = i as f64 * 0.5;
            assert_eq!(seen(&s, az, top_deg(&s, az) + 0.05), SKY, "{az}");
            assert_eq!(seen(&s, az, 21.0), SKY);
            let g = seen(&s, az, -0.5 - (i % 80) as f64);
            assert_eq!((g.q, g.u, g.v), (0.0, 0.0, 0.0));
            assert!((0.7 * 0.12..=1.3 * 0.12).contains(&g.i), "ground {}", g.i);
        }
        // At zero height nothing stands above the horizon.
        let flat = skyline(0.0, 1.0, 0.5, 3);
        assert_eq!(seen(&flat, 33.0, 0.01), SKY);
        assert_eq!(seen(&flat, 33.0, -0.01).dolp(), 0.0);
    }

    #[test]
    fn objects_are_dark_and_weakly_polarized_at_varying_angles() {
        let s = skyline(20.0, 1.0, 0.5, 9);
        let mut angles = Vec::new();
        for i in 0..3600 {
            let az = i as f64 * 0.1;
            let top = top_deg(&s, az);
            if top > 2.0 {
                let o = seen(&s, az, 0.5 * top);
                assert!(o.dolp() <= 0.04 + 1e-12, "DoLP {}", o.dolp());
                assert!((0.5 * 0.09..=1.5 * 0.09).contains(&o.i), "{}", o.i);
                angles.push(o.aop_rad());
            }
        }
        assert!(angles.len() > 2000, "{} object samples", angles.len());
        let spread = angles.iter().fold(f64::MIN, |a, &b| a.max(b)) - angles.iter().fold(f64::MAX, |a, &b| a.min(b));
        assert!(spread > 1.5, "E-vectors all alike: spread {spread} rad");
    }

    #[test]
    fn buildings_are_flat_topped_and_trees_are_not() {
        let flat_share = |trees: f64| {
            let s = skyline(20.0, 1.0, trees, 5);
            let e = &s.sin_elevation;
            let (mut flat, mut raised) = (0, 0);
            for i in 0..BINS {
                if e[i] > 0.1 {
                    raised += 1;
                    flat += (e[i] == e[(i + 1) % BINS]) as usize;
                }
            }
            flat as f64 / raised as f64
        };
        let (buildings, trees) = (flat_share(0.0), flat_share(1.0));
        assert!(buildings > 0.8 && trees < 0.2, "flat share: buildings {buildings}, trees {trees}");
    }

    #[test]
    fn the_skyline_is_seeded() {
        assert_eq!(skyline(20.0, 0.7, 0.5, 3), skyline(20.0, 0.7, 0.5, 3));
        assert_ne!(skyline(20.0, 0.7, 0.5, 3).sin_elevation, skyline(20.0, 0.7, 0.5, 4).sin_elevation);
    }
}
