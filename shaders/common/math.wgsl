// f64 helpers the WGSL built-ins lack: f64 sin/cos, atan2 and the f64 constants.
// WGSL (SPIR-V GLSL.std.450) has no f64 transcendentals, and its f32 ones have
// vendor-defined precision (Vulkan allows atan2 4096 ulp), so the chain's few
// transcendentals in f64 are ours. CPU twin: f64 libm (results agree to ~1e-16).

const PI_F64: f64 = 3.141592653589793lf;
const HALF_PI_F64: f64 = 1.5707963267948966lf;
const TAU_F64: f64 = 6.283185307179586lf;
const DEG_PER_RAD_F64: f64 = 57.29577951308232lf;

// (sin x, cos x) for |x| ≤ π (a hair beyond is fine): fold to t ∈ [0, π/2], Taylor
// series through t²⁵ (truncation < 1e-20 on [0, π/2]).
fn sin_cos_f64(x: f64) -> vec2<f64> {
    let ax = abs(x);
    let flip = ax > HALF_PI_F64;
    let t = select(ax, PI_F64 - ax, flip);
    let z = t * t;
    var s = 1.0lf;
    var c = 1.0lf;
    // sin t = t(1 − z/(2·3)(1 − z/(4·5)(…))), cos t = 1 − z/(1·2)(1 − z/(3·4)(…)).
    for (var n = 12; n >= 1; n--) {
        let a = f64(2 * n);
        s = 1.0lf - z / (a * (a + 1.0lf)) * s;
        c = 1.0lf - z / ((a - 1.0lf) * a) * c;
    }
    s = s * t;
    return vec2<f64>(select(s, -s, x < 0.0lf), select(c, -c, flip));
}

// atan2(y, x) in (−π, π], f64: the f32 built-in, then one exact correction
// a = a₀ + atan(tan(a − a₀)), tan(a − a₀) = (y cos a₀ − x sin a₀)/(x cos a₀ + y sin a₀).
fn atan2_f64(y: f64, x: f64) -> f64 {
    if (x == 0.0lf && y == 0.0lf) {
        return 0.0lf;
    }
    let a0 = f64(atan2(f32(y), f32(x)));
    let sc = sin_cos_f64(a0);
    let t = (y * sc.y - x * sc.x) / (x * sc.y + y * sc.x);
    // atan t for |t| ≲ 1e-3: t − t³/3 + t⁵/5 (error < t⁷/7).
    let t2 = t * t;
    var a = a0 + t * (1.0lf - t2 * (1.0lf / 3.0lf - t2 * 0.2lf));
    a = select(a, a - TAU_F64, a > PI_F64);
    a = select(a, a + TAU_F64, a <= -PI_F64);
    return a;
}

// An angle of period 180° wrapped into (−90°, 90°] (conventions::wrap_deg_90).
fn wrap_deg_90(a_deg: f64) -> f64 {
    let r = a_deg - 180.0lf * floor(a_deg / 180.0lf);
    return select(r, r - 180.0lf, r > 90.0lf);
}

fn dot3(a: vec3<f64>, b: vec3<f64>) -> f64 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn cross3(a: vec3<f64>, b: vec3<f64>) -> vec3<f64> {
    return vec3<f64>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

// Host parameters travel as f32 (hi, lo) pairs (layout-safe, f64 to ~2⁻⁴⁸): x = hi + lo.
struct Wide4 {
    hi: vec4<f32>,
    lo: vec4<f32>,
}

fn wide(w: Wide4) -> vec4<f64> {
    return vec4<f64>(w.hi) + vec4<f64>(w.lo);
}
