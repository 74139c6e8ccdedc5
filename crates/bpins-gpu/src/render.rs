//! Driver of `shaders/kernels/render.wgsl`: whole frames rendered on the device and
//! read back (for dumps and the parity checks). CPU twin: `bpins_core::simulate`.

use crate::device::{Gpu, RenderEntry};
use crate::masks::EffectMasks;
use crate::params::{mosaic_positions, tile_bands, FrameParams, RenderDims};
use crate::{GpuError, Result};
use bpins_core::sensor::{Channel, ColourTiles, DEFAULT_MOSAIC};
use bpins_core::twin::ChainFrame;
use bpins_core::twin::SkyMaps;

/// Workgroup edge of the 2-D kernels (`@workgroup_size(16, 16, 1)`).
pub(crate) const WG_EDGE: u32 = 16;

/// Noise-free chain of one pixel, as `chain_maps` writes it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChainSample {
    /// Photo-signal of each channel (0°, 45°, 90°, 135°), DN.
    pub signal_dn: [f32; 4],
    /// AoP of the Stokes vector reaching the analyzers, degrees, image frame, (−90, 90].
    pub aop_deg: f32,
    pub dolp: f32,
    /// AoE: AoP − β (β the image angle about the true principal point), degrees, (−90, 90].
    pub aoe_deg: f32,
}

impl Gpu {
    /// How many items of `per_item_bytes` output fit one dispatch (device limits); an
    /// error naming `what` when not even one does.
    pub(crate) fn batch_size(&self, n: usize, per_item_bytes: u64, what: &str) -> Result<usize> {
        let limit = self.max_binding_bytes();
        if per_item_bytes > limit {
            return Err(GpuError::TooLarge { what: what.to_string(), bytes: per_item_bytes, limit });
        }
        let by_z = self.limits.max_compute_workgroups_per_dimension as u64;
        Ok(((limit / per_item_bytes.max(1)).min(by_z) as usize).clamp(1, n.max(1)))
    }

    /// Runs one `render.wgsl` entry over `frames` (`w × h` each) writing `per_pixel`
    /// f32 per pixel; batches as the device's limits allow.
    fn render(
        &self,
        entry: RenderEntry,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
        per_pixel: usize,
    ) -> Result<Vec<Vec<f32>>> {
        let dims = RenderDims { size: [w as u32, h as u32, 0, 0], mosaic: mosaic_positions(mosaic), tiles: [0; 4] };
        self.render_grouped(entry, frames, 1, dims, per_pixel)
    }

    /// [`Gpu::render`] where each output frame reads `per_item` consecutive frames of
    /// `frames` (a colour sensor's three bands), on the sensor `dims` (its `size.z`
    /// set per batch).
    fn render_grouped(
        &self,
        entry: RenderEntry,
        frames: &[ChainFrame],
        per_item: usize,
        dims: RenderDims,
        per_pixel: usize,
    ) -> Result<Vec<Vec<f32>>> {
        let (w, h) = (dims.size[0] as usize, dims.size[1] as usize);
        let per_frame = (w * h * per_pixel) as u64 * 4;
        let n = frames.len() / per_item;
        let batch = self.batch_size(n, per_frame, &format!("a {w} × {h} px frame"))?;
        let mut out = Vec::with_capacity(n);
        for chunk in frames.chunks(batch * per_item) {
            let params = chunk.iter().map(FrameParams::try_from).collect::<Result<Vec<FrameParams>>>()?;
            let items = (chunk.len() / per_item) as u32;
            // The entry point running the hooks some frame of the chunk has on.
            let pipeline = &self.pipelines.render(&self.device, entry, EffectMasks::of(&params));
            let dims = RenderDims { size: [w as u32, h as u32, items, 0], ..dims };
            let (u, f) = (self.uniform("dims", &dims), self.storage("frames", &params));
            let o = self.output("frames out", per_frame * items as u64);
            let group = self.bind(pipeline, &[&u, &f, &o]);
            let groups = [(w as u32).div_ceil(WG_EDGE), (h as u32).div_ceil(WG_EDGE), items];
            let data: Vec<f32> = self.run(&[(pipeline, &group, groups)], &o)?;
            out.extend(data.chunks_exact(w * h * per_pixel).map(|c| c.to_vec()));
        }
        Ok(out)
    }

    /// DoFP mosaics (`w × h`, row-major DN), bitwise-comparable to
    /// `bpins_core::twin::render_mosaic` of each frame (tolerances: TOLERANCES.md).
    pub fn render_mosaic(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
    ) -> Result<Vec<Vec<f32>>> {
        self.render(RenderEntry::Mosaic, frames, w, h, mosaic, 1)
    }

    /// Colour-polarization DoFP mosaics (`w × h`, row-major DN), one per element of
    /// `frames` (its three band frames by [`Band::index`](bpins_core::sensor::Band::index)):
    /// each pixel through the band over it (`tiles`), and where a mosaic effect
    /// (crosstalk) mixes it with its edge neighbours, each neighbour through its own
    /// band's frame; the sensor stage is the first band's (the bands share it). The
    /// WGSL twin of bpins-core's `simulate::render_colour_mosaic` (tolerances: TOLERANCES.md).
    pub fn render_colour_mosaic(
        &self,
        frames: &[[ChainFrame; 3]],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
        tiles: &ColourTiles,
    ) -> Result<Vec<Vec<f32>>> {
        let all: Vec<ChainFrame> = frames.iter().flatten().cloned().collect();
        let dims =
            RenderDims { size: [w as u32, h as u32, 0, 0], mosaic: mosaic_positions(mosaic), tiles: tile_bands(tiles) };
        self.render_grouped(RenderEntry::ColourMosaic, &all, 3, dims, 1)
    }

    /// Colocated frames: per frame, one `w × h` plane per channel of `channels` (as
    /// `bpins_core::twin::render_colocated`).
    pub fn render_colocated(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        channels: &[Channel],
    ) -> Result<Vec<Vec<Vec<f32>>>> {
        let all = self.render(RenderEntry::Colocated, frames, w, h, &DEFAULT_MOSAIC, 4)?;
        Ok(all
            .iter()
            .map(|px| channels.iter().map(|c| px.iter().skip(c.index()).step_by(4).copied().collect()).collect())
            .collect())
    }

    /// The noise-free chain of every pixel of each frame (`w × h`, row-major).
    /// The sky's AoP, DoLP and AoE maps of `frames` (`w × h`), no DN rendered: the WGSL
    /// twin of `bpins_core::twin::sky_maps`.
    pub fn sky_maps(&self, frames: &[ChainFrame], w: usize, h: usize) -> Result<Vec<SkyMaps>> {
        let all = self.render(RenderEntry::SkyMaps, frames, w, h, &DEFAULT_MOSAIC, 3)?;
        Ok(all
            .iter()
            .map(|px| {
                let mut m = SkyMaps { width_px: w, height_px: h, ..Default::default() };
                for c in px.chunks_exact(3) {
                    m.aop_deg.push(c[0]);
                    m.dolp.push(c[1]);
                    m.aoe_deg.push(c[2]);
                }
                m
            })
            .collect())
    }

    pub fn chain_maps(&self, frames: &[ChainFrame], w: usize, h: usize) -> Result<Vec<Vec<ChainSample>>> {
        let all = self.render(RenderEntry::ChainMaps, frames, w, h, &DEFAULT_MOSAIC, 7)?;
        Ok(all
            .iter()
            .map(|px| {
                px.chunks_exact(7)
                    .map(|c| ChainSample {
                        signal_dn: [c[0], c[1], c[2], c[3]],
                        aop_deg: c[4],
                        dolp: c[5],
                        aoe_deg: c[6],
                    })
                    .collect()
            })
            .collect())
    }
}
