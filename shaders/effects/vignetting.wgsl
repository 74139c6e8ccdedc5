// vignetting — the lens passes less light toward the edge of the field.
// CPU twin and physics doc: crates/bpins-core/src/effects/vignetting.rs.
//   S_out = S_in · max(1 + v2·r² + v4·r⁴, 0), any frame (a scalar).

// Applies the radial falloff to the ray's Stokes vector (any frame); p = (v2, v4, 0, 0).
fn vignetting(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes {
    // Falloff factor at the ray's squared normalised radius, at least 0.
    let k = max(1.0lf + p.x * g.r2 + p.y * g.r2 * g.r2, 0.0lf);
    return Stokes(k * s.i, k * s.q, k * s.u, k * s.v);
}
