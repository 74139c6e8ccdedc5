// Single-scattering Rayleigh sky in the ray's meridional frame.
// CPU twin: crates/bpins-core/src/sky/rayleigh.rs (`sky_stokes`), same steps.
//   radiance ∝ ½(1 + cos²γ), DoLP = d_max sin²γ/(1 + cos²γ), E ⊥ (sun, view)
//   e = sun × view; I = ½(1 + cos²γ), Q_p = ½ d_max (e_p² − e_s²), U_p = −d_max e_p e_s
// (division-free form; seed paper eq. 1–3). Units: relative radiance.

// The sky Stokes vector s with its radiance shaped by (a1, a2) at cos γ = cos_gamma
// (a per-frame nuisance of the fit; 0 in simulation). CPU twin: sky/radiance_shape.rs.
fn radiance_shape(a1: f64, a2: f64, cos_gamma: f64, s: Stokes) -> Stokes {
    // Shape factor 1 + a1 cos γ + a2 cos²γ, at least 0; exactly 1 at a1 = a2 = 0.
    let k = max(1.0lf + a1 * cos_gamma + a2 * cos_gamma * cos_gamma, 0.0lf);
    return Stokes(k * s.i, k * s.q, k * s.u, k * s.v);
}

fn sky_stokes(sun: vec3<f64>, dmax: f64, view: vec3<f64>, basis: MeridionalBasis) -> Stokes {
    let cg = dot3(sun, view);
    let cg2 = cg * cg;
    let radiance = 0.5lf * (1.0lf + cg2);
    let e = cross3(sun, view);
    let ep = dot3(e, basis.p);
    let es = dot3(e, basis.s);
    return Stokes(radiance, 0.5lf * dmax * (ep * ep - es * es), -dmax * ep * es, 0.0lf);
}
