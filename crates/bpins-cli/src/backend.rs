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
        Backend::Gpu => Box::new(open_gpu()?),
    })
}

/// Opens the GPU twin and names its adapter on stderr.
fn open_gpu() -> anyhow::Result<bpins_gpu::Gpu> {
    let g = bpins_gpu::Gpu::new().context("opening the GPU backend")?;
    eprintln!("GPU adapter: {}{}", g.adapter_name(), if g.is_cpu() { " — a CPU rasterizer" } else { "" });
    Ok(g)
}

/// A sweep's engine on backend `b`: the rayon reference, or the GPU twin opened into
/// `gpu` (which the engine borrows, so it lives as long as the caller's slot).
pub fn sums_engine(b: Backend, gpu: &mut Option<bpins_gpu::Gpu>) -> anyhow::Result<&dyn bpins_core::sweep::SumsEngine> {
    Ok(match b {
        Backend::Cpu => &bpins_core::sweep::CpuSums,
        Backend::Gpu => gpu.insert(open_gpu()?),
    })
}
