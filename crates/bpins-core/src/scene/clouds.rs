//! # `clouds` — seeded clouds fixed in the world
//!
//! ```text
//! cloud k: centre at azimuth U(0, 360°), sin(elevation) U(sin h_min, 1) (uniform on
//!          the sky above h_min), angular radius r_k ~ U(r_min, r_max), core
//!          brightness b_k = 1 + (brightness − 1)·U(½, 1); per frame a turn
//!          θ_k = σ·(√c·n₀ + √(1 − c)·n_k), n₀, n_k ~ N(0, 1), c = coherence
//!          (n₀ is the frame's, shared by every cloud: the turns of a frame's clouds
//!          are correlated with coefficient c, each still of spread σ)
//! ρ²  = (1 − d·c_k)/(1 − cos r_k)          (≈ (angle from the centre / r_k)²)
//! ρ²  ← ρ²·(1 − ½·texture·n(d))            ragged edge, n ∈ [−1, 1] seeded value noise
//! τ   = (1 − ρ²)² inside (ρ² < 1), else 0   soft profile: 1 at the core, 0 at the edge
//! ω   = rim·4ρ²(1 − ρ²) inside, else 0      the rim: 0 at the core and the edge, `rim` at ρ² = ½
//! I   ← I·(1 + (b_k·w − 1)·max(τ, ω))       rims lit like the core; w = 1/r_band (white light,
//!                                           `FieldFrame::white_over_sky`; 1 for mono)
//! DoLP ← DoLP·(1 − (1 − dolp_factor)·τ)     rims stay polarized (only the core depolarizes)
//! AoE ← AoE + max(τ, ω)·θ_k                 (Q, U) rotated by 2·max(τ, ω)·θ_k
//! ```
//!
//! Each cloud in turn (overlaps compound). What this stands for: a cloud adds
//! multiply-scattered, nearly unpolarized light to the single-scattered skylight
//! behind it, so its radiance rises and its DoLP falls; thin cloud keeps most of the
//! sky's E-vector pattern but turns it by a few to tens of degrees. Measured: under
//! clouds the DoLP falls well below the clear sky's while the angle of polarization
//! largely continues the clear-sky pattern, with deviations of up to tens of degrees
//! (Pomozi, Horváth & Wehner, "How the clear-sky angle of polarization pattern
//! continues underneath clouds", J. Exp. Biol. 204, 2933 (2001); Hegedüs, Åkesson &
//! Horváth, J. Opt. Soc. Am. A 24, 2347 (2007)); the defaults follow the samples'
//! field sky (DoLP to 15 %, brighter by up to 2.5×). A real cloud's sunlit rim is
//! bright and still partly polarized with its E-vectors turned, and the turns of
//! neighbouring clouds share the light field beneath them: `rim` and `coherence`
//! make those (both 0 by default: the soft depolarized discs of earlier versions,
//! bit for bit). The profile and the turn are a
//! phenomenological model, not radiative transfer. Source: as cited. Units: angles in degrees, brightness and dolp_factor
//! dimensionless. Frame: centres in world ENU (fixed over a capture); the Stokes
//! vector in the ray's meridional frame (the turn is about the ray, so any frame).
//!
//! | param                | unit | default | range       |
//! |----------------------|------|---------|-------------|
//! | `count`              | 1    | 6       | [0, 64]     |
//! | `radius_min_deg`     | deg  | 5       | [0.5, 45]   |
//! | `radius_max_deg`     | deg  | 12      | [0.5, 45]   |
//! | `min_elevation_deg`  | deg  | 10      | [0, 89]     |
//! | `brightness`         | 1    | 2.5     | [0.1, 5]    |
//! | `dolp_factor`        | 1    | 0.15    | [0, 1]      |
//! | `rotation_sigma_deg` | deg  | 17      | [0, 90]     |
//! | `texture`            | 1    | 0.3     | [0, 1]      |
//! | `coherence`          | 1    | 0       | [0, 1]      |
//! | `rim`                | 1    | 0       | [0, 1]      |
//!
//! Cannot: cloud shadows or the sun dimmed behind a cloud (the sun's disc is added
//! after the clouds), motion during a capture, layered or overcast skies, the
//! E-vector turn varying inside a cloud beyond the profile τ, a cloud's colour other
//! than white (its added light is spectrally flat in every band: on a colour sensor a
//! cloud is whiter than the blue sky, as all-sky imagers see it; Long et al., J. Atmos.
//! Oceanic Technol. 23, 633 (2006)), a band-dependent DoLP factor.

use super::frame::element_index;
use super::texture::Texture;
use super::{Draws, ElementDef, FieldElement, FieldRay, Layer, ParamSpec};
use crate::conventions::enu_from_az_el_deg;
use crate::stokes::Stokes;
use glam::DVec3;
use std::sync::Arc;

pub const ELEMENT: ElementDef = ElementDef {
    name: "clouds",
    summary: "seeded clouds fixed in the world: brighter, less polarized, E-vectors turned per frame",
    source: "Pomozi, Horvath & Wehner 2001 (J. Exp. Biol. 204); phenomenological profile",
    params: &[
        ParamSpec::shape("count", "count", 6.0, 0.0, 64.0, "number of clouds").vanishing_at(0.0),
        ParamSpec::shape("radius_min_deg", "deg", 5.0, 0.5, 45.0, "smallest angular radius"),
        ParamSpec::shape("radius_max_deg", "deg", 12.0, 0.5, 45.0, "largest angular radius"),
        ParamSpec::shape("min_elevation_deg", "deg", 10.0, 0.0, 89.0, "lowest elevation of a cloud's centre"),
        ParamSpec::shape("brightness", "1", 2.5, 0.1, 5.0, "radiance factor at the brightest cloud's core"),
        ParamSpec::shape("dolp_factor", "1", 0.15, 0.0, 1.0, "DoLP factor at a cloud's core"),
        ParamSpec::shape(
            "rotation_sigma_deg",
            "deg",
            17.0,
            0.0,
            90.0,
            "1σ of each cloud's E-vector turn, drawn per frame",
        ),
        ParamSpec::shape("texture", "1", 0.3, 0.0, 1.0, "raggedness of the edges (0: smooth discs)"),
        ParamSpec::shape(
            "coherence",
            "1",
            0.0,
            0.0,
            1.0,
            "share of the turn's variance common to every cloud of a frame (correlation of two clouds' turns)",
        ),
        ParamSpec::shape(
            "rim",
            "1",
            0.0,
            0.0,
            1.0,
            "strength of the bright, polarized, turned rim (its turn's share of the core's at ρ² = ½)",
        ),
    ],
    layer: Layer::Cloud,
    prepare: |v, cx| Arc::new(Clouds::new(v, cx.seed, cx.frame)),
};

/// One cloud of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cloud {
    /// Unit centre direction, ENU.
    pub centre_world: DVec3,
    pub radius_rad: f64,
    /// Radiance factor at the core, b_k.
    pub brightness: f64,
    /// This frame's E-vector turn at the core, θ_k, radians.
    pub turn_rad: f64,
    /// 1 − cos r_k.
    one_minus_cos_r: f64,
    /// Largest 1 − d·c that a ragged edge reaches (quick rejection).
    reach: f64,
    texture: Texture,
}

/// The clouds of one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Clouds {
    pub clouds: Vec<Cloud>,
    pub dolp_factor: f64,
    pub texture: f64,
    /// Strength of the rim, `rim`.
    pub rim: f64,
}

impl Clouds {
    /// From the values in [`ELEMENT`]'s parameter order: the clouds of frame `frame`
    /// under `seed` (centres and sizes the same in every frame, turns drawn per frame).
    pub fn new(v: &[f64], seed: u64, frame: u32) -> Self {
        let count = v[0].max(0.0) as u32;
        let (r_lo, r_hi) = (v[1].min(v[2]).to_radians(), v[1].max(v[2]).to_radians());
        let sin_min = v[3].to_radians().sin();
        let (brightness, dolp_factor, sigma_rad, texture) = (v[4], v[5], v[6].to_radians(), v[7]);
        let (coherence, rim) = (v.get(8).copied().unwrap_or(0.0), v.get(9).copied().unwrap_or(0.0));
        let world = Draws::world(seed, &ELEMENT);
        let this_frame = Draws::frame(seed, &ELEMENT, frame);
        // The frame's common turn (draw 64: past the largest count's own draws); at
        // coherence 0 each turn is σ·n_k exactly, as before the parameter existed.
        let common = if coherence > 0.0 { coherence.sqrt() * this_frame.normal(64) } else { 0.0 };
        let own = (1.0 - coherence).sqrt();
        let clouds = (0..count)
            .map(|k| {
                let u = |j: u32| world.uniform(4 * k + j);
                let el_deg = (sin_min + (1.0 - sin_min) * u(1)).clamp(-1.0, 1.0).asin().to_degrees();
                let radius_rad = r_lo + (r_hi - r_lo) * u(2);
                let one_minus_cos_r = 1.0 - radius_rad.cos();
                Cloud {
                    centre_world: enu_from_az_el_deg(360.0 * u(0), el_deg),
                    radius_rad,
                    brightness: 1.0 + (brightness - 1.0) * (0.5 + 0.5 * u(3)),
                    turn_rad: if coherence > 0.0 {
                        sigma_rad * (common + own * this_frame.normal(k))
                    } else {
                        sigma_rad * this_frame.normal(k)
                    },
                    one_minus_cos_r,
                    reach: one_minus_cos_r / (1.0 - 0.5 * texture),
                    texture: Texture::new(seed, element_index(&ELEMENT), k),
                }
            })
            .collect();
        Clouds { clouds, dolp_factor, texture, rim }
    }

    /// The cloud profile τ ∈ [0, 1] of cloud `c` along the unit ENU ray `d`.
    #[inline]
    pub fn profile(&self, c: &Cloud, d: DVec3) -> f64 {
        self.profiles(c, d).0
    }

    /// The core profile τ and the rim profile ω of cloud `c` along the unit ENU ray `d`.
    #[inline]
    pub fn profiles(&self, c: &Cloud, d: DVec3) -> (f64, f64) {
        let x = 1.0 - d.dot(c.centre_world);
        if x >= c.reach {
            return (0.0, 0.0);
        }
        let mut rho2 = x / c.one_minus_cos_r;
        if self.texture > 0.0 {
            // Ragged edge: noise of a few features across the cloud, fixed in the world.
            rho2 *= 1.0 - 0.5 * self.texture * c.texture.fbm(d * (3.0 / c.radius_rad), 3);
        }
        if rho2 >= 1.0 {
            return (0.0, 0.0);
        }
        ((1.0 - rho2) * (1.0 - rho2), self.rim * 4.0 * rho2 * (1.0 - rho2))
    }
}

impl FieldElement for Clouds {
    /// The sky's Stokes vector `s` (meridional frame of `ray`) seen through the clouds.
    #[inline]
    fn apply(&self, ray: &FieldRay, s: Stokes) -> Stokes {
        let mut s = s;
        for c in &self.clouds {
            let (tau, omega) = self.profiles(c, ray.d_world);
            if tau == 0.0 && omega == 0.0 {
                continue;
            }
            // Brighter, less polarized at the core, E-vector turned by τθ (Q, U rotated
            // by 2τθ); a rim (ω) lit and turned like the core but still polarized.
            let lit = tau.max(omega);
            // The cloud's light is white: in a band frame its brightness over the band's
            // sky is b_k·w (w = white_over_sky; 1 for a monochrome sensor).
            let ki = 1.0 + (c.brightness * ray.white_over_sky - 1.0) * lit;
            let kp = ki * (1.0 - (1.0 - self.dolp_factor) * tau);
            let (s2, c2) = (2.0 * lit * c.turn_rad).sin_cos();
            s = Stokes::new(ki * s.i, kp * (c2 * s.q - s2 * s.u), kp * (s2 * s.q + c2 * s.u), kp * s.v);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use glam::DMat3;

    fn values(count: f64, texture: f64) -> Vec<f64> {
        vec![count, 5.0, 12.0, 10.0, 2.5, 0.15, 17.0, texture, 0.0, 0.0]
    }

    fn through(c: &Clouds, d: DVec3, s: Stokes) -> Stokes {
        let b = meridional_basis(d);
        c.apply(&FieldRay { d_cam: d, d_world: d, basis: &b, cam_from_world: &DMat3::IDENTITY, white_over_sky: 1.0 }, s)
    }

    const SKY: Stokes = Stokes::new(0.8, 0.25, -0.15, 0.0);

    #[test]
    fn no_cloud_is_the_identity_and_clear_sky_is_untouched() {
        let none = Clouds::new(&values(0.0, 0.3), 7, 0);
        assert_eq!(through(&none, DVec3::new(0.2, 0.1, 0.97).normalize(), SKY), SKY);
        let c = Clouds::new(&values(1.0, 0.3), 7, 0);
        // 60° from the cloud's centre: far outside.
        let axis = c.clouds[0].centre_world;
        let away = (axis * 0.5 + axis.cross(DVec3::Z).normalize() * 0.75f64.sqrt()).normalize();
        assert_eq!(through(&c, away, SKY), SKY);
    }

    #[test]
    fn the_core_is_brighter_less_polarized_and_turned_by_the_frame_angle() {
        let c = Clouds::new(&values(3.0, 0.0), 11, 2);
        for k in &c.clouds {
            let s = through(&c, k.centre_world, SKY);
            assert!((s.i / SKY.i - k.brightness).abs() < 1e-9, "{} vs {}", s.i / SKY.i, k.brightness);
            assert!((s.dolp() / SKY.dolp() - 0.15).abs() < 1e-9);
            let turn = crate::conventions::wrap_deg_90((s.aop_rad() - SKY.aop_rad()).to_degrees());
            assert!((turn - k.turn_rad.to_degrees()).abs() < 1e-6, "{turn} vs {}", k.turn_rad.to_degrees());
            assert!((1.25..=2.5).contains(&k.brightness));
        }
        // The profile falls from the core to the edge.
        let k = &c.clouds[0];
        let side = k.centre_world.cross(DVec3::Z).normalize();
        let at = |f: f64| {
            let a = f * k.radius_rad;
            c.profile(k, k.centre_world * a.cos() + side * a.sin())
        };
        assert!(at(0.0) > at(0.5) && at(0.5) > at(0.9) && at(0.9) > 0.0 && at(1.01) == 0.0);
    }

    #[test]
    fn a_cloud_core_is_white_in_every_band_frame() {
        // A blue sky (r_R 0.625, r_B 1.25 against green): each band frame's gain
        // multiplies by r_b, the element adds its light over the sky by 1/r_b.
        let c = Clouds::new(&values(2.0, 0.0), 11, 2);
        let k = &c.clouds[0];
        let b = meridional_basis(k.centre_world);
        let seen = |r: f64| {
            let ray = FieldRay {
                d_cam: k.centre_world,
                d_world: k.centre_world,
                basis: &b,
                cam_from_world: &DMat3::IDENTITY,
                white_over_sky: 1.0 / r,
            };
            r * c.apply(&ray, SKY).i
        };
        // At the core: the white cloud's radiance, b_k times the green sky, in each band.
        for r in [0.625, 1.0, 1.25] {
            assert!((seen(r) / SKY.i - k.brightness).abs() < 1e-9, "r {r}: {}", seen(r) / SKY.i);
        }
        // So its red/blue ratio is 1 where the sky's is 0.5, and the green frame is
        // bitwise the monochrome one.
        assert!((seen(0.625) / seen(1.25) - 1.0).abs() < 1e-12);
        assert_eq!(seen(1.0), through(&c, k.centre_world, SKY).i);
    }

    #[test]
    fn clouds_are_fixed_in_the_world_and_turns_are_drawn_per_frame() {
        let v = values(8.0, 0.3);
        let (a, b, other) = (Clouds::new(&v, 5, 0), Clouds::new(&v, 5, 1), Clouds::new(&v, 6, 0));
        assert_eq!(a, Clouds::new(&v, 5, 0));
        for (x, y) in a.clouds.iter().zip(&b.clouds) {
            assert_eq!((x.centre_world, x.radius_rad, x.brightness), (y.centre_world, y.radius_rad, y.brightness));
            assert_ne!(x.turn_rad, y.turn_rad);
        }
        assert_ne!(a.clouds[0].centre_world, other.clouds[0].centre_world);
        for k in &a.clouds {
            assert!(k.centre_world.z >= 10f64.to_radians().sin() - 1e-12);
            assert!((5.0..=12.0).contains(&k.radius_rad.to_degrees()));
        }
    }

    #[test]
    fn coherent_turns_are_correlated_with_the_asked_coefficient_and_keep_their_spread() {
        let mut v = values(64.0, 0.0);
        v[8] = 0.7;
        let frames: Vec<Clouds> = (0..60).map(|f| Clouds::new(&v, 3, f)).collect();
        // Correlation of cloud 0's and cloud 1's turns over frames, and the pooled spread.
        let (a, b): (Vec<f64>, Vec<f64>) = frames.iter().map(|c| (c.clouds[0].turn_rad, c.clouds[1].turn_rad)).unzip();
        let n = a.len() as f64;
        let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
        let cov = a.iter().zip(&b).map(|(x, y)| (x - ma) * (y - mb)).sum::<f64>() / n;
        let (va, vb) =
            (a.iter().map(|x| (x - ma).powi(2)).sum::<f64>() / n, b.iter().map(|y| (y - mb).powi(2)).sum::<f64>() / n);
        let rho = cov / (va * vb).sqrt();
        assert!((rho - 0.7).abs() < 0.2, "correlation {rho}");
        let all: Vec<f64> = frames.iter().flat_map(|c| c.clouds.iter().map(|k| k.turn_rad.to_degrees())).collect();
        let sd = (all.iter().map(|t| t * t).sum::<f64>() / all.len() as f64).sqrt();
        assert!((sd - 17.0).abs() < 2.5, "σ {sd}°");
        // Coherence 0 is the independent draw, bit for bit.
        let mut w = v.clone();
        w[8] = 0.0;
        let (x, y) = (Clouds::new(&w, 3, 5), Clouds::new(&values(64.0, 0.0), 3, 5));
        assert_eq!(x, y);
    }

    #[test]
    fn a_rim_is_lit_turned_and_still_polarized_and_rim_zero_is_the_old_cloud() {
        let mut v = values(1.0, 0.0);
        v[9] = 1.0;
        let c = Clouds::new(&v, 11, 2);
        let k = &c.clouds[0];
        let side = k.centre_world.cross(DVec3::Z).normalize();
        // ρ² = ½: the rim's peak, τ = ¼.
        let a = (1.0 - 0.5 * k.one_minus_cos_r).acos();
        let d = k.centre_world * a.cos() + side * a.sin();
        let (tau, omega) = c.profiles(k, d);
        assert!((tau - 0.25).abs() < 1e-9 && (omega - 1.0).abs() < 1e-9, "{tau} {omega}");
        let s = through(&c, d, SKY);
        let turn = crate::conventions::wrap_deg_90((s.aop_rad() - SKY.aop_rad()).to_degrees());
        assert!((turn - k.turn_rad.to_degrees()).abs() < 1e-6, "rim turned by the whole θ: {turn}");
        assert!((s.i / SKY.i - k.brightness).abs() < 1e-9, "rim lit like the core");
        assert!((s.dolp() / SKY.dolp() - (1.0 - 0.85 * 0.25)).abs() < 1e-9, "rim keeps most of its DoLP");
        let mut w = v.clone();
        w[9] = 0.0;
        let plain = Clouds::new(&w, 11, 2);
        let old = through(&plain, d, SKY);
        assert!((old.i / SKY.i - (1.0 + (k.brightness - 1.0) * 0.25)).abs() < 1e-9);
    }

    #[test]
    fn turns_have_the_asked_spread() {
        let v = values(64.0, 0.0);
        let turns: Vec<f64> =
            (0..40).flat_map(|f| Clouds::new(&v, 3, f).clouds.into_iter().map(|c| c.turn_rad.to_degrees())).collect();
        let n = turns.len() as f64;
        let mean = turns.iter().sum::<f64>() / n;
        let sd = (turns.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / n).sqrt();
        assert!(mean.abs() < 1.5 && (sd - 17.0).abs() < 1.0, "mean {mean}°, σ {sd}°");
    }
}
