// lens_depolarization — the lens scrambles part of the polarization toward the edge.
// CPU twin and physics doc: crates/bpins-core/src/effects/lens_depolarization.rs.
//   M = diag(1, a, a, a), a = max(1 − p2·r², 0), any frame (isotropic).

// Applies the depolarizer to the ray's Stokes vector (any frame); p = (p2, 0, 0, 0).
fn lens_depolarization(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes {
    // Retained polarized fraction a = 1 − p2·r², at least 0; exactly 1 at p2 = 0.
    let a = max(1.0lf - p.x * g.r2, 0.0lf);
    return Stokes(s.i, a * s.q, a * s.u, a * s.v);
}
