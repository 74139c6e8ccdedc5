// Counter-based random numbers keyed by (seed, trial, frame, pixel, channel, stream).
// CPU twin: crates/bpins-core/src/noise.rs — keep in sync, operation for operation.
//
// Hash pcg4d (Jarzynski & Olano, JCGT 9(3) 2020, §3). Keying:
//   frame key  k = pcg4d(seed_lo, seed_hi, trial, frame)               (host, per frame)
//   draw       h = pcg4d(pcg4d(pixel ^ k.x, (pair | stream << 4) ^ k.y, k.z, k.w))
//   uniform    u1 = ((h.x >> 8) + 1)·2⁻²⁴ ∈ (0, 1],  turns k = h.y >> 8
//   normal     n = √(−2 ln u1)·(cos 2πk/2²⁴, sin 2πk/2²⁴)     Box–Muller, in f32
// ln and sin/cos are Cephes f32 polynomials (logf.c, sinf.c, cosf.c), not the WGSL
// built-ins, whose precision differs by vendor: the GPU draws the CPU's numbers (to
// an ulp where a driver fuses a multiply-add).

const STREAM_TEMPORAL: u32 = 0u;
const STREAM_DSNU: u32 = 1u;
const STREAM_PRNU: u32 = 2u;

fn pcg4d(v_in: vec4<u32>) -> vec4<u32> {
    var v = v_in * 1664525u + 1013904223u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v = v ^ (v >> vec4<u32>(16u));
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}

// Four independent 32-bit words for (pixel, channel pair, stream) under frame key k.
fn frame_bits(k: vec4<u32>, pixel: u32, pair: u32, stream: u32) -> vec4<u32> {
    return pcg4d(pcg4d(vec4<u32>(pixel ^ k.x, (pair | (stream << 4u)) ^ k.y, k.z, k.w)));
}

// Natural logarithm of a normal, finite x > 0 (Cephes logf polynomial).
fn ln_f32(x: f32) -> f32 {
    // x = m·2^e with m ∈ [1, 2), then centred: m ∈ [√½, √2).
    let bits = bitcast<u32>(x);
    var e = f32(i32(bits >> 23u) - 127);
    var m = bitcast<f32>((bits & 0x007fffffu) | 0x3f800000u);
    let big = m > 1.41421356;
    m = select(m, 0.5 * m, big);
    e = select(e, e + 1.0, big);
    // ln m = f − f²/2 + f³·P(f), f = m − 1.
    let f = m - 1.0;
    let z = f * f;
    var p = 7.0376836e-2;
    p = p * f - 1.1514610e-1;
    p = p * f + 1.1676999e-1;
    p = p * f - 1.2420141e-1;
    p = p * f + 1.4249323e-1;
    p = p * f - 1.6668058e-1;
    p = p * f + 2.0000714e-1;
    p = p * f - 2.4999994e-1;
    p = p * f + 3.3333331e-1;
    // ln 2 split into 0.693359375 and a small correction.
    let y = f * z * p + e * -2.1219444e-4 - 0.5 * z;
    return f + y + e * 0.69335938;
}

// (sin 2πk/2²⁴, cos 2πk/2²⁴), k < 2²⁴: exact integer quadrant reduction, Cephes sinf/cosf.
fn sin_cos_turns24(k: u32) -> vec2<f32> {
    // Nearest quarter turn q and the remainder in [−2²¹, 2²¹) of 2⁻²⁴ turns.
    let q = (k + (1u << 21u)) >> 22u;
    let rem = i32(k) - i32(q << 22u);
    let x = f32(rem) * (6.2831855 / 16777216.0);
    let z = x * x;
    let s = ((-1.9515296e-4 * z + 8.332161e-3) * z - 1.6666655e-1) * z * x + x;
    let c = ((2.4433157e-5 * z - 1.3887316e-3) * z + 4.1666646e-2) * z * z - 0.5 * z + 1.0;
    // sin(qπ/2 + x), cos(qπ/2 + x): swap on odd q; sin negative for q = 2, 3; cos for q = 1, 2.
    let odd = (q & 1u) == 1u;
    var ss = select(s, c, odd);
    var cc = select(c, s, odd);
    ss = select(ss, -ss, (q & 2u) != 0u);
    cc = select(cc, -cc, ((q + 1u) & 2u) != 0u);
    return vec2<f32>(ss, cc);
}

// The normals of channels 2·pair and 2·pair + 1 (cosine and sine branches), widened to f64.
fn normal_pair(k: vec4<u32>, pixel: u32, pair: u32, stream: u32) -> vec2<f64> {
    let h = frame_bits(k, pixel, pair, stream);
    let u1 = f32(i32((h.x >> 8u) + 1u)) * (1.0 / 16777216.0);
    let r = sqrt(-2.0 * ln_f32(u1));
    let sc = sin_cos_turns24(h.y >> 8u);
    return vec2<f64>(f64(r * sc.y), f64(r * sc.x));
}

// The standard normal number of (pixel, channel, stream).
fn normal(k: vec4<u32>, pixel: u32, channel: u32, stream: u32) -> f64 {
    let n = normal_pair(k, pixel, channel >> 1u, stream);
    return select(n.x, n.y, (channel & 1u) == 1u);
}
