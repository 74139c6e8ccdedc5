// vignetting — the lens passes less light toward the edge of the field.
// CPU twin and physics doc: crates/bpins-core/src/effects/vignetting.rs.
//   S_out = S_in · max(1 + v2·r² + v4·r⁴, 0), any frame (a scalar).

fn vignetting(v2: f64, v4: f64, r2: f64, s: Stokes) -> Stokes {
    let k = max(1.0lf + v2 * r2 + v4 * r2 * r2, 0.0lf);
    return Stokes(k * s.i, k * s.q, k * s.u, k * s.v);
}
