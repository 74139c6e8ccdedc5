//! # `polarimetric_nonuniformity` — each micro-polarizer of the die is a little different
//!
//! ```text
//! Δθ_p = σ_θ·n₁(p) + g_x·(u − c_x)/1000 + g_y·(v − c_y)/1000     analyzer angle change, degrees
//! ε_p  = max(ε_k + σ_ε·n₂(p), 0)                                 extinction (1/ER)
//! G_p  = G_k·(1 + σ_G·n₃(p))                                     polarizer transmission (gain)
//! n_i(p) = normal(DIE_KEY, u | v << 16, k, i)                    seeded hash (PCG4D), not a stream
//! ```
//!
//! Source: Powell & Gruev 2013, "Calibration methods for division-of-focal-plane
//! polarimeters", Opt. Express 21(18) 21039: a DoFP's pixels differ in analyzer
//! orientation, diattenuation (ε) and transmission, with both a white pixel-to-pixel
//! spread and a smooth trend across the die from the lithography. Units: angles in
//! degrees (gradient per 1000 px from the principal point, (u, v) pixel column and
//! row), ε and the gain spread dimensionless. Frame: image (the analyzer stage,
//! after the rotation of the ray's Stokes vector to image x), per pixel and channel:
//! an analyzer effect ([`super::Apply::Analyzer`]), run by `chain::site_signal_dn`
//! and its WGSL twin.
//!
//! The spread is a seeded integer hash of (column, row, channel) (`noise::FrameKey`
//! with the fixed [`DIE_KEY`]), bitwise the same on the CPU and the GPU: one simulated
//! die, the same in every capture, so a fit on a simulated capture can recover the
//! spreads' size. A real die's pattern is not this one: on a real sky capture the
//! white spreads are indistinguishable from noise (the fit finds them near 0) and
//! only the gradient is measured; `bpins calibrate` on a lab capture measures the real
//! per-pixel angle, ε and gain maps (`--calibration` then corrects them).
//!
//! | param              | unit | neutral | fit bounds | physical  |
//! |--------------------|------|---------|------------|-----------|
//! | `angle_sigma_deg`  | deg  | 0       | [0, 5]     | [0, 2]    |
//! | `angle_grad_x_deg` | deg  | 0       | [−10, 10]  | ±2        |
//! | `angle_grad_y_deg` | deg  | 0       | [−10, 10]  | ±2        |
//! | `eps_sigma`        | 1    | 0       | [0, 0.1]   | [0, 0.03] |
//! | `gain_sigma`       | 1    | 0       | [0, 0.2]   | [0, 0.05] |
//!
//! Physical ranges: engineering bounds (no datasheet of the IMX250MZR or the PHX050S
//! states a pixel-to-pixel spread): a spread of 2° (1σ) in angle, 0.03 in ε or 5 % in
//! transmission, or a trend of 2° per 1000 px (5° across a 2448 px die), would be a die
//! far outside what lithography draws; a fitted value beyond them stands in for a misfit.
//!
//! Cannot: spatially correlated (non-white) spread beyond the linear gradient, a
//! gradient of ε or gain, or a die pattern other than the hash's (a real die's maps
//! come from `bpins calibrate`).

use super::{AnalyzerParams, Apply, EffectDef, ParamSpec, PixelAnalyzer, PixelSite, Stage};
use crate::camera::RayGeometry;
use crate::noise::FrameKey;
use crate::stokes::Analyzer;

/// The simulated die's hash key (WGSL `DIE_KEY` in the twin; tested equal).
pub const DIE_KEY: [u32; 4] = [0x5EED_D1E5, 0x0B1A_5ED0, 0x9E37_79B9, 0x7F4A_7C15];

const fn spec(
    name: &'static str,
    unit: &'static str,
    typical: f64,
    (min, max): (f64, f64),
    physical: (f64, f64),
    doc: &'static str,
) -> ParamSpec {
    ParamSpec { name, unit, neutral: 0.0, typical, min, max, physical: Some(physical), doc }
}

pub const EFFECT: EffectDef = EffectDef {
    name: "polarimetric_nonuniformity",
    summary: "per-pixel analyzer angle, eps and gain spreads (seeded die) plus an angle gradient across the die",
    source: "Powell & Gruev 2013, Opt. Express 21(18) 21039 (DoFP pixel-to-pixel non-uniformity)",
    stage: Stage::Analyzer,
    params: &[
        spec(
            "angle_sigma_deg",
            "deg",
            0.5,
            (0.0, 5.0),
            (0.0, 2.0),
            "white spread of each pixel's analyzer angle (1 sigma)",
        ),
        spec(
            "angle_grad_x_deg",
            "deg",
            0.6,
            (-10.0, 10.0),
            (-2.0, 2.0),
            "analyzer angle change per 1000 px along image x",
        ),
        spec(
            "angle_grad_y_deg",
            "deg",
            -0.4,
            (-10.0, 10.0),
            (-2.0, 2.0),
            "analyzer angle change per 1000 px along image y (down)",
        ),
        spec("eps_sigma", "1", 0.005, (0.0, 0.1), (0.0, 0.03), "white spread of each pixel's eps = 1/ER (1 sigma)"),
        spec(
            "gain_sigma",
            "1",
            0.01,
            (0.0, 0.2),
            (0.0, 0.05),
            "white spread of each pixel's polarizer transmission (1 sigma)",
        ),
    ],
    apply: Apply::Analyzer {
        params: |v| [v[0].to_radians(), v[1].to_radians() * 1e-3, v[2].to_radians() * 1e-3, v[3], v[4], 0.0, 0.0, 0.0],
        pixel: polarimetric_nonuniformity,
    },
    wgsl: Some(include_str!("../../../../shaders/effects/polarimetric_nonuniformity.wgsl")),
    derivatives: &[],
    inseparable: None,
};

/// The pixel `site`'s analyzer `a` on the simulated die; p = (σ_θ rad, g_x rad/px,
/// g_y rad/px, σ_ε, σ_G, 0, 0, 0).
#[inline(always)]
pub fn polarimetric_nonuniformity(
    p: &AnalyzerParams,
    site: &PixelSite,
    _g: &RayGeometry,
    a: PixelAnalyzer,
) -> PixelAnalyzer {
    // Seeded standard normals of this pixel and channel (the same hash on the GPU).
    let key = FrameKey(DIE_KEY);
    let id = site.u | (site.v << 16);
    let (n1, n2, n3) = (key.normal(id, site.ch, 0), key.normal(id, site.ch, 1), key.normal(id, site.ch, 2));
    // Angle change: white spread plus the die's gradient from the principal point, radians.
    let dtheta = p[0] * n1 + p[1] * site.x_px + p[2] * site.y_px;
    // Turn the analyzer by Δθ (its doubled angle by 2Δθ): exact at Δθ = 0.
    let (s2, c2) = (2.0 * dtheta).sin_cos();
    let an = a.analyzer;
    PixelAnalyzer {
        analyzer: Analyzer {
            cos2t: an.cos2t * c2 - an.sin2t * s2,
            sin2t: an.sin2t * c2 + an.cos2t * s2,
            eps: (an.eps + p[3] * n2).max(0.0),
        },
        gain: a.gain * (1.0 + p[4] * n3),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::ray_at_r2;
    use crate::stokes::{analyzer_intensity, Stokes};

    fn site(u: u32, v: u32, ch: u32) -> PixelSite {
        PixelSite { u, v, ch, x_px: u as f64 - 100.0, y_px: v as f64 - 80.0 }
    }

    fn params(v: [f64; 5]) -> AnalyzerParams {
        let Apply::Analyzer { params, .. } = EFFECT.apply else { unreachable!() };
        params(&v)
    }

    const A: PixelAnalyzer = PixelAnalyzer { analyzer: Analyzer { cos2t: 0.0, sin2t: 1.0, eps: 0.01 }, gain: 1.1 };

    #[test]
    fn zero_strength_is_the_identity() {
        let g = ray_at_r2(0.1);
        for (u, v, ch) in [(0, 0, 0), (17, 300, 3), (1023, 5, 1)] {
            assert_eq!(polarimetric_nonuniformity(&params([0.0; 5]), &site(u, v, ch), &g, A), A);
        }
    }

    #[test]
    fn the_gradient_turns_the_analyzer_by_its_malus_angle() {
        // A pure gradient of 2° per 1000 px: 500 px right of the principal point the
        // analyzer sits at 45° + 1°, so fully polarized light at 45° + 1° passes all.
        let p = params([0.0, 2.0, 0.0, 0.0, 0.0]);
        let s = site(600, 80, 1);
        let out = polarimetric_nonuniformity(&p, &s, &ray_at_r2(0.0), A);
        let a = 46f64.to_radians() * 2.0;
        let light = Stokes::new(1.0, a.cos(), a.sin(), 0.0);
        let no_eps = Analyzer { eps: 0.0, ..out.analyzer };
        assert!((analyzer_intensity(light, &no_eps) - 1.0).abs() < 1e-12);
        // Malus: crossed light (at 46° + 90°) is blocked.
        let crossed = Stokes::new(1.0, -a.cos(), -a.sin(), 0.0);
        assert!(analyzer_intensity(crossed, &no_eps).abs() < 1e-12);
        // The principal point's row and column are unchanged in the other direction.
        assert_eq!(out.analyzer.eps, A.analyzer.eps);
        assert_eq!(out.gain, A.gain);
    }

    #[test]
    fn the_spreads_have_their_sigma_and_are_fixed_per_pixel() {
        let p = params([0.5, 0.0, 0.0, 0.005, 0.01]);
        let g = ray_at_r2(0.0);
        let (mut sa, mut se, mut sg, n) = (0.0, 0.0, 0.0, 20_000);
        for i in 0..n {
            let s = site(i % 200, i / 200, 2);
            let a0 = PixelAnalyzer { analyzer: Analyzer { cos2t: 1.0, sin2t: 0.0, eps: 0.05 }, gain: 1.0 };
            let out = polarimetric_nonuniformity(&p, &s, &g, a0);
            // The same pixel gives the same analyzer every time (a die, not noise).
            assert_eq!(out, polarimetric_nonuniformity(&p, &s, &g, a0));
            let dtheta_deg = 0.5 * out.analyzer.sin2t.atan2(out.analyzer.cos2t).to_degrees();
            sa += dtheta_deg * dtheta_deg;
            se += (out.analyzer.eps - 0.05).powi(2);
            sg += (out.gain - 1.0).powi(2);
        }
        let rms = |x: f64| (x / n as f64).sqrt();
        assert!((rms(sa) / 0.5 - 1.0).abs() < 0.03, "angle {}", rms(sa));
        assert!((rms(se) / 0.005 - 1.0).abs() < 0.03, "eps {}", rms(se));
        assert!((rms(sg) / 0.01 - 1.0).abs() < 0.03, "gain {}", rms(sg));
    }

    #[test]
    fn the_wgsl_twin_uses_the_same_die_key() {
        let src = EFFECT.wgsl.unwrap();
        let want = format!(
            "const DIE_KEY: vec4<u32> = vec4<u32>({:#010x}u, {:#010x}u, {:#010x}u, {:#010x}u);",
            DIE_KEY[0], DIE_KEY[1], DIE_KEY[2], DIE_KEY[3]
        );
        assert!(src.contains(&want), "{want}");
    }
}
