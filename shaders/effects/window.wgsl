// window — a tilted flat window (or decentred dome) in front of the lens.
// CPU twin and physics doc: crates/bpins-core/src/effects/window.rs.
//   n the window's unit normal (camera frame), κ = 0.112 (Fresnel plate, n = 1.5):
//   D = κ((n·p)² − (n·s)² − p_z², −2(n·p)(n·s)), the tilt's part of the plate's
//   diattenuation; M = [[1, Dᵀ, 0], [D, c·1 + D Dᵀ/(1 + c), 0], [0, 0, c]],
//   c = √(1 − |D|²), on (I, Q_p, U_p, V) in the ray's meridional frame.

const WINDOW_D_LIMIT: f64 = 0.999lf;

// The tilted window's diattenuation vector (D_q, D_u) along the ray g, less its
// symmetric part, clamped to |D| ≤ 0.999; p = (n_x, n_y, n_z, κ).
fn window_diattenuation(p: vec4<f64>, g: RayGeometry) -> vec2<f64> {
    // The window's normal on the ray's meridional basis: n·p and n·s.
    let np = p.x * g.basis.p.x + p.y * g.basis.p.y + p.z * g.basis.p.z;
    let ns = p.x * g.basis.s.x + p.y * g.basis.s.y + p.z * g.basis.s.z;
    // D = κ((n·p)² − (n·s)², −2(n·p)(n·s)) less the untilted window's κ(p_z², 0): exactly 0 at n = z.
    let dq = p.w * (np * np - ns * ns - g.basis.p.z * g.basis.p.z);
    let du = -2.0lf * p.w * np * ns;
    // Clamp |D| below 1 (a perfect polarizer has no inverse); exactly D where |D| ≤ limit.
    let d2 = dq * dq + du * du;
    var scale = 1.0lf;
    if (d2 > WINDOW_D_LIMIT * WINDOW_D_LIMIT) {
        scale = WINDOW_D_LIMIT / sqrt(d2);
    }
    return vec2<f64>(dq * scale, du * scale);
}

// Applies the window's diattenuator to a meridional-frame Stokes vector; p = (n_x, n_y, n_z, κ).
fn window(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes {
    // Diattenuation vector D along this ray.
    let d = window_diattenuation(p, g);
    // c = √(1 − |D|²); D Dᵀ/(1 + c) is the (1 − c) D̂ D̂ᵀ term, exactly 0 at D = 0.
    let c = sqrt(1.0lf - (d.x * d.x + d.y * d.y));
    let dot = (d.x * s.q + d.y * s.u) / (1.0lf + c);
    return Stokes(s.i + d.x * s.q + d.y * s.u, d.x * s.i + c * s.q + d.x * dot, d.y * s.i + c * s.u + d.y * dot, c * s.v);
}
