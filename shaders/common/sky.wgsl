// Single-scattering Rayleigh sky in the ray's meridional frame.
// CPU twin: crates/bpins-core/src/sky/rayleigh.rs (`sky_stokes`), same steps.
//   radiance ∝ ½(1 + cos²γ), DoLP = d_max sin²γ/(1 + cos²γ), E ⊥ (sun, view)
//   e = sun × view; I = ½(1 + cos²γ), Q_p = ½ d_max (e_p² − e_s²), U_p = −d_max e_p e_s
// (division-free form; seed paper eq. 1–3). Units: relative radiance.

fn sky_stokes(sun: vec3<f64>, dmax: f64, view: vec3<f64>, basis: MeridionalBasis) -> Stokes {
    let cg = dot3(sun, view);
    let cg2 = cg * cg;
    let radiance = 0.5lf * (1.0lf + cg2);
    let e = cross3(sun, view);
    let ep = dot3(e, basis.p);
    let es = dot3(e, basis.s);
    return Stokes(radiance, 0.5lf * dmax * (ep * ep - es * es), -dmax * ep * es, 0.0lf);
}
