//! What a fitted model leaves: AoP and DoLP residual RMS, residual profiles and
//! residual maps (measured − model).

use crate::capture::{Capture, FrameData};
use crate::conventions::wrap_deg_90;
use crate::error::Result;
use crate::fit::input::frames::FitFrames;
use crate::fit::input::noise::NoiseModel;
use crate::fit::model::problem::{problem, FitFrame, Problem};
use crate::fit::output::profiles::{Position, Profile, Profiler};
use crate::fit::{FitOptions, FitState};
use crate::recon::Reconstructor;
use crate::sensor::Layout;
use rayon::prelude::*;

/// Model DoLP below which an AoP residual is not counted (the angle is undefined).
const AOP_MIN_MODEL_DOLP: f64 = 0.01;

/// One polarization sample's residuals from its measured and model DN by channel:
/// (measured − model AoP in degrees, wrapped to ±90°, where the model DoLP exceeds
/// [`AOP_MIN_MODEL_DOLP`]; measured − model DoLP; the model DoLP).
pub(crate) fn pol_residual(rec: &Reconstructor, meas: &[f64; 4], model: &[f64; 4]) -> (Option<f64>, f64, f64) {
    let (a, b) = (rec.stokes(meas), rec.stokes(model));
    let aop = (b.dolp() > AOP_MIN_MODEL_DOLP).then(|| wrap_deg_90(a.aop_rad().to_degrees() - b.aop_rad().to_degrees()));
    (aop, a.dolp() - b.dolp(), b.dolp())
}

/// RMS of measured − model AoP (degrees, model DoLP > 0.01) and DoLP over the
/// superpixels (DoFP) or pixels (colocated) of every frame, nominal inversion.
pub(crate) fn polarization_residuals(pb: &Problem, theta: &[f64]) -> Result<(f64, f64)> {
    let c = pb.capture;
    let rec = Reconstructor::new(&Default::default(), c.sensor.black_level_dn, &c.sensor.channels())?;
    // Frame by frame in parallel, summed in frame order.
    let per_frame =
        (0..pb.frames.len()).into_par_iter().map(|k| frame_pol_sums(pb, &rec, theta, k)).collect::<Result<Vec<_>>>()?;
    let (mut sa, mut na, mut sd, mut nd) = (0.0, 0usize, 0.0, 0usize);
    for (a, b, c, d) in per_frame {
        (sa, na, sd, nd) = (sa + a, na + b, sd + c, nd + d);
    }
    let rms = |s: f64, n: usize| if n > 0 { (s / n as f64).sqrt() } else { f64::NAN };
    Ok((rms(sa, na), rms(sd, nd)))
}

/// Frame `k`'s sums of squared AoP residuals (with their count) and DoLP residuals
/// (with theirs).
fn frame_pol_sums(pb: &Problem, rec: &Reconstructor, theta: &[f64], k: usize) -> Result<(f64, usize, f64, usize)> {
    let (mut sa, mut na, mut sd, mut nd) = (0.0, 0usize, 0.0, 0usize);
    let f = pb.chain(theta, k)?;
    for_each_sample(pb, k, 1, &[&f], |_, _, [meas, model]| {
        let (da, dd, _) = pol_residual(rec, meas, model);
        if let Some(d) = da {
            sa += d * d;
            na += 1;
        }
        sd += dd * dd;
        nd += 1;
    });
    Ok((sa, na, sd, nd))
}

/// Visits every usable polarization sample of frame `k` (a DoFP mosaic's whole 2 × 2
/// tiles, a colocated sensor's pixels; every `stride`-th one along each axis) with its
/// measured DN by channel and each of `fits`'s model DN by channel (`[measured,
/// fits[0], fits[1], …]`: `N` is one more than the fits); (u, v) is the sample's pixel
/// (a superpixel's top-left one). A sample with any measured channel not usable (sky
/// mask, saturation, border) is skipped.
pub(crate) fn for_each_sample<const N: usize>(
    pb: &Problem,
    k: usize,
    stride: usize,
    fits: &[&FitFrame],
    mut visit: impl FnMut(usize, usize, &[[f64; 4]; N]),
) {
    debug_assert_eq!(fits.len() + 1, N);
    let c = pb.capture;
    let stride = stride.max(1);
    let mut buf = Vec::new();
    let mut at = [[1.0; 4]; N];
    for r in pb.frames.rects(k) {
        match &c.sensor.layout {
            Layout::Dofp { mosaic } => {
                // Whole 2 × 2 tiles (a sampled block starts at even coordinates).
                for j in (r.v0.div_ceil(2)..r.v1 / 2).step_by(stride) {
                    for i in (r.u0.div_ceil(2)..r.u1 / 2).step_by(stride) {
                        for (dv, row) in mosaic.iter().enumerate() {
                            for (du, ch) in row.iter().enumerate() {
                                for (m, f) in fits.iter().enumerate() {
                                    pb.pixel(f, k, 2 * i + du, 2 * j + dv, &mut buf);
                                    if m == 0 {
                                        at[0][ch.index()] = buf[0].0;
                                    }
                                    at[m + 1][ch.index()] = buf[0].1;
                                }
                            }
                        }
                        if at[0].iter().all(|&y| pb.usable(k, 2 * i, 2 * j, y)) {
                            visit(2 * i, 2 * j, &at);
                        }
                    }
                }
            }
            Layout::Colocated { channels } => {
                for (u, v) in r.points(stride) {
                    for (m, f) in fits.iter().enumerate() {
                        pb.pixel(f, k, u, v, &mut buf);
                        for (c, &(y, model)) in channels.iter().zip(&buf) {
                            if m == 0 {
                                at[0][c.index()] = y;
                            }
                            at[m + 1][c.index()] = model;
                        }
                    }
                    if at[0].iter().all(|&y| pb.usable(k, u, v, y)) {
                        visit(u, v, &at);
                    }
                }
            }
        }
    }
}

/// Residual maps of a fitted model, stacked over frames (the mean of measured −
/// model) and frame by frame, with its residual profiles in sky space.
#[derive(Clone, Debug, PartialEq)]
pub struct ResidualMaps {
    pub width_px: u32,
    pub height_px: u32,
    /// Normalised DN residual (measured − model)/σ per pixel, mean over frames (NaN masked).
    pub dn_z: Vec<f32>,
    /// Mean over frames of that residual squared (χ² per sample: 1 where the model fits).
    pub dn_chi2: Vec<f32>,
    /// Size of the AoP and DoLP maps: superpixels (DoFP) or pixels (colocated).
    pub pol_width: u32,
    pub pol_height: u32,
    /// AoP residual, degrees (where the model DoLP > 0.01), mean over frames.
    pub aop_deg: Vec<f32>,
    /// DoLP residual, mean over frames.
    pub dolp: Vec<f32>,
    /// The same, frame by frame.
    pub frames: Vec<FrameMaps>,
    /// Profiles against scattering angle, radius, image azimuth, mosaic position,
    /// analyzer channel and model DoLP, over every frame.
    pub profiles: Vec<Profile>,
}

/// One frame's residual maps (sizes as in [`ResidualMaps`]; NaN where masked).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameMaps {
    pub dn_z: Vec<f32>,
    pub aop_deg: Vec<f32>,
    pub dolp: Vec<f32>,
}

/// The residual maps and profiles of `state` under `opts`, every frame's maps kept.
pub fn residual_maps(
    c: &Capture,
    frames: &[FrameData],
    opts: &FitOptions,
    state: &FitState,
    noise: NoiseModel,
) -> Result<ResidualMaps> {
    let mut each = Vec::with_capacity(frames.len());
    let mut maps = residual_maps_of(c, &FitFrames::all(c, frames)?, opts, state, noise, &mut |_, m| each.push(m))?;
    maps.frames = each;
    Ok(maps)
}

/// The residual maps and profiles of `state` under `opts` on every pixel of every
/// frame (a sampled frame is read again whole, one at a time), each frame's maps handed
/// to `each_frame(k, maps)` as they are made instead of kept (`ResidualMaps::frames`
/// stays empty): memory bounded by the frame, not the capture.
pub fn residual_maps_of(
    c: &Capture,
    frames: &FitFrames,
    opts: &FitOptions,
    state: &FitState,
    noise: NoiseModel,
    each_frame: &mut dyn FnMut(usize, FrameMaps),
) -> Result<ResidualMaps> {
    let (pb, theta) = problem(c, frames, opts, Some(state), noise)?;
    let (w, h) = (pb.w(), pb.h());
    let rec = Reconstructor::new(&Default::default(), c.sensor.black_level_dn, &c.sensor.channels())?;
    let (pw, ph, dofp) = match &c.sensor.layout {
        Layout::Dofp { .. } => (w / 2, h / 2, true),
        Layout::Colocated { .. } => (w, h, false),
    };
    // Profile positions from the nominal camera (radius, azimuth) and the fitted
    // model (scattering angle, DoLP).
    let nominal = c.intrinsics();
    let mut profiler = Profiler::new(corner_radius(&pb));
    let position = |f: &crate::chain::ChainFrame, d: glam::DVec3, u: f64, v: f64| {
        let (x, y) = nominal.normalised(u, v);
        Position {
            scattering_deg: d.dot(f.sun_cam).clamp(-1.0, 1.0).acos().to_degrees(),
            radius: (x * x + y * y).sqrt(),
            azimuth_deg: y.atan2(x).to_degrees(),
            mosaic: f64::NAN,
            channel: f64::NAN,
            model_dolp: f64::NAN,
            band: f64::NAN,
        }
    };
    // Stacked sums: Σz with its count, Σz² (the same count).
    let mut z = vec![(0.0f64, 0u32); w * h];
    let mut z2 = vec![0.0f64; w * h];
    let mut aop = vec![(0.0f64, 0u32); pw * ph];
    let mut dolp = vec![(0.0f64, 0u32); pw * ph];
    // Pixel rows per polarization row (a superpixel is two rows of a DoFP mosaic).
    let rows_per = if dofp { 2 } else { 1 };
    let band_px = rows_per * w;
    let ctx =
        Bands { pb: &pb, rec: &rec, w, h, pw, ph, dofp, rows_per, corner: corner_radius(&pb), position: &position };
    for k in 0..frames.len() {
        let f = pb.chain(&theta, k)?;
        let data = frames.full_frame(c, k)?;
        let mut fm =
            FrameMaps { dn_z: vec![f32::NAN; w * h], aop_deg: vec![f32::NAN; pw * ph], dolp: vec![f32::NAN; pw * ph] };
        // The bands of `rows_per` rows (one polarization row each) in parallel, each
        // writing its own rows of the DN maps; then, in band order (the same sums
        // whatever the threads), their polarization rows and profiles.
        let bands: Vec<Band> = fm
            .dn_z
            .par_chunks_mut(band_px)
            .zip(z.par_chunks_mut(band_px).zip(z2.par_chunks_mut(band_px)))
            .enumerate()
            .map(|(b, (dn_z, (zb, z2b)))| ctx.band(&f, k, &data, b, dn_z, zb, z2b))
            .collect();
        for (pv, band) in bands.into_iter().enumerate() {
            profiler.merge(&band.profiler);
            for (pu, pol) in band.pol.into_iter().enumerate() {
                let Some((da, dd)) = pol else { continue };
                let i = pv * pw + pu;
                if let Some(x) = da {
                    aop[i].0 += x;
                    aop[i].1 += 1;
                    fm.aop_deg[i] = x as f32;
                }
                dolp[i].0 += dd;
                dolp[i].1 += 1;
                fm.dolp[i] = dd as f32;
            }
        }
        each_frame(k, fm);
    }
    let mean = |v: &[(f64, u32)]| -> Vec<f32> {
        v.iter().map(|&(s, n)| if n > 0 { (s / n as f64) as f32 } else { f32::NAN }).collect()
    };
    Ok(ResidualMaps {
        width_px: w as u32,
        height_px: h as u32,
        dn_z: mean(&z),
        dn_chi2: z
            .iter()
            .zip(&z2)
            .map(|(&(_, n), &s2)| if n > 0 { (s2 / n as f64) as f32 } else { f32::NAN })
            .collect(),
        pol_width: pw as u32,
        pol_height: ph as u32,
        aop_deg: mean(&aop),
        dolp: mean(&dolp),
        frames: Vec::new(),
        profiles: profiler.finish(),
    })
}

/// What one band of rows of a frame needs that does not change between bands.
struct Bands<'a, P: Fn(&crate::chain::ChainFrame, glam::DVec3, f64, f64) -> Position + Sync> {
    pb: &'a Problem<'a>,
    rec: &'a Reconstructor,
    w: usize,
    h: usize,
    pw: usize,
    ph: usize,
    dofp: bool,
    rows_per: usize,
    corner: f64,
    position: &'a P,
}

/// One band's results beside the DN rows it wrote: its polarization row (per sample:
/// AoP residual where defined and DoLP residual, `None` where not usable) and its
/// profile sums.
struct Band {
    pol: Vec<Option<(Option<f64>, f64)>>,
    profiler: Profiler,
}

impl<P: Fn(&crate::chain::ChainFrame, glam::DVec3, f64, f64) -> Position + Sync> Bands<'_, P> {
    /// Band `b` of frame `k` (rows b·rows_per …): its DN residuals into `dn_z` (the
    /// frame's map) and `z`, `z2` (the stacked sums), its rows only.
    #[allow(clippy::too_many_arguments)]
    fn band(
        &self,
        f: &crate::fit::model::problem::FitFrame,
        k: usize,
        data: &FrameData,
        b: usize,
        dn_z: &mut [f32],
        z: &mut [(f64, u32)],
        z2: &mut [f64],
    ) -> Band {
        let (pb, c, w, pw) = (self.pb, self.pb.capture, self.w, self.pw);
        let mut profiler = Profiler::new(self.corner);
        // A colour sensor's pixel's band (a 2 × 2 tile lies under one filter); none on
        // a monochrome one.
        let band_of =
            |u: usize, v: usize| c.sensor.colour.as_ref().map_or(f64::NAN, |t| t.band_at(u, v).index() as f64);
        let mut buf = Vec::new();
        // Per pixel: DN residuals; gather the channels of each polarization sample of
        // the band's polarization row, then its residuals.
        let mut meas = vec![[1.0f64; 4]; pw];
        let mut model = vec![[1.0f64; 4]; pw];
        let mut ok = vec![true; pw];
        let (v0, v1) = (b * self.rows_per, ((b + 1) * self.rows_per).min(self.h));
        let pv = b;
        for v in v0..v1 {
            for u in 0..w {
                pb.pixel_of(f, u, v, data, &mut buf);
                let pu = if self.dofp { u / 2 } else { u };
                let inside = pu < pw && pv < self.ph;
                // The pixel's ray through the fitted camera, once for all it is used for.
                let g = f.intr.geometry(u as f64, v as f64);
                let at = Position {
                    mosaic: if self.dofp { ((u % 2) + 2 * (v % 2)) as f64 } else { f64::NAN },
                    model_dolp: crate::chain::ray_stokes(f, &g).dolp(),
                    band: band_of(u, v),
                    ..(self.position)(f, g.d, u as f64, v as f64)
                };
                let i = (v - v0) * w + u;
                for (q, &(y, m)) in buf.iter().enumerate() {
                    let usable = pb.usable(k, u, v, y);
                    let ch = match &c.sensor.layout {
                        Layout::Dofp { mosaic } => Layout::dofp_channel(mosaic, u, v).index(),
                        Layout::Colocated { channels } => channels[q].index(),
                    };
                    if usable {
                        let r = (y - m) / pb.noise.variance_dn2(m - c.sensor.black_level_dn).sqrt();
                        z[i].0 += r;
                        z[i].1 += 1;
                        z2[i] += r * r;
                        dn_z[i] = r as f32;
                        profiler.add_dn(&Position { channel: ch as f64, ..at }, r);
                    }
                    if !inside {
                        continue;
                    }
                    meas[pu][ch] = y;
                    model[pu][ch] = m;
                    ok[pu] &= usable;
                }
            }
        }
        let mut pol = Vec::new();
        if v1 - v0 == self.rows_per && pv < self.ph {
            pol = (0..pw)
                .map(|pu| {
                    if !ok[pu] {
                        return None;
                    }
                    let (da, dd, model_dolp) = pol_residual(self.rec, &meas[pu], &model[pu]);
                    // A superpixel sits at the centre of its four pixels.
                    let (u, v) =
                        if self.dofp { (2.0 * pu as f64 + 0.5, 2.0 * pv as f64 + 0.5) } else { (pu as f64, pv as f64) };
                    let d = f.intr.geometry(u, v).d;
                    let band = band_of(if self.dofp { 2 * pu } else { pu }, if self.dofp { 2 * pv } else { pv });
                    profiler.add_pol(&Position { model_dolp, band, ..(self.position)(f, d, u, v) }, da, dd);
                    Some((da, dd))
                })
                .collect();
        }
        Band { pol, profiler }
    }
}

/// Largest distance of an image corner from the nominal principal point, focal lengths.
fn corner_radius(pb: &Problem) -> f64 {
    let intr = pb.capture.intrinsics();
    let (w, h) = (pb.w() as f64 - 1.0, pb.h() as f64 - 1.0);
    [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
        .iter()
        .map(|&(u, v)| {
            let (x, y) = intr.normalised(u, v);
            (x * x + y * y).sqrt()
        })
        .fold(0.0, f64::max)
}
