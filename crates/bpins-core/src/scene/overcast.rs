//! # `overcast` — a cloud deck over most of the sky, with holes of clear sky
//!
//! ```text
//! n(d)  = fbm(d / scale, 4)                   world-fixed value noise on the ray, in [−1, 1]
//! t     = the (1 − cover) quantile of n over the dome above `min_elevation_deg` (4 096
//!         directions of a Fibonacci lattice, uniform in solid angle)
//! c(d)  = smoothstep(t − edge, t + edge, n(d))   the deck's cover along d: 1 under it, 0 in a hole
//! θ(d)  = σ·(n_f + 2·m(d))                    the deck's E-vector turn: n_f ~ N(0, 1) per frame,
//!                                              m a second world-fixed fbm (amplitude ~0.3)
//! I    ← I·(1 + (brightness·w − 1)·c)        w = 1/r_band: the deck is white (1 for mono)
//! DoLP ← DoLP·(1 − (1 − dolp_factor)·c)
//! AoE  ← AoE + c·θ(d)                          (Q, U) rotated by 2cθ
//! ```
//!
//! What this stands for: under a stratus deck the sky's DoLP falls to a few per cent
//! while its angle of polarization still loosely follows the clear-sky pattern, with
//! deviations of tens of degrees that vary across the deck; the holes show the clear
//! sky behind (Hegedüs, Åkesson & Horváth, "Polarization patterns of thick clouds:
//! overcast skies have distribution of the angle of polarization similar to that of
//! clear skies", J. Opt. Soc. Am. A 24, 2347 (2007); Pomozi, Horváth & Wehner, J. Exp.
//! Biol. 204, 2933 (2001)). A thin veil is the same element at `cover = 1` with a
//! `dolp_factor` near 1 and a small turn. Source: as cited; the profile and the
//! turn are phenomenological, not radiative transfer. Units: angles in degrees,
//! `cover`, `edge`, `brightness`, `dolp_factor` dimensionless (`edge` in the noise's
//! units, where n spans about ±0.5). Frame: the deck fixed in world ENU (the same
//! holes in every frame of a capture); the Stokes vector in the ray's meridional
//! frame (the turn is about the ray, so any frame).
//!
//! | param                | unit | default | range         |
//! |----------------------|------|---------|---------------|
//! | `cover`              | 1    | 0.9     | [0, 1]        |
//! | `scale_deg`          | deg  | 25      | [2, 90]       |
//! | `edge`               | 1    | 0.05    | [0.001, 1]    |
//! | `brightness`         | 1    | 1.5     | [0.1, 5]      |
//! | `dolp_factor`        | 1    | 0.08    | [0, 1]        |
//! | `rotation_sigma_deg` | deg  | 20      | [0, 90]       |
//! | `min_elevation_deg`  | deg  | 0       | [0, 85]       |
//!
//! Cannot: layers at different heights, the sun dimmed behind the deck (the sun's
//! disc is added after it), motion during a capture, wind-stretched features (the
//! noise is isotropic), a cover below the horizon (the ground is the skyline's).

use super::frame::element_index;
use super::texture::Texture;
use super::{Draws, ElementDef, FieldElement, FieldRay, Layer, ParamSpec};
use crate::stokes::Stokes;
use glam::DVec3;
use std::sync::Arc;

pub const ELEMENT: ElementDef = ElementDef {
    name: "overcast",
    summary: "a cloud deck fixed in the world over `cover` of the dome, with holes of clear sky: brighter, \
              nearly unpolarized, E-vectors turned across the deck",
    source: "Hegedus, Akesson & Horvath 2007 (JOSA A 24); Pomozi, Horvath & Wehner 2001; phenomenological",
    params: &[
        ParamSpec::shape("cover", "1", 0.9, 0.0, 1.0, "fraction of the dome above the horizon under the deck")
            .vanishing_at(0.0),
        ParamSpec::shape("scale_deg", "deg", 25.0, 2.0, 90.0, "size of the deck's features (and of its holes)"),
        ParamSpec::shape("edge", "1", 0.05, 0.001, 1.0, "softness of the holes' edges, in the noise's units"),
        ParamSpec::shape("brightness", "1", 1.5, 0.1, 5.0, "radiance factor under the deck"),
        ParamSpec::shape("dolp_factor", "1", 0.08, 0.0, 1.0, "DoLP factor under the deck"),
        ParamSpec::shape(
            "rotation_sigma_deg",
            "deg",
            20.0,
            0.0,
            90.0,
            "scale of the deck's E-vector turn (a per-frame common part and a part varying across the deck)",
        ),
        ParamSpec::shape(
            "min_elevation_deg",
            "deg",
            0.0,
            0.0,
            85.0,
            "`cover` is the share of the sky above this elevation (a camera's view: 40° for a zenith fisheye)",
        ),
    ],
    layer: Layer::Cloud,
    prepare: |v, cx| Arc::new(Overcast::new(v, cx.seed, cx.frame)),
};

/// Directions of the lattice the cover's threshold is measured on.
const LATTICE: usize = 4096;
/// Octaves of the deck's noise.
const OCTAVES: u32 = 4;

/// The deck of one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Overcast {
    /// Threshold t of the noise and the edge's half-width (noise units); `None`
    /// thresholds: the deck covers nothing (`cover = 0`) or everything (`cover = 1`).
    threshold: f64,
    edge: f64,
    cover: f64,
    /// 1 / scale, features per radian.
    per_rad: f64,
    brightness: f64,
    dolp_factor: f64,
    sigma_rad: f64,
    /// This frame's common turn n_f.
    frame_turn: f64,
    deck: Texture,
    turns: Texture,
}

impl Overcast {
    /// From the values in [`ELEMENT`]'s parameter order: the deck of frame `frame`
    /// under `seed` (its holes the same in every frame, its common turn drawn per frame).
    pub fn new(v: &[f64], seed: u64, frame: u32) -> Self {
        let (cover, scale_rad, edge) = (v[0].clamp(0.0, 1.0), v[1].to_radians(), v[2]);
        let salt = element_index(&ELEMENT);
        let deck = Texture::new(seed, salt, 0);
        let per_rad = 1.0 / scale_rad;
        // The threshold that puts `cover` of the dome above the lowest elevation under
        // the deck (z uniform on [sin h_min, 1]: uniform in solid angle).
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let z_min = v.get(6).copied().unwrap_or(0.0).to_radians().sin();
        let mut n: Vec<f64> = (0..LATTICE)
            .map(|i| {
                let z = z_min + (1.0 - z_min) * (i as f64 + 0.5) / LATTICE as f64;
                let r = (1.0 - z * z).sqrt();
                let (s, c) = (golden * i as f64).sin_cos();
                deck.fbm(DVec3::new(r * c, r * s, z) * per_rad, OCTAVES)
            })
            .collect();
        n.sort_by(f64::total_cmp);
        let k = ((1.0 - cover) * LATTICE as f64).round() as usize;
        let threshold = n[k.min(LATTICE - 1)];
        Overcast {
            threshold,
            edge,
            cover,
            per_rad,
            brightness: v[3],
            dolp_factor: v[4],
            sigma_rad: v[5].to_radians(),
            frame_turn: Draws::frame(seed, &ELEMENT, frame).normal(0),
            deck,
            turns: Texture::new(seed, salt, 1),
        }
    }

    /// The deck's cover c ∈ [0, 1] along the unit ENU ray `d`.
    #[inline]
    pub fn cover_at(&self, d: DVec3) -> f64 {
        if self.cover <= 0.0 {
            return 0.0;
        }
        if self.cover >= 1.0 {
            return 1.0;
        }
        let n = self.deck.fbm(d * self.per_rad, OCTAVES);
        let x = ((n - (self.threshold - self.edge)) / (2.0 * self.edge)).clamp(0.0, 1.0);
        x * x * (3.0 - 2.0 * x)
    }
}

impl FieldElement for Overcast {
    /// The sky's Stokes vector `s` (meridional frame of `ray`) seen through the deck.
    #[inline]
    fn apply(&self, ray: &FieldRay, s: Stokes) -> Stokes {
        let c = self.cover_at(ray.d_world);
        if c == 0.0 {
            return s;
        }
        // Brighter, nearly unpolarized, E-vector turned by cθ (Q, U rotated by 2cθ).
        let theta = self.sigma_rad * (self.frame_turn + 2.0 * self.turns.fbm(ray.d_world * self.per_rad, 2));
        // The deck's light is white (w = white_over_sky: 1/r_band, 1 for mono).
        let ki = 1.0 + (self.brightness * ray.white_over_sky - 1.0) * c;
        let kp = ki * (1.0 - (1.0 - self.dolp_factor) * c);
        let (s2, c2) = (2.0 * c * theta).sin_cos();
        Stokes::new(ki * s.i, kp * (c2 * s.q - s2 * s.u), kp * (s2 * s.q + c2 * s.u), kp * s.v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use glam::DMat3;

    fn values(cover: f64) -> Vec<f64> {
        ELEMENT.params.iter().enumerate().map(|(i, p)| if i == 0 { cover } else { p.typical }).collect()
    }

    fn through(o: &Overcast, d: DVec3, s: Stokes) -> Stokes {
        let b = meridional_basis(d);
        o.apply(&FieldRay { d_cam: d, d_world: d, basis: &b, cam_from_world: &DMat3::IDENTITY, white_over_sky: 1.0 }, s)
    }

    const SKY: Stokes = Stokes::new(0.8, 0.25, -0.15, 0.0);

    /// Directions on the upper hemisphere, uniform in solid angle (another lattice than
    /// the element's own).
    fn dome(n: usize) -> impl Iterator<Item = DVec3> {
        (0..n).map(move |i| {
            let z = ((i as f64 * 0.618_034) % 1.0).max(1e-3);
            let phi = i as f64 * 2.399_963 * 1.37;
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
    }

    #[test]
    fn no_cover_is_the_identity_and_full_cover_is_the_deck_everywhere() {
        let clear = Overcast::new(&values(0.0), 4, 0);
        for d in dome(200) {
            assert_eq!(through(&clear, d, SKY), SKY);
        }
        let full = Overcast::new(&values(1.0), 4, 0);
        for d in dome(200) {
            let s = through(&full, d, SKY);
            assert!((s.i / SKY.i - 1.5).abs() < 1e-12);
            assert!((s.dolp() / SKY.dolp() - 0.08).abs() < 1e-9);
        }
    }

    #[test]
    fn the_deck_covers_the_asked_fraction_of_the_dome() {
        for cover in [0.1, 0.3, 0.5, 0.7, 0.9] {
            let o = Overcast::new(&values(cover), 9, 0);
            let n = 20_000;
            let under = dome(n).filter(|&d| o.cover_at(d) > 0.5).count() as f64 / n as f64;
            assert!((under - cover).abs() < 0.04, "cover {cover}: {under} of the dome under the deck");
        }
    }

    #[test]
    fn the_cover_can_be_asked_of_the_sky_above_an_elevation() {
        let mut v = values(0.7);
        v[6] = 45.0;
        let o = Overcast::new(&v, 9, 0);
        let above: Vec<DVec3> = dome(20_000).filter(|d| d.z > 45f64.to_radians().sin()).collect();
        let under = above.iter().filter(|&&d| o.cover_at(d) > 0.5).count() as f64 / above.len() as f64;
        assert!((under - 0.7).abs() < 0.05, "{under} of the sky above 45° under the deck");
    }

    #[test]
    fn holes_show_the_clear_sky_and_the_deck_is_bright_unpolarized_and_turned() {
        let o = Overcast::new(&values(0.9), 9, 3);
        let (mut holes, mut deck) = (0, 0);
        for d in dome(4000) {
            let c = o.cover_at(d);
            let s = through(&o, d, SKY);
            if c == 0.0 {
                assert_eq!(s, SKY);
                holes += 1;
            } else if c == 1.0 {
                assert!((s.i / SKY.i - 1.5).abs() < 1e-12 && (s.dolp() / SKY.dolp() - 0.08).abs() < 1e-9);
                deck += 1;
            }
        }
        assert!(holes > 100 && deck > 2000, "{holes} in holes, {deck} under the deck");
    }

    #[test]
    fn the_deck_is_fixed_in_the_world_and_its_turn_drawn_per_frame() {
        let v = values(0.8);
        let (a, b, other) = (Overcast::new(&v, 5, 0), Overcast::new(&v, 5, 1), Overcast::new(&v, 6, 0));
        let d = DVec3::new(0.3, -0.2, 0.93).normalize();
        assert_eq!(a.cover_at(d), b.cover_at(d));
        assert_eq!(a, Overcast::new(&v, 5, 0));
        assert_ne!(a.frame_turn, b.frame_turn);
        assert!(dome(500).any(|d| a.cover_at(d) != other.cover_at(d)));
    }
}
