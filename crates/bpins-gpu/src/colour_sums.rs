//! Driver of `colour_mosaic_heading_sums` in `shaders/kernels/sums.wgsl`: each band's
//! heading sums of colour-polarization mosaics, reduced on the device (then
//! `reduce.wgsl`); only SUMS_LEN numbers per (job, context, band) come back, never the
//! mosaic. CPU twins: `bpins_core::twin::colour_mosaic_heading_sums` (a mosaic given)
//! and the sweep's `colour_heading_sums` (each trial's mosaic rendered first, here by
//! `render.wgsl`'s `render_colour_mosaic` into a buffer the sums pass reads in place).

use crate::device::{Gpu, RenderEntry};
use crate::masks::EffectMasks;
use crate::params::{mosaic_positions, tile_bands, FrameParams, HeadingParams, ReconParams};
use crate::params::{ReduceDims, RenderDims, SampleGrid, SumsDims};
use crate::precision::Precision;
use crate::render::WG_EDGE;
use crate::sums::{sums_from, MAX_CONTEXTS, SUMS_LEN, SUMS_ROWS};
use crate::{GpuError, Result};
use bpins_core::sensor::{Channel, ColourTiles};
use bpins_core::twin::{ChainFrame, ColourSumsJob, HeadingContext, HeadingSums, Reconstructor};
use std::ops::Range;

/// Device memory one dispatch's colour mosaics may take, bytes (besides the device's
/// own binding limit).
const MOSAIC_BATCH_BYTES: u64 = 256 << 20;

/// Where a batch's mosaics come from.
#[derive(Clone, Copy)]
enum Mosaics<'a> {
    /// Rendered on the device, one per element (its three band frames).
    Render(&'a [&'a [ChainFrame; 3]]),
    /// Given (`w × h` DN each), uploaded as they are.
    Given(&'a [&'a [f32]]),
}

impl Mosaics<'_> {
    fn len(&self) -> usize {
        match self {
            Mosaics::Render(f) => f.len(),
            Mosaics::Given(d) => d.len(),
        }
    }
}

/// One reading of a mosaic: which one (index into the [`Mosaics`]), its inversion, its
/// contexts.
struct BandJob<'a> {
    mosaic: usize,
    rec: &'a Reconstructor,
    contexts: &'a [HeadingContext],
}

/// The pipeline constants of `colour_mosaic_heading_sums` (as [`crate::sums`]'s
/// `SumsVariant` decides them from the assumed cameras; no frame is rendered there).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct ColourSumsVariant {
    /// Every context of every job puts every superpixel on the same assumed ray.
    shared_rays: bool,
    /// The projection id every assumed camera has; 4 where they differ.
    projection: u32,
    /// Some assumed camera has a radial distortion.
    distortion: bool,
}

impl ColourSumsVariant {
    fn of(heading: &[HeadingParams], n_ctx: usize) -> Self {
        let rays = |h: &HeadingParams| (h.camera, h.distortion, h.grid);
        let shared_rays = heading.chunks(n_ctx).all(|ctx| ctx.iter().all(|h| rays(h) == rays(&ctx[0])));
        let id = heading.first().map_or(4.0, |h| h.camera.hi[3]);
        let same = heading.iter().all(|h| h.camera.hi[3] == id) && (0.0..4.0).contains(&id);
        let projection = if same { id as u32 } else { 4 };
        let distortion = heading.iter().any(|h| (0..2).any(|i| h.distortion.hi[i] != 0.0 || h.distortion.lo[i] != 0.0));
        ColourSumsVariant { shared_rays, projection, distortion }
    }

    fn constants(self) -> [(&'static str, f64); 3] {
        [
            ("SHARED_RAYS", if self.shared_rays { 1.0 } else { 0.0 }),
            ("CAMERA_PROJECTION", self.projection as f64),
            ("CAMERA_DISTORTION", if self.distortion { 1.0 } else { 0.0 }),
        ]
    }
}

/// Splits jobs reading mosaics `of` (non-decreasing, each job the same mosaic as the
/// one before or a later one) into dispatches of at most `most_mosaics` mosaics and
/// `most_jobs` jobs: (the jobs, the mosaics they read). A mosaic whose jobs are split
/// is in both dispatches (rendered twice where it is rendered).
fn batches(of: &[usize], most_mosaics: usize, most_jobs: usize) -> Vec<(Range<usize>, Range<usize>)> {
    let (most_mosaics, most_jobs) = (most_mosaics.max(1), most_jobs.max(1));
    let mut out = Vec::new();
    let mut start = 0;
    while start < of.len() {
        let m0 = of[start];
        let mut end = start + 1;
        while end < of.len() && end - start < most_jobs && of[end] - m0 < most_mosaics {
            end += 1;
        }
        out.push((start..end, m0..of[end - 1] + 1));
        start = end;
    }
    out
}

impl Gpu {
    /// Each band's heading sums (by [`Band::index`](bpins_core::sensor::Band::index)),
    /// one set per context, of each job's colour trial (`w × h` px): the sweep's
    /// colour reduce on the device. Jobs that follow one another with the same `frames`
    /// (a trial's readings) share one mosaic, rendered once on the device
    /// ([`Gpu::render_colour_mosaic`]'s kernel) and summed there; only the sums come back.
    /// CPU twin: the sweep's `colour_heading_sums` per job.
    #[allow(clippy::too_many_arguments)]
    pub fn colour_heading_sums(
        &self,
        jobs: &[ColourSumsJob],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
        tiles: &ColourTiles,
        full_scale_dn: f64,
    ) -> Result<Vec<Vec<[HeadingSums; 3]>>> {
        let mut frames: Vec<&[ChainFrame; 3]> = Vec::new();
        let mut band_jobs = Vec::with_capacity(jobs.len());
        for (k, j) in jobs.iter().enumerate() {
            if k == 0 || !std::ptr::eq(jobs[k - 1].frames, j.frames) {
                frames.push(j.frames);
            }
            band_jobs.push(BandJob { mosaic: frames.len() - 1, rec: j.rec, contexts: j.contexts });
        }
        self.band_sums(Mosaics::Render(&frames), &band_jobs, w, h, mosaic, tiles, full_scale_dn)
    }

    /// Each band's heading sums of colour mosaics already rendered (`dn`, each `w × h`
    /// DN, row-major), one set per context of `contexts`, per mosaic: the WGSL twin of
    /// `bpins_core::twin::colour_mosaic_heading_sums` (same arguments, the mosaics
    /// batched), summed on the device from the uploaded DN.
    #[allow(clippy::too_many_arguments)]
    pub fn colour_mosaic_heading_sums(
        &self,
        dn: &[&[f32]],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
        tiles: &ColourTiles,
        rec: &Reconstructor,
        full_scale_dn: f64,
        contexts: &[HeadingContext],
    ) -> Result<Vec<Vec<[HeadingSums; 3]>>> {
        if let Some(d) = dn.iter().find(|d| d.len() != w * h) {
            return Err(GpuError::Unsupported(format!("a mosaic of {} DN given for a {w} × {h} px sensor", d.len())));
        }
        let jobs: Vec<BandJob> = (0..dn.len()).map(|k| BandJob { mosaic: k, rec, contexts }).collect();
        self.band_sums(Mosaics::Given(dn), &jobs, w, h, mosaic, tiles, full_scale_dn)
    }

    /// The jobs' band sums, in dispatches the device's limits allow.
    #[allow(clippy::too_many_arguments)]
    fn band_sums(
        &self,
        mosaics: Mosaics,
        jobs: &[BandJob],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
        tiles: &ColourTiles,
        full_scale_dn: f64,
    ) -> Result<Vec<Vec<[HeadingSums; 3]>>> {
        let n_ctx = jobs.iter().map(|j| j.contexts.len()).max().unwrap_or(0).max(1);
        if n_ctx > MAX_CONTEXTS {
            return Err(GpuError::Unsupported(format!(
                "{n_ctx} heading contexts for one frame; the sums kernel takes at most {MAX_CONTEXTS}"
            )));
        }
        let (sw, sh) = (w / 2, h / 2);
        // One invocation per run of one parity's superpixels along a row, ROWS rows per
        // workgroup; partials per (job, context, band): one per invocation.
        let runs = self.sums_runs_per_row(sw.div_ceil(2) as u32);
        let wg_rows = (sh as u32).div_ceil(SUMS_ROWS);
        let n_part = (wg_rows * SUMS_ROWS * 2 * runs) as u64;
        let float = self.precision.float_bytes();
        let per_job = n_ctx as u64 * 3 * n_part * SUMS_LEN as u64 * float;
        let what = format!("partial band sums of a {w} × {h} px frame");
        // The reduce runs one workgroup per (value, job, context, band), or (serial, on a
        // CPU adapter) one invocation: its sets within one dimension's workgroups.
        let max_wg = self.limits.max_compute_workgroups_per_dimension as usize;
        let by_reduce = max_wg.min(max_wg * 64 / SUMS_LEN) / (3 * n_ctx);
        let most_jobs = self.batch_size(jobs.len(), per_job, &what)?.min(by_reduce);
        let per_mosaic = (w * h * 4) as u64;
        let limit = self.max_binding_bytes().min(MOSAIC_BATCH_BYTES.max(per_mosaic));
        let most_mosaics = self.batch_size(mosaics.len(), per_mosaic, &format!("a {w} × {h} px frame"))?;
        let most_mosaics = most_mosaics.min((limit / per_mosaic.max(1)) as usize);
        let of: Vec<usize> = jobs.iter().map(|j| j.mosaic).collect();
        let mut out = Vec::with_capacity(jobs.len());
        for (job_range, mosaic_range) in batches(&of, most_mosaics, most_jobs) {
            let chunk = &jobs[job_range];
            let recon: Vec<ReconParams> =
                chunk.iter().map(|j| ReconParams::new(j.rec, mosaic, full_scale_dn)).collect();
            // Superpixel (i, j) at (0.5 + 2i, 0.5 + 2j) px, as the CPU's even and odd rows put it.
            let grid = SampleGrid { x0_px: 0.5, y0_px: 0.5, step_px: 2.0 };
            let heading: Vec<HeadingParams> = chunk
                .iter()
                .flat_map(|j| {
                    (0..n_ctx).map(move |c| match j.contexts.get(c) {
                        Some(ctx) => HeadingParams::new(ctx, grid),
                        None => HeadingParams::disabled(),
                    })
                })
                .collect();
            let which: Vec<u32> = chunk.iter().map(|j| (j.mosaic - mosaic_range.start) as u32).collect();
            let dims = SumsDims {
                samples: [sw as u32, sh as u32, n_ctx as u32, 0],
                image: [w as u32, h as u32, wg_rows, runs],
                tiles: tile_bands(tiles),
            };
            let n_sets = (chunk.len() * n_ctx * 3) as u32;
            let rdims = ReduceDims { size: [n_part as u32, n_sets, 0, 0] };
            let (u, r, hb, wb) = (
                self.uniform("colour sums dims", &dims),
                self.storage("recon", &recon),
                self.storage("heading", &heading),
                self.storage("mosaic of job", &which),
            );
            let partials = self.output("partials", per_job * chunk.len() as u64);
            let sums = self.output("sums", n_sets as u64 * SUMS_LEN as u64 * float);
            let ru = self.uniform("reduce dims", &rdims);
            // The mosaics: rendered by a first pass, or uploaded.
            let items = mosaic_range.len() as u32;
            let (render, dn) = match mosaics {
                Mosaics::Render(frames) => {
                    let params = frames[mosaic_range.clone()]
                        .iter()
                        .flat_map(|f| f.iter())
                        .map(FrameParams::try_from)
                        .collect::<Result<Vec<FrameParams>>>()?;
                    let pipeline =
                        self.pipelines.render(&self.device, RenderEntry::ColourMosaic, EffectMasks::of(&params));
                    let rd = RenderDims {
                        size: [w as u32, h as u32, items, 0],
                        mosaic: mosaic_positions(mosaic),
                        tiles: tile_bands(tiles),
                    };
                    let (ud, f) = (self.uniform("render dims", &rd), self.storage("frames", &params));
                    let dn = self.output("colour mosaics", per_mosaic * items as u64);
                    let group = self.bind(&pipeline, &[&ud, &f, &dn]);
                    (Some((pipeline, group)), dn)
                }
                Mosaics::Given(dn) => {
                    let all: Vec<f32> = dn[mosaic_range.clone()].iter().flat_map(|d| d.iter().copied()).collect();
                    (None, self.storage("colour mosaics", &all))
                }
            };
            let p = &self.pipelines;
            let constants = ColourSumsVariant::of(&heading, n_ctx).constants();
            let band_sums = p.colour_sums(&self.device, &constants);
            let g1 = self.bind_at(&band_sums, &[(0, &u), (2, &r), (3, &hb), (4, &partials), (5, &dn), (6, &wb)]);
            // The partials' reduce: a tree per (value, set) on a GPU; on a CPU adapter one
            // invocation per (value, set), whose barriers would cost more than its additions.
            let (reduce, reduce_groups) = if self.is_cpu() {
                (&p.reduce_partials_serial, [(SUMS_LEN as u32 * n_sets).div_ceil(64), 1, 1])
            } else {
                (&p.reduce_partials, [SUMS_LEN as u32, n_sets, 1])
            };
            let g2 = self.bind(reduce, &[&ru, &partials, &sums]);
            let mut passes = Vec::with_capacity(3);
            if let Some((pipeline, group)) = &render {
                passes.push((pipeline, group, [(w as u32).div_ceil(WG_EDGE), (h as u32).div_ceil(WG_EDGE), items]));
            }
            passes.push((&band_sums, &g1, [wg_rows, 2 * runs, chunk.len() as u32]));
            passes.push((reduce, &g2, reduce_groups));
            // The sums come back in the kernels' precision.
            let data: Vec<f64> = match self.precision {
                Precision::F64 => self.run(&passes, &sums)?,
                Precision::F32 => self.run::<f32>(&passes, &sums)?.into_iter().map(f64::from).collect(),
            };
            for (k, job) in chunk.iter().enumerate() {
                let set = |c: usize, b: usize| sums_from(&data[((k * n_ctx + c) * 3 + b) * SUMS_LEN..][..SUMS_LEN]);
                out.push((0..job.contexts.len()).map(|c| [0, 1, 2].map(|b| set(c, b))).collect());
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batches_keep_each_job_with_its_mosaic_within_both_limits() {
        // Trials of 2, 1 and 3 readings.
        let of = [0, 0, 1, 2, 2, 2];
        assert_eq!(batches(&of, 8, 8), vec![(0..6, 0..3)]);
        assert_eq!(batches(&of, 2, 8), vec![(0..3, 0..2), (3..6, 2..3)]);
        // A trial split by the job limit: its mosaic in both dispatches.
        assert_eq!(batches(&of, 8, 4), vec![(0..4, 0..3), (4..6, 2..3)]);
        assert_eq!(batches(&of, 1, 1).len(), 6);
        assert!(batches(&[], 4, 4).is_empty());
        for (most_m, most_j) in [(1, 1), (1, 3), (2, 2), (3, 5)] {
            let b = batches(&of, most_m, most_j);
            let covered: Vec<usize> = b.iter().flat_map(|(j, _)| j.clone()).collect();
            assert_eq!(covered, (0..of.len()).collect::<Vec<_>>());
            for (j, m) in &b {
                assert!(j.len() <= most_j && m.len() <= most_m, "{j:?} {m:?}");
                assert!(j.clone().all(|k| m.contains(&of[k])), "{j:?} reads outside {m:?}");
            }
        }
    }
}
