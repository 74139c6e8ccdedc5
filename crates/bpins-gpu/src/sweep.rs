//! `bpins sweep` on the GPU: the core's [`bpins_core::twin::SumsEngine`] with the
//! WGSL twin. The trials are set up on the host exactly as for the CPU (same draws,
//! same frames, same noise); only their pixels are reduced on the device. A colour
//! sensor's trials are rendered on the device (crosstalk across bands and all) and
//! summed there band by band ([`Gpu::colour_heading_sums`], the twin of the CPU's
//! [`bpins_core::twin::colour_mosaic_heading_sums`]): no frame comes back.

use crate::device::Gpu;
use crate::sums::{SampleLayout, SumsJob};
use bpins_core::sensor::{Channel, ColourTiles, Layout};
use bpins_core::twin::{ColourSumsJob, HeadingSums};
use bpins_core::twin::{SumsEngine, SumsJob as CoreJob, MAX_CONTEXTS};

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

    /// Each trial's colour mosaic rendered on the device once for all its readings (a
    /// trial's jobs are consecutive and share its frames) and summed there band by band
    /// ([`Gpu::colour_heading_sums`]): only the sums come back, as for a monochrome sweep.
    fn colour_heading_sums(
        &self,
        jobs: &[ColourSumsJob],
        mosaic: &[[Channel; 2]; 2],
        tiles: &ColourTiles,
        w: usize,
        h: usize,
        mask_full_scale_dn: f64,
    ) -> bpins_core::Result<Vec<Vec<[HeadingSums; 3]>>> {
        Gpu::colour_heading_sums(self, jobs, w, h, mosaic, tiles, mask_full_scale_dn).map_err(crate::into_core)
    }
}
