// lens_retardance — the lens delays s against p (a linear retarder, fast axis p).
// CPU twin and physics doc: crates/bpins-core/src/effects/lens_retardance.rs.
//   δ = delta2·r²; U' = U cos δ + V sin δ, V' = −U sin δ + V cos δ; meridional frame.

// Applies the retarder to a meridional-frame Stokes vector; p = (delta2 in rad per r², 0, 0, 0).
fn lens_retardance(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes {
    // Retardance δ = delta2·r² at the ray, fast axis p; reduced to [−π, π] for
    // sin_cos_f64 (the CPU's libm reduces internally).
    let d = p.x * g.r2;
    let sc = sin_cos_f64(d - TAU_F64 * round(d / TAU_F64));
    return Stokes(s.i, s.q, sc.y * s.u + sc.x * s.v, -sc.x * s.u + sc.y * s.v);
}
