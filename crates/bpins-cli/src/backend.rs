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
pub fn open(b: Backend) -> anyhow::Result<Box<dyn bpins_core::twin::Backend>> {
    Ok(match b {
        Backend::Cpu => Box::new(bpins_core::twin::Cpu),
        Backend::Gpu => Box::new(open_gpu()?),
    })
}

/// Opens the GPU twin at `--gpu-precision` (default: f64 where the adapter has it).
pub fn open_gpu_quiet() -> anyhow::Result<bpins_gpu::Gpu> {
    bpins_gpu::Gpu::with_precision(GPU_PRECISION.get().copied().flatten()).context("opening the GPU backend")
}

/// Opens the GPU twin and names its adapter and precision on stderr (and, on a CPU
/// rasterizer, what it costs: [`cpu_adapter_note`]).
pub fn open_gpu() -> anyhow::Result<bpins_gpu::Gpu> {
    let g = open_gpu_quiet()?;
    say!(
        "GPU adapter: {}{}, {} kernels",
        g.adapter_name(),
        if is_cpu_rasterizer(&g) { " — a CPU rasterizer" } else { "" },
        g.precision().name()
    );
    if let Some(note) = cpu_adapter_note(&g) {
        say!("{note}");
    }
    Ok(g)
}

/// Whether the adapter runs on the CPU: wgpu says so (`DeviceType::Cpu`: lavapipe,
/// SwiftShader, and wgpu's GL backend on llvmpipe), or its name does.
pub fn is_cpu_rasterizer(g: &bpins_gpu::Gpu) -> bool {
    g.is_cpu() || cpu_by_name(&g.adapter_name())
}

fn cpu_by_name(adapter: &str) -> bool {
    let name = adapter.to_lowercase();
    ["llvmpipe", "lavapipe", "softpipe", "swiftshader"].iter().any(|n| name.contains(n))
}

/// What a CPU rasterizer costs, said before the work starts (a terminal then shows a
/// bar, a log `progress:` lines): `None` on a real GPU.
pub fn cpu_adapter_note(g: &bpins_gpu::Gpu) -> Option<String> {
    cpu_note(&g.adapter_name(), g.is_cpu())
}

/// [`cpu_adapter_note`] of the adapter named `adapter` ([`bpins_gpu::Gpu::adapter_name`]:
/// "name (driver, backend)"), `cpu` where wgpu calls it a CPU device. The factors
/// were measured on 2 cores (`bpins run --trials-per-azimuth 1` and `2`: 2.6 s and
/// 7.6 s on `--backend cpu`, 6.2 s and 11.7 s on lavapipe, 15.4 s and 39.0 s on GL
/// llvmpipe; the paper sweep's 2.25× on lavapipe: docs/gpu.md).
fn cpu_note(adapter: &str, cpu: bool) -> Option<String> {
    if !(cpu || cpu_by_name(adapter)) {
        return None;
    }
    let same = "`--backend cpu` (the rayon reference; the same results within TOLERANCES.md)";
    Some(if adapter.ends_with(", Gl)") {
        format!(
            "note: wgpu's GL backend on a CPU rasterizer (llvmpipe) runs the GPU kernels on this machine's cores: \
             about 5× the time of {same} and 2–3× that of Vulkan's lavapipe, measured on 2 cores. For the GPU \
             twin on the CPU install lavapipe (Debian: `apt-get install mesa-vulkan-drivers libvulkan1`; bpins \
             picks Vulkan before GL); for speed, a real GPU or `--backend cpu`."
        )
    } else {
        format!(
            "note: a CPU rasterizer runs the GPU kernels on this machine's cores: about 2× the time of {same} \
             (2.25× measured on 2 cores, docs/gpu.md); for speed, a real GPU or `--backend cpu`."
        )
    })
}

/// A sweep's engine on backend `b`: the rayon reference, or the GPU twin opened into
/// `gpu` (which the engine borrows, so it lives as long as the caller's slot).
pub fn sums_engine(b: Backend, gpu: &mut Option<bpins_gpu::Gpu>) -> anyhow::Result<&dyn bpins_core::SumsEngine> {
    Ok(match b {
        Backend::Cpu => &bpins_core::CpuSums,
        Backend::Gpu => gpu.insert(open_gpu()?),
    })
}

#[cfg(test)]
mod tests {
    use super::cpu_note;

    #[test]
    fn a_cpu_rasterizer_is_told_what_it_costs_and_gl_how_to_get_lavapipe() {
        let gl = "llvmpipe (LLVM 15.0.6, 256 bits) ( 4.5 (Core Profile) Mesa 22.3.6, Gl)";
        let note = cpu_note(gl, true).expect("GL llvmpipe is a CPU rasterizer");
        for part in ["5× the time of `--backend cpu`", "apt-get install mesa-vulkan-drivers libvulkan1", "lavapipe"] {
            assert!(note.contains(part), "{note}");
        }
        let lavapipe = "llvmpipe (LLVM 15.0.6, 256 bits) (llvmpipe Mesa 22.3.6 (LLVM 15.0.6), Vulkan)";
        let note = cpu_note(lavapipe, true).expect("lavapipe is a CPU rasterizer");
        assert!(note.contains("2× the time of `--backend cpu`") && !note.contains("apt-get"), "{note}");
        // By name where the driver does not say (an older wgpu, another backend).
        assert!(cpu_note("SwiftShader Device (Subzero) (SwiftShader driver, Vulkan)", false).is_some());
        assert_eq!(cpu_note("NVIDIA H100 80GB HBM3 (NVIDIA 550.54, Vulkan)", false), None);
    }
}
