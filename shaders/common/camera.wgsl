// Camera geometry: pixel → ray and its meridional basis, camera frame (x columns,
// y rows down, z optical axis). CPU twin: crates/bpins-core/src/camera.rs
// (`Intrinsics::geometry`, `ray_geometry`) — same steps, same names.
// Projections r = f_px·g(θ): pinhole tan θ, equidistant θ, equisolid 2 sin(θ/2),
// stereographic 2 tan(θ/2) (CONVENTIONS.md). The fisheyes' sin θ, cos θ come in
// closed form from r (equisolid, stereographic) or from sin_cos_f64 (equidistant).

const PROJ_PINHOLE: u32 = 0u;
const PROJ_EQUIDISTANT: u32 = 1u;
const PROJ_EQUISOLID: u32 = 2u;
const PROJ_STEREOGRAPHIC: u32 = 3u;

struct Intrinsics {
    projection: u32,
    f_px: f64,
    cx_px: f64,
    cy_px: f64,
    distortion: vec2<f64>, // radial (k1, k2): distorted = ideal·(1 + k1 r² + k2 r⁴)
}

// (f_px, cx_px, cy_px, projection) and (k1, k2, 0, 0) as the host packs them.
fn intrinsics_from(w: Wide4, k: Wide4) -> Intrinsics {
    let x = wide(w);
    return Intrinsics(u32(w.hi.w), x.x, x.y, x.z, wide(k).xy);
}

// Ideal normalised coordinates of the distorted ones: r·(1 + k1 r² + k2 r⁴) = r_d by
// twelve Newton steps from r = min(r_d, r_fold), each kept in [0, r_fold]; beyond the
// distortion's fold a pixel sees the fold's ray (camera::undistort).
fn undistort(k: vec2<f64>, xd: f64, yd: f64) -> vec2<f64> {
    let rd = sqrt(xd * xd + yd * yd);
    let fold = distortion_fold(k);
    var r = select(rd, min(rd, fold.x), fold.y != 0.0lf);
    for (var n = 0; n < 12; n++) {
        let r2 = r * r;
        let slope = 1.0lf + 3.0lf * k.x * r2 + 5.0lf * k.y * r2 * r2;
        // At the fold (slope 0) the step is undefined: r stays.
        var next = max(r - (r * (1.0lf + k.x * r2 + k.y * r2 * r2) - rd) / slope, 0.0lf);
        next = select(next, min(next, fold.x), fold.y != 0.0lf);
        r = select(r, next, slope > 0.0lf);
    }
    let scale = select(1.0lf, r / rd, rd > 0.0lf);
    return vec2<f64>(xd * scale, yd * scale);
}

// (r_fold, 1) for the smallest r > 0 where 1 + 3 k1 r² + 5 k2 r⁴ = 0, or (0, 0) where
// the distortion never folds (camera::distortion_fold_r): with s = r², the roots of
// 5 k2 s² + 3 k1 s + 1 = 0 are 2 / (−3 k1 ∓ √(9 k1² − 20 k2)).
fn distortion_fold(k: vec2<f64>) -> vec2<f64> {
    let b = 3.0lf * k.x;
    let disc = b * b - 20.0lf * k.y;
    let d = select(-b + sqrt(max(disc, 0.0lf)), 0.0lf, disc < 0.0lf);
    let has = d > 0.0lf;
    return vec2<f64>(select(0.0lf, sqrt(2.0lf / select(1.0lf, d, has)), has), select(0.0lf, 1.0lf, has));
}

struct MeridionalBasis {
    p: vec3<f64>,
    s: vec3<f64>,
    cos2b: f64,
    sin2b: f64,
}

struct RayGeometry {
    d: vec3<f64>,
    basis: MeridionalBasis,
    r2: f64,
}

fn ray_geometry(ca: f64, sa: f64, st: f64, ct: f64, r2: f64) -> RayGeometry {
    let basis = MeridionalBasis(vec3<f64>(ct * ca, ct * sa, -st), vec3<f64>(-sa, ca, 0.0lf), ca * ca - sa * sa, -2.0lf * ca * sa);
    return RayGeometry(vec3<f64>(st * ca, st * sa, ct), basis, r2);
}

// Pipeline constants of the kernels that set them (frame_sums, sums.rs `SumsVariant`):
// the projection id every camera of the dispatch has (4: they differ, each camera's
// own), and 0 where no camera of the dispatch has a radial distortion. llvmpipe runs
// the untaken side of a uniform branch under a lane mask (every projection and the
// twelve Newton steps of undistort for every ray); a constant removes it at compile time.
override CAMERA_PROJECTION: u32 = 4u;
override CAMERA_DISTORTION: u32 = 1u;

// Ray, meridional basis and squared normalised radius of pixel (u, v).
fn geometry(intr: Intrinsics, u_px: f64, v_px: f64) -> RayGeometry {
    var xn = (u_px - intr.cx_px) / intr.f_px;
    var yn = (v_px - intr.cy_px) / intr.f_px;
    // The lens's radial distortion removed (radial_distortion).
    if (CAMERA_DISTORTION != 0u && any(intr.distortion != vec2<f64>(0.0lf))) {
        let n = undistort(intr.distortion, xn, yn);
        xn = n.x;
        yn = n.y;
    }
    let r2 = xn * xn + yn * yn;
    // On the axis the radial direction defaults to image +x (β = 0) and θ = 0.
    let on_axis = r2 == 0.0lf;
    let inv_r = select(1.0lf / sqrt(r2), 0.0lf, on_axis);
    let ca = select(xn * inv_r, 1.0lf, on_axis);
    let sa = select(yn * inv_r, 0.0lf, on_axis);
    let r = r2 * inv_r;
    var st: f64;
    var ct: f64;
    // The projection (the dispatch's constant where it has one).
    let projection = select(intr.projection, CAMERA_PROJECTION, CAMERA_PROJECTION < 4u);
    switch projection {
        case 0u: {
            // tan θ = r: cos θ = 1/√(1 + r²), sin θ = r cos θ.
            ct = 1.0lf / sqrt(1.0lf + r2);
            st = r2 * inv_r * ct;
        }
        case 1u: {
            // θ = r, beyond the domain (θ ≥ π) the rim.
            let sc = sin_cos_f64(min(r, PI_F64));
            st = select(sc.x, 0.0lf, r >= PI_F64);
            ct = select(sc.y, -1.0lf, r >= PI_F64);
        }
        case 2u: {
            // sin(θ/2) = r/2: sin θ = r √(1 − r²/4), cos θ = 1 − r²/2; r ≥ 2 is the rim.
            let rim = r >= 2.0lf;
            st = select(r * sqrt(max(1.0lf - 0.25lf * r2, 0.0lf)), 0.0lf, rim);
            ct = select(1.0lf - 0.5lf * r2, -1.0lf, rim);
        }
        default: {
            // tan(θ/2) = r/2 = t: sin θ = 2t/(1 + t²), cos θ = (1 − t²)/(1 + t²).
            let t = 0.5lf * r;
            let den = 1.0lf + t * t;
            st = 2.0lf * t / den;
            ct = (1.0lf - t * t) / den;
        }
    }
    return ray_geometry(ca, sa, st, ct, r2);
}

// Image angle β of the offset (du, dv) px: counter-clockwise from image +x as seen
// in the displayed image (v down), CONVENTIONS.md.
fn image_angle_rad(du_px: f64, dv_px: f64) -> f64 {
    return atan2_f64(-dv_px, du_px);
}
