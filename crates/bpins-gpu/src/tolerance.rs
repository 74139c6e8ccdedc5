//! How closely the GPU must reproduce the CPU reference (`TOLERANCES.md` explains
//! each figure). Enforced by the parity tests and by `bpins agree`.

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
