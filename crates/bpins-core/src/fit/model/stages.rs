//! A difference column's chain from the base chain's stages: a side of a Jacobian
//! column whose parameter moves only a late stage of the chain reuses the base
//! chain's earlier stages at the same pixel instead of evaluating them again.
//!
//! ```text
//! pixel (u, v) ─ camera ─▶ ray g ─ sky_along ─▶ S_sky ─ lens_to_image ─▶ S_image ─ analyzer ─▶ DN
//!                intr              sun, d_max,          per-pixel effects        analyzers, gains,
//!                                  quartic sky, shape   (`ChainFrame::ray`)      analyzer effects
//! Reuse:         Nothing           Ray                  Sky                      Image
//! ```
//!
//! A heading or d_max column starts at the sky (the same ray), a lens effect's at the
//! lens (the same sky), an analyzer or sensor effect's at the analyzer (the same
//! Stokes vector at the pixel): the same operations on the same numbers as the whole
//! chain ([`Reuse::between`] compares every field the skipped stages read), so the
//! same bits, at a fraction of the work. Crosstalk mixes a pixel with its
//! neighbours' chains: a frame with any is evaluated whole.

use crate::camera::RayGeometry;
use crate::chain::{lens_to_image, site_signal_dn, sky_along, ChainFrame};
use crate::stokes::Stokes;

/// How much of the base chain's pixel a frame's chain can reuse: every stage before
/// the first one it changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Reuse {
    /// Nothing: the camera differs (or crosstalk is on).
    Nothing,
    /// The ray: the sky differs (the sun in the camera frame, d_max, the quartic sky,
    /// the DoLP shape, scene elements).
    Ray,
    /// The ray and the sky: a per-pixel effect differs.
    Sky,
    /// The Stokes vector at the pixel: only the analyzer or what follows it differs.
    Image,
}

impl Reuse {
    /// What `f`'s chain can reuse of `base`'s at the same pixel.
    pub fn between(f: &ChainFrame, base: &ChainFrame) -> Reuse {
        if f.intr != base.intr || f.has_mosaic_effects() || base.has_mosaic_effects() {
            Reuse::Nothing
        } else if f.sun_cam != base.sun_cam
            || f.dmax != base.dmax
            || f.sky != base.sky
            || f.active.sky != base.active.sky
            || f.field != base.field
        {
            Reuse::Ray
        } else if f.ray != base.ray || f.active.ray != base.active.ray {
            Reuse::Sky
        } else {
            Reuse::Image
        }
    }
}

/// One pixel's chain stages: its ray, the sky along it (meridional frame) and the
/// Stokes vector at the pixel (image frame).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Stages {
    pub g: RayGeometry,
    pub sky: Stokes,
    pub image: Stokes,
}

impl Stages {
    /// Pixel (u, v)'s stages under `f`, from `reuse` on: the stages `reuse` covers are
    /// `self`'s (a base chain's at this pixel), the rest evaluated under `f`.
    #[inline(always)]
    pub fn from(mut self, f: &ChainFrame, (u, v): (usize, usize), reuse: Reuse) -> Stages {
        if reuse < Reuse::Ray {
            // Pixel → ray through the true camera.
            self.g = f.intr.geometry(u as f64, v as f64);
        }
        if reuse < Reuse::Sky {
            // Skylight along the ray, meridional frame.
            self.sky = sky_along::<true>(f, &self.g);
        }
        if reuse < Reuse::Image {
            // The lens, then the image x frame.
            self.image = lens_to_image(f, &self.g, self.sky);
        }
        self
    }

    /// Pixel (u, v)'s stages under `f`, all evaluated.
    #[inline(always)]
    pub fn of(f: &ChainFrame, (u, v): (usize, usize)) -> Stages {
        let g = f.intr.geometry(u as f64, v as f64);
        let sky = sky_along::<true>(f, &g);
        Stages { g, sky, image: lens_to_image(f, &g, sky) }
    }

    /// Photo-signal in DN of channel `ch` at pixel (u, v) under `f` (`chain::site_signal_dn`).
    #[inline(always)]
    pub fn signal_dn(&self, f: &ChainFrame, (u, v): (usize, usize), ch: usize) -> f64 {
        site_signal_dn(f, self.image, &self.g, u as u32, v as u32, ch)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::{mosaic_pixel_signal_dn, Scene};
    use crate::effects::{EffectSet, REGISTRY};
    use crate::sensor::DEFAULT_MOSAIC;

    fn frame(set: &EffectSet, scene: &Scene) -> ChainFrame {
        ChainFrame::noise_free(&set.model(), &intrinsics(), scene)
    }

    /// Every effect at its typical strength beside the quartic sky and the DoLP shape
    /// (so each stage has work to do), the mosaic effects apart (crosstalk: a frame
    /// with one reuses nothing).
    fn base_set() -> EffectSet {
        let mut set = EffectSet::new();
        for e in REGISTRY.iter().filter(|e| !matches!(e.apply, crate::effects::Apply::Mosaic { .. })) {
            for p in e.params {
                set.set(e.name, p.name, p.typical).unwrap();
            }
        }
        set
    }

    #[test]
    fn a_side_reuses_the_stages_before_the_first_it_changes_with_the_same_bits() {
        let (set, sc) = (base_set(), scene());
        let base = frame(&set, &sc);
        // (what changes, what the side can reuse)
        let cases: Vec<(&str, ChainFrame, Reuse)> = vec![
            ("focal length", frame(&with(&set, "focal_length", "scale", 0.03), &sc), Reuse::Nothing),
            ("heading", frame(&set, &Scene { heading_deg: sc.heading_deg + 0.01, ..sc }), Reuse::Ray),
            ("d_max", frame(&set, &Scene { dmax: sc.dmax + 0.01, ..sc }), Reuse::Ray),
            ("mount tilt", frame(&with(&set, "mount_tilt", "tilt_x_deg", 1.2), &sc), Reuse::Ray),
            ("neutral points", frame(&with(&set, "sky_neutral_points", "separation_deg", 21.0), &sc), Reuse::Ray),
            ("window", frame(&with(&set, "window", "tilt_x_deg", 5.5), &sc), Reuse::Sky),
            ("lens off", frame(&with(&set, "lens_retardance", "delta2_deg", 0.0), &sc), Reuse::Sky),
            ("extinction", frame(&with(&set, "extinction_ratio", "eps45", 0.03), &sc), Reuse::Image),
            ("gain", frame(&with(&set, "channel_response", "gain90", 0.02), &sc), Reuse::Image),
            ("the base", base.clone(), Reuse::Image),
        ];
        for (what, f, want) in &cases {
            assert_eq!(Reuse::between(f, &base), *want, "{what}");
            for (u, v) in [(3, 4), (305, 255), (600, 17), (120, 498)] {
                let st = Stages::of(&base, (u, v)).from(f, (u, v), *want);
                let whole = Stages::of(f, (u, v));
                assert_eq!((st.g, st.sky, st.image), (whole.g, whole.sky, whole.image), "{what} at ({u}, {v})");
                for ch in 0..4 {
                    assert_eq!(st.signal_dn(f, (u, v), ch), whole.signal_dn(f, (u, v), ch), "{what}");
                }
                // …and the chain's own per-pixel signal.
                let ch = crate::sensor::Layout::dofp_channel(&DEFAULT_MOSAIC, u, v).index();
                assert_eq!(st.signal_dn(f, (u, v), ch), mosaic_pixel_signal_dn(f, u, v, 612, 512, &DEFAULT_MOSAIC));
            }
        }
    }

    #[test]
    fn crosstalk_reuses_nothing() {
        let sc = scene();
        let base = frame(&with(&base_set(), "crosstalk", "c", 0.01), &sc);
        let f = frame(&with(&base_set(), "crosstalk", "c", 0.011), &sc);
        assert_eq!(Reuse::between(&f, &base), Reuse::Nothing);
        assert_eq!(Reuse::between(&frame(&base_set(), &sc), &base), Reuse::Nothing);
    }

    fn with(set: &EffectSet, effect: &str, param: &str, value: f64) -> EffectSet {
        let mut s = set.clone();
        s.set(effect, param, value).unwrap();
        s
    }
}
