//! Seeded value noise on world directions: the texture of clouds, crowns, walls and
//! ground, fixed in the world (the same direction gives the same value in every frame).
//!
//! ```text
//! h(i, j, k) = pcg4d(i ⊕ k₀, j ⊕ k₁, k ⊕ k₂, k₃ + o).x → [−1, 1)   lattice value, octave o
//! v(p)       = Σ over the 8 lattice corners of p: w(t_x) w(t_y) w(t_z) · h,
//!              w(t) = t²(3 − 2t) (smoothstep), t the position within the cell
//! fbm(p)     = Σ_o 2^−o · v(2^o p) / Σ_o 2^−o                    fractal sum, in [−1, 1]
//! ```
//!
//! Source: value noise and its fractal (fBm) sum, D. S. Ebert, F. K. Musgrave et al.,
//! *Texturing and Modeling: A Procedural Approach*, 3rd ed. (2003), ch. 2 ("lattice
//! noises") and ch. 16; the hash is the project's `pcg4d` (`noise.rs`), so the texture
//! is a pure function of (seed, element, salt, point). Units: `p` is a world (ENU)
//! direction times a scale in features per radian. Cannot: anisotropy (real clouds
//! are stretched by wind), or anything band-limited beyond the smoothstep (value
//! noise has visible lattice alignment at a single octave).

use crate::noise::pcg4d;
use glam::DVec3;

/// One seeded noise field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Texture {
    key: [u32; 4],
}

impl Texture {
    /// The field of `element` (its registry index) and `salt` (which of its fields) under `seed`.
    pub fn new(seed: u64, element: u32, salt: u32) -> Self {
        Texture { key: pcg4d([seed as u32, (seed >> 32) as u32, element ^ 0x7e57_0000, salt]) }
    }

    /// Lattice value at integer point (i, j, k) of octave `o`, in [−1, 1).
    #[inline(always)]
    fn lattice(&self, i: i64, j: i64, k: i64, o: u32) -> f64 {
        let k4 = self.key;
        let h = pcg4d([i as u32 ^ k4[0], j as u32 ^ k4[1], k as u32 ^ k4[2], k4[3].wrapping_add(o)]);
        (h[0] >> 8) as f64 * (2.0 / 16_777_216.0) - 1.0
    }

    /// Value noise at `p` for octave `o`, in [−1, 1].
    #[inline]
    fn value(&self, p: DVec3, o: u32) -> f64 {
        let f = p.floor();
        let t = p - f;
        let w = |t: f64| t * t * (3.0 - 2.0 * t);
        let (wx, wy, wz) = (w(t.x), w(t.y), w(t.z));
        let (i, j, k) = (f.x as i64, f.y as i64, f.z as i64);
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let edge = |j: i64, k: i64| lerp(self.lattice(i, j, k, o), self.lattice(i + 1, j, k, o), wx);
        let face = |k: i64| lerp(edge(j, k), edge(j + 1, k), wy);
        lerp(face(k), face(k + 1), wz)
    }

    /// Fractal sum of `octaves` (≥ 1) octaves at `p`, in [−1, 1].
    #[inline]
    pub fn fbm(&self, p: DVec3, octaves: u32) -> f64 {
        let (mut sum, mut norm, mut amp, mut q) = (0.0, 0.0, 1.0, p);
        for o in 0..octaves.max(1) {
            sum += amp * self.value(q, o);
            norm += amp;
            amp *= 0.5;
            q *= 2.0;
        }
        sum / norm
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_lie_in_range_have_zero_mean_and_vary() {
        let t = Texture::new(3, 1, 0);
        let (mut s1, mut s2, n) = (0.0, 0.0, 20_000);
        for i in 0..n {
            let p = DVec3::new(i as f64 * 0.37, (i % 97) as f64 * 0.61, (i % 13) as f64 * 1.7);
            let v = t.fbm(p, 3);
            assert!((-1.0..=1.0).contains(&v), "{v}");
            s1 += v;
            s2 += v * v;
        }
        let (mean, var) = (s1 / n as f64, s2 / n as f64 - (s1 / n as f64).powi(2));
        assert!(mean.abs() < 0.05 && var > 0.02, "mean {mean}, variance {var}");
    }

    #[test]
    fn noise_is_continuous_and_seeded() {
        let t = Texture::new(3, 1, 0);
        let p = DVec3::new(4.3, -2.9, 7.05);
        let e = DVec3::splat(1e-7);
        assert!((t.fbm(p, 3) - t.fbm(p + e, 3)).abs() < 1e-5);
        // Across a lattice plane too.
        let q = DVec3::new(5.0, 1.5, 0.5);
        assert!((t.fbm(q - e, 2) - t.fbm(q + e, 2)).abs() < 1e-5);
        assert_eq!(t.fbm(p, 3), Texture::new(3, 1, 0).fbm(p, 3));
        assert_ne!(t.fbm(p, 3), Texture::new(4, 1, 0).fbm(p, 3));
        assert_ne!(t.fbm(p, 3), Texture::new(3, 2, 0).fbm(p, 3));
        assert_ne!(t.fbm(p, 3), Texture::new(3, 1, 1).fbm(p, 3));
    }
}
