// lens_diattenuation — the lens transmits p and s polarizations unequally.
// CPU twin and physics doc: crates/bpins-core/src/effects/lens_diattenuation.rs.
//   ρ = rho2·r² (clamped to ±0.999), M = [[1, ρ, 0], [ρ, 1, 0], [0, 0, √(1 − ρ²)]]
// on (I, Q_p, U_p), meridional frame; seed paper §2.2 eq. 10, inverse eq. 13.

const RHO_LIMIT: f64 = 0.999lf;

fn rho_at(rho2: f64, r2: f64) -> f64 {
    return min(max(rho2 * r2, -RHO_LIMIT), RHO_LIMIT);
}

// Applies the lens Mueller matrix to a meridional-frame Stokes vector; p = (rho2, 0, 0, 0).
fn lens_diattenuation(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes {
    // ρ at the ray's squared normalised radius, clamped below 1.
    let rho = rho_at(p.x, g.r2);
    let c = sqrt(1.0lf - rho * rho);
    return Stokes(s.i + rho * s.q, rho * s.i + s.q, c * s.u, c * s.v);
}

// Inverts the lens Mueller matrix (seed eq. 13: reconstruction with ρ known).
fn lens_diattenuation_inverse(rho2: f64, r2: f64, s: Stokes) -> Stokes {
    let rho = rho_at(rho2, r2);
    let det = 1.0lf - rho * rho;
    let c = sqrt(det);
    return Stokes((s.i - rho * s.q) / det, (s.q - rho * s.i) / det, s.u / c, s.v / c);
}
