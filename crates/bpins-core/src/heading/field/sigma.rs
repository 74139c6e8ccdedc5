//! Step 5 of the field estimator (`mod.rs`): each extractor's heading from the
//! weighted sums of the cells the robust loop (`robust.rs`) kept, per block of the
//! image, and its 1σ parts — the fit's own, the delete-one-block jackknife, the
//! reference tilt's, the sun's, the floor, and the two extractors' disagreement.

use super::observe::{cone_sun, Obs};
use super::robust::{Robust, Scratch};
use super::stats::jackknife_sd;
use super::{Cells, FieldContext, FieldHeading, FieldOptions, NoHeading, SigmaParts};
use crate::conventions::{heading_deg_from_level_sun, image_angle_rad, level_from_camera, wrap_deg_180, wrap_rad_90};
use crate::heading::{meridian, sun_vector, Extractor, HeadingSums};
use glam::{DMat3, DVec3};
use std::f64::consts::FRAC_PI_2;

/// Jackknife blocks per side of the image (BLOCKS² in all).
pub(super) const BLOCKS: usize = 4;

/// Per-block weighted sums of one extractor: the sun vector's scatter, or the
/// meridian band (cells with |ψ| < band inside the zenith disc).
pub(super) fn block_sums(
    obs: &[Obs],
    w: &[(f64, f64, f64, f64)],
    extractor: Extractor,
    band: (f64, f64, f64),
) -> [HeadingSums; BLOCKS * BLOCKS] {
    let mut sums = [HeadingSums::default(); BLOCKS * BLOCKS];
    let (band_rad, zmin_cos, zmax_cos) = band;
    for (o, &(rw, var, sg2, _)) in obs.iter().zip(w) {
        if rw <= 0.0 {
            continue;
        }
        let b = &mut sums[o.block];
        match extractor {
            Extractor::SunVector => b.add_scatter_weighted(o.e, rw / (var * sg2)),
            Extractor::MeridianLine => {
                // |ψ| < band, ψ = AoE − 90°: cos 2ψ = −cos 2·AoE > cos 2·band.
                let cos_2aoe = (o.ep * o.ep - o.es * o.es) / (o.ep * o.ep + o.es * o.es);
                if -cos_2aoe > (2.0 * band_rad).cos() && o.d.z <= zmin_cos && o.d.z >= zmax_cos {
                    let psi = wrap_rad_90(o.es.atan2(o.ep) - FRAC_PI_2);
                    let beta = image_angle_rad(o.d.x, o.d.y);
                    b.add_band_weighted(beta, psi, o.cos2b, o.sin2b, rw / var);
                }
            }
        }
    }
    sums
}

/// Heading (degrees) and fit 1σ of one extractor from level-frame sums, the sun's
/// branch taken nearest `hint` (level frame).
pub(super) fn solve(
    sums: &HeadingSums,
    extractor: Extractor,
    ctx: &FieldContext,
    hint: DVec3,
) -> Result<(f64, f64), String> {
    let est = match extractor {
        Extractor::SunVector => {
            let (vals, mut vecs) = sun_vector::scatter_eigen(sums).map_err(|e| e.to_string())?;
            if vecs[0].dot(hint) < 0.0 {
                vecs[0] = -vecs[0];
            }
            sun_vector::heading_from_eigen(vals, vecs, sums.n, DMat3::IDENTITY, ctx.sun_az_deg)
        }
        Extractor::MeridianLine => meridian::solve_line(sums, image_angle_rad(hint.x, hint.y), ctx.sun_az_deg, true),
    }
    .map_err(|e| e.to_string())?;
    Ok((est.heading_deg, est.sigma_deg))
}

/// Step 5 for one extractor on the fit `r` left in `sc`.
pub(super) fn heading(
    r: &Robust,
    e: Extractor,
    cells: &Cells,
    ctx: &FieldContext,
    opts: &FieldOptions,
    sc: &Scratch,
) -> FieldHeading {
    let level = ctx.level_from_camera();
    let band = meridian_band(ctx, opts, level, cells);
    let hint = cone_sun(ctx, r.heading_deg);
    let coherent_deg = if r.coherent_deg.is_finite() { r.coherent_deg } else { 0.0 };
    let read = |e: Extractor| {
        finish(&block_sums(&sc.obs, &sc.b.w, e, band), e, ctx, opts, hint, level).map(|(h, parts)| {
            let jackknife_deg = parts.jackknife_deg * r.jackknife_t;
            (h, SigmaParts { coherent_deg, misfit_deg: r.misfit_deg, jackknife_deg, ..parts })
        })
    };
    let result = read(e).map_err(NoHeading::Solver).map(|(h, parts)| {
        // The other extractor reads the same cells another way (the E-vectors' common
        // normal, or the solar meridian's line): where the two disagree beyond twice
        // the 1σ of their difference, the sky holds something neither models (a turned
        // region that one weighs more than the other), and the disagreement joins the 1σ.
        let other = match e {
            Extractor::SunVector => Extractor::MeridianLine,
            Extractor::MeridianLine => Extractor::SunVector,
        };
        let cross_deg = match read(other) {
            Ok((h2, p2)) => {
                let d = wrap_deg_180(h - h2).abs();
                if d > 2.0 * parts.total_deg().hypot(p2.total_deg()) {
                    d
                } else {
                    0.0
                }
            }
            Err(_) => 0.0,
        };
        (h, SigmaParts { cross_deg, ..parts })
    });
    FieldHeading { extractor: e, result, quality: r.quality, source: crate::sky::SkySource::Given, fitted_share: None }
}

/// The sum of every block's sums.
pub(super) fn sum_blocks(blocks: &[HeadingSums]) -> HeadingSums {
    let mut t = HeadingSums::default();
    for b in blocks {
        t += *b;
    }
    t
}

/// The meridian line's band and zenith disc: (band half-width, cos z_min, cos z_max),
/// the disc the largest about the zenith inside the image, less the tilt.
pub(super) fn meridian_band(ctx: &FieldContext, opts: &FieldOptions, level: DMat3, cells: &Cells) -> (f64, f64, f64) {
    let i = &ctx.intr;
    // The principal point's distance to the nearest edge of the read image, as
    // HeadingContext's r_max.
    let (w, h) = ((cells.cols * cells.cell_px) as f64, (cells.rows * cells.cell_px) as f64);
    let r_max_px = i.cx_px.min(i.cy_px).min(w - 1.0 - i.cx_px).min(h - 1.0 - i.cy_px).max(0.0);
    let disc = i.projection.angle_from_radius(r_max_px / i.f_px).unwrap_or(FRAC_PI_2);
    let off_axis = (level * DVec3::Z).z.clamp(-1.0, 1.0).acos();
    let zmax = (disc - off_axis).min(FRAC_PI_2 - opts.horizon_margin_deg.to_radians()).max(0.0);
    (opts.band_deg.to_radians(), (0.02f64).cos(), zmax.cos())
}

/// Step 5 for one extractor: heading, and its 1σ parts.
fn finish(
    blocks: &[HeadingSums],
    e: Extractor,
    ctx: &FieldContext,
    opts: &FieldOptions,
    hint: DVec3,
    level: DMat3,
) -> Result<(f64, SigmaParts), String> {
    let total = sum_blocks(blocks);
    let (heading_deg, fit_deg) = solve(&total, e, ctx, hint)?;
    // Delete-one-block jackknife over the blocks that hold samples.
    let mut used = 0;
    let mut dev = [0.0; BLOCKS * BLOCKS];
    let mut solved = 0;
    for b in blocks.iter().filter(|b| b.n > 0.0 || b.line.iter().any(|l| l[6] > 0.0)) {
        used += 1;
        if let Ok((h, _)) = solve(&total.minus(b), e, ctx, hint) {
            dev[solved] = wrap_deg_180(h - heading_deg);
            solved += 1;
        }
    }
    let (dev, k) = (&dev[..solved], used as f64);
    let jackknife_deg = if dev.len() >= 2 && dev.len() as f64 == k {
        jackknife_sd(dev)
    } else {
        // Too few blocks to leave one out (or one that cannot be left out): the fit's
        // own σ, doubled.
        2.0 * fit_deg
    };
    // The reference tilt's error, propagated: ∂ψ/∂tilt through the camera-frame sun.
    let s_cam = level.transpose() * cone_sun(ctx, heading_deg);
    let eps = 1e-3;
    let dpsi = |dx: f64, dy: f64| {
        let l = level_from_camera(ctx.tilt_x_deg + dx, ctx.tilt_y_deg + dy)
            * level_from_camera(ctx.mount_tilt_deg[0], ctx.mount_tilt_deg[1]);
        wrap_deg_180(heading_deg_from_level_sun(l * s_cam, ctx.sun_az_deg) - heading_deg) / eps
    };
    let tilt_deg = ctx.tilt_sigma_deg * dpsi(eps, 0.0).hypot(dpsi(0.0, eps));
    Ok((
        heading_deg,
        SigmaParts {
            fit_deg,
            jackknife_deg,
            coherent_deg: 0.0,
            misfit_deg: 0.0,
            cross_deg: 0.0,
            tilt_deg,
            sun_deg: ctx.sun_sigma_deg,
            floor_deg: opts.sigma_floor_deg,
        },
    ))
}
