//! The compute backend a command runs on: the rayon reference or the GPU twin.

use anyhow::Context;
use std::sync::OnceLock;

/// `--gpu-precision` (global: every command that opens the GPU reads it).
static GPU_PRECISION: OnceLock<Option<bpins_gpu::Precision>> = OnceLock::new();

/// Sets `--gpu-precision` once, before any command runs.
pub fn set_gpu_precision(p: Option<bpins_gpu::Precision>) {
    let _ = GPU_PRECISION.set(p);
}

/// `--backend`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// The rayon reference implementation.
    Cpu,
    /// The WGSL twin through wgpu (lavapipe where there is no GPU); --gpu-precision.
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
pub fn open(b: Backend) -> anyhow::Result<Box<dyn bpins_core::internal::backend::Backend>> {
    Ok(match b {
        Backend::Cpu => Box::new(bpins_core::internal::backend::Cpu),
        Backend::Gpu => Box::new(open_gpu()?),
    })
}

/// Opens the GPU twin at `--gpu-precision` (default: f64 where the adapter has it).
pub fn open_gpu_quiet() -> anyhow::Result<bpins_gpu::Gpu> {
    bpins_gpu::Gpu::with_precision(GPU_PRECISION.get().copied().flatten()).context("opening the GPU backend")
}

/// Opens the GPU twin and names its adapter and precision on stderr.
pub fn open_gpu() -> anyhow::Result<bpins_gpu::Gpu> {
    let g = open_gpu_quiet()?;
    say!(
        "GPU adapter: {}{}, {} kernels",
        g.adapter_name(),
        if g.is_cpu() { " — a CPU rasterizer" } else { "" },
        g.precision().name()
    );
    Ok(g)
}

/// A sweep's engine on backend `b`: the rayon reference, or the GPU twin opened into
/// `gpu` (which the engine borrows, so it lives as long as the caller's slot).
pub fn sums_engine(
    b: Backend,
    gpu: &mut Option<bpins_gpu::Gpu>,
) -> anyhow::Result<&dyn bpins_core::internal::sweep::SumsEngine> {
    Ok(match b {
        Backend::Cpu => &bpins_core::internal::sweep::CpuSums,
        Backend::Gpu => gpu.insert(open_gpu()?),
    })
}
