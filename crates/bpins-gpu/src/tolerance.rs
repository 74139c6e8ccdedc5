//! How closely the GPU must reproduce the CPU reference (`TOLERANCES.md` explains
//! each figure). Enforced by the parity tests and by `bpins agree`.

use crate::precision::Precision;

/// Noise-free photo-signal (analyzer intensity × gain), relative to the CPU value.
pub const INTENSITY_REL: f64 = 1e-5;
/// Rounded DN: at most this many DN apart...
pub const DN_MAX_ABS: f64 = 1.0;
/// ...and at most this fraction of pixels off at all (0.01 %).
pub const DN_OFF_FRACTION: f64 = 1e-4;
/// AoP, degrees, compared where the DoLP exceeds [`AOP_MIN_DOLP`].
pub const AOP_DEG: f64 = 1e-3;
pub const AOP_MIN_DOLP: f64 = 0.01;
/// DoLP, absolute.
pub const DOLP_ABS: f64 = 1e-5;
/// Heading from the same frame, degrees, every extractor.
pub const HEADING_DEG: f64 = 1e-3;

/// The f32 kernels' bounds (TOLERANCES.md, "The f32 path"): statistical, since f32's
/// 6e-8 puts a few pixels in a thousand on the other side of a rounding boundary.
pub mod f32 {
    /// Noise-free photo-signal, relative (see [`INTENSITY_FLOOR`]).
    pub const INTENSITY_REL: f64 = 1e-3;
    /// Rounded DN: at most this many DN apart...
    pub const DN_MAX_ABS: f64 = 1.0;
    /// ...on at most this fraction of pixels (1 %).
    pub const DN_OFF_FRACTION: f64 = 1e-2;
    /// AoP and AoE, degrees, where DoLP > [`super::AOP_MIN_DOLP`].
    pub const AOP_DEG: f64 = 1e-2;
    /// DoLP, absolute.
    pub const DOLP_ABS: f64 = 1e-4;
    /// Heading from the same frame, degrees, for an estimate whose own 1σ is at most
    /// HEADING_SIGMA_SHARE × this; a less determined estimate may differ by
    /// σ / HEADING_SIGMA_SHARE (`agree::compare`).
    pub const HEADING_DEG: f64 = 1e-2;
    /// The share of an estimate's own 1σ that f32 rounding may move it by: 1/10.
    pub const HEADING_SIGMA_SHARE: f64 = 10.0;
    /// The intensity is compared relative to the pixel's value, or to this share of
    /// the frame's brightest pixel where the pixel is darker (f32 loses the digits a
    /// near-black pixel's cancellations cost, as at a strong vignetting's corner).
    pub const INTENSITY_FLOOR: f64 = 1e-3;
}

/// The stages `bpins agree` and the parity tests compare, in report order, with their
/// bound at `precision`: (name, tolerance, unit).
pub fn stages(precision: Precision) -> [(&'static str, f64, &'static str); 7] {
    let t = match precision {
        Precision::F64 => [INTENSITY_REL, AOP_DEG, DOLP_ABS, DN_MAX_ABS, DN_OFF_FRACTION, HEADING_DEG],
        Precision::F32 => {
            [f32::INTENSITY_REL, f32::AOP_DEG, f32::DOLP_ABS, f32::DN_MAX_ABS, f32::DN_OFF_FRACTION, f32::HEADING_DEG]
        }
    };
    [
        ("intensity", t[0], "relative"),
        ("aop_deg", t[1], "deg"),
        ("dolp", t[2], "1"),
        ("aoe_deg", t[1], "deg"),
        ("dn", t[3], "DN"),
        ("dn_off_fraction", t[4], "fraction of pixels"),
        ("heading_deg", t[5], "deg"),
    ]
}

/// Largest |a − b| over two DN images and the fraction of samples that differ.
pub fn dn_diff(cpu: &[f32], gpu: &[f32]) -> (f64, f64) {
    let mut max: f64 = if cpu.len() == gpu.len() { 0.0 } else { f64::INFINITY };
    let mut off = 0usize;
    for (a, b) in cpu.iter().zip(gpu) {
        let d = (*a as f64 - *b as f64).abs();
        if d > 0.0 || d.is_nan() {
            off += 1;
        }
        max = if d.is_nan() { f64::INFINITY } else { max.max(d) };
    }
    (max, off as f64 / cpu.len().max(1) as f64)
}

/// Difference of two angles of period 180°, in (−90°, 90°].
pub fn aop_diff_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(180.0);
    if d > 90.0 {
        d - 180.0
    } else {
        d
    }
}

/// Difference of two headings, in (−180°, 180°].
pub fn heading_diff_deg(a: f64, b: f64) -> f64 {
    bpins_core::conventions::wrap_deg_180(a - b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_wrap_and_count() {
        assert!((aop_diff_deg(89.9995, -89.9995) - (-0.001)).abs() < 1e-9);
        assert!((heading_diff_deg(359.9995, 0.0005) + 0.001).abs() < 1e-9);
        assert_eq!(dn_diff(&[1.0, 2.0, 3.0, 4.0], &[1.0, 3.0, 3.0, 4.0]), (1.0, 0.25));
        assert_eq!(dn_diff(&[1.0], &[f32::NAN]).0, f64::INFINITY);
    }
}
