// Stokes vectors and the micro-polarizer analyzers. CPU twin: crates/bpins-core/src/stokes.rs.
// Frames: "image" = Q referred to image +x, "meridional" = Q referred to the ray's p.

struct Stokes {
    i: f64,
    q: f64,
    u: f64,
    v: f64,
}

// Rotates a meridional-frame Stokes vector into the image frame (rotation by 2β).
fn meridional_to_image(s: Stokes, cos2b: f64, sin2b: f64) -> Stokes {
    return Stokes(s.i, s.q * cos2b - s.u * sin2b, s.q * sin2b + s.u * cos2b, s.v);
}

// Inverse of meridional_to_image.
fn image_to_meridional(s: Stokes, cos2b: f64, sin2b: f64) -> Stokes {
    return Stokes(s.i, s.q * cos2b + s.u * sin2b, -s.q * sin2b + s.u * cos2b, s.v);
}

// One analyzer: cos 2θ, sin 2θ of its (true) angle and ε = 1/ER.
struct Analyzer {
    cos2t: f64,
    sin2t: f64,
    eps: f64,
}

// Intensity behind a partial polarizer: ½[(1+ε) I + (1−ε)(Q cos 2θ + U sin 2θ)].
fn analyzer_intensity(s: Stokes, a: Analyzer) -> f64 {
    return 0.5lf * ((1.0lf + a.eps) * s.i + (1.0lf - a.eps) * (s.q * a.cos2t + s.u * a.sin2t));
}

// Angle of polarization in (−90°, 90°], radians (as Stokes::aop_rad).
fn aop_rad(s: Stokes) -> f64 {
    let a = 0.5lf * atan2_f64(s.u, s.q);
    return select(a, a + PI_F64, a <= -HALF_PI_F64);
}

fn dolp(s: Stokes) -> f64 {
    return select(0.0lf, sqrt(s.q * s.q + s.u * s.u) / s.i, s.i > 0.0lf);
}
