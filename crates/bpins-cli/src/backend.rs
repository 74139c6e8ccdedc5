//! The compute backend a command runs on: the rayon reference or the GPU twin.

use anyhow::Context;
use bpins_core::chain::ChainFrame;
use bpins_core::montecarlo::{Source, SweepConfig, TrialResult};
use bpins_core::sensor::Channel;

/// `--backend`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// The rayon reference implementation.
    Cpu,
    /// The WGSL twin through wgpu on Vulkan (lavapipe where there is no GPU).
    Gpu,
}

impl Backend {
    pub fn name(self) -> &'static str {
        match self {
            Backend::Cpu => "cpu",
            Backend::Gpu => "gpu",
        }
    }
}

/// An opened backend.
pub enum Engine {
    Cpu,
    Gpu(Box<bpins_gpu::Gpu>),
}

impl Engine {
    pub fn open(b: Backend) -> anyhow::Result<Engine> {
        Ok(match b {
            Backend::Cpu => Engine::Cpu,
            Backend::Gpu => {
                let g = bpins_gpu::Gpu::new().context("opening the GPU backend")?;
                eprintln!("GPU adapter: {}{}", g.adapter_name(), if g.is_cpu() { " — a CPU rasterizer" } else { "" });
                Engine::Gpu(Box::new(g))
            }
        })
    }

    pub fn render_mosaic(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        mosaic: &[[Channel; 2]; 2],
    ) -> anyhow::Result<Vec<Vec<f32>>> {
        match self {
            Engine::Cpu => Ok(frames.iter().map(|f| bpins_core::simulate::render_mosaic(f, w, h, mosaic)).collect()),
            Engine::Gpu(g) => Ok(g.render_mosaic(frames, w, h, mosaic)?),
        }
    }

    pub fn render_colocated(
        &self,
        frames: &[ChainFrame],
        w: usize,
        h: usize,
        channels: &[Channel],
    ) -> anyhow::Result<Vec<Vec<Vec<f32>>>> {
        match self {
            Engine::Cpu => {
                Ok(frames.iter().map(|f| bpins_core::simulate::render_colocated(f, w, h, channels)).collect())
            }
            Engine::Gpu(g) => Ok(g.render_colocated(frames, w, h, channels)?),
        }
    }

    pub fn run_sweep(
        &self,
        cfg: &SweepConfig,
        sources: &[Source],
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> anyhow::Result<Vec<TrialResult>> {
        match self {
            Engine::Cpu => Ok(bpins_core::montecarlo::run_sweep(cfg, sources, progress)?),
            Engine::Gpu(g) => Ok(bpins_gpu::montecarlo::run_sweep(g, cfg, sources, progress)?),
        }
    }
}
