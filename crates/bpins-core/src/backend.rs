//! Where the per-pixel chain runs: a [`Backend`] renders frames and runs the seed
//! paper's sweep. [`Cpu`] is the rayon reference in this crate; `bpins-gpu`'s `Gpu`
//! implements the same trait with the WGSL twin, so a program (the CLI's `run` and
//! `simulate` among them) picks a backend without knowing which it got.
//!
//! ```
//! use bpins_core::internal::backend::{Backend, Cpu};
//! use bpins_core::internal::chain::ChainFrame;
//! # use bpins_core::camera::{Intrinsics, Projection};
//! # use bpins_core::internal::chain::Scene;
//! # let intr = Intrinsics::new(Projection::Pinhole, 300.0, 31.5, 23.5);
//! # let scene = Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 0.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
//! let frame = ChainFrame::noise_free(&Default::default(), &intr, &scene);
//! let backend: Box<dyn Backend> = Box::new(Cpu);
//! let dn = backend.render_mosaic(&[frame], 64, 48, &bpins_core::sensor::DEFAULT_MOSAIC)?;
//! assert_eq!((backend.name(), dn[0].len()), ("cpu", 64 * 48));
//! # Ok::<(), bpins_core::Error>(())
//! ```

use crate::chain::ChainFrame;
use crate::error::Result;
use crate::montecarlo::{Source, SweepConfig, TrialResult};
use crate::sensor::Channel;
use crate::simulate::SkyMaps;

/// A compute backend for the per-pixel chain. Errors are the core's
/// ([`crate::Error::Backend`] for what a backend itself cannot do).
pub trait Backend: Send + Sync {
    /// A short name: `cpu`, `gpu`.
    fn name(&self) -> &str;

    /// DoFP mosaics (`w × h` DN, row-major) of `frames`, bit-identical per seed.
    fn render_mosaic(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
    ) -> Result<Vec<Vec<f32>>>;

    /// Colocated frames: per frame one `w × h` plane per channel of `channels`.
    fn render_colocated(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        channels: &[Channel],
    ) -> Result<Vec<Vec<Vec<f32>>>>;

    /// The sky's AoP, DoLP and AoE maps of each frame on a `w × h` sensor, without
    /// rendering DN ([`crate::simulate::sky_maps`]).
    fn sky_maps(&self, frames: &[ChainFrame], w: usize, h: usize) -> Result<Vec<SkyMaps>>;

    /// The seed paper's Monte Carlo sweep (`bpins run`).
    fn run_sweep(
        &self,
        cfg: &SweepConfig,
        sources: &[Source],
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Vec<TrialResult>>;
}

/// The rayon reference implementation.
#[derive(Clone, Copy, Debug, Default)]
pub struct Cpu;

impl Backend for Cpu {
    fn name(&self) -> &str {
        "cpu"
    }

    fn render_mosaic(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
    ) -> Result<Vec<Vec<f32>>> {
        Ok(frames.iter().map(|f| crate::simulate::render_mosaic(f, w, h, mosaic)).collect())
    }

    fn render_colocated(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        channels: &[Channel],
    ) -> Result<Vec<Vec<Vec<f32>>>> {
        Ok(frames.iter().map(|f| crate::simulate::render_colocated(f, w, h, channels)).collect())
    }

    fn sky_maps(&self, frames: &[ChainFrame], w: usize, h: usize) -> Result<Vec<SkyMaps>> {
        Ok(frames.iter().map(|f| crate::simulate::sky_maps(f, w, h)).collect())
    }

    fn run_sweep(
        &self,
        cfg: &SweepConfig,
        sources: &[Source],
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Vec<TrialResult>> {
        crate::montecarlo::run_sweep(cfg, sources, progress)
    }
}
