//! # `radial_distortion` — the lens bends rays radially (Brown's even polynomial)
//!
//! ```text
//! (x_d, y_d) = (x, y) · (1 + k1 r² + k2 r⁴),   r² = x² + y²   normalised coords (focal lengths)
//! ```
//!
//! Source: EFFECTS.md; D. C. Brown, "Decentering distortion of lenses",
//! Photogrammetric Engineering 32(3) 1966 (the radial terms). Frame: the image plane
//! in focal lengths, (x, y) the ideal coordinates the projection maps to a field
//! angle, (x_d, y_d) where the ray actually lands. A pixel is inverted to its ideal
//! coordinates by a fixed count of Newton steps (`camera::undistort`); directions
//! about the principal point are kept, so the meridional frame and every AoE about
//! the principal point are unchanged — only which field angle a radius sees. Lens
//! effects that grow with r use the ideal r. Folded on the host into the true
//! camera's intrinsics; the per-pixel inversion is part of the camera geometry on
//! both backends (`shaders/common/camera.wgsl`, `undistort`).
//!
//! | param | unit | neutral | fit bounds | physical |
//! |-------|------|---------|------------|----------|
//! | `k1`  | 1    | 0       | ±1         | ±0.5     |
//! | `k2`  | 1    | 0       | ±1         | ±0.5     |
//!
//! Where the distortion folds inside the image (1 + 3 k1 r² + 5 k2 r⁴ reaches 0 at
//! r_fold, as k1 = k2 = −1 does at r = 0.49), no ray lands beyond the fold's radius:
//! those pixels see the fold's ray (`camera::distortion_fold_r`), defined alike at f64
//! and f32 on both backends.
//!
//! Cannot: decentring or thin-prism distortion, or what a real folding lens shows
//! beyond its fold (vignetting to black, or a second image).

use super::{Apply, EffectDef, Model, ParamSpec, Stage};

/// The range a real lens's distortion has about its declared projection. Engineering
/// bound: machine-vision lenses calibrated against the right projection leave Brown
/// coefficients of a few tenths at most; beyond ±0.5 the declared projection is wrong (a
/// fisheye declared a pinhole) or the value stands in for a misfit.
const K_PHYSICAL: (f64, f64) = (-0.5, 0.5);

pub const EFFECT: EffectDef = EffectDef {
    name: "radial_distortion",
    summary: "distorted = ideal * (1 + k1 r^2 + k2 r^4), normalised coordinates",
    source: "EFFECTS.md; Brown 1966 (radial terms)",
    stage: Stage::Geometry,
    params: &[
        ParamSpec {
            name: "k1",
            unit: "1",
            neutral: 0.0,
            typical: -0.05,
            min: -1.0,
            max: 1.0,
            physical: Some(K_PHYSICAL),
            doc: "radial distortion per r²",
        },
        ParamSpec {
            name: "k2",
            unit: "1",
            neutral: 0.0,
            typical: 0.02,
            min: -1.0,
            max: 1.0,
            physical: Some(K_PHYSICAL),
            doc: "radial distortion per r⁴",
        },
    ],
    apply: Apply::Frame(apply),
    wgsl: None,
    derivatives: &[],
    inseparable: None,
};

fn apply(v: &[f64], m: &mut Model) {
    m.geometry.distortion[0] += v[0];
    m.geometry.distortion[1] += v[1];
}

#[cfg(test)]
mod tests {
    use crate::camera::{distortion_fold_r, undistort};
    use crate::chain::tests::{ideal_frame, intrinsics, stokes_at};
    use crate::effects::{EffectSet, Model};

    #[test]
    fn undistort_inverts_the_polynomial() {
        let k = [-0.2, 0.05];
        for (x, y) in [(0.3, -0.1), (0.0, 0.5), (-0.45, 0.4), (0.0, 0.0)] {
            let r2: f64 = x * x + y * y;
            let f = 1.0 + k[0] * r2 + k[1] * r2 * r2;
            let (ux, uy) = undistort(k, x * f, y * f);
            assert!((ux - x).abs() < 1e-14 && (uy - y).abs() < 1e-14, "({x}, {y}) → ({ux}, {uy})");
        }
        assert_eq!(undistort([0.0, 0.0], 0.3, 0.2), (0.3, 0.2));
    }

    #[test]
    fn beyond_the_fold_a_pixel_sees_the_folds_ray_and_the_map_stays_continuous() {
        // k1 = k2 = −1 (the range's corner): the slope 1 − 3r² − 5r⁴ vanishes at r² = (√29 − 3)/10.
        let k = [-1.0, -1.0];
        let r_fold = distortion_fold_r(k);
        assert!((r_fold * r_fold - (29f64.sqrt() - 3.0) / 10.0).abs() < 1e-15);
        let slope = |r: f64| 1.0 + 3.0 * k[0] * r * r + 5.0 * k[1] * r.powi(4);
        assert!(slope(r_fold).abs() < 1e-12);
        let rd_fold = r_fold * (1.0 + k[0] * r_fold * r_fold + k[1] * r_fold.powi(4));
        let mut last = 0.0;
        for n in 0..=400 {
            let rd = 1.5 * n as f64 / 400.0;
            let r = undistort(k, rd, 0.0).0;
            assert!(r.is_finite() && r >= last - 1e-12 && r <= r_fold * (1.0 + 1e-15), "r_d {rd}: r {r} after {last}");
            if rd < 0.9 * rd_fold {
                // Inside the fold the polynomial is inverted.
                assert!((r * (1.0 + k[0] * r * r + k[1] * r.powi(4)) - rd).abs() < 1e-12, "r_d {rd}");
            }
            if rd > rd_fold {
                // Newton halves its distance to a fold each step: within 2⁻¹² of r_fold.
                assert!(r_fold - r < 1e-4, "r_d {rd}: r {r}, fold {r_fold}");
            }
            last = r;
        }
        // No fold: monotonic distortions, and none at all.
        assert_eq!(distortion_fold_r([0.0, 0.0]), f64::MAX);
        assert_eq!(distortion_fold_r([0.2, 0.05]), f64::MAX);
        assert!((distortion_fold_r([-0.05, 0.0]) - (1.0f64 / 0.15).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn a_pixel_sees_the_ray_of_its_undistorted_position_and_the_centre_is_fixed() {
        let mut set = EffectSet::new();
        set.set("radial_distortion", "k1", -0.15).unwrap();
        set.set("radial_distortion", "k2", 0.02).unwrap();
        let (dist, ideal) = (ideal_frame(&set.model()), ideal_frame(&Model::default()));
        let i = intrinsics();
        for (u, v) in [(5.0, 7.0), (600.0, 20.0), (100.0, 500.0)] {
            let (xd, yd) = ((u - i.cx_px) / i.f_px, (v - i.cy_px) / i.f_px);
            let (x, y) = undistort([-0.15, 0.02], xd, yd);
            let (a, b) = (stokes_at(&dist, u, v), stokes_at(&ideal, i.cx_px + x * i.f_px, i.cy_px + y * i.f_px));
            assert!((a.i - b.i).abs() < 1e-12 && (a.q - b.q).abs() < 1e-12 && (a.u - b.u).abs() < 1e-12);
        }
        assert_eq!(stokes_at(&dist, i.cx_px, i.cy_px), stokes_at(&ideal, i.cx_px, i.cy_px));
        // Projecting a ray lands where the distorted camera sees it.
        let d = dist.intr.ray(40.0, 480.0);
        let (u, v) = dist.intr.project(d).unwrap();
        assert!((u - 40.0).abs() < 1e-9 && (v - 480.0).abs() < 1e-9, "({u}, {v})");
    }
}
