//! # `analyzer_incidence` — the analyzers see the chief ray obliquely toward the edge
//!
//! ```text
//! tan χ = c·r                         chief-ray angle on the sensor; r: normalised radius (focal lengths)
//! tan ψ' = tan ψ / cos χ              ψ: analyzer axis from the plane of incidence (image angle β)
//! ε' = ε + e2·sin²χ
//! ```
//!
//! Source: the geometric projection of a polarizer's transmission axis onto the plane
//! transverse to an oblique ray (Chipman, Lam & Young 2018, *Polarized Light and
//! Optical Systems*, polarizers at non-normal incidence): the axis component in the
//! plane of incidence is foreshortened by cos χ, so the effective axis turns away
//! from that plane by up to ≈ χ²/4 rad; a wire-grid's or absorptive film's extinction
//! worsens with incidence (`e2`, lowest order in sin²χ). The chief-ray angle grows
//! with the image radius as for an exit pupil at L = f/c in front of the sensor
//! (c = 0: image-space telecentric); fisheyes and short lenses have large c. Frame:
//! image; the plane of incidence of pixel (u, v) contains the optical axis, so its
//! image angle is the pixel's radial angle β (`RayGeometry::basis`). Units: c and e2
//! dimensionless. An analyzer effect (`chain::site_signal_dn`), per pixel and channel.
//!
//! | param | unit | neutral | fit bounds | physical |
//! |-------|------|---------|------------|----------|
//! | `c`   | 1    | 0       | [0, 2]     | [0, 1]   |
//! | `e2`  | 1    | 0       | [0, 1]     | [0, 0.3] |
//!
//! Cannot: the transmission's own fall with incidence (an intensity-only radial
//! falloff: that is `vignetting`), micro-lens shifts, a chief-ray angle that is not
//! radial or not monotonic in r, or the analyzer's retardance at oblique incidence.

use super::{AnalyzerParams, Apply, EffectDef, ParamSpec, PixelAnalyzer, PixelSite, Stage};
use crate::camera::RayGeometry;
use crate::stokes::Analyzer;

/// The range a real lens and sensor's c has. Engineering bound: c = 1 is a chief ray at
/// 45° to the sensor one focal length off the axis; microlensed CMOS pixels (the IMX250MZR's
/// included) are designed for chief rays of a few tens of degrees at the corner, beyond
/// which they lose most of their light.
const C_PHYSICAL: (f64, f64) = (0.0, 1.0);
/// The range a real analyzer's e2 has. Engineering bound: e2 = 0.3 worsens ε by 0.075 at
/// a 30° chief ray (ER 100 → 12), more than wire-grid polarizers lose there.
const E2_PHYSICAL: (f64, f64) = (0.0, 0.3);

pub const EFFECT: EffectDef = EffectDef {
    name: "analyzer_incidence",
    summary:
        "analyzer axis and eps change with the chief-ray angle (tan chi = c r): axis projected, eps + e2 sin^2 chi",
    source: "projection of the polarizer axis onto an oblique ray's transverse plane (Chipman, Lam & Young 2018)",
    stage: Stage::Analyzer,
    params: &[
        ParamSpec {
            name: "c",
            unit: "1",
            neutral: 0.0,
            typical: 0.5,
            min: 0.0,
            max: 2.0,
            physical: Some(C_PHYSICAL),
            doc: "tan of the chief-ray angle per normalised image radius (f / exit-pupil distance)",
        },
        ParamSpec {
            name: "e2",
            unit: "1",
            neutral: 0.0,
            typical: 0.05,
            min: 0.0,
            max: 1.0,
            physical: Some(E2_PHYSICAL),
            doc: "increase of eps = 1/ER per sin^2 of the chief-ray angle",
        },
    ],
    apply: Apply::Analyzer { params: |v| [v[0] * v[0], v[1], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], pixel: analyzer_incidence },
    wgsl: Some(include_str!("../../../../shaders/effects/analyzer_incidence.wgsl")),
    derivatives: &[],
    inseparable: None,
};

/// The analyzer `a` seen along the pixel's oblique chief ray; p = (c², e2, 0, …).
#[inline(always)]
pub fn analyzer_incidence(p: &AnalyzerParams, _site: &PixelSite, g: &RayGeometry, a: PixelAnalyzer) -> PixelAnalyzer {
    // Chief-ray angle χ: tan²χ = c²·r², sin²χ and cos χ from it (exactly 0 and 1 at c = 0).
    let t2 = p[0] * g.r2;
    let sin2_chi = t2 / (1.0 + t2);
    let cos_chi = 1.0 / (1.0 + t2).sqrt();
    // The analyzer's doubled angle from the plane of incidence (image angle β): C, S.
    let (c2b, s2b) = (g.basis.cos2b, g.basis.sin2b);
    let an = a.analyzer;
    let c = an.cos2t * c2b + an.sin2t * s2b;
    let s = an.sin2t * c2b - an.cos2t * s2b;
    // Projected axis (cos ψ cos χ, sin ψ): its doubled angle changes by (δC, δS), with
    // D = cos²ψ·sin²χ the foreshortening; both exactly 0 at χ = 0.
    let d = 0.5 * (1.0 + c) * sin2_chi;
    let dc = -d * (1.0 - c) / (1.0 - d);
    let ds = s * (cos_chi / (1.0 - d) - 1.0);
    // Back to the image frame, added to the analyzer's own doubled angle.
    PixelAnalyzer {
        analyzer: Analyzer {
            cos2t: an.cos2t + (dc * c2b - ds * s2b),
            sin2t: an.sin2t + (dc * s2b + ds * c2b),
            eps: an.eps + p[1] * sin2_chi,
        },
        gain: a.gain,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Intrinsics, Projection};

    fn params(c: f64, e2: f64) -> AnalyzerParams {
        let Apply::Analyzer { params, .. } = EFFECT.apply else { unreachable!() };
        params(&[c, e2])
    }

    const SITE: PixelSite = PixelSite { u: 0, v: 0, ch: 0, x_px: 0.0, y_px: 0.0 };

    #[test]
    fn zero_strength_and_the_axis_are_the_identity() {
        let intr = Intrinsics::new(Projection::Equidistant, 300.0, 320.0, 240.0);
        let a = PixelAnalyzer { analyzer: Analyzer::at(45.0, 0.7, 0.01), gain: 1.2 };
        for (u, v) in [(0.0, 0.0), (320.0, 240.0), (600.0, 30.0)] {
            assert_eq!(analyzer_incidence(&params(0.0, 0.0), &SITE, &intr.geometry(u, v), a), a);
        }
        // On the optical axis the chief ray is normal: nothing changes at any strength.
        assert_eq!(analyzer_incidence(&params(1.5, 0.5), &SITE, &intr.geometry(320.0, 240.0), a), a);
    }

    #[test]
    fn the_axis_is_the_projection_onto_the_ray_and_eps_grows_with_sin2_chi() {
        // An analyzer at image angle θ, a pixel whose plane of incidence is at β: the
        // projected axis is at β + atan2(sin ψ, cos ψ cos χ), ψ = θ − β.
        let intr = Intrinsics::new(Projection::Pinhole, 300.0, 320.0, 240.0);
        let (c, e2) = (0.8, 0.1);
        for (u, v) in [(600.0, 30.0), (100.0, 400.0), (320.0, 10.0)] {
            let g = intr.geometry(u, v);
            let beta = 0.5 * g.basis.sin2b.atan2(g.basis.cos2b);
            let chi = (c * g.r2.sqrt()).atan();
            for theta_deg in [0.0, 30.0, 45.0, 100.0, 135.0] {
                let a = PixelAnalyzer { analyzer: Analyzer::at(theta_deg, 0.0, 0.01), gain: 1.0 };
                let out = analyzer_incidence(&params(c, e2), &SITE, &g, a);
                let psi = theta_deg.to_radians() - beta;
                let want = beta + psi.sin().atan2(psi.cos() * chi.cos());
                let (c2, s2) = ((2.0 * want).cos(), (2.0 * want).sin());
                assert!((out.analyzer.cos2t - c2).abs() < 1e-12 && (out.analyzer.sin2t - s2).abs() < 1e-12);
                assert!((out.analyzer.eps - (0.01 + e2 * chi.sin().powi(2))).abs() < 1e-15);
                // An axis in or across the plane of incidence does not turn.
                if (psi.sin() * psi.cos()).abs() < 1e-12 {
                    assert!((out.analyzer.cos2t - a.analyzer.cos2t).abs() < 1e-12);
                }
            }
        }
    }
}
