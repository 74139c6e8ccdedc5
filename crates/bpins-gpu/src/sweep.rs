//! `bpins sweep` on the GPU: the core's [`bpins_core::twin::SumsEngine`] with the
//! WGSL twin. The trials are set up on the host exactly as for the CPU (same draws,
//! same frames, same noise); only their pixels are reduced on the device. A colour
//! sensor's trials are rendered on the device (crosstalk across bands and all) and
//! read back whole, their superpixels summed band by band on the host by the CPU's
//! own reduce ([`bpins_core::twin::colour_mosaic_heading_sums`]).

use crate::device::Gpu;
use crate::sums::{SampleLayout, SumsJob};
use bpins_core::sensor::{Channel, ColourTiles, Layout};
use bpins_core::twin::{colour_mosaic_heading_sums, ChainFrame, ColourSumsJob, HeadingSums};
use bpins_core::twin::{SumsEngine, SumsJob as CoreJob, MAX_CONTEXTS};

/// Host memory a colour sweep's read-back mosaics may hold at once, bytes.
const COLOUR_READBACK_BYTES: usize = 256 << 20;

impl SumsEngine for Gpu {
    fn name(&self) -> &str {
        "gpu"
    }

    fn field_scenes(&self) -> bool {
        false
    }

    fn heading_sums(
        &self,
        jobs: &[CoreJob],
        layout: &Layout,
        w: usize,
        h: usize,
        mask_full_scale_dn: f64,
    ) -> bpins_core::Result<Vec<Vec<HeadingSums>>> {
        const _: () = assert!(MAX_CONTEXTS <= crate::sums::MAX_CONTEXTS);
        let (sample, mask) = match layout {
            Layout::Colocated { .. } => (SampleLayout::Colocated, 0.0),
            Layout::Dofp { mosaic } => (SampleLayout::Superpixels { mosaic: *mosaic }, mask_full_scale_dn),
        };
        let gpu_jobs: Vec<SumsJob> = jobs
            .iter()
            .map(|j| SumsJob { frame: j.frame, rec: j.rec, mask_full_scale_dn: mask, contexts: j.contexts.to_vec() })
            .collect();
        Gpu::heading_sums(self, &gpu_jobs, w, h, sample).map_err(crate::into_core)
    }

    /// Each trial's colour mosaic rendered on the device ([`Gpu::render_colour_mosaic`])
    /// once for all its readings (a trial's jobs are consecutive and share its frames),
    /// read back (the whole frame, unlike the monochrome sweep's sums) and summed band
    /// by band as the CPU sums its own mosaic.
    fn colour_heading_sums(
        &self,
        jobs: &[ColourSumsJob],
        mosaic: &[[Channel; 2]; 2],
        tiles: &ColourTiles,
        w: usize,
        h: usize,
        mask_full_scale_dn: f64,
    ) -> bpins_core::Result<Vec<Vec<[HeadingSums; 3]>>> {
        let most = (COLOUR_READBACK_BYTES / (4 * w * h).max(1)).max(1);
        let mut out = Vec::with_capacity(jobs.len());
        let mut start = 0;
        while start < jobs.len() {
            // The next jobs over at most `most` trials' frames, and which frame each reads.
            let (mut frames, mut which): (Vec<[ChainFrame; 3]>, Vec<usize>) = (Vec::new(), Vec::new());
            let mut end = start;
            while end < jobs.len() {
                if end == start || !std::ptr::eq(jobs[end - 1].frames, jobs[end].frames) {
                    if frames.len() == most {
                        break;
                    }
                    frames.push(jobs[end].frames.clone());
                }
                which.push(frames.len() - 1);
                end += 1;
            }
            let dn = Gpu::render_colour_mosaic(self, &frames, w, h, mosaic, tiles).map_err(crate::into_core)?;
            for (j, k) in jobs[start..end].iter().zip(which) {
                out.push(colour_mosaic_heading_sums(
                    &dn[k],
                    w,
                    h,
                    mosaic,
                    tiles,
                    j.rec,
                    mask_full_scale_dn,
                    j.contexts,
                ));
            }
            start = end;
        }
        Ok(out)
    }
}
