//! Driver of `shaders/kernels/sums.wgsl` and `reduce.wgsl`: heading sums of whole
//! frames reduced on the device; only 119 numbers per (frame, context) come back.
//! CPU twins: `bpins_core::twin::mosaic_heading_sums` (DoFP superpixels) and the
//! per-trial loop of `bpins_core::twin::run_trial` (colocated pixels).

use crate::device::Gpu;
use crate::masks::EffectMasks;
use crate::params::{FrameParams, HeadingParams, ReconParams, ReduceDims, SampleGrid, SumsDims};
use crate::precision::Precision;
use crate::{GpuError, Result};
use bpins_core::sensor::{Channel, DEFAULT_MOSAIC};
use bpins_core::twin::ChainFrame;
use bpins_core::twin::Reconstructor;
use bpins_core::twin::{HeadingContext, HeadingSums, SECTORS};

/// Values per (frame, context): 6 scatter terms, n, then 7 band sums per sector
/// (`SUMS_LEN` in `common/heading.wgsl`).
pub const SUMS_LEN: usize = 7 + 7 * SECTORS;

/// Rows of samples per workgroup of `frame_sums`, one invocation each (`ROWS` in
/// `kernels/sums.wgsl`).
pub(crate) const SUMS_ROWS: u32 = 64;

/// Samples one invocation sums along its row on a GPU (on a CPU adapter: the whole row).
const GPU_RUN_SAMPLES: u32 = 128;

/// Heading contexts a frame may carry (`MAX_CTX` in `kernels/sums.wgsl`).
pub const MAX_CONTEXTS: usize = 2;

/// The specialisation of `frame_sums` a dispatch runs (its pipeline constants
/// `SUMS_LAYOUT`, `SHARED_RAYS`, `SUMS_NOISE`, the generated dispatch's effect masks
/// `SKY_ON`, … ([`EffectMasks`]) and camera.wgsl's `CAMERA_PROJECTION`,
/// `CAMERA_DISTORTION`): what is uniform over the whole dispatch is decided at compile
/// time, since llvmpipe runs the untaken side of a uniform branch too.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct SumsVariant {
    /// 0 DoFP superpixels without mosaic effects, 1 DoFP with (crosstalk, …), 2 colocated.
    layout: u32,
    /// Every context of every frame has the same assumed camera, distortion and grid.
    shared_rays: bool,
    /// The sensor noise some frame draws: bit 0 temporal, 1 DSNU, 2 PRNU.
    noise: u32,
    /// The registry hooks some frame has on (the analyzer effects among them:
    /// `ChainFrame::has_analyzer_effects`).
    masks: EffectMasks,
    /// The projection id every camera (true and assumed) has; 4 where they differ.
    projection: u32,
    /// Some camera (true or assumed) has a radial distortion.
    distortion: bool,
}

impl SumsVariant {
    pub(crate) fn constants(self) -> Vec<(&'static str, f64)> {
        let mut c = vec![
            ("SUMS_LAYOUT", self.layout as f64),
            ("SHARED_RAYS", if self.shared_rays { 1.0 } else { 0.0 }),
            ("SUMS_NOISE", self.noise as f64),
            ("CAMERA_PROJECTION", self.projection as f64),
            ("CAMERA_DISTORTION", if self.distortion { 1.0 } else { 0.0 }),
        ];
        c.extend(self.masks.constants());
        c
    }

    /// The variant for these frames and their contexts (`n_ctx` per frame).
    fn of(layout: SampleLayout, frames: &[FrameParams], heading: &[HeadingParams], n_ctx: usize) -> SumsVariant {
        let layout = match layout {
            // A mosaic effect (crosstalk; FrameParams::mosaic.x) anywhere in the dispatch.
            SampleLayout::Superpixels { .. } => {
                u32::from(frames.iter().any(|f| f.mosaic.hi[0] != 0.0 || f.mosaic.lo[0] != 0.0))
            }
            SampleLayout::Colocated => 2,
        };
        let rays = |h: &HeadingParams| (h.camera, h.distortion, h.grid);
        let shared_rays = heading.chunks(n_ctx).all(|ctx| ctx.iter().all(|h| rays(h) == rays(&ctx[0])));
        // FrameParams::noise: read noise, system gain, DSNU, PRNU (sensor_noise's tests).
        let on = |w: &crate::params::Wide4, k: usize| w.hi[k] as f64 + w.lo[k] as f64 > 0.0;
        let noise = frames.iter().fold(0, |bits, f| {
            bits | u32::from(on(&f.noise, 0) || on(&f.noise, 1))
                | (u32::from(on(&f.noise, 2)) << 1)
                | (u32::from(on(&f.noise, 3)) << 2)
        });
        // The hooks off their neutral vector in some frame.
        let masks = EffectMasks::of(frames);
        // Every camera, true (FrameParams) and assumed (HeadingParams): the projection id
        // (camera.w, an exact small integer) and the distortion (k1, k2).
        let cameras = || {
            let true_cams = frames.iter().map(|f| (&f.camera, &f.distortion));
            true_cams.chain(heading.iter().map(|h| (&h.camera, &h.distortion)))
        };
        let ids: Vec<f32> = cameras().map(|(c, _)| c.hi[3]).collect();
        let projection = match ids.first() {
            Some(&id) if ids.iter().all(|&x| x == id) && (0.0..4.0).contains(&id) => id as u32,
            _ => 4,
        };
        let distortion = cameras().any(|(_, k)| (0..2).any(|i| k.hi[i] != 0.0 || k.lo[i] != 0.0));
        SumsVariant { layout, shared_rays, noise, masks, projection, distortion }
    }
}

/// How a frame's samples come from its pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SampleLayout {
    /// DoFP mosaic reconstructed as 2 × 2 superpixels at the tile centres.
    Superpixels { mosaic: [[Channel; 2]; 2] },
    /// Colocated channels, one sample per pixel (DN kept in f64, as the Monte Carlo).
    Colocated,
}

/// One frame to reduce: its chain, its Stokes inversion and the contexts (1 or more)
/// its sums are accumulated under.
#[derive(Clone, Debug)]
pub struct SumsJob<'a> {
    pub frame: &'a ChainFrame,
    pub rec: &'a Reconstructor,
    /// Samples with a DN outside (0, this) are masked; 0 masks nothing.
    pub mask_full_scale_dn: f64,
    pub contexts: Vec<HeadingContext>,
}

impl Gpu {
    /// Heading sums of every job's frame (`w × h` px), one per context, in job order.
    pub fn heading_sums(
        &self,
        jobs: &[SumsJob],
        w: usize,
        h: usize,
        layout: SampleLayout,
    ) -> Result<Vec<Vec<HeadingSums>>> {
        let (sw, sh, grid, mosaic, layout_id) = match layout {
            SampleLayout::Superpixels { mosaic } => {
                (w / 2, h / 2, SampleGrid { x0_px: 0.5, y0_px: 0.5, step_px: 2.0 }, mosaic, 0)
            }
            SampleLayout::Colocated => (w, h, SampleGrid { x0_px: 0.0, y0_px: 0.0, step_px: 1.0 }, DEFAULT_MOSAIC, 1),
        };
        let n_ctx = jobs.iter().map(|j| j.contexts.len()).max().unwrap_or(0).max(1);
        if n_ctx > MAX_CONTEXTS {
            return Err(GpuError::Unsupported(format!(
                "{n_ctx} heading contexts for one frame; the sums kernel takes at most {MAX_CONTEXTS}"
            )));
        }
        // One invocation per run of samples along a row, ROWS rows per workgroup.
        let runs = self.sums_runs_per_row(sw as u32);
        let wg_rows = (sh as u32).div_ceil(SUMS_ROWS);
        // Partials per (frame, context): one per invocation.
        let n_part = (wg_rows * SUMS_ROWS * runs) as u64;
        let float = self.precision.float_bytes();
        let per_job = n_ctx as u64 * n_part * SUMS_LEN as u64 * float;
        let batch = self.batch_size(jobs.len(), per_job, &format!("partial sums of a {w} × {h} px frame"))?;
        let mut out = Vec::with_capacity(jobs.len());
        for chunk in jobs.chunks(batch) {
            let frames = chunk.iter().map(|j| FrameParams::try_from(j.frame)).collect::<Result<Vec<FrameParams>>>()?;
            let recon: Vec<ReconParams> =
                chunk.iter().map(|j| ReconParams::new(j.rec, &mosaic, j.mask_full_scale_dn)).collect();
            let heading: Vec<HeadingParams> = chunk
                .iter()
                .flat_map(|j| {
                    (0..n_ctx).map(move |c| match j.contexts.get(c) {
                        Some(ctx) => HeadingParams::new(ctx, grid),
                        None => HeadingParams::disabled(),
                    })
                })
                .collect();
            let dims = SumsDims {
                samples: [sw as u32, sh as u32, n_ctx as u32, layout_id],
                image: [w as u32, h as u32, wg_rows, runs],
                tiles: [0; 4],
            };
            let n_jobs = (chunk.len() * n_ctx) as u32;
            let rdims = ReduceDims { size: [n_part as u32, n_jobs, 0, 0] };
            let (u, f, r, hb) = (
                self.uniform("sums dims", &dims),
                self.storage("frames", &frames),
                self.storage("recon", &recon),
                self.storage("heading", &heading),
            );
            let partials = self.output("partials", per_job * chunk.len() as u64);
            let sums = self.output("sums", n_jobs as u64 * SUMS_LEN as u64 * float);
            let ru = self.uniform("reduce dims", &rdims);
            let p = &self.pipelines;
            let frame_sums = p.frame_sums(&self.device, SumsVariant::of(layout, &frames, &heading, n_ctx));
            let g1 = self.bind(&frame_sums, &[&u, &f, &r, &hb, &partials]);
            let g2 = self.bind(&p.reduce_partials, &[&ru, &partials, &sums]);
            let passes = [
                (&frame_sums, &g1, [wg_rows, runs, chunk.len() as u32]),
                (&p.reduce_partials, &g2, [SUMS_LEN as u32, n_jobs, 1]),
            ];
            // The sums come back in the kernels' precision.
            let data: Vec<f64> = match self.precision {
                Precision::F64 => self.run(&passes, &sums)?,
                Precision::F32 => self.run::<f32>(&passes, &sums)?.into_iter().map(f64::from).collect(),
            };
            for (j, job) in chunk.iter().enumerate() {
                let of_job = &data[j * n_ctx * SUMS_LEN..][..n_ctx * SUMS_LEN];
                out.push(of_job.chunks_exact(SUMS_LEN).take(job.contexts.len()).map(sums_from).collect());
            }
        }
        Ok(out)
    }
}

impl Gpu {
    /// Runs per row of `sw` samples, one invocation each. A CPU adapter (llvmpipe) runs
    /// a workgroup's SIMD groups on one thread: whole rows give it long loops and few
    /// partials. A GPU needs many invocations in flight: runs of about GPU_RUN_SAMPLES.
    pub(crate) fn sums_runs_per_row(&self, sw: u32) -> u32 {
        if self.is_cpu() {
            1
        } else {
            sw.div_ceil(GPU_RUN_SAMPLES).max(1)
        }
    }
}

/// `HeadingSums` from the kernel's SUMS_LEN values.
pub(crate) fn sums_from(v: &[f64]) -> HeadingSums {
    let mut s = HeadingSums::default();
    s.scatter.copy_from_slice(&v[..6]);
    s.n = v[6];
    for (k, l) in s.line.iter_mut().enumerate() {
        l.copy_from_slice(&v[7 + 7 * k..][..7]);
    }
    s
}
