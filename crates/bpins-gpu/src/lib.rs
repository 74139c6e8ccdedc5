//! # bpins-gpu — the measurement chain as WGSL compute shaders
//!
//! The GPU twin of `bpins-core`: the same per-pixel chain (sky, projection, lens
//! Mueller, effects, analyzers, sensor response with noise, Stokes, AoP/DoLP, heading
//! sums) in `shaders/`, run through wgpu on Vulkan, Metal, DX12 or GL — Mesa lavapipe
//! where there is no GPU, the vendor driver where there is. The CPU code is the reference: every WGSL
//! function has a CPU twin of the same name, argument order and step comments.
//!
//! * Noise: the CPU's counter-based generator (`common/noise.wgsl`), so both backends
//!   draw the same numbers and agree trial by trial.
//! * Precision: the radiometric chain and the sums run in f64 (`SHADER_F64`), the
//!   noise's transcendentals in f32 exactly as the CPU evaluates them; where the
//!   adapter lacks f64, or by choice, the same source runs in f32 ([`precision`]),
//!   with statistical tolerances.
//! * Heading: reduced on the device (each invocation sums a run of a row, then a
//!   per-frame reduce); 119 numbers per frame come back, never the frame. A colour
//!   sensor's mosaic is rendered and summed band by band on the device: 3 × 119 per
//!   frame and context ([`Gpu::colour_heading_sums`]).
//! * Batches: many frames (trials) per dispatch, split where the device's buffer
//!   limits require it.
//!
//! Tolerances between the backends are in [`tolerance`] (and `TOLERANCES.md`).

pub mod agree;
mod colour_sums;
mod device;
mod masks;
pub mod montecarlo;
pub mod params;
pub mod precision;
pub mod ray_dispatch;
mod render;
pub mod shaders;
mod sums;
pub mod sweep;
mod timing;
pub mod tolerance;

pub use device::{Gpu, Traffic};
pub use precision::Precision;
pub use render::ChainSample;
pub use sums::{SampleLayout, SumsJob, SUMS_LEN};
pub use timing::KernelTime;
/// wgpu, as this crate's API names its types (`wgpu::Backends` in [`Gpu::open`]).
pub use wgpu;

/// What can go wrong on the device.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found ({0}); install a Vulkan driver (Debian: mesa-vulkan-drivers libvulkan1 for lavapipe)"
    )]
    NoAdapter(String),
    #[error("the adapter {adapter} lacks {feature}, which the bpins kernels need")]
    MissingFeature { adapter: String, feature: &'static str },
    #[error("GPU device error: {0}")]
    Device(String),
    #[error("GPU out of memory: {0}")]
    OutOfMemory(String),
    #[error("not supported by the GPU backend: {0}")]
    Unsupported(String),
    #[error("shader error: {0}")]
    Shader(String),
    #[error("{what} needs a {bytes} B buffer; this device allows {limit} B per buffer")]
    TooLarge { what: String, bytes: u64, limit: u64 },
    #[error(transparent)]
    Core(#[from] bpins_core::Error),
}

pub type Result<T> = std::result::Result<T, GpuError>;

/// A device error in the core's words: [`bpins_core::Error::Backend`] (a core error
/// the GPU path passed on stays itself).
fn into_core(e: GpuError) -> bpins_core::Error {
    match e {
        GpuError::Core(c) => c,
        other => bpins_core::Error::Backend { backend: "gpu".into(), message: other.to_string() },
    }
}

/// The WGSL twin as a [`bpins_core::twin::Backend`]: what the core's rayon
/// reference does, on the device.
impl bpins_core::twin::Backend for Gpu {
    fn name(&self) -> &str {
        "gpu"
    }

    fn render_mosaic(
        &self,
        frames: &[bpins_core::twin::ChainFrame],
        w: usize,
        h: usize,
        mosaic: &[[bpins_core::sensor::Channel; 2]; 2],
    ) -> bpins_core::Result<Vec<Vec<f32>>> {
        Gpu::render_mosaic(self, frames, w, h, mosaic).map_err(into_core)
    }

    /// Each pixel through its band's frame, crosstalk with each neighbour through its
    /// own band's ([`Gpu::render_colour_mosaic`]): no band-at-a-time default, no refusal.
    fn render_colour_mosaic(
        &self,
        frames: &[[bpins_core::twin::ChainFrame; 3]],
        w: usize,
        h: usize,
        mosaic: &[[bpins_core::sensor::Channel; 2]; 2],
        tiles: &bpins_core::sensor::ColourTiles,
    ) -> bpins_core::Result<Vec<Vec<f32>>> {
        Gpu::render_colour_mosaic(self, frames, w, h, mosaic, tiles).map_err(into_core)
    }

    fn render_colocated(
        &self,
        frames: &[bpins_core::twin::ChainFrame],
        w: usize,
        h: usize,
        channels: &[bpins_core::sensor::Channel],
    ) -> bpins_core::Result<Vec<Vec<Vec<f32>>>> {
        Gpu::render_colocated(self, frames, w, h, channels).map_err(into_core)
    }

    fn sky_maps(
        &self,
        frames: &[bpins_core::twin::ChainFrame],
        w: usize,
        h: usize,
    ) -> bpins_core::Result<Vec<bpins_core::twin::SkyMaps>> {
        Gpu::sky_maps(self, frames, w, h).map_err(into_core)
    }

    fn run_sweep(
        &self,
        cfg: &bpins_core::twin::SweepConfig,
        sources: &[bpins_core::twin::Source],
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> bpins_core::Result<Vec<bpins_core::twin::TrialResult>> {
        montecarlo::run_sweep(self, cfg, sources, progress).map_err(into_core)
    }
}
