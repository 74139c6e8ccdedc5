//! # `stray_light` — veiling glare toward the sun
//!
//! ```text
//! I' = I + a · κ / (κ + 1 − cos γ),   cos γ = d · sun      κ = 0.05 (half strength at γ ≈ 18°)
//! Q, U, V unchanged (the glare is unpolarized)
//! ```
//!
//! Source: the glare spread function of a camera lens (ISO 9358:1994 veiling glare
//! index; its angular fall is a power of the angle from the source, here the
//! Lorentzian-like κ/(κ + 1 − cos γ) ≈ 2κ/(2κ + γ²), which falls as γ⁻² away from
//! the sun, as measured glare spread functions do): light of the sun scattered by the
//! lens's surfaces, coatings and barrel reaches every pixel, most near the sun's image.
//! Units: `a` in the sky model's radiance at the sun (the sky's unit), γ the angle
//! between the pixel's ray and the sun. Frame: any (unpolarized light is the same in
//! every frame); camera frame for the sun direction, which the effect takes from the
//! frame context (`Apply::Ray::frame`: the sun in the true camera frame, on both
//! backends through the frame's per-pixel vector). A per-pixel effect, after the
//! lens's Mueller matrices and before vignetting.
//!
//! | param | unit | neutral | fit bounds | physical |
//! |-------|------|---------|------------|----------|
//! | `a`   | 1    | 0       | [0, 1]     | [0, 0.3] |
//!
//! Separable from a sky capture only where the sky's radiance is known: with the
//! radiance a free nuisance the fit weighs the glare against the fitted radiance
//! toward the sun (under the CIE clear sky, type 12, `a` = 0.05 is read 0.030 ± 0.002,
//! measured), so the diagnosis lists it as inseparable there
//! (`diagnose::inseparable`) and measures it with the radiance held at
//! Rayleigh's.
//!
//! Cannot: ghost images (discrete reflections between surfaces, off the sun's
//! direction), polarized flare, a lens hood that cuts off a sun outside the field,
//! glare of other bright sources (clouds, ground), or a spread whose width differs
//! from κ's.

use super::{Apply, EffectDef, FrameContext, Inseparable, ParamSpec, RayParams, SkyBlindness, Stage};
use crate::camera::RayGeometry;
use crate::stokes::Stokes;

/// The range a real lens's glare has. Engineering bound: veiling-glare indices (ISO
/// 9358) of camera lenses are a few per cent of the source; a = 0.3 already adds, toward
/// the sun, a third of the sky's radiance there.
const A_PHYSICAL: (f64, f64) = (0.0, 0.3);

/// κ of the glare profile: 1 − cos γ at which the glare is half its peak.
pub const KAPPA: f64 = 0.05;

pub const EFFECT: EffectDef = EffectDef {
    name: "stray_light",
    summary: "unpolarized glare a k/(k + 1 - cos gamma) toward the sun (k = 0.05), lowers the DoLP near the sun",
    source: "lens glare spread function (ISO 9358 veiling glare), falling as gamma^-2 from the sun",
    stage: Stage::Lens,
    params: &[ParamSpec {
        name: "a",
        unit: "1",
        neutral: 0.0,
        typical: 0.05,
        min: 0.0,
        max: 1.0,
        physical: Some(A_PHYSICAL),
        doc: "glare radiance toward the sun, in the sky's radiance at the sun",
    }],
    apply: Apply::Ray { params: |v| [v[0], 0.0, 0.0, 0.0], frame: Some(with_sun), pixel: stray_light },
    wgsl: Some(include_str!("../../../../shaders/effects/stray_light.wgsl")),
    derivatives: &[],
    inseparable: Some(Inseparable {
        when: SkyBlindness::FreeRadiance,
        why: |_| {
            "unpolarized glare toward the sun: with the sky's radiance a free nuisance (a real sky brightens toward \
             the sun), the capture weighs the glare only against the fitted radiance, not in the sky's unit at the \
             sun (under the CIE clear sky it is read 40 % low, measured); where the sky's radiance is known \
             (Rayleigh's, `--rayleigh-radiance`) it is measured, or measure the lens's glare spread in the lab"
                .to_string()
        },
    }),
};

/// The vector completed with the frame's sun (camera frame): (a, sun x, y, z); left
/// neutral at a = 0, so a frame without glare keeps the ideal chain's vector.
fn with_sun(p: RayParams, c: &FrameContext) -> RayParams {
    if p[0] == 0.0 {
        return p;
    }
    [p[0], c.sun_cam.x, c.sun_cam.y, c.sun_cam.z]
}

/// Adds the glare along the ray `g` to its Stokes vector (any frame); p = (a, sun).
#[inline(always)]
pub fn stray_light(p: &RayParams, g: &RayGeometry, s: Stokes) -> Stokes {
    // cos γ between the ray and the sun; 0·… = 0 glare where a = 0 (exact identity).
    let cos_g = p[1] * g.d.x + p[2] * g.d.y + p[3] * g.d.z;
    let glare = p[0] * (KAPPA / (KAPPA + 1.0 - cos_g));
    Stokes { i: s.i + glare, q: s.q, u: s.u, v: s.v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{ideal_frame, intrinsics, scene, stokes_at};
    use crate::chain::{ChainFrame, Scene};
    use crate::effects::{EffectSet, Model};

    #[test]
    fn zero_strength_is_the_identity_and_stays_neutral_in_the_frame() {
        let f = ideal_frame(&Model::default());
        let g = f.intr.geometry(30.0, 400.0);
        let s = Stokes::new(0.8, 0.1, -0.2, 0.0);
        assert_eq!(stray_light(&[0.0; 4], &g, s), s);
        let mut set = EffectSet::new();
        set.enable("stray_light").unwrap();
        assert!(!ideal_frame(&set.model()).has_pixel_effects());
    }

    #[test]
    fn glare_is_unpolarized_strongest_toward_the_sun_and_follows_the_sun() {
        let mut set = EffectSet::new();
        set.set("stray_light", "a", 0.1).unwrap();
        let (f, f0) = (ideal_frame(&set.model()), ideal_frame(&Model::default()));
        let mut by_angle = Vec::new();
        for (u, v) in [(0.0, 0.0), (611.0, 0.0), (305.5, 255.5), (0.0, 511.0), (611.0, 511.0)] {
            let (s, s0) = (stokes_at(&f, u, v), stokes_at(&f0, u, v));
            // Only I grows; Q and U are the sky's.
            assert_eq!((s.q, s.u, s.v), (s0.q, s0.u, s0.v));
            let cos_g = f.intr.geometry(u, v).d.dot(f.sun_cam);
            let want = 0.1 * KAPPA / (KAPPA + 1.0 - cos_g);
            assert!((s.i - s0.i - want).abs() < 1e-15);
            by_angle.push((cos_g, s.i - s0.i));
        }
        // Closer to the sun (larger cos γ), more glare.
        by_angle.sort_by(|a, b| a.0.total_cmp(&b.0));
        for w in by_angle.windows(2) {
            assert!(w[1].1 > w[0].1, "{by_angle:?}");
        }
        // The sun behind the camera's back: the frame context moves the glare with it.
        let behind = Scene { sun_az_deg: scene().sun_az_deg + 180.0, ..scene() };
        let t = ChainFrame::noise_free(&set.model(), &intrinsics(), &behind);
        let t_ideal = ChainFrame::noise_free(&Model::default(), &intrinsics(), &behind);
        let cos_g = t.intr.geometry(0.0, 0.0).d.dot(t.sun_cam);
        let glare = stokes_at(&t, 0.0, 0.0).i - stokes_at(&t_ideal, 0.0, 0.0).i;
        assert!((glare - 0.1 * KAPPA / (KAPPA + 1.0 - cos_g)).abs() < 1e-15);
        let before = stokes_at(&f, 0.0, 0.0).i - stokes_at(&f0, 0.0, 0.0).i;
        assert!((glare - before).abs() > 1e-4, "{glare} vs {before}");
    }
}
