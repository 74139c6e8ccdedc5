//! Camera geometry: pixel ↔ ray for pinhole and fisheye projections, and the
//! meridional (p, s) basis of each ray.
//!
//! Source: CONVENTIONS.md "Pixels and projection". Frame: camera (x columns, y rows
//! down, z optical axis). Units: pixels for image coordinates, the focal length in
//! pixels `f_px = f / pitch`; normalised coordinates are in focal lengths.
//!
//! * Pinhole: `x_n = (u − c_x)/f_px`, `y_n = (v − c_y)/f_px`, ray ∝ `(x_n, y_n, 1)`.
//! * Fisheye: the field angle θ maps to `r = f_px·g(θ)`: equidistant `g = θ`,
//!   equisolid `2 sin(θ/2)`, stereographic `2 tan(θ/2)`; pinhole is `tan θ`.
//!
//! Cannot: model decentred lenses or thin-prism distortion; rays beyond the
//! projection's domain (θ ≥ 90° for pinhole, ≥ 180° for the fisheyes) are `None`.

use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Lens projection `r = f_px·g(θ)` (CONVENTIONS.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Projection {
    Pinhole,
    Equidistant,
    Equisolid,
    Stereographic,
}

impl Projection {
    pub const ALL: [Projection; 4] =
        [Projection::Pinhole, Projection::Equidistant, Projection::Equisolid, Projection::Stereographic];

    pub fn name(self) -> &'static str {
        match self {
            Projection::Pinhole => "pinhole",
            Projection::Equidistant => "equidistant",
            Projection::Equisolid => "equisolid",
            Projection::Stereographic => "stereographic",
        }
    }

    /// `g(θ)`: normalised image radius (focal lengths) of field angle `theta_rad`.
    pub fn radius_from_angle(self, theta_rad: f64) -> f64 {
        match self {
            Projection::Pinhole => theta_rad.tan(),
            Projection::Equidistant => theta_rad,
            Projection::Equisolid => 2.0 * (0.5 * theta_rad).sin(),
            Projection::Stereographic => 2.0 * (0.5 * theta_rad).tan(),
        }
    }

    /// `g⁻¹(r)`: field angle (radians) of normalised radius `r`; `None` outside the domain.
    pub fn angle_from_radius(self, r: f64) -> Option<f64> {
        let t = match self {
            Projection::Pinhole => r.atan(),
            Projection::Equidistant => r,
            Projection::Equisolid => {
                if r > 2.0 {
                    return None;
                }
                2.0 * (0.5 * r).asin()
            }
            Projection::Stereographic => 2.0 * (0.5 * r).atan(),
        };
        (t < std::f64::consts::PI).then_some(t)
    }
}

/// Intrinsics of one camera: projection, focal length and principal point in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    pub projection: Projection,
    /// Focal length in pixels, `f / pitch`.
    pub f_px: f64,
    /// Principal point (x, y) in pixels, pixel centres at integers.
    pub cx_px: f64,
    pub cy_px: f64,
    /// Radial distortion (k1, k2) of the normalised image coordinates:
    /// distorted = ideal·(1 + k1 r² + k2 r⁴), r the ideal radius (`radial_distortion`).
    pub distortion: [f64; 2],
}

impl Intrinsics {
    /// Ideal (distortion-free) camera: projection, focal length and principal point.
    pub fn new(projection: Projection, f_px: f64, cx_px: f64, cy_px: f64) -> Self {
        Intrinsics { projection, f_px, cx_px, cy_px, distortion: [0.0; 2] }
    }

    /// Normalised image coordinates (focal lengths) of pixel `(u, v)`, the lens's
    /// radial distortion removed (what the projection maps to a field angle).
    #[inline]
    pub fn normalised(&self, u_px: f64, v_px: f64) -> (f64, f64) {
        let (x, y) = self.normalised_distorted(u_px, v_px);
        if self.distortion == [0.0; 2] {
            (x, y)
        } else {
            undistort(self.distortion, x, y)
        }
    }

    /// Normalised coordinates of pixel `(u, v)` as imaged (distortion not removed).
    #[inline(always)]
    fn normalised_distorted(&self, u_px: f64, v_px: f64) -> (f64, f64) {
        ((u_px - self.cx_px) / self.f_px, (v_px - self.cy_px) / self.f_px)
    }

    /// Unit ray (camera frame) seen by the point at normalised coordinates `(x_n, y_n)`.
    #[inline]
    pub fn ray_from_normalised(&self, x_n: f64, y_n: f64) -> DVec3 {
        match self.projection {
            Projection::Pinhole => DVec3::new(x_n, y_n, 1.0).normalize(),
            p => {
                let r = (x_n * x_n + y_n * y_n).sqrt();
                if r == 0.0 {
                    return DVec3::Z;
                }
                // Beyond the domain the ray is clamped to the rim; callers mask by
                // `in_domain` where it matters.
                let theta = p.angle_from_radius(r).unwrap_or(std::f64::consts::PI);
                let (st, ct) = theta.sin_cos();
                DVec3::new(st * x_n / r, st * y_n / r, ct)
            }
        }
    }

    /// Unit ray (camera frame) seen by pixel `(u, v)`.
    #[inline]
    pub fn ray(&self, u_px: f64, v_px: f64) -> DVec3 {
        let (x_n, y_n) = self.normalised(u_px, v_px);
        self.ray_from_normalised(x_n, y_n)
    }

    /// Ray, meridional basis and normalised radius of pixel `(u, v)` in one go.
    ///
    /// Computed from the radial direction `(cos a, sin a)` and the field angle θ
    /// rather than from the normalised ray, which keeps the two square roots
    /// independent (the per-pixel hot path): `d = (sin θ cos a, sin θ sin a, cos θ)`,
    /// `p = (cos θ cos a, cos θ sin a, −sin θ)`, `s = (−sin a, cos a, 0)`.
    #[inline(always)]
    pub fn geometry(&self, u_px: f64, v_px: f64) -> RayGeometry {
        let (x_n, y_n) = self.normalised(u_px, v_px);
        let r2 = x_n * x_n + y_n * y_n;
        // Branch-free (so row loops vectorize): on the axis the radial direction
        // defaults to image +x (β = 0) and θ = 0.
        let on_axis = r2 == 0.0;
        let inv_r = if on_axis { 0.0 } else { 1.0 / r2.sqrt() };
        let (ca, sa) = if on_axis { (1.0, 0.0) } else { (x_n * inv_r, y_n * inv_r) };
        let (st, ct) = match self.projection {
            Projection::Pinhole => {
                // tan θ = r: cos θ = 1/√(1 + r²), sin θ = r cos θ.
                let ct = 1.0 / (1.0 + r2).sqrt();
                (r2 * inv_r * ct, ct)
            }
            p => p.angle_from_radius(r2 * inv_r).unwrap_or(std::f64::consts::PI).sin_cos(),
        };
        ray_geometry(ca, sa, st, ct, r2)
    }

    /// Row kernel: `out[i] = f(i, &geometry(x0_px + step_px·i, y_px))` for a row of
    /// samples. The projection is dispatched once per row, so with `f` inlined and
    /// branch-free the pinhole loop has no branch and the compiler vectorizes it
    /// (the ray never goes to memory: keep `T` small, a few f64).
    #[inline(always)]
    pub fn map_row<T>(
        &self,
        y_px: f64,
        x0_px: f64,
        step_px: f64,
        out: &mut [T],
        mut f: impl FnMut(usize, &RayGeometry) -> T,
    ) {
        match self.projection {
            Projection::Pinhole if self.distortion == [0.0; 2] => {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = f(i, &self.geometry_pinhole(x0_px + step_px * i as f64, y_px));
                }
            }
            _ => {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = f(i, &self.geometry(x0_px + step_px * i as f64, y_px));
                }
            }
        }
    }

    /// Row kernel driver: calls `f(i, &geometry(x0_px + step_px·i, y_px))` for `i < n`,
    /// the projection dispatched once per row (as [`Self::map_row`], for kernels that
    /// write several outputs per sample).
    #[inline(always)]
    pub(crate) fn for_row(
        &self,
        y_px: f64,
        x0_px: f64,
        step_px: f64,
        n: usize,
        mut f: impl FnMut(usize, &RayGeometry),
    ) {
        match self.projection {
            Projection::Pinhole if self.distortion == [0.0; 2] => {
                for i in 0..n {
                    f(i, &self.geometry_pinhole(x0_px + step_px * i as f64, y_px));
                }
            }
            _ => {
                for i in 0..n {
                    f(i, &self.geometry(x0_px + step_px * i as f64, y_px));
                }
            }
        }
    }

    /// [`Self::geometry`] for a pinhole camera without distortion (no dispatch).
    #[inline(always)]
    fn geometry_pinhole(&self, u_px: f64, v_px: f64) -> RayGeometry {
        let (x_n, y_n) = self.normalised_distorted(u_px, v_px);
        let r2 = x_n * x_n + y_n * y_n;
        let on_axis = r2 == 0.0;
        let inv_r = if on_axis { 0.0 } else { 1.0 / r2.sqrt() };
        let (ca, sa) = if on_axis { (1.0, 0.0) } else { (x_n * inv_r, y_n * inv_r) };
        let ct = 1.0 / (1.0 + r2).sqrt();
        ray_geometry(ca, sa, r2 * inv_r * ct, ct, r2)
    }

    /// Pixel `(u, v)` where the camera-frame direction `d` images; `None` when the
    /// projection cannot image it.
    pub fn project(&self, d: DVec3) -> Option<(f64, f64)> {
        let d = d.normalize();
        let rho = (d.x * d.x + d.y * d.y).sqrt();
        let theta = rho.atan2(d.z);
        if self.projection == Projection::Pinhole && d.z <= 0.0 {
            return None;
        }
        if rho == 0.0 {
            return Some((self.cx_px, self.cy_px));
        }
        let r = self.projection.radius_from_angle(theta);
        // Radial distortion of the ideal normalised radius.
        let [k1, k2] = self.distortion;
        let r = r * (1.0 + k1 * r * r + k2 * r * r * r * r);
        Some((self.cx_px + self.f_px * r * d.x / rho, self.cy_px + self.f_px * r * d.y / rho))
    }
}

/// Ideal normalised coordinates of the distorted ones `(x_d, y_d)`: the radius r with
/// r·(1 + k1 r² + k2 r⁴) = r_d by twelve Newton steps from r = r_d (a fixed count, so
/// the WGSL twin takes the same steps), the direction unchanged.
///
/// Where the distortion folds (its slope 1 + 3 k1 r² + 5 k2 r⁴ reaches 0 at r_fold,
/// [`distortion_fold_r`]), no ray lands beyond the fold's distorted radius: such a
/// pixel sees the fold's ray (r = r_fold), and every Newton step is kept in
/// [0, r_fold], so the map is defined, continuous and the same at any float precision
/// everywhere instead of wandering where the polynomial has no inverse.
#[inline(always)]
pub fn undistort(k: [f64; 2], x_d: f64, y_d: f64) -> (f64, f64) {
    let rd = (x_d * x_d + y_d * y_d).sqrt();
    let r_fold = distortion_fold_r(k);
    let mut r = rd.min(r_fold);
    for _ in 0..12 {
        let r2 = r * r;
        let slope = 1.0 + 3.0 * k[0] * r2 + 5.0 * k[1] * r2 * r2;
        // At the fold (slope 0) the step is undefined: r stays.
        let next = (r - (r * (1.0 + k[0] * r2 + k[1] * r2 * r2) - rd) / slope).clamp(0.0, r_fold);
        r = if slope > 0.0 { next } else { r };
    }
    let scale = if rd > 0.0 { r / rd } else { 1.0 };
    (x_d * scale, y_d * scale)
}

/// The smallest normalised radius r > 0 where the distortion's slope
/// 1 + 3 k1 r² + 5 k2 r⁴ vanishes (its fold), or `f64::MAX` where it never does. With
/// s = r²: 5 k2 s² + 3 k1 s + 1 = 0, whose roots are 2 / (−3 k1 ∓ √(9 k1² − 20 k2))
/// (the form that holds at k2 = 0 too).
#[inline(always)]
pub fn distortion_fold_r(k: [f64; 2]) -> f64 {
    let b = 3.0 * k[0];
    let disc = b * b - 20.0 * k[1];
    let sq = disc.max(0.0).sqrt();
    // A root s = 2/d is positive where d > 0; the smaller s is the larger d, −b + √.
    let d = if disc < 0.0 { 0.0 } else { -b + sq };
    if d > 0.0 {
        (2.0 / d).sqrt()
    } else {
        f64::MAX
    }
}

/// A pixel's unit ray `d` (camera frame), its meridional basis and its squared
/// normalised radius `r2` (focal lengths²), from [`Intrinsics::geometry`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayGeometry {
    pub d: DVec3,
    pub basis: MeridionalBasis,
    pub r2: f64,
}

/// Ray and basis from the radial direction (cos a, sin a) and field angle (sin θ, cos θ).
#[inline(always)]
fn ray_geometry(ca: f64, sa: f64, st: f64, ct: f64, r2: f64) -> RayGeometry {
    RayGeometry {
        d: DVec3::new(st * ca, st * sa, ct),
        basis: MeridionalBasis {
            p: DVec3::new(ct * ca, ct * sa, -st),
            s: DVec3::new(-sa, ca, 0.0),
            cos2b: ca * ca - sa * sa,
            sin2b: -2.0 * ca * sa,
        },
        r2,
    }
}

/// The meridional basis of a unit camera-frame ray `d`, and the doubled radial
/// angle 2β of its image point.
///
/// `p` (meridional) lies in the plane of the optical axis and the ray, pointing away
/// from the axis; `s = d × p` (sagittal). In the image an ideal lens maps `p` onto the
/// radial direction from the principal point and `s` onto the tangential one, so a
/// field `e_p·p + e_s·s` has AoE `atan2(−e_s, e_p)` (CONVENTIONS.md, AoE).
/// On the axis (β undefined) the basis is the camera's x, y and β = 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeridionalBasis {
    pub p: DVec3,
    pub s: DVec3,
    /// cos 2β and sin 2β, β = image angle of the radial direction.
    pub cos2b: f64,
    pub sin2b: f64,
}

#[inline]
pub fn meridional_basis(d: DVec3) -> MeridionalBasis {
    let rho2 = d.x * d.x + d.y * d.y;
    if rho2 == 0.0 {
        return MeridionalBasis { p: DVec3::X, s: DVec3::Y, cos2b: 1.0, sin2b: 0.0 };
    }
    let inv_rho = 1.0 / rho2.sqrt();
    let rho = rho2 * inv_rho;
    let (ca, sa) = (d.x * inv_rho, d.y * inv_rho); // radial direction in pixel axes (y down)
    MeridionalBasis {
        p: DVec3::new(d.z * ca, d.z * sa, -rho),
        s: DVec3::new(-sa, ca, 0.0),
        // β = atan2(−sa, ca): cos 2β = ca² − sa², sin 2β = −2·ca·sa.
        cos2b: ca * ca - sa * sa,
        sin2b: -2.0 * ca * sa,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn intr(p: Projection) -> Intrinsics {
        Intrinsics { projection: p, f_px: 580.0, cx_px: 305.5, cy_px: 255.5, distortion: [0.0; 2] }
    }

    #[test]
    fn project_inverts_ray_for_every_projection() {
        for p in Projection::ALL {
            let c = intr(p);
            for (u, v) in [(0.0, 0.0), (611.0, 511.0), (305.5, 255.5), (100.0, 400.0)] {
                let (u2, v2) = c.project(c.ray(u, v)).unwrap();
                assert!((u2 - u).abs() < 1e-9 && (v2 - v).abs() < 1e-9, "{p:?}");
            }
        }
    }

    #[test]
    fn pinhole_ray_matches_the_convention_formula() {
        let c = intr(Projection::Pinhole);
        let d = c.ray(405.5, 155.5);
        let want = DVec3::new(100.0 / 580.0, -100.0 / 580.0, 1.0).normalize();
        assert!((d - want).length() < 1e-15);
    }

    #[test]
    fn fisheye_radius_follows_g_of_theta() {
        let th = 0.7;
        assert!((Projection::Equidistant.radius_from_angle(th) - th).abs() < 1e-15);
        assert!((Projection::Equisolid.radius_from_angle(th) - 2.0 * (th / 2.0).sin()).abs() < 1e-15);
        assert!((Projection::Stereographic.radius_from_angle(th) - 2.0 * (th / 2.0).tan()).abs() < 1e-15);
        for p in Projection::ALL {
            let r = p.radius_from_angle(th);
            assert!((p.angle_from_radius(r).unwrap() - th).abs() < 1e-12);
        }
    }

    #[test]
    fn geometry_agrees_with_ray_and_basis_for_every_projection() {
        for p in Projection::ALL {
            let c = intr(p);
            for (u, v) in [(0.0, 0.0), (500.0, 30.0), (306.0, 255.5), (305.5, 255.5)] {
                let g = c.geometry(u, v);
                let d = c.ray(u, v);
                let b = meridional_basis(d);
                assert!((g.d - d).length() < 1e-12, "{p:?}");
                assert!((g.basis.p - b.p).length() < 1e-12 && (g.basis.s - b.s).length() < 1e-12, "{p:?}");
                assert!((g.basis.cos2b - b.cos2b).abs() < 1e-12 && (g.basis.sin2b - b.sin2b).abs() < 1e-12);
                let (x, y) = c.normalised(u, v);
                assert_eq!(g.r2, x * x + y * y);
            }
        }
    }

    #[test]
    fn row_geometry_is_bitwise_the_per_pixel_geometry() {
        for p in Projection::ALL {
            let c = intr(p);
            let mut out = vec![c.geometry(0.0, 0.0); 40];
            c.map_row(255.5, 290.5, 0.5, &mut out, |_, g| *g);
            for (i, g) in out.iter().enumerate() {
                assert_eq!(*g, c.geometry(290.5 + 0.5 * i as f64, 255.5), "{p:?} {i}");
            }
        }
    }

    #[test]
    fn meridional_basis_is_orthonormal_and_right_handed() {
        let c = intr(Projection::Equisolid);
        for (u, v) in [(0.0, 0.0), (500.0, 30.0), (306.0, 255.5)] {
            let d = c.ray(u, v);
            let b = meridional_basis(d);
            assert!((b.p.length() - 1.0).abs() < 1e-12);
            assert!((b.s.length() - 1.0).abs() < 1e-12);
            assert!(b.p.dot(d).abs() < 1e-12 && b.s.dot(d).abs() < 1e-12 && b.p.dot(b.s).abs() < 1e-12);
            assert!((d.cross(b.p) - b.s).length() < 1e-12);
            // 2β agrees with the radial angle of the pixel about the principal point.
            let beta = crate::conventions::image_angle_rad(u - c.cx_px, v - c.cy_px);
            assert!(((2.0 * beta).cos() - b.cos2b).abs() < 1e-12);
            assert!(((2.0 * beta).sin() - b.sin2b).abs() < 1e-12);
        }
    }
}
