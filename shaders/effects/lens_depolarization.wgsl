// lens_depolarization — the lens scrambles part of the polarization toward the edge.
// CPU twin and physics doc: crates/bpins-core/src/effects/lens_depolarization.rs.
//   M = diag(1, a, a, a), a = max(1 − p2·r², 0), any frame (isotropic).

fn lens_depolarization(p2: f64, r2: f64, s: Stokes) -> Stokes {
    // Retained polarized fraction a = 1 − p2·r², at least 0; exactly 1 at p2 = 0.
    let a = max(1.0lf - p2 * r2, 0.0lf);
    return Stokes(s.i, a * s.q, a * s.u, a * s.v);
}
