//! The interface a GPU twin of the chain is built on (`bpins-gpu`, the WGSL compute
//! shaders): narrower than the crate and wider than the front door, and named as such.
//!
//! A twin reproduces the CPU reference on another device, so it needs what a user of
//! the [`crate::render`] front door never sees: the per-pixel kernels (same names and
//! argument order as the WGSL functions), the frame and scene blocks they read (the
//! host side of the `#[repr(C)]` parameter structs the twin packs), the reconstructor's
//! weights, the heading's per-context sums and their layout, the noise streams, the
//! reference drivers the parity tests compare against, and the two traits a device
//! implements: [`Backend`] (frames and sky maps) and [`SumsEngine`] (a sweep's per-pixel
//! sums). Everything here is the CPU reference itself, re-exported, not a copy.
//!
//! It changes with the shaders: a new effect or a new parameter block shows here and in
//! `docs/api/bpins-core.txt` in the same change.

/// The devices: what a backend renders (mosaics, co-located channels, sky maps, a
/// sweep's trials), and the CPU reference (rayon) that implements it.
pub use crate::backend::{Backend, Cpu};
/// The per-pixel chain: one frame's model, geometry and scene, which effects are
/// active (the twin's effect masks), the noise stream indices, and the two kernels a
/// twin's parity tests call pixel by pixel (a ray's Stokes vector, a site's signal).
pub use crate::chain::{ray_stokes, site_signal_dn, ActiveEffects, ChainFrame, NoiseIndex, Scene};
/// The lens's diattenuation at a ray (`rho`'s square at the frame, its value at a
/// radius), which the heading's context carries.
pub use crate::effects::lens_diattenuation::{rho2, rho_at};
/// The heading's per-pixel sums, what they are read in (a context), their sector count.
pub use crate::heading::{Extractor, HeadingContext, HeadingSums, SECTORS};
/// The seed paper's Monte Carlo, trial by trial: the draws, the peak intensity, the
/// set-up and finish of a trial around its sums, and the reference drivers.
pub use crate::montecarlo::{draw, run_sweep, run_trial, sweep_peak, Source, SweepConfig, TrialResult, TrialSetup};
/// The counter-based noise: a frame's key and the stream of a pixel, channel and kind.
pub use crate::noise::{stream, FrameKey};
/// The Stokes reconstruction's weights, as the twin uploads them.
pub use crate::recon::Reconstructor;
/// The CPU reference renderers and reducers the twin's outputs are compared with.
pub use crate::simulate::{
    colocated_heading_sums, mosaic_heading_sums, peak_intensity, render_colocated, render_mosaic, sky_maps, SkyMaps,
};
/// A sweep's sums engine (the CPU's is [`crate::CpuSums`]): the job it is given (a
/// colour sensor's too) and the most heading contexts one trial reads; a colour
/// mosaic's band sums, for a twin that renders the mosaic and reads it back.
#[cfg(feature = "io")]
pub use crate::sweep::{colour_mosaic_heading_sums, ColourSumsJob, SumsEngine, SumsJob, MAX_CONTEXTS};
