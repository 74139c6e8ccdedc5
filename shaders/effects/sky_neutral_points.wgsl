// sky_neutral_points — the Berry–Dennis–Lee quartic sky (neutral points split).
// CPU twin and physics doc: crates/bpins-core/src/effects/sky_neutral_points.rs.
//   ξ = (E + iN)/(1 + U); ω·e^{−2iA} = −4 Π (ξ c_P − s_P e^{iA}) e^{−2iA} / (1 + |ξ|²)²
//   χ = ½ arg(ω e^{−2iA}), DoLP = d_max |ω|/(2 − |ω|), radiance as Rayleigh.

// The frame constants, from the effect's vector (NeutralPoints::to_params on the host).
struct NeutralPoints {
    east: vec3<f64>,
    north: vec3<f64>,
    up: vec3<f64>,
    half_angles: array<vec2<f64>, 4>, // (cos θ_P/2, sin θ_P/2)
    eia: vec2<f64>,                   // (cos A, sin A)
}

fn cmul(a: vec2<f64>, b: vec2<f64>) -> vec2<f64> {
    return vec2<f64>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

// The quartic sky along the ray g in place of the sky so far s where it is on (p[0].w = 1:
// the frame's constants, NeutralPoints::to_params); s itself otherwise.
fn sky_neutral_points(p: array<vec4<f64>, 5>, sun: vec3<f64>, dmax: f64, g: RayGeometry, s: Stokes) -> Stokes {
    if (p[0].w == 0.0lf) {
        return s;
    }
    let np = NeutralPoints(p[0].xyz, p[1].xyz, p[2].xyz, array<vec2<f64>, 4>(p[3].xy, p[3].zw, p[4].xy, p[4].zw),
        vec2<f64>(p[1].w, p[2].w));
    return quartic_sky(np, sun, dmax, g.d, g.basis);
}

fn quartic_sky(np: NeutralPoints, sun: vec3<f64>, dmax: f64, view: vec3<f64>, basis: MeridionalBasis) -> Stokes {
    // Radiance as Rayleigh.
    let cg = dot3(sun, view);
    let radiance = 0.5lf * (1.0lf + cg * cg);
    // The ray in the stereographic chart of the ENU world.
    let e = dot3(view, np.east);
    let n = dot3(view, np.north);
    let u = dot3(view, np.up);
    let den = 1.0lf + u;
    if (den <= 1e-12lf) {
        return Stokes(radiance, 0.0lf, 0.0lf, 0.0lf); // the nadir: the chart's pole
    }
    let x = e / den;
    let y = n / den;
    let rho2 = x * x + y * y;
    // ω·e^{−2iA} = −4 Π (ξ c_P − s_P e^{iA}) e^{−2iA} / (1 + |ξ|²)².
    var w = vec2<f64>(-4.0lf, 0.0lf);
    for (var k = 0; k < 4; k++) {
        let cs = np.half_angles[k];
        w = cmul(w, vec2<f64>(x * cs.x - cs.y * np.eia.x, y * cs.x - cs.y * np.eia.y));
    }
    let e2 = vec2<f64>(np.eia.x * np.eia.x - np.eia.y * np.eia.y, 2.0lf * np.eia.x * np.eia.y);
    w = cmul(w, vec2<f64>(e2.x, -e2.y));
    let kk = 1.0lf / ((1.0lf + rho2) * (1.0lf + rho2));
    w = w * kk;
    let mag = sqrt(w.x * w.x + w.y * w.y);
    if (mag == 0.0lf) {
        return Stokes(radiance, 0.0lf, 0.0lf, 0.0lf); // a neutral point
    }
    // cos 2χ, sin 2χ of the E-vector in the chart.
    let c2 = w.x / mag;
    let s2 = w.y / mag;
    // Unit tangents of the chart's x and y directions at ξ (ENU → camera frame).
    let q = 1.0lf / (1.0lf + rho2);
    let tx = (np.east * (1.0lf - x * x + y * y) + np.north * (-2.0lf * x * y) + np.up * (-2.0lf * x)) * q;
    let ty = (np.east * (-2.0lf * x * y) + np.north * (1.0lf + x * x - y * y) + np.up * (-2.0lf * y)) * q;
    let a = dot3(tx, basis.p);
    let b = dot3(ty, basis.p);
    let c = dot3(tx, basis.s);
    let d = dot3(ty, basis.s);
    // e = cos χ tx + sin χ ty: cos 2φ = (e·p)² − (e·s)², sin 2φ = −2 (e·p)(e·s).
    let cos2phi = 0.5lf * ((a * a - c * c) + (b * b - d * d)) + 0.5lf * c2 * ((a * a - c * c) - (b * b - d * d))
        + s2 * (a * b - c * d);
    let sin2phi = -((a * c + b * d) + c2 * (a * c - b * d) + s2 * (a * d + b * c));
    // Polarized radiance I·DoLP, DoLP = d_max |ω|/(2 − |ω|).
    let pol = radiance * dmax * mag / (2.0lf - mag);
    return Stokes(radiance, pol * cos2phi, pol * sin2phi, 0.0lf);
}
