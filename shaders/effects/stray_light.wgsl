// stray_light — veiling glare toward the sun.
// CPU twin and physics doc: crates/bpins-core/src/effects/stray_light.rs.
//   I' = I + a·κ/(κ + 1 − cos γ), cos γ = d·sun, κ = 0.05; Q, U, V unchanged.

const STRAY_LIGHT_KAPPA: f64 = 0.05lf;

// Adds the glare along the ray g to its Stokes vector (any frame); p = (a, sun x, y, z).
fn stray_light(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes {
    // cos γ between the ray and the sun; 0·… = 0 glare where a = 0 (exact identity).
    let cos_g = p.y * g.d.x + p.z * g.d.y + p.w * g.d.z;
    let glare = p.x * (STRAY_LIGHT_KAPPA / (STRAY_LIGHT_KAPPA + 1.0lf - cos_g));
    return Stokes(s.i + glare, s.q, s.u, s.v);
}
