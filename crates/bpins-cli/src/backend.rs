//! The compute backend a command runs on: the rayon reference or the GPU twin.

use anyhow::Context;

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

/// Opens the backend `b` (the library's trait: the CLI only chooses).
pub fn open(b: Backend) -> anyhow::Result<Box<dyn bpins_core::backend::Backend>> {
    Ok(match b {
        Backend::Cpu => Box::new(bpins_core::backend::Cpu),
        Backend::Gpu => {
            let g = bpins_gpu::Gpu::new().context("opening the GPU backend")?;
            eprintln!("GPU adapter: {}{}", g.adapter_name(), if g.is_cpu() { " — a CPU rasterizer" } else { "" });
            Box::new(g)
        }
    })
}
