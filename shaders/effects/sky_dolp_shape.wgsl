// sky_dolp_shape — an unpolarized diffuse share t flattens the sky's DoLP fall-off.
// CPU twin and physics doc: crates/bpins-core/src/effects/sky_dolp_shape.rs.
//   DoLP = d_max·w/(1 + (1 − t)(1 − w)), w = |ω| (sin²γ on a Rayleigh sky); from the
//   sky step's p = DoLP/d_max = w/(2 − w): p' = p/(1 − ½t(1 − p)); I unchanged.

// The sky's Stokes vector s with its DoLP reshaped by the diffuse share t = p[0].x
// (dolp_shape); exactly s at t = 0.
fn sky_dolp_shape(p: array<vec4<f64>, 5>, sun: vec3<f64>, dmax: f64, g: RayGeometry, s: Stokes) -> Stokes {
    if (p[0].x == 0.0lf) {
        return s;
    }
    return dolp_shape(p[0].x, dmax, s);
}

// The sky's Stokes vector s (meridional frame, peak DoLP dmax) with its DoLP reshaped
// by the diffuse share t; I and V kept.
fn dolp_shape(t: f64, dmax: f64, s: Stokes) -> Stokes {
    // The sky step's DoLP over d_max: p = w/(2 − w) ∈ [0, 1] (0 where there is no
    // polarization to reshape).
    let den = s.i * dmax;
    var p = 0.0lf;
    if (den > 0.0lf) {
        p = min(sqrt(s.q * s.q + s.u * s.u) / den, 1.0lf);
    }
    // p' = p/(1 − ½t(1 − p)): Q and U by the factor p'/p, exactly 1 at t = 0.
    let k = 1.0lf / (1.0lf - 0.5lf * t * (1.0lf - p));
    return Stokes(s.i, k * s.q, k * s.u, s.v);
}
