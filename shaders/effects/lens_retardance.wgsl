// lens_retardance — the lens delays s against p (a linear retarder, fast axis p).
// CPU twin and physics doc: crates/bpins-core/src/effects/lens_retardance.rs.
//   δ = delta2·r²; U' = U cos δ + V sin δ, V' = −U sin δ + V cos δ; meridional frame.

fn lens_retardance(delta2_rad: f64, r2: f64, s: Stokes) -> Stokes {
    // δ reduced to [−π, π] for sin_cos_f64 (the CPU's libm reduces internally).
    let d = delta2_rad * r2;
    let sc = sin_cos_f64(d - TAU_F64 * round(d / TAU_F64));
    return Stokes(s.i, s.q, sc.y * s.u + sc.x * s.v, -sc.x * s.u + sc.y * s.v);
}
