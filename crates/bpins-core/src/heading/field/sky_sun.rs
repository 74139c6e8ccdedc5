//! The sun as the sky shows it, with no sun given: its bearing from the image top and
//! its elevation, each with its 1σ — the measurement `crate::locate` builds a place
//! and true north from.
//!
//! ```text
//! 1. start: the sun vector of every observed cell (least eigenvector of
//!    Σ w e eᵀ, w = 1/(σ_α² + 0.3°²), level frame, the branch above the horizon);
//!    its elevation h₀
//! 2. the field estimator's robust loop (mod.rs, steps 3–4) at the sun (A = 0, h),
//!    any elevation offset allowed; h ← h + the sky's own elevation offset
//!    (`FieldQuality::sun_elevation_offset_deg`), until it moves by < 0.02° (≤ 6 rounds)
//! 3. bearing b = −ψ (with A = 0 the heading ψ is minus the sun's bearing); its 1σ the
//!    field heading's (step 5 of mod.rs, no sun or tilt σ other than the frame's tilt)
//! 4. elevation h = asin(s_z) of the final weighted sun vector s; its 1σ² =
//!    max(σ_fit, σ_jack, σ_coherent·cos h)² + σ_shared² + σ_tilt² + σ_floor²: σ_fit the
//!    eigenvector's rotation toward the zenith (sun_vector.rs's formula with the
//!    vertical tangent u: σ₀²·Σ_k (u·v_k)²/(λ_k − λ₀)), σ_jack the delete-one-block
//!    jackknife of h over the 4 × 4 blocks, σ_coherent the heading's (spatial.rs);
//!    σ_shared = m·√(W·Σ_k (u·v_k)²/(λ_k − λ₀)) for the used cells' RMS residual m
//!    beyond their noise taken as shared by every cell (W = Σw: n coherent terms do
//!    not average out; a narrow view near the zenith amplifies them, since its
//!    E-vectors are nearly level); σ_tilt = the tilt's 1σ (a tilt about the horizontal
//!    axis across the sun moves h 1:1)
//! 5. the neutral points as a nuisance: Berry, Dennis & Lee's quartic sky (the
//!    `sky_neutral_points` effect's model) fitted to the same cells with the same final
//!    weights, unknowns the sun's level azimuth α, its elevation h and q = sin²(s/4)
//!    of the neutral points' separation s (q enters the E-vector field linearly, so
//!    it is free through 0, Rayleigh's sky); Levenberg–Marquardt from step 4's sun and
//!    q = 0. Where the split is seen (|q| > 3σ_q) the elevation is the quartic fit's
//!    h, its 1σ² = step 4's (with the quartic fit's misfit m where smaller) + σ_n²,
//!    σ_n² = C_hh − C_hh|q the variance the free q adds (marginal minus conditional,
//!    C = (JᵀJ)⁻¹·max(1, χ²/dof)); else step 4's elevation and 1σ stand (a Rayleigh
//!    sky pays nothing: the quartic h is 1.5× noisier there). A split too small to be
//!    seen biases step 4's h little: the change of the pattern is second order in s
//!    (q = sin²(s/4)), so 3σ_q (s ≈ 4°–5° in the ±28° view) moves h by ≈ 0.05°–0.08°
//!    (scaled from the 2.8° at 30°); σ_n goes to `locate` as a bias shared by all
//!    frames (one sky, one separation)
//! ```
//!
//! Why step 5: with the neutral points 30° apart the Rayleigh sun's elevation is off
//! by ≈ 3° in a ±28° view near the zenith while the cells' residual stays small (the
//! pattern a little off the sun looks like Rayleigh's for a different sun); the free
//! separation takes that bias out and puts what the view cannot tell apart into the
//! 1σ (docs/locate.md: per frame 0.42° RMS against 2.8° read as Rayleigh's).
//!
//! Frame: the level camera (CONVENTIONS.md; the frame's reference tilt undone): the
//! bearing is the sun's azimuth minus the azimuth of the image top, degrees from
//! North toward East, in [0°, 360°); the elevation in degrees above the horizon; the
//! quartic sky's chart ξ = (x + iy)/(1 + z) of the level frame (sky_neutral_points.rs
//! uses ENU's; a turn about the vertical only turns the chart).
//!
//! Cannot: a separation that differs between the sun's and the anti-sun's pair, or a
//! sky other than Rayleigh's and Berry's quartic (the DoLP is not used: its maximum and
//! shape are not known); a sun within half a separation of the zenith (the quartic
//! model's own limit); tell the sun from the anti-sun when it stands below the horizon
//! (the branch above is taken), read a sun within 1° of the zenith (no bearing) or
//! below −10° (refused as by the heading); an elevation bias shared by every frame (a
//! mount tilt not in the calibration) passes into the latitude.

use super::robust::{self, Scratch};
use super::sigma::{self, block_sums, sum_blocks, BLOCKS};
use super::{Cells, FieldContext, FieldOptions, FieldQuality, FieldScratch, NoHeading};
use crate::conventions::{wrap_deg_180, wrap_deg_360, wrap_rad_90};
use crate::heading::{sun_vector, Extractor, HeadingSums};
use crate::lsq::{jackknife_sigma, Lm};
use glam::DVec3;
use nalgebra::Complex;

/// Rounds of step 2 at most, and the elevation step that ends them, degrees.
const ROUNDS: usize = 6;
const SETTLED_DEG: f64 = 0.02;
/// Per-cell model error of the start's weights, radians (as the start search's).
const START_SIGMA_RAD: f64 = 0.3 * std::f64::consts::PI / 180.0;

/// The sun one frame's sky shows, in the level camera frame, with 1σ.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SkySun {
    /// The sun's azimuth minus the camera's heading (the image top's azimuth), [0°, 360°).
    pub bearing_deg: f64,
    pub bearing_sigma_deg: f64,
    /// The sun's elevation above the level frame's horizon, degrees.
    pub elevation_deg: f64,
    pub elevation_sigma_deg: f64,
    /// The elevation and its 1σ a Rayleigh sky would give (steps 2–4, the separation
    /// held at 0), degrees.
    pub rayleigh_elevation_deg: f64,
    pub rayleigh_elevation_sigma_deg: f64,
    /// What the free separation adds to the elevation's 1σ, degrees (in
    /// `elevation_sigma_deg` where the split is seen; a sky's separation is shared by
    /// every frame of a sequence, so `locate` takes it as a shared bias).
    pub elevation_nuisance_sigma_deg: f64,
    /// The neutral points' separation the quartic sky fits (step 5; signed, negative a
    /// split across the solar vertical, 0 Rayleigh's) and its 1σ, degrees.
    pub separation_deg: f64,
    pub separation_sigma_deg: f64,
    pub quality: FieldQuality,
}

/// The sun of one frame's cells (see the module doc); `ctx`'s sun is ignored, its
/// camera and tilt are used. Errs with the field estimator's reasons (too little sky,
/// an ambiguous or misfitting one, a sun out of range).
pub fn sky_sun(
    cells: &Cells,
    ctx: &FieldContext,
    opts: &FieldOptions,
    scratch: &mut FieldScratch,
) -> Result<SkySun, NoHeading> {
    let sc = &mut scratch.robust;
    let mut ctx = FieldContext { sun_az_deg: 0.0, sun_sigma_deg: 0.0, ..*ctx };
    let lenient = FieldOptions { max_sun_offset_deg: 180.0, ..*opts };
    // Step 1.
    super::observe::observe(cells, &ctx, opts, ctx.level_from_camera(), &mut sc.slots, &mut sc.obs);
    let mut start = HeadingSums::default();
    for o in &sc.obs {
        start.add_scatter_weighted(o.e, 1.0 / (o.var_aop + START_SIGMA_RAD * START_SIGMA_RAD));
    }
    let quality0 = FieldQuality { cells_total: cells.grid_len(), cells_valid: sc.obs.len(), ..Default::default() };
    let (_, vecs) = sun_vector::scatter_eigen(&start).map_err(|_| too_little(quality0))?;
    let mut h = vecs[0].z.abs().clamp(0.0, 1.0).asin().to_degrees().clamp(0.5, 88.0);
    // Step 2.
    let mut r = None;
    for _ in 0..ROUNDS {
        ctx.sun_el_deg = h;
        let fit = robust::fitted(cells, &ctx, &lenient, sc).map_err(|e| e.1)?;
        let step = fit.quality.sun_elevation_offset_deg;
        h = (h + step).clamp(0.5, 88.0);
        r = Some(fit);
        if step.abs() < SETTLED_DEG {
            break;
        }
    }
    let r = r.expect("ROUNDS ≥ 1");
    // Step 3.
    let fh = sigma::heading(&r, Extractor::SunVector, cells, &ctx, opts, sc);
    let (psi, parts) = fh.result?;
    // Step 4.
    let (rayleigh_deg, rayleigh_sigma_deg) =
        elevation(sc, r.coherent_deg, r.misfit_rms_deg, ctx.tilt_sigma_deg, opts.sigma_floor_deg)
            .ok_or_else(|| NoHeading::Solver("the sky's sun vector is degenerate".into()))?;
    // Step 5.
    let q = quartic_fit(sc, psi, rayleigh_deg).ok_or_else(|| {
        NoHeading::Solver("the quartic sky (neutral points as a nuisance) could not be fitted".into())
    })?;
    let sigma_deg = if q.misfit_rms_deg < r.misfit_rms_deg {
        elevation(sc, r.coherent_deg, q.misfit_rms_deg, ctx.tilt_sigma_deg, opts.sigma_floor_deg)
            .map_or(rayleigh_sigma_deg, |x| x.1)
    } else {
        rayleigh_sigma_deg
    };
    Ok(SkySun {
        bearing_deg: wrap_deg_360(-psi),
        bearing_sigma_deg: parts.total_deg(),
        elevation_deg: if q.split { q.elevation_deg } else { rayleigh_deg },
        elevation_sigma_deg: if q.split { sigma_deg.hypot(q.nuisance_sigma_deg) } else { rayleigh_sigma_deg },
        rayleigh_elevation_deg: rayleigh_deg,
        rayleigh_elevation_sigma_deg: rayleigh_sigma_deg,
        elevation_nuisance_sigma_deg: q.nuisance_sigma_deg,
        separation_deg: q.separation_deg,
        separation_sigma_deg: q.separation_sigma_deg,
        quality: r.quality,
    })
}

/// Step 5's answer: the quartic sky's sun elevation, the 1σ its free separation adds
/// to it, and the separation (signed: negative is a split across the solar vertical).
#[derive(Clone, Copy, Debug, PartialEq)]
struct QuarticFit {
    elevation_deg: f64,
    nuisance_sigma_deg: f64,
    separation_deg: f64,
    separation_sigma_deg: f64,
    /// The used cells' RMS residual beyond their noise under the quartic sky, degrees
    /// (as `robust.rs`'s `misfit_rms_deg` under Rayleigh's).
    misfit_rms_deg: f64,
    /// Whether the split is seen: |q| over SPLIT_SIGMAS of its 1σ.
    split: bool,
}

/// A split the fit sees: |q| over this many of its 1σ.
const SPLIT_SIGMAS: f64 = 3.0;

/// Scale of the fitted separation parameter: p₂ = Q_SCALE·q, q = sin²(s/4).
const Q_SCALE: f64 = 100.0;
/// A separation past this (|q| of a 90° split) is no sky the quartic model describes.
const Q_MAX: f64 = 0.146_446_6;

/// The chart angle of the E-vector `e` at the unit ray `d` (level frame, z up): the
/// stereographic chart ξ = (x + iy)/(1 + z) (sky_neutral_points.rs), its differential
/// dξ = (e_x + i e_y)/(1 + z) − (x + iy)·e_z/(1 + z)²; arg dξ, radians (axial).
fn chart_angle(d: DVec3, e: DVec3) -> Option<f64> {
    let den = 1.0 + d.z;
    if den < 1e-9 {
        return None;
    }
    let dxi = Complex::new(e.x, e.y) / den - Complex::new(d.x, d.y) * (e.z / (den * den));
    Some(dxi.im.atan2(dxi.re))
}

/// The quartic sky's E-vector chart angle at the unit ray `d` (level frame), radians:
/// Berry, Dennis & Lee (2004) eq. 4.2 as sky_neutral_points.rs evaluates it, with the
/// two factors of each pair multiplied out: for the sun's pair (half angles u ± v,
/// u = θ_S/2, v = s/4, E = e^{iA})
///   (ξ cos(u−v) − E sin(u−v))(ξ cos(u+v) − E sin(u+v))
///     = ξ²(cos²u − q) − ξE sin 2u + E²(sin²u − q),   q = sin²v,
/// the anti-sun's the same with u + π/2; χ = ½ arg(−Π·E⁻²). q enters linearly (the
/// split is second order in s), so q < 0 (a split across the solar vertical) keeps
/// the fit smooth through the Rayleigh sky at q = 0.
fn quartic_angle(d: DVec3, azimuth_rad: f64, zenith_rad: f64, q: f64) -> f64 {
    let xi = Complex::new(d.x, d.y) / (1.0 + d.z).max(1e-12);
    let e = Complex::from_polar(1.0, azimuth_rad);
    let (su, cu) = (0.5 * zenith_rad).sin_cos();
    let s2u = zenith_rad.sin();
    let (xi2, xe, e2) = (xi * xi, xi * e, e * e);
    let sun = xi2 * (cu * cu - q) - xe * s2u + e2 * (su * su - q);
    let anti = xi2 * (su * su - q) + xe * s2u + e2 * (cu * cu - q);
    let w = -(sun * anti) * e2.conj();
    0.5 * w.im.atan2(w.re)
}

/// Step 5: the sun's azimuth α, elevation h and the neutral points' q fitted to the
/// used cells' E-vectors with their final weights (Levenberg–Marquardt from the
/// Rayleigh sun, q = 0). The 1σ the free q adds to h: √(C_hh − C_hh|q), the marginal
/// minus the conditional variance of (JᵀJ)⁻¹·max(1, χ²/dof).
fn quartic_fit(sc: &Scratch, psi_deg: f64, h_deg: f64) -> Option<QuarticFit> {
    // Level-frame sun for A = 0: s = (cos h·sin ψ, −cos h·cos ψ, sin h).
    let (sp, cp) = psi_deg.to_radians().sin_cos();
    let alpha0 = (-cp).atan2(sp).to_degrees();
    // (ray, chart angle, √weight, robust weight, noise variance) of the used cells.
    let cells: Vec<(DVec3, f64, f64, f64, f64)> = sc
        .obs
        .iter()
        .zip(&sc.b.w)
        .filter(|(_, w)| w.0 > 0.0)
        .filter_map(|(o, w)| Some((o.d, chart_angle(o.d, o.e)?, (w.0 / w.1).sqrt(), w.0, o.var_aop)))
        .collect();
    if cells.len() < 6 {
        return None;
    }
    let f = |p: &[f64; 3]| -> Option<Vec<f64>> {
        let (a, z, q) = (p[0].to_radians(), (90.0 - p[1]).to_radians(), p[2] / Q_SCALE);
        Some(cells.iter().map(|&(d, chi, sw, ..)| wrap_rad_90(chi - quartic_angle(d, a, z, q)) * sw).collect())
    };
    let fit = LM.solve([alpha0, h_deg, 0.0], &f)?;
    let p = fit.p;
    let q = p[2] / Q_SCALE;
    if !(p[1] > 0.0 && p[1] < 90.0 && q.abs() < Q_MAX) {
        return None;
    }
    let k = fit.chi2_per_dof().max(1.0);
    let cov = fit.covariance()?;
    let jtj = fit.jtj();
    let cond = k / (jtj[(1, 1)] - jtj[(0, 1)].powi(2) / jtj[(0, 0)]);
    let nuisance = (cov[1][1] - cond).max(0.0).sqrt();
    // s = 4·asin √|q|, signed; its 1σ the step of s that q's 1σ makes beyond |q|.
    let sigma_q = cov[2][2].sqrt() / Q_SCALE;
    let sep = |q: f64| 4.0 * q.abs().sqrt().min(1.0).asin().to_degrees() * q.signum();
    let separation_deg = sep(q);
    let separation_sigma_deg = sep(q.abs() + sigma_q) - sep(q.abs());
    // The misfit beyond the noise over the cells of weight ≥ ½, as robust.rs's.
    let (a, z, qq) = (p[0].to_radians(), (90.0 - p[1]).to_radians(), q);
    let (sw, swd2, noise) = cells.iter().filter(|c| c.3 >= 0.5).fold((0.0, 0.0, 0.0), |(s, d2, n), c| {
        let delta = wrap_rad_90(c.1 - quartic_angle(c.0, a, z, qq));
        (s + c.3, d2 + c.3 * delta * delta, n + c.3 * c.4)
    });
    let misfit_rms_deg = if sw > 0.0 { ((swd2 - noise).max(0.0) / sw).sqrt().to_degrees() } else { f64::NAN };
    Some(QuarticFit {
        elevation_deg: p[1],
        nuisance_sigma_deg: nuisance,
        separation_deg,
        separation_sigma_deg,
        misfit_rms_deg,
        split: q.abs() > SPLIT_SIGMAS * sigma_q,
    })
}

/// Step 5's Levenberg–Marquardt search ([`crate::lsq`]): central differences of 10⁻³
/// on (α°, h°, 100·q), up to 50 Jacobians of 10 damping tries each, until a step lowers
/// χ² by less than 10⁻⁹ of it.
const LM: Lm<3> = Lm { step: [1e-3; 3], iterations: 50, tries: 10, rel_tol: 1e-9, ridge: 0.0 };

fn too_little(q: FieldQuality) -> NoHeading {
    NoHeading::TooLittleSky { used: q.cells_valid, total: q.cells_total }
}

/// The sun above the horizon from level-frame sums: (elevation, fit 1σ, and the 1σ
/// per radian of a misfit every cell shares), degrees.
fn sun_elevation(sums: &HeadingSums, weight_sum: f64) -> Option<(f64, f64, f64)> {
    let (vals, vecs) = sun_vector::scatter_eigen(sums).ok()?;
    let s = if vecs[0].z < 0.0 { -vecs[0] } else { vecs[0] };
    // The vertical tangent at s (toward the zenith); the rotation of s toward the other
    // eigenvectors has variance σ₀²/(λ_k − λ₀), σ₀² = λ₀/(n − 2) (sun_vector.rs).
    let up = DVec3::Z - s * s.z;
    let up = if up.length() > 1e-9 { up.normalize() } else { return None };
    let sigma0_sq = vals[0].max(0.0) / (sums.n - 2.0).max(1.0);
    let gain: f64 = (1..3).map(|k| up.dot(vecs[k]).powi(2) / (vals[k] - vals[0])).sum();
    // A misfit δ shared by every cell moves s by up to δ·√(W·gain), W = Σw: the
    // coherent sum of n terms w·δ·(e·v_k) against λ_k − λ₀ ~ Σ w (e·v_k)².
    Some((s.z.clamp(-1.0, 1.0).asin().to_degrees(), (sigma0_sq * gain).sqrt().to_degrees(), (weight_sum * gain).sqrt()))
}

/// Step 4 on the final weights left in `sc`: (elevation, 1σ), degrees. `misfit_deg`
/// is the used cells' RMS residual beyond their noise, taken as shared by all.
fn elevation(
    sc: &Scratch,
    coherent_deg: f64,
    misfit_deg: f64,
    tilt_sigma_deg: f64,
    floor_deg: f64,
) -> Option<(f64, f64)> {
    let blocks = block_sums(&sc.obs, &sc.b.w, Extractor::SunVector, (0.0, 0.0, 0.0));
    let total = sum_blocks(&blocks);
    let weight_sum: f64 = sc.b.w.iter().filter(|x| x.0 > 0.0).map(|x| x.0 / (x.1 * x.2)).sum();
    let (h, fit, per_rad) = sun_elevation(&total, weight_sum)?;
    let misfit = if misfit_deg.is_finite() { misfit_deg * per_rad } else { 0.0 };
    let mut dev = Vec::with_capacity(BLOCKS * BLOCKS);
    let used: Vec<_> = blocks.iter().filter(|b| b.n > 0.0).collect();
    for b in &used {
        if let Some((hb, ..)) = sun_elevation(&total.minus(b), weight_sum) {
            dev.push(wrap_deg_180(hb - h));
        }
    }
    let jack = if dev.len() == used.len() { jackknife_sigma(&dev) } else { None }.unwrap_or(2.0 * fit);
    let coherent = if coherent_deg.is_finite() { coherent_deg * h.to_radians().cos() } else { 0.0 };
    let data = fit.max(jack).max(coherent);
    let sigma = (data * data + misfit.powi(2) + tilt_sigma_deg.powi(2) + floor_deg.powi(2)).sqrt();
    Some((h, sigma))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::meridional_basis;
    use crate::effects::sky_neutral_points::{sky_neutral_points, NeutralPoints};
    use glam::DMat3;

    /// Rays over a ±40° view about the zenith, and a few suns (level frame, z up).
    fn rays() -> Vec<DVec3> {
        let mut v = Vec::new();
        for i in -4..=4 {
            for k in -4..=4 {
                v.push(DVec3::new(0.18 * i as f64, 0.18 * k as f64, 1.0).normalize());
            }
        }
        v
    }

    fn sun(az_deg: f64, el_deg: f64) -> DVec3 {
        let (sa, ca) = az_deg.to_radians().sin_cos();
        let (se, ce) = el_deg.to_radians().sin_cos();
        DVec3::new(ce * ca, ce * sa, se)
    }

    /// At q = 0 the quartic angle is Rayleigh's: the E-vector ⊥ the scattering plane.
    #[test]
    fn the_quartic_angle_at_q_zero_is_rayleighs() {
        for (az, el) in [(10.0, 30.0), (200.0, 55.0), (-80.0, 70.0)] {
            let s = sun(az, el);
            for d in rays() {
                let e = d.cross(s).normalize();
                let r = wrap_rad_90(
                    chart_angle(d, e).unwrap() - quartic_angle(d, az.to_radians(), (90.0 - el).to_radians(), 0.0),
                );
                assert!(r.abs() < 1e-9, "sun ({az}, {el}), ray {d}: {r}");
            }
        }
    }

    /// The quartic angle at q = sin²(s/4) is the E-vector the `sky_neutral_points`
    /// effect renders at separation s (a CPU copy of Berry, Dennis & Lee eq. 4.2), and
    /// not Rayleigh's.
    #[test]
    fn the_quartic_angle_matches_the_rendered_berry_sky() {
        for (az, el, sep_deg) in [(10.0, 35.0, 30.0), (200.0, 50.0, 20.0), (120.0, 25.0, 45.0)] {
            let s = sun(az, el);
            let sep = f64::to_radians(sep_deg);
            let np = NeutralPoints::new(&DMat3::IDENTITY, s, sep);
            let q = (0.25 * sep).sin().powi(2);
            let mut off_rayleigh = 0.0f64;
            for d in rays() {
                let b = meridional_basis(d);
                let g = crate::camera::RayGeometry { d, basis: b, r2: 0.0 };
                let st = sky_neutral_points(&np.to_params(), s, 1.0, &g, crate::stokes::Stokes::default());
                let phi = 0.5 * st.u.atan2(st.q);
                let e = phi.cos() * b.p - phi.sin() * b.s;
                let chi = chart_angle(d, e).unwrap();
                let (a, z) = (az.to_radians(), (90.0 - el).to_radians());
                let r = wrap_rad_90(chi - quartic_angle(d, a, z, q));
                assert!(r.abs() < 1e-6, "sun ({az}, {el}), s {sep_deg}°, ray {d}: {r}");
                off_rayleigh = off_rayleigh.max(wrap_rad_90(chi - quartic_angle(d, a, z, 0.0)).abs());
            }
            assert!(off_rayleigh.to_degrees() > 1.0, "{sep_deg}°: only {off_rayleigh} rad off Rayleigh's");
        }
    }
}
