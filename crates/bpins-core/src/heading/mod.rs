//! Heading extraction: from reconstructed Stokes samples to the camera's heading.
//!
//! Every sample is reduced to a few sums ([`HeadingSums`], one pass, no image kept),
//! and each extractor solves from the sums — the same reduction runs on the GPU.
//! Per sample, with the camera as the user believes it ([`HeadingContext`]):
//!
//! ```text
//! ray d, basis (p, s), 2β  ← assumed intrinsics at the sample's pixel position
//! (I, Q_p, U_p)            ← image → meridional frame; lens ρ inverted if known (eq. 13)
//! AoE φ = ½ atan2(U_p, Q_p),  P = √(Q_p² + U_p²)           (seed eq. 5–6: φ = α − β)
//! E-vector e = cos φ·p − sin φ·s                             camera frame
//! ```
//!
//! Extractors (the seed does not state its own; PAPER.md):
//! * [`Extractor::SunVector`] — least-squares sun vector: the sun is ⊥ every E-vector,
//!   so it is the eigenvector of least eigenvalue of `Σ w e eᵀ`, w = P².
//! * [`Extractor::MeridianLine`] — the solar meridian read off the AoE image as a
//!   half-line from the assumed principal point toward the sun, where AoE = ±90°
//!   (seed §3).
//!
//! Both report a 1σ from the scatter of their own residuals: a statistical
//! uncertainty that assumes independent samples; systematic errors (a wrong
//! principal point, a tilt) are not in it.

mod eigen;
pub mod field;
pub mod meridian;
pub mod sun_vector;

use crate::camera::{Intrinsics, RayGeometry};
use crate::effects::lens_diattenuation::lens_diattenuation_inverse;
use crate::error::{Error, Result};
use crate::recon::PolImage;
use crate::stokes::{image_to_meridional, Stokes};
use rayon::prelude::*;
use std::ops::AddAssign;

/// The heading extractors bpins offers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Extractor {
    SunVector,
    MeridianLine,
}

impl Extractor {
    pub const ALL: [Extractor; 2] = [Extractor::SunVector, Extractor::MeridianLine];

    pub fn name(self) -> &'static str {
        match self {
            Extractor::SunVector => "sun_vector",
            Extractor::MeridianLine => "meridian_line",
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            Extractor::SunVector => "least-squares sun vector over all E-vectors (weights P²)",
            Extractor::MeridianLine => {
                "solar meridian line through the assumed principal point, read off the AoE image"
            }
        }
    }

    pub fn from_name(name: &str) -> Option<Extractor> {
        Extractor::ALL.into_iter().find(|e| e.name() == name)
    }
}

/// What the extractor knows: the camera as believed, the sun and the tilt.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadingContext {
    /// Assumed intrinsics (nominal principal point unless calibrated).
    pub intr: Intrinsics,
    /// Known lens diattenuation `rho2`, inverted per sample (0: not compensated).
    pub lens_rho2: f64,
    pub sun_az_deg: f64,
    pub sun_el_deg: f64,
    /// Known tilt of the frame (its reference), degrees, about camera x then y.
    pub tilt_x_deg: f64,
    pub tilt_y_deg: f64,
    /// Known tilt of the camera on its mount (`mount_tilt`), degrees; composes after
    /// the frame's tilt as rotations (CONVENTIONS.md, Tilt).
    pub mount_tilt_deg: [f64; 2],
    /// Half-width of the AoE band around ±90° that the meridian line uses, degrees.
    pub band_deg: f64,
    /// The line fit uses samples between these radii from the principal point, pixels:
    /// β is undefined at the principal point, and a disc inside the image keeps the
    /// band mirror-symmetric about any line through the principal point (no bias from
    /// the frame's corners).
    pub r_min_px: f64,
    pub r_max_px: f64,
}

impl HeadingContext {
    /// A level camera with assumed intrinsics `intr`, an image of `width_px × height_px`
    /// pixels, under the sun at (az, el).
    pub fn new(intr: Intrinsics, width_px: usize, height_px: usize, sun_az_deg: f64, sun_el_deg: f64) -> Self {
        let r_max_px =
            intr.cx_px.min(intr.cy_px).min(width_px as f64 - 1.0 - intr.cx_px).min(height_px as f64 - 1.0 - intr.cy_px);
        HeadingContext {
            intr,
            lens_rho2: 0.0,
            sun_az_deg,
            sun_el_deg,
            tilt_x_deg: 0.0,
            tilt_y_deg: 0.0,
            mount_tilt_deg: [0.0; 2],
            band_deg: 5.0,
            r_min_px: 0.02 * intr.f_px,
            r_max_px: r_max_px.max(0.0),
        }
    }
}

impl HeadingContext {
    /// `Rx(tilt_x)·Ry(tilt_y)·Rx(mount_x)·Ry(mount_y)`: camera → level-camera coordinates.
    pub fn level_from_camera(&self) -> glam::DMat3 {
        crate::conventions::level_from_camera(self.tilt_x_deg, self.tilt_y_deg)
            * crate::conventions::level_from_camera(self.mount_tilt_deg[0], self.mount_tilt_deg[1])
    }
}

/// One extractor's answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadingEstimate {
    /// Heading ψ in [0°, 360°).
    pub heading_deg: f64,
    /// 1σ statistical uncertainty, degrees.
    pub sigma_deg: f64,
    /// Samples the extractor used.
    pub samples: usize,
}

/// Angular sectors (by β about the principal point) the band sums are kept in, so
/// the meridian line can use the sun's half only, chosen at solve time.
pub const SECTORS: usize = 16;

/// The sums both extractors solve from; additive over samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadingSums {
    /// Σ w e eᵀ (camera frame): xx, xy, xz, yy, yz, zz.
    pub scatter: [f64; 6],
    /// Number of samples in the scatter.
    pub n: f64,
    /// Meridian band per sector: Σ s², Σ s c, Σ c², Σ ψ s, Σ ψ c, Σ ψ², count;
    /// s = sin 2β, c = cos 2β, ψ = AoE − 90° in radians.
    pub line: [[f64; 7]; SECTORS],
}

impl Default for HeadingSums {
    fn default() -> Self {
        HeadingSums { scatter: [0.0; 6], n: 0.0, line: [[0.0; 7]; SECTORS] }
    }
}

impl AddAssign for HeadingSums {
    fn add_assign(&mut self, o: Self) {
        for k in 0..6 {
            self.scatter[k] += o.scatter[k];
        }
        self.n += o.n;
        for (a, b) in self.line.iter_mut().zip(&o.line) {
            for k in 0..7 {
                a[k] += b[k];
            }
        }
    }
}

impl HeadingSums {
    /// Adds one sample: image-frame Stokes `s` at pixel position `(x_px, y_px)`.
    #[inline(always)]
    pub fn accumulate(&mut self, ctx: &HeadingContext, cos_2band: f64, x_px: f64, y_px: f64, s: Stokes) {
        // Assumed ray and meridional basis at the sample.
        let g = ctx.intr.geometry(x_px, y_px);
        self.add(ctx, cos_2band, x_px, y_px, &contribution(ctx, &g, s));
    }

    /// Adds a whole row of samples at `y_px`, sample `i` at `x0_px + step_px·i`
    /// (NaN Stokes are skipped); bitwise a loop of [`Self::accumulate`]. The
    /// per-sample work runs as one branch-free loop that the compiler vectorizes,
    /// into columns (structure of arrays); then the sums are added in sample order.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn accumulate_row(
        &mut self,
        ctx: &HeadingContext,
        cos_2band: f64,
        y_px: f64,
        x0_px: f64,
        step_px: f64,
        stokes: &[Stokes],
        scratch: &mut RowScratch,
    ) {
        // One loop per case of the known lens (a constant ρ₂ = 0 drops its inversion
        // from the loop rather than computing and discarding it per sample).
        if ctx.lens_rho2 != 0.0 {
            self.accumulate_row_in(ctx, cos_2band, y_px, x0_px, step_px, stokes, scratch);
        } else {
            let ctx = HeadingContext { lens_rho2: 0.0, ..*ctx };
            self.accumulate_row_in(&ctx, cos_2band, y_px, x0_px, step_px, stokes, scratch);
        }
    }

    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn accumulate_row_in(
        &mut self,
        ctx: &HeadingContext,
        cos_2band: f64,
        y_px: f64,
        x0_px: f64,
        step_px: f64,
        stokes: &[Stokes],
        scratch: &mut RowScratch,
    ) {
        let n = stokes.len();
        if n == 0 {
            return;
        }
        scratch.cols.resize(COLS * n, 0.0);
        let mut it = scratch.cols.chunks_exact_mut(n);
        let cols: [&mut [f64]; COLS] = std::array::from_fn(|_| &mut it.next().expect("COLS columns")[..n]);
        let [m0, m1, m2, m3, m4, m5, valid, band, qp, up, c2b, s2b] = cols;
        let stokes = &stokes[..n];
        let (r_min2, r_max2) = (ctx.r_min_px * ctx.r_min_px, ctx.r_max_px * ctx.r_max_px);
        // Per sample (vectorized): contribution along the assumed ray, and whether the
        // sample falls in the meridian band (as `add` decides it).
        ctx.intr.for_row(
            y_px,
            x0_px,
            step_px,
            n,
            #[inline(always)]
            |i, g| {
                let c = contribution(ctx, g, stokes[i]);
                [m0[i], m1[i], m2[i], m3[i], m4[i], m5[i]] = c.m;
                valid[i] = c.n;
                let (dx, dy) = (x0_px + step_px * i as f64 - ctx.intr.cx_px, y_px - ctx.intr.cy_px);
                let r2_px = dx * dx + dy * dy;
                // `!(a < b)` as in `add` (not `a >= b`: the same for NaN).
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                let in_band = c.n != 0.0 && !(-c.qp < cos_2band * c.pol) && r2_px >= r_min2 && r2_px <= r_max2;
                band[i] = if in_band { 1.0 } else { 0.0 };
                (qp[i], up[i], c2b[i], s2b[i]) = (c.qp, c.up, c.cos2b, c.sin2b);
            },
        );
        // The scatter, in sample order.
        for i in 0..n {
            for (acc, m) in self.scatter.iter_mut().zip([&m0, &m1, &m2, &m3, &m4, &m5]) {
                *acc += m[i];
            }
            self.n += valid[i];
        }
        // The meridian band (few samples), in sample order.
        for i in (0..n).filter(|&i| band[i] != 0.0) {
            let (dx, dy) = (x0_px + step_px * i as f64 - ctx.intr.cx_px, y_px - ctx.intr.cy_px);
            self.add_band(dx, dy, qp[i], up[i], c2b[i], s2b[i]);
        }
    }

    /// Adds one sample's contribution: the scatter, and the meridian band where
    /// ψ = AoE − 90° lies within the band (cos 2ψ = −cos 2φ = −Q_p/P).
    #[inline(always)]
    fn add(&mut self, ctx: &HeadingContext, cos_2band: f64, x_px: f64, y_px: f64, c: &Contribution) {
        for k in 0..6 {
            self.scatter[k] += c.m[k];
        }
        self.n += c.n;
        if c.n == 0.0 || -c.qp < cos_2band * c.pol {
            return;
        }
        let (dx, dy) = (x_px - ctx.intr.cx_px, y_px - ctx.intr.cy_px);
        let r2_px = dx * dx + dy * dy;
        if r2_px >= ctx.r_min_px * ctx.r_min_px && r2_px <= ctx.r_max_px * ctx.r_max_px {
            self.add_band(dx, dy, c.qp, c.up, c.cos2b, c.sin2b);
        }
    }

    /// Adds a band sample at `(dx, dy)` px from the principal point to its sector's
    /// line sums: ψ = AoE − 90° = ½ atan2(−U_p, −Q_p), regressed on (sin 2β, cos 2β).
    #[inline(always)]
    fn add_band(&mut self, dx: f64, dy: f64, qp: f64, up: f64, cos2b: f64, sin2b: f64) {
        let psi = 0.5 * (-up).atan2(-qp);
        // Weight 1: ×1.0 is exact, so these sums are bitwise the unweighted ones.
        self.add_band_weighted(crate::conventions::image_angle_rad(dx, dy), psi, cos2b, sin2b, 1.0);
    }

    /// Adds `w·e eᵀ` to the scatter (one weighted sample; `e` a unit E-vector).
    pub(crate) fn add_scatter_weighted(&mut self, e: glam::DVec3, w: f64) {
        let e = [e.x, e.y, e.z];
        for (acc, (i, j)) in self.scatter.iter_mut().zip([(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]) {
            *acc += w * e[i] * e[j];
        }
        self.n += 1.0;
    }

    /// Adds a weighted band sample to the line sums of the sector of image angle
    /// `beta_rad`: ψ = AoE − 90° (radians), regressed on (sin 2β, cos 2β).
    pub(crate) fn add_band_weighted(&mut self, beta_rad: f64, psi_rad: f64, cos2b: f64, sin2b: f64, w: f64) {
        let l = &mut self.line[sector_of(beta_rad)];
        let (sb, cb) = (sin2b, cos2b);
        for (acc, x) in l.iter_mut().zip([sb * sb, sb * cb, cb * cb, psi_rad * sb, psi_rad * cb, psi_rad * psi_rad]) {
            *acc += w * x;
        }
        l[6] += 1.0;
    }

    /// `self − other`, term by term (a sum with one block's samples left out).
    pub(crate) fn minus(&self, other: &HeadingSums) -> HeadingSums {
        let mut d = *self;
        for k in 0..6 {
            d.scatter[k] -= other.scatter[k];
        }
        d.n -= other.n;
        for (a, b) in d.line.iter_mut().zip(&other.line) {
            for k in 0..7 {
                a[k] -= b[k];
            }
        }
        d
    }

    /// Sums over every valid sample of `img`; rows in parallel, added in row order
    /// (bit-identical whatever the thread count).
    pub fn from_image(img: &PolImage, ctx: &HeadingContext) -> HeadingSums {
        let cos_2band = Self::cos_2band(ctx);
        HeadingSums::sum_rows(
            img.height,
            || (RowScratch::default(), Vec::with_capacity(img.width)),
            |(scratch, row), j| {
                let mut acc = HeadingSums::default();
                row.clear();
                // As `img.stokes(i, j)`, NaN intensity where invalid.
                row.extend(img.iqu[j * img.width..][..img.width].iter().map(|&[i, q, u]| {
                    if i.is_nan() {
                        Stokes::new(f64::NAN, 0.0, 0.0, 0.0)
                    } else {
                        Stokes::new(i, q, u, 0.0)
                    }
                }));
                let (x0, y) = img.position_px(0, j);
                acc.accumulate_row(ctx, cos_2band, y, x0, img.step_px, row, scratch);
                acc
            },
        )
    }

    /// cos 2·band of the meridian band test, as [`Self::accumulate`] takes it.
    pub fn cos_2band(ctx: &HeadingContext) -> f64 {
        (2.0 * ctx.band_deg.to_radians()).cos()
    }

    /// Sums of `rows` rows, `row(scratch, j)` giving row `j`'s: rows in parallel (one
    /// `init()` scratch per rayon job, reused over its rows), then added sequentially in
    /// row order, so bit-identical whatever the thread count.
    pub(crate) fn sum_rows<S, I, R>(rows: usize, init: I, row: R) -> HeadingSums
    where
        S: Send,
        I: Fn() -> S + Sync + Send,
        R: Fn(&mut S, usize) -> HeadingSums + Sync + Send,
    {
        let rows: Vec<HeadingSums> = (0..rows).into_par_iter().map_init(init, row).collect();
        let mut total = HeadingSums::default();
        for r in rows {
            total += r;
        }
        total
    }

    /// Solves for the heading with `extractor`.
    pub fn solve(&self, extractor: Extractor, ctx: &HeadingContext) -> Result<HeadingEstimate> {
        match extractor {
            Extractor::SunVector => sun_vector::solve(self, ctx),
            Extractor::MeridianLine => meridian::solve(self, ctx),
        }
    }
}

/// Columns of [`HeadingSums::accumulate_row`]'s scratch: the six scatter terms, n,
/// in band, Q_p, U_p, cos 2β, sin 2β.
const COLS: usize = 12;

/// Reusable buffers of [`HeadingSums::accumulate_row`] (per-sample columns).
#[derive(Clone, Debug, Default)]
pub(crate) struct RowScratch {
    cols: Vec<f64>,
}

/// What one sample adds: its scatter terms, whether it counts (`n` = 1 or 0), and
/// what the meridian band needs (Q_p, U_p, P and 2β of its assumed ray).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Contribution {
    pub m: [f64; 6],
    pub n: f64,
    pub qp: f64,
    pub up: f64,
    pub pol: f64,
    pub cos2b: f64,
    pub sin2b: f64,
}

/// One sample's contribution: image-frame Stokes `s` seen along the assumed ray `g`.
/// Pure and branch-free (invalid or unpolarized samples contribute zero).
#[inline(always)]
pub(crate) fn contribution(ctx: &HeadingContext, g: &RayGeometry, s: Stokes) -> Contribution {
    let b = &g.basis;
    // Image → meridional frame; undo a known lens diattenuation (seed eq. 13).
    let mut sm = image_to_meridional(s, b.cos2b, b.sin2b);
    if ctx.lens_rho2 != 0.0 {
        sm = lens_diattenuation_inverse(ctx.lens_rho2, g.r2, sm);
    }
    let p2 = sm.q * sm.q + sm.u * sm.u;
    let valid = p2 > 0.0 && sm.i > 0.0; // false for NaN (masked) samples
    let pol = p2.sqrt();
    // Sun vector: w e eᵀ with e = cos φ p − sin φ s, w = P², without half angles:
    // e eᵀ = ½(1 + cos 2φ) p pᵀ + ½(1 − cos 2φ) s sᵀ − ½ sin 2φ (p sᵀ + s pᵀ),
    // and P² cos 2φ = P·Q_p, P² sin 2φ = P·U_p.
    let (wa, wb, wc) = (0.5 * (p2 + pol * sm.q), 0.5 * (p2 - pol * sm.q), -0.5 * pol * sm.u);
    let (p, q) = (b.p, b.s);
    let m = |i: usize, j: usize| wa * p[i] * p[j] + wb * q[i] * q[j] + wc * (p[i] * q[j] + q[i] * p[j]);
    let terms = [m(0, 0), m(0, 1), m(0, 2), m(1, 1), m(1, 2), m(2, 2)];
    Contribution {
        m: if valid { terms } else { [0.0; 6] },
        n: if valid { 1.0 } else { 0.0 },
        qp: sm.q,
        up: sm.u,
        pol,
        cos2b: b.cos2b,
        sin2b: b.sin2b,
    }
}

/// Convenience: heading of one reconstructed image with one extractor.
pub fn estimate(img: &PolImage, ctx: &HeadingContext, extractor: Extractor) -> Result<HeadingEstimate> {
    HeadingSums::from_image(img, ctx).solve(extractor, ctx)
}

/// Sector of image angle `beta_rad` (any value), 0..SECTORS.
#[inline]
pub(crate) fn sector_of(beta_rad: f64) -> usize {
    let t = beta_rad.rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU;
    ((t * SECTORS as f64) as usize).min(SECTORS - 1)
}

/// Centre image angle of sector `k`, radians.
pub(crate) fn sector_centre_rad(k: usize) -> f64 {
    (k as f64 + 0.5) * std::f64::consts::TAU / SECTORS as f64
}

pub(crate) fn too_few(what: &str, n: f64) -> Error {
    Error::Heading(format!("{what}: only {n} usable samples"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use crate::chain::{pixel_stokes, ChainFrame, Scene};
    use crate::effects::EffectSet;

    #[test]
    fn row_sums_are_bitwise_the_per_sample_sums() {
        let mut set = EffectSet::new();
        set.set("lens_diattenuation", "rho2", 0.8).unwrap();
        let scene = Scene {
            sun_az_deg: 40.0,
            sun_el_deg: 25.0,
            heading_deg: 30.0,
            tilt_x_deg: 0.0,
            tilt_y_deg: 0.0,
            dmax: 0.6,
        };
        for p in Projection::ALL {
            let intr = Intrinsics { projection: p, f_px: 400.0, cx_px: 305.5, cy_px: 255.5, distortion: [0.0; 2] };
            let f = ChainFrame::noise_free(&set.model(), &intr, &scene);
            for rho2 in [0.0, 0.8] {
                let ctx = HeadingContext { lens_rho2: rho2, ..HeadingContext::new(intr, 612, 512, 40.0, 25.0) };
                let cos_2band = (2.0 * ctx.band_deg.to_radians()).cos();
                let (mut row, mut one) = (HeadingSums::default(), HeadingSums::default());
                let mut scratch = RowScratch::default();
                for y in [3.5, 100.5, 255.5, 400.5] {
                    let (x0, step) = (0.5, 2.0);
                    let mut s: Vec<Stokes> = (0..306).map(|i| pixel_stokes(&f, x0 + step * i as f64, y)).collect();
                    s[7].i = f64::NAN; // a masked sample
                    row.accumulate_row(&ctx, cos_2band, y, x0, step, &s, &mut scratch);
                    for (i, s) in s.iter().enumerate() {
                        one.accumulate(&ctx, cos_2band, x0 + step * i as f64, y, *s);
                    }
                }
                assert_eq!(row, one, "{p:?} ρ₂ {rho2}");
                assert!(row.line.iter().map(|l| l[6]).sum::<f64>() > 10.0, "{p:?}: band samples");
            }
        }
    }
}
