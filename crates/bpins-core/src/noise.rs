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
//! `ln` and `sin`/`cos` are our own branch-free f32 polynomials ([`ln_f32`],
//! [`sin_cos_turns24`]), not libm: the same operations in the same order on every
//! platform (and in WGSL, whose built-ins differ by vendor), and row loops of draws
//! vectorize. Both are the Cephes single-precision minimax polynomials (S. Moshier,
//! Cephes Math Library, `logf.c`, `sinf.c`, `cosf.c`):
//!
//! ```text
//! ln x   x = m·2^e, m ∈ [√½, √2): e·ln 2 + f + f³·P₉(f) − f²/2,  f = m − 1
//! sin/cos of 2π·k/2²⁴ (k = h.y >> 8): quadrant q = (k + 2²¹) >> 22, exact remainder
//!        k − q·2²² → x ∈ [−π/4, π/4]; sin x = x + x³·S₃(x²), cos x = 1 − x²/2 + x⁴·C₃(x²);
//!        swap and signs by q
//! ```
//!
//! Measured against f64 libm (tests below): |ln error| ≤ 2 ulp of the result (and
//! ≤ 1e-7·max(1, |ln x|)), |sin, cos error| ≤ 2e-7 absolute over every uniform.
//!
//! Fixed-pattern noise (DSNU, PRNU) uses `frame = FIXED_PATTERN_FRAME`, so it is the
//! same in every frame of a trial.

/// Streams: independent families of draws for the same pixel and channel.
pub mod stream {
    /// Temporal read + shot noise of one exposure.
    pub(crate) const TEMPORAL: u32 = 0;
    /// Per-pixel offset non-uniformity (DSNU).
    pub const DSNU: u32 = 1;
    /// Per-pixel gain non-uniformity (PRNU).
    pub const PRNU: u32 = 2;
    /// Per-trial parameter draws of a Monte Carlo (pixel = parameter index).
    pub const TRIAL: u32 = 3;
    /// Draws of the scene elements and field attitudes (`scene`; pixel = draw index).
    pub(crate) const SCENE: u32 = 4;
}

/// Frame index used for noise that is fixed over the frames of one trial.
pub const FIXED_PATTERN_FRAME: u32 = u32::MAX;

/// The pcg4d hash (Jarzynski & Olano 2020).
#[inline(always)]
pub fn pcg4d(v: [u32; 4]) -> [u32; 4] {
    // (Element by element rather than `array::map`, whose loop would keep the row
    // loops around a draw from vectorizing.)
    let lcg = |x: u32| x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
    let mut v = [lcg(v[0]), lcg(v[1]), lcg(v[2]), lcg(v[3])];
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
    v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
    v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    let xs = |x: u32| x ^ (x >> 16);
    v = [xs(v[0]), xs(v[1]), xs(v[2]), xs(v[3])];
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
    pub(crate) fn normal_pair(&self, pixel: u32, pair: u32, stream: u32) -> (f64, f64) {
        let h = self.bits(pixel, pair, stream);
        let (r, s, c) = box_muller_parts(h);
        ((r * c) as f64, (r * s) as f64)
    }
}

/// Pixels per chunk of the row kernels. A chunk is hashed lane-parallel (u32, 8 AVX2
/// lanes per vector, [`pcg4d_lanes`]) and transformed in f32, then widened to f64:
/// two vectors in flight hide the latency of pcg4d's serial chain of multiplies.
const LANES: usize = 16;

/// [`pcg4d`] of `LANES` independent inputs, `v[word][lane]`, step by step over all
/// lanes, so each step is independent vector operations.
#[inline(always)]
fn pcg4d_lanes(v: &mut [[u32; LANES]; 4]) {
    for w in v.iter_mut() {
        for x in w.iter_mut() {
            *x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        }
    }
    mix_lanes(v);
    for w in v.iter_mut() {
        for x in w.iter_mut() {
            *x ^= *x >> 16;
        }
    }
    mix_lanes(v);
}

/// pcg4d's mixing round, `v.x += v.y·v.w; v.y += v.z·v.x; v.z += v.x·v.y; v.w += v.y·v.z`.
#[inline(always)]
fn mix_lanes(v: &mut [[u32; LANES]; 4]) {
    let [x, y, z, w] = v;
    for l in 0..LANES {
        x[l] = x[l].wrapping_add(y[l].wrapping_mul(w[l]));
    }
    for l in 0..LANES {
        y[l] = y[l].wrapping_add(z[l].wrapping_mul(x[l]));
    }
    for l in 0..LANES {
        z[l] = z[l].wrapping_add(x[l].wrapping_mul(y[l]));
    }
    for l in 0..LANES {
        w[l] = w[l].wrapping_add(y[l].wrapping_mul(z[l]));
    }
}

impl FrameKey {
    /// [`Self::bits`] of the `LANES` pixels `pixel0 + l`, pair `pair(l)` (lane-parallel).
    #[inline(always)]
    fn bits_lanes(&self, pixel0: u32, pair: impl Fn(usize) -> u32, stream: u32) -> [[u32; LANES]; 4] {
        let k = self.0;
        let mut v = [[0u32; LANES]; 4];
        #[allow(clippy::needless_range_loop)] // v[word][lane]: lane-major on purpose
        for l in 0..LANES {
            v[0][l] = pixel0.wrapping_add(l as u32) ^ k[0];
            v[1][l] = (pair(l) | (stream << 4)) ^ k[1];
            v[2][l] = k[2];
            v[3][l] = k[3];
        }
        pcg4d_lanes(&mut v);
        pcg4d_lanes(&mut v);
        v
    }

    /// Row kernel: `out[i] = self.normal(pixel0 + i, channels[i & 1], stream)` — a DoFP
    /// row alternates two channels (give the same one twice for a single channel).
    /// Branch-free, so the compiler vectorizes the hashes and the Box–Muller.
    pub(crate) fn normal_row(&self, pixel0: u32, channels: [u32; 2], stream: u32, out: &mut [f64]) {
        let mut x = [0f32; LANES];
        // LANES is even: lane parity is pixel parity.
        let ch = |l: usize| if l & 1 == 0 { channels[0] } else { channels[1] };
        for (c, chunk) in out.chunks_mut(LANES).enumerate() {
            let h = self.bits_lanes(pixel0.wrapping_add((c * LANES) as u32), |l| ch(l) >> 1, stream);
            for (l, x) in x.iter_mut().enumerate() {
                let (r, s, cs) = box_muller_parts([h[0][l], h[1][l], h[2][l], h[3][l]]);
                // normal(): the cosine branch for even channels, the sine for odd.
                *x = r * if ch(l) & 1 == 0 { cs } else { s };
            }
            for (o, x) in chunk.iter_mut().zip(&x) {
                *o = *x as f64;
            }
        }
    }

    /// Row kernel: the normals of all four channels of pixels `pixel0 + i`, i.e.
    /// `[normal(p, 0, ·), normal(p, 1, ·), normal(p, 2, ·), normal(p, 3, ·)]`.
    pub(crate) fn normal4_row(&self, pixel0: u32, stream: u32, out: &mut [[f64; 4]]) {
        let mut x = [[0f32; LANES]; 4];
        for (c, chunk) in out.chunks_mut(LANES).enumerate() {
            let p0 = pixel0.wrapping_add((c * LANES) as u32);
            for pair in 0..2 {
                let h = self.bits_lanes(p0, |_| pair as u32, stream);
                for l in 0..LANES {
                    let (r, s, cs) = box_muller_parts([h[0][l], h[1][l], h[2][l], h[3][l]]);
                    x[2 * pair][l] = r * cs;
                    x[2 * pair + 1][l] = r * s;
                }
            }
            for (l, o) in chunk.iter_mut().enumerate() {
                *o = [x[0][l] as f64, x[1][l] as f64, x[2][l] as f64, x[3][l] as f64];
            }
        }
    }
}

/// Box–Muller from one hash: radius `√(−2 ln u₁)` and `(sin 2πu₂, cos 2πu₂)`, f32.
#[inline(always)]
fn box_muller_parts(h: [u32; 4]) -> (f32, f32, f32) {
    // (Through i32: the same exact value, and a single vector instruction.)
    let u1 = ((h[0] >> 8) + 1) as i32 as f32 * (1.0 / 16_777_216.0);
    let r = (-2.0 * ln_f32(u1)).sqrt();
    let (s, c) = sin_cos_turns24(h[1] >> 8);
    (r, s, c)
}

/// Natural logarithm of a normal, finite `x > 0` (f32; Cephes `logf` polynomial).
/// Branch-free: subnormals, zero, negatives, infinities and NaN are not handled
/// (the uniforms here lie in [2⁻²⁴, 1]).
#[inline(always)]
pub fn ln_f32(x: f32) -> f32 {
    // x = m·2^e with m ∈ [1, 2), then centred: m ∈ [√½, √2).
    let bits = x.to_bits();
    let e = ((bits >> 23) as i32 - 127) as f32;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let big = m > std::f32::consts::SQRT_2;
    let (m, e) = if big { (0.5 * m, e + 1.0) } else { (m, e) };
    // ln m = f − f²/2 + f³·P(f), f = m − 1 (exact, Sterbenz).
    let f = m - 1.0;
    let z = f * f;
    let mut p = 7.037_683_6e-2_f32;
    p = p * f - 1.151_461e-1;
    p = p * f + 1.167_699_9e-1;
    p = p * f - 1.242_014_1e-1;
    p = p * f + 1.424_932_3e-1;
    p = p * f - 1.666_805_8e-1;
    p = p * f + 2.000_071_4e-1;
    p = p * f - 2.499_999_4e-1;
    p = p * f + 3.333_333e-1; // Cephes 3.3333331174E-1, the same f32
                              // ln 2 split into 0.693359375 (exact in a few bits) and a small correction.
    let y = f * z * p + e * -2.121_944_4e-4 - 0.5 * z;
    f + y + e * 0.693_359_4
}

/// `(sin 2πt, cos 2πt)` of the angle `t = k·2⁻²⁴` turns, `k < 2²⁴` (f32; Cephes
/// `sinf`/`cosf` polynomials on |x| ≤ π/4). The quadrant and the remainder are
/// taken in integers, so the reduction is exact; branch-free.
#[inline(always)]
pub fn sin_cos_turns24(k: u32) -> (f32, f32) {
    // Nearest quarter turn q (0..=4) and the remainder in [−2²¹, 2²¹) of 2⁻²⁴ turns.
    let q = (k + (1 << 21)) >> 22;
    let rem = k as i32 - (q << 22) as i32;
    let x = rem as f32 * (std::f32::consts::TAU / 16_777_216.0);
    let z = x * x;
    let s = ((-1.951_529_6e-4_f32 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * x + x;
    let c = ((2.443_315_7e-5_f32 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    // sin(qπ/2 + x), cos(qπ/2 + x): swap on odd q; sin negative for q = 2, 3; cos for q = 1, 2.
    let (s, c) = if q & 1 == 1 { (c, s) } else { (s, c) };
    let s = if q & 2 != 0 { -s } else { s };
    let c = if (q + 1) & 2 != 0 { -c } else { c };
    (s, c)
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

    #[test]
    fn ln_f32_is_within_two_ulp_of_libm_on_every_uniform() {
        let mut worst_ulp = 0.0f64;
        for k in (1u32..=1 << 24).step_by(7).chain([1, 2, 3, (1 << 24) - 1, 1 << 24]) {
            let x = k as f32 * (1.0 / 16_777_216.0);
            let want = (x as f64).ln();
            let got = ln_f32(x) as f64;
            let ulp = (want.abs() as f32).max(f32::MIN_POSITIVE);
            let ulp = (f32::from_bits(ulp.to_bits() + 1) - ulp) as f64;
            worst_ulp = worst_ulp.max((got - want).abs() / ulp);
            assert!((got - want).abs() <= 1e-7 * want.abs().max(1.0), "ln({x}) = {got}, want {want}");
        }
        assert!(worst_ulp <= 2.0, "ln_f32 error {worst_ulp} ulp");
        assert_eq!(ln_f32(1.0), 0.0);
    }

    #[test]
    fn sin_cos_turns_match_libm_on_every_uniform() {
        let mut worst = 0.0f64;
        for k in (0u32..1 << 24).step_by(5).chain([0, 1 << 21, (1 << 21) - 1, 1 << 22, 3 << 22, (1 << 24) - 1]) {
            let a = std::f64::consts::TAU * k as f64 / 16_777_216.0;
            let (s, c) = sin_cos_turns24(k);
            worst = worst.max((s as f64 - a.sin()).abs()).max((c as f64 - a.cos()).abs());
        }
        assert!(worst <= 2e-7, "sin/cos error {worst}");
        assert_eq!(sin_cos_turns24(0), (0.0, 1.0));
    }

    #[test]
    fn row_kernels_draw_bitwise_the_per_pixel_normals() {
        let k = FrameKey::new(4, 5, 6);
        let mut row = vec![0.0; 37];
        let mut row4 = vec![[0.0; 4]; 37];
        let p0 = u32::MAX - 20; // wraps around, as `(v·w + u) as u32` does
        for chans in [[2, 1], [3, 0], [1, 1]] {
            k.normal_row(p0, chans, stream::TEMPORAL, &mut row);
            for (i, x) in row.iter().enumerate() {
                assert_eq!(*x, k.normal(p0.wrapping_add(i as u32), chans[i & 1], stream::TEMPORAL));
            }
        }
        k.normal4_row(p0, stream::DSNU, &mut row4);
        for (i, x) in row4.iter().enumerate() {
            let p = p0.wrapping_add(i as u32);
            assert_eq!(*x, [0, 1, 2, 3].map(|c| k.normal(p, c, stream::DSNU)));
        }
    }
}
