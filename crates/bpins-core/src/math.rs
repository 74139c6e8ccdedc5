//! Branch-free forms of libm functions for the row kernels: a call to libm inside a row
//! loop stops it vectorizing (x86-64-v3, `.cargo/config.toml`), so the kernels that
//! need an angle per pixel (`chain::angles_row`) use these instead.
//!
//! [`atan2`]: the argument reduced to t = min(|x|, |y|)/max(|x|, |y|) ∈ [0, 1], then to
//! |t'| ≤ 0.66 by atan t = π/4 + atan((t − 1)/(t + 1)) above 0.66, and atan t' as
//! t' + t'·z·P(z)/Q(z), z = t'², with the degree-4/5 rational approximation of the
//! Cephes library's `atan` (S. L. Moshier, *Methods and Programs for Mathematical
//! Functions*, 1989; coefficients as published there). The quadrant is restored with
//! selects. Agrees with libm's `atan2` to a few ulp (tested); its WGSL counterpart
//! (`atan2_f64` in `shaders/common/math.wgsl`) is a different method with its own
//! tolerance (TOLERANCES.md).
//!
//! [`atan2_f32`]: the same reduction in single precision, atan t' by the odd
//! polynomial of Cephes' `atanf` (degree 9, |t'| ≤ tan(π/8) = 0.4142 after the
//! reflection about π/4), for the maps kernel's float32 pixels: eight lanes at once.
//!
//! [`sin_cos_quarter`]: sin and cos on |x| ≤ π/4 by fdlibm's kernel polynomials, for
//! the analyzer rows of `pixel_analyzers` (the quadrant taken out exactly there).

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

const P: [f64; 5] = [
    -8.750_608_600_031_904e-1,
    -1.615_753_718_733_365e1,
    -7.500_855_792_314_705e1,
    -1.228_866_684_490_136e2,
    -6.485_021_904_942_025e1,
];
const Q: [f64; 5] = [
    2.485_846_490_142_306e1,
    1.650_270_098_316_988_5e2,
    4.328_810_604_912_903e2,
    4.853_903_996_359_137e2,
    1.945_506_571_482_614e2,
];

/// atan t for t ∈ [0, 1].
#[inline(always)]
fn atan_unit(t: f64) -> f64 {
    // Above tan(33.4°) = 0.66, reflect about π/4: atan t = π/4 + atan((t − 1)/(t + 1)).
    let high = t > 0.66;
    let x = if high { (t - 1.0) / (t + 1.0) } else { t };
    let off = if high { FRAC_PI_4 } else { 0.0 };
    let z = x * x;
    let p = (((P[0] * z + P[1]) * z + P[2]) * z + P[3]) * z + P[4];
    let q = ((((z + Q[0]) * z + Q[1]) * z + Q[2]) * z + Q[3]) * z + Q[4];
    off + (x + x * (z * p / q))
}

/// atan2(y, x) in (−π, π], as `f64::atan2` for finite arguments (0 at the origin), to a
/// few ulp; branch-free, so loops over it vectorize.
#[inline(always)]
pub fn atan2(y: f64, x: f64) -> f64 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    // t = lo/hi ∈ [0, 1]; 0 at the origin.
    let t = if hi > 0.0 { lo / hi } else { 0.0 };
    let a = atan_unit(t);
    // Octant, then quadrant, then the sign of y (sign bits, so signed zeros go where
    // libm's do: atan2(+0, −0) = π, atan2(−0, +0) = −0).
    let a = if ay > ax { FRAC_PI_2 - a } else { a };
    let a = if x.is_sign_negative() { PI - a } else { a };
    if y.is_sign_negative() {
        -a
    } else {
        a
    }
}

/// atan2(y, x) in (−π, π] in single precision (Cephes `atanf`), within 2 ulp of the
/// correctly rounded result for finite arguments (0 at the origin), branch-free so
/// that loops over it vectorize eight lanes wide.
#[inline(always)]
pub fn atan2_f32(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let t = if hi > 0.0 { lo / hi } else { 0.0 };
    // Above tan(π/8), reflect about π/4.
    let high = t > 0.414_213_57;
    let r = if high { (t - 1.0) / (t + 1.0) } else { t };
    let z = r * r;
    let p = (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_294_9e-1) * z * r + r;
    let a = if high { FRAC_PI_4 + p } else { p };
    let a = if ay > ax { FRAC_PI_2 - a } else { a };
    let a = if x.is_sign_negative() { PI - a } else { a };
    if y.is_sign_negative() {
        -a
    } else {
        a
    }
}

/// An angle of period 180° in (−270°, 270°) wrapped into (−90°, 90°]: the same number
/// as `conventions::wrap_deg_90` there (a zero may differ in sign), with selects instead
/// of a remainder: the exact a ± 180 is a multiple of ulp(a) no larger than a, so it is
/// representable and both forms round nothing.
#[inline(always)]
pub fn wrap_deg_90_near(a_deg: f64) -> f64 {
    let a = if a_deg > 90.0 { a_deg - 180.0 } else { a_deg };
    let a = if a > 90.0 { a - 180.0 } else { a };
    let a = if a <= -90.0 { a + 180.0 } else { a };
    if a <= -90.0 {
        a + 180.0
    } else {
        a
    }
}

/// sin x and cos x for |x| ≤ π/4, within 1 ulp of libm's (tested): the minimax
/// polynomials of fdlibm's kernels `__kernel_sin` and `__kernel_cos` (Sun Microsystems
/// 1993, `k_sin.c`, `k_cos.c`, as in musl's `__sin.c`, `__cos.c`), with their
/// evaluation order and no argument tail. No reduction: the caller brings the angle
/// into range (`pixel_analyzers`: the analyzer's quadrant taken out exactly).
/// Branch-free, so loops over it vectorize.
#[inline(always)]
#[allow(clippy::excessive_precision)] // fdlibm's digits, as published
pub fn sin_cos_quarter(x: f64) -> (f64, f64) {
    const S: [f64; 6] = [
        -1.666_666_666_666_663_243_48e-1,
        8.333_333_333_322_489_461_24e-3,
        -1.984_126_982_985_794_931_34e-4,
        2.755_731_370_707_006_767_89e-6,
        -2.505_076_025_340_686_341_95e-8,
        1.589_690_995_211_550_102_21e-10,
    ];
    const C: [f64; 6] = [
        4.166_666_666_666_660_190_37e-2,
        -1.388_888_888_887_410_957_49e-3,
        2.480_158_728_947_672_941_78e-5,
        -2.755_731_435_139_066_330_35e-7,
        2.087_572_321_298_174_827_90e-9,
        -1.135_964_755_778_819_482_65e-11,
    ];
    let z = x * x;
    let w = z * z;
    let rs = S[1] + z * (S[2] + z * S[3]) + z * w * (S[4] + z * S[5]);
    let sin = x + z * x * (S[0] + z * rs);
    let rc = z * (C[0] + z * (C[1] + z * C[2])) + w * w * (C[3] + z * (C[4] + z * C[5]));
    let hz = 0.5 * z;
    let one_minus = 1.0 - hz;
    let cos = one_minus + (((1.0 - one_minus) - hz) + z * rc);
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conventions::wrap_deg_90;

    /// Units in the last place between `a` and `b`.
    fn ulps(a: f64, b: f64) -> u64 {
        if a == b {
            return 0;
        }
        (a.to_bits() as i64).abs_diff(b.to_bits() as i64)
    }

    #[test]
    fn atan2_is_libm_s_to_a_few_ulp_everywhere() {
        let mut worst = 0;
        let mut abs = 0f64;
        // A dense spiral of directions and magnitudes, both signs, both axes.
        for k in 0..200_000 {
            let th = -PI + 2.0 * PI * (k as f64 + 0.37) / 200_000.0;
            let r = 10f64.powf(-6.0 + 12.0 * ((k * 7919) % 1000) as f64 / 1000.0);
            let (y, x) = (r * th.sin(), r * th.cos());
            let (got, want) = (atan2(y, x), y.atan2(x));
            abs = abs.max((got - want).abs());
            if want.abs() > 1e-3 {
                worst = worst.max(ulps(got, want));
            }
        }
        assert!(worst <= 4 && abs < 1e-15, "{worst} ulp, {abs:e} rad");
        for (y, x) in [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0), (1.0, 1.0), (-2.0, -2.0), (3.0, -3.0)] {
            assert!((atan2(y, x) - f64::atan2(y, x)).abs() < 1e-15, "({y}, {x})");
        }
        // Signed zeros as libm: (−π, π], the negative x axis +π from above, −π from below.
        for (y, x) in [(0.0, 0.0), (-0.0, 0.0), (0.0, -0.0), (-0.0, -0.0), (0.0, -1.0), (-0.0, -1.0), (-0.0, 2.0)] {
            assert_eq!(atan2(y, x).to_bits(), f64::atan2(y, x).to_bits(), "({y}, {x})");
        }
    }

    #[test]
    fn atan2_f32_is_within_a_few_ulp_of_the_double_result() {
        let mut worst = 0f64;
        for k in 0..200_000 {
            let th = -PI + 2.0 * PI * (k as f64 + 0.37) / 200_000.0;
            let r = 10f64.powf(-6.0 + 12.0 * ((k * 7919) % 1000) as f64 / 1000.0);
            let (y, x) = ((r * th.sin()) as f32, (r * th.cos()) as f32);
            let want = (y as f64).atan2(x as f64);
            let err = (atan2_f32(y, x) as f64 - want).abs() / (want.abs().max(1e-3) * f32::EPSILON as f64);
            worst = worst.max(err);
        }
        assert!(worst <= 2.0, "{worst} ulp");
        for (y, x) in [(0.0f32, 0.0f32), (-0.0, 0.0), (0.0, -0.0), (-0.0, -1.0), (1.0, 0.0), (-1.0, 0.0)] {
            assert_eq!(atan2_f32(y, x), f32::atan2(y, x), "({y}, {x})");
        }
    }

    #[test]
    fn sin_cos_quarter_is_libm_s_to_an_ulp() {
        let (mut worst, mut abs) = (0, 0f64);
        for k in 0..=200_000 {
            let x = FRAC_PI_4 * (k as f64 / 100_000.0 - 1.0) * (1.0 - 1e-16);
            let ((s, c), (ws, wc)) = (sin_cos_quarter(x), x.sin_cos());
            abs = abs.max((s - ws).abs()).max((c - wc).abs());
            worst = worst.max(ulps(c, wc));
            if ws.abs() > 1e-300 {
                worst = worst.max(ulps(s, ws));
            }
        }
        assert!(worst <= 1 && abs <= 1.2e-16, "{worst} ulp, {abs:e}");
        assert_eq!(sin_cos_quarter(0.0), (0.0, 1.0));
    }

    #[test]
    fn the_near_wrap_is_the_remainder_wrap_exactly() {
        for k in 0..100_000 {
            let a = -269.999 + 539.998 * (k as f64 + 0.5) / 100_000.0;
            assert_eq!(wrap_deg_90_near(a), wrap_deg_90(a), "{a}");
        }
        for a in [90.0, -90.0, 180.0, -180.0, 0.0, 89.999_999_999_999_99, 269.0, -269.0, 1e-300, -90.000_000_000_001] {
            assert_eq!(wrap_deg_90_near(a), wrap_deg_90(a), "{a}");
        }
    }
}
