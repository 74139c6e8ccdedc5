// window — a tilted flat window (or decentred dome) in front of the lens.
// CPU twin and physics doc: crates/bpins-core/src/effects/window.rs.
//   D = 2 p_z (k·p_xy, k·s_xy), k = (kx, ky) = κ·tilt; Fresnel plate to first order in
//   the tilt; M = [[1, Dᵀ, 0], [D, c·1 + D Dᵀ/(1 + c), 0], [0, 0, c]], c = √(1 − |D|²),
//   on (I, Q_p, U_p, V) in the ray's meridional frame.

const WINDOW_D_LIMIT: f64 = 0.999lf;

// The window's diattenuation vector (D_q, D_u) along the ray g, clamped to |D| ≤ 0.999.
fn window_diattenuation(p: vec4<f64>, g: RayGeometry) -> vec2<f64> {
    // D = 2 p_z (k·p_xy, k·s_xy): the first-order tilt term of κ((n·p)² − (n·s)², 2(n·p)(n·s)).
    let dq = 2.0lf * g.basis.p.z * (p.x * g.basis.p.x + p.y * g.basis.p.y);
    let du = 2.0lf * g.basis.p.z * (p.x * g.basis.s.x + p.y * g.basis.s.y);
    // Clamp |D| below 1 (a perfect polarizer has no inverse); exactly D where |D| ≤ limit.
    let d2 = dq * dq + du * du;
    var scale = 1.0lf;
    if (d2 > WINDOW_D_LIMIT * WINDOW_D_LIMIT) {
        scale = WINDOW_D_LIMIT / sqrt(d2);
    }
    return vec2<f64>(dq * scale, du * scale);
}

// Applies the window's diattenuator to a meridional-frame Stokes vector; p = (kx, ky, 0, 0).
fn window(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes {
    // Diattenuation vector D along this ray.
    let d = window_diattenuation(p, g);
    // c = √(1 − |D|²); D Dᵀ/(1 + c) is the (1 − c) D̂ D̂ᵀ term, exactly 0 at D = 0.
    let c = sqrt(1.0lf - (d.x * d.x + d.y * d.y));
    let dot = (d.x * s.q + d.y * s.u) / (1.0lf + c);
    return Stokes(s.i + d.x * s.q + d.y * s.u, d.x * s.i + c * s.q + d.x * dot, d.y * s.i + c * s.u + d.y * dot, c * s.v);
}
