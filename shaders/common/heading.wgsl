// Heading sums: one sample's contribution to the sums both extractors solve from.
// CPU twin: crates/bpins-core/src/heading/mod.rs (`contribution`, `sector_of`,
// `HeadingSums::add`), same steps. Per sample, along the *assumed* ray:
//   (I, Q_p, U_p) ← image → meridional frame; lens ρ inverted if known (eq. 13)
//   scatter  w e eᵀ, e = cos φ p − sin φ s, w = P² (φ = AoE)            camera frame
//   band     ψ = AoE − 90° = ½ atan2(−U_p, −Q_p) where |ψ| ≤ band, in a disc around
//            the principal point: Σ s², Σ sc, Σ c², Σ ψs, Σ ψc, Σ ψ², n per sector of β

const SECTORS: u32 = 16u;
// Per (frame, context) sums: 6 scatter terms, n, then 16 sectors × 7 band sums.
const SUMS_LEN: u32 = 119u;

// Keep in sync with `HeadingParams` in crates/bpins-gpu/src/params.rs.
struct HeadingParams {
    camera: Wide4,  // assumed f_px, cx_px, cy_px, projection id
    distortion: Wide4, // assumed radial distortion k1, k2, 0, 0
    band: Wide4,    // known lens rho2 (0: not compensated), cos 2·band, r_min_px², r_max_px²
    grid: Wide4,    // sample (i, j) sits at (x0 + step·i, y0 + step·j) px: x0, y0, step, enabled (0/1)
}

struct Contribution {
    m: array<f64, 6>,
    n: f64,
    qp: f64,
    up: f64,
    pol: f64,
    cos2b: f64,
    sin2b: f64,
}

// One sample's contribution: image-frame Stokes s seen along the assumed ray g;
// `ok` false for a masked sample (the CPU's NaN intensity).
fn contribution(lens_rho2: f64, g: RayGeometry, s: Stokes, ok: bool) -> Contribution {
    let b = g.basis;
    // Image → meridional frame; undo a known lens diattenuation (seed eq. 13).
    var sm = image_to_meridional(s, b.cos2b, b.sin2b);
    if (lens_rho2 != 0.0lf) {
        sm = lens_diattenuation_inverse(lens_rho2, g.r2, sm);
    }
    let p2 = sm.q * sm.q + sm.u * sm.u;
    let valid = ok && p2 > 0.0lf && sm.i > 0.0lf;
    let pol = sqrt(p2);
    // w e eᵀ without half angles: P² cos 2φ = P·Q_p, P² sin 2φ = P·U_p.
    let wa = 0.5lf * (p2 + pol * sm.q);
    let wb = 0.5lf * (p2 - pol * sm.q);
    let wc = -0.5lf * pol * sm.u;
    let p = b.p;
    let q = b.s;
    var m = array<f64, 6>(0.0lf, 0.0lf, 0.0lf, 0.0lf, 0.0lf, 0.0lf);
    if (valid) {
        m[0] = wa * p.x * p.x + wb * q.x * q.x + wc * (p.x * q.x + q.x * p.x);
        m[1] = wa * p.x * p.y + wb * q.x * q.y + wc * (p.x * q.y + q.x * p.y);
        m[2] = wa * p.x * p.z + wb * q.x * q.z + wc * (p.x * q.z + q.x * p.z);
        m[3] = wa * p.y * p.y + wb * q.y * q.y + wc * (p.y * q.y + q.y * p.y);
        m[4] = wa * p.y * p.z + wb * q.y * q.z + wc * (p.y * q.z + q.y * p.z);
        m[5] = wa * p.z * p.z + wb * q.z * q.z + wc * (p.z * q.z + q.z * p.z);
    }
    return Contribution(m, select(0.0lf, 1.0lf, valid), sm.q, sm.u, pol, b.cos2b, b.sin2b);
}

// Sector (0..SECTORS) of image angle beta_rad ∈ (−π, π].
fn sector_of(beta_rad: f64) -> u32 {
    let b = select(beta_rad, beta_rad + TAU_F64, beta_rad < 0.0lf);
    return min(u32(floor(b / TAU_F64 * f64(SECTORS))), SECTORS - 1u);
}

// Whether a sample at (dx, dy) px from the assumed principal point is in the meridian
// band (as HeadingSums::add decides it: cos 2ψ = −Q_p/P ≥ cos 2·band, inside the disc).
fn in_band(hp: vec4<f64>, c: Contribution, dx: f64, dy: f64) -> bool {
    let r2_px = dx * dx + dy * dy;
    return c.n != 0.0lf && !(-c.qp < hp.y * c.pol) && r2_px >= hp.z && r2_px <= hp.w;
}

// The 7 band sums of one band sample (ψ regressed on sin 2β, cos 2β).
fn band_terms(c: Contribution) -> array<f64, 7> {
    let psi = 0.5lf * atan2_f64(-c.up, -c.qp);
    let sb = c.sin2b;
    let cb = c.cos2b;
    return array<f64, 7>(sb * sb, sb * cb, cb * cb, psi * sb, psi * cb, psi * psi, 1.0lf);
}
