//! Helpers shared by the CLI's end-to-end test binaries.

/// Whether the GPU twin can run here; without an adapter the GPU tests report
/// themselves skipped, except with `CI` set, where that is a failure.
pub fn gpu_available() -> bool {
    match bpins_gpu::Gpu::new() {
        Ok(_) => true,
        Err(e) if std::env::var_os("CI").is_some() => panic!("CI is set and the GPU backend cannot run: {e}"),
        Err(e) => {
            eprintln!("SKIPPED (no usable Vulkan adapter): {e}");
            false
        }
    }
}
