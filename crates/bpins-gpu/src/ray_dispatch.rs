//! The WGSL dispatch of the per-pixel effects, generated from their names: the twin of
//! `ray_effects` in `crates/bpins-core/src/chain/mod.rs`, which calls the same
//! functions in the same (registry) order.
//!
//! Shared by `build.rs` (which has no registry: it finds the per-pixel effects among
//! `shaders/effects/*.wgsl` by their signature, to validate the kernels with naga) and
//! `shaders.rs` (which takes them from the registry, `bpins_core::effects::RAY_EFFECTS`,
//! in chain order). A test checks that both find the same effects.

/// The signature every per-pixel effect's WGSL twin defines (`name` its effect's name).
pub fn ray_signature(name: &str) -> String {
    format!("fn {name}(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes")
}

/// The per-pixel effects among WGSL `files` (file stem, source): those whose source
/// defines [`ray_signature`] of their stem, in the order given.
pub fn ray_effects_in(files: &[(String, String)]) -> Vec<&str> {
    files.iter().filter(|(stem, src)| src.contains(&ray_signature(stem))).map(|(stem, _)| stem.as_str()).collect()
}

/// WGSL: `RAY_COUNT` and `ray_effects`, which applies the effects `names` in order,
/// effect `k` with its vector `p[k]` (`FrameParams::ray`). At least one name (WGSL has
/// no empty arrays; the registry test keeps one).
pub fn ray_effects_wgsl(names: &[&str]) -> String {
    let mut s = String::from(
        "// Generated from the effect registry by crates/bpins-gpu/src/ray_dispatch.rs.\n\
         // CPU twin: `ray_effects` in crates/bpins-core/src/chain/mod.rs.\n\n",
    );
    s += &format!("const RAY_COUNT: u32 = {}u;\n\n", names.len());
    s += "// Every per-pixel effect on the ray g's meridional-frame Stokes vector, in registry order.\n";
    s += "fn ray_effects(p: array<vec4<f64>, RAY_COUNT>, g: RayGeometry, s: Stokes) -> Stokes {\n";
    s += "    var out = s;\n";
    for (k, name) in names.iter().enumerate() {
        s += &format!("    out = {name}(p[{k}], g, out);\n");
    }
    s += "    return out;\n}\n";
    s
}

/// The signature every analyzer effect's WGSL twin defines (`name` its effect's name).
pub fn analyzer_signature(name: &str) -> String {
    format!("fn {name}(p: array<vec4<f64>, 2>, site: PixelSite, g: RayGeometry, a: PixelAnalyzer) -> PixelAnalyzer")
}

/// The analyzer effects among WGSL `files` (file stem, source): those whose source
/// defines [`analyzer_signature`] of their stem, in the order given.
pub fn analyzer_effects_in(files: &[(String, String)]) -> Vec<&str> {
    files.iter().filter(|(stem, src)| src.contains(&analyzer_signature(stem))).map(|(stem, _)| stem.as_str()).collect()
}

/// WGSL: `ANALYZER_COUNT` and `analyzer_effects`, which applies the analyzer effects
/// `names` in order, effect `k` with its vectors `p[k]` (`FrameParams::analyzer`); the
/// twin of `chain::analyzer_effects`. At least one name (WGSL has no empty arrays).
pub fn analyzer_effects_wgsl(names: &[&str]) -> String {
    let mut s = String::from("// Generated from the effect registry by crates/bpins-gpu/src/ray_dispatch.rs.\n\n");
    s += &format!("const ANALYZER_COUNT: u32 = {}u;\n\n", names.len());
    s += "// Every analyzer effect on pixel site's analyzer a (ray g), in registry order.\n";
    s += "fn analyzer_effects(p: array<array<vec4<f64>, 2>, ANALYZER_COUNT>, site: PixelSite, g: RayGeometry, \
          a: PixelAnalyzer) -> PixelAnalyzer {\n";
    s += "    var out = a;\n";
    for (k, name) in names.iter().enumerate() {
        s += &format!("    out = {name}(p[{k}], site, g, out);\n");
    }
    s += "    return out;\n}\n";
    s
}
