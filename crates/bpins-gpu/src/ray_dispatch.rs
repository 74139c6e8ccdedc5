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

/// The signature every sky effect's WGSL twin defines (`name` its effect's name).
pub fn sky_signature(name: &str) -> String {
    format!("fn {name}(p: array<vec4<f64>, 5>, sun: vec3<f64>, dmax: f64, g: RayGeometry, s: Stokes) -> Stokes")
}

/// The sky effects among WGSL `files` (file stem, source): those whose source defines
/// [`sky_signature`] of their stem, in the order given.
pub fn sky_effects_in(files: &[(String, String)]) -> Vec<&str> {
    files.iter().filter(|(stem, src)| src.contains(&sky_signature(stem))).map(|(stem, _)| stem.as_str()).collect()
}

/// WGSL: `SKY_COUNT` and `sky_effects`, which applies the sky effects `names` in order,
/// effect `k` with its vectors `p[k]` (`FrameParams::sky`); the twin of
/// `chain::sky_effects`. At least one name (WGSL has no empty arrays).
pub fn sky_effects_wgsl(names: &[&str]) -> String {
    let mut s = String::from("// Generated from the effect registry by crates/bpins-gpu/src/ray_dispatch.rs.\n\n");
    s += &format!("const SKY_COUNT: u32 = {}u;\n\n", names.len());
    s += "// Every sky effect on the sky's meridional-frame Stokes vector s along the ray g, in registry order.\n";
    s += "fn sky_effects(p: array<array<vec4<f64>, 5>, SKY_COUNT>, sun: vec3<f64>, dmax: f64, g: RayGeometry, \
          s: Stokes) -> Stokes {\n";
    s += "    var out = s;\n";
    for (k, name) in names.iter().enumerate() {
        s += &format!("    out = {name}(p[{k}], sun, dmax, g, out);\n");
    }
    s += "    return out;\n}\n";
    s
}

/// The signature every sensor effect's WGSL twin defines (`name` its effect's name).
pub fn sensor_signature(name: &str) -> String {
    format!("fn {name}(p: vec4<f64>, signal_dn: f64, full_scale_dn: f64) -> f64")
}

/// The sensor effects among WGSL `files` (file stem, source), in the order given.
pub fn sensor_effects_in(files: &[(String, String)]) -> Vec<&str> {
    files.iter().filter(|(stem, src)| src.contains(&sensor_signature(stem))).map(|(stem, _)| stem.as_str()).collect()
}

/// WGSL: `SENSOR_COUNT` and `sensor_effects`, which applies the sensor effects `names`
/// in order, effect `k` with its vector `p[k]` (`FrameParams::sensor`); the twin of
/// `chain::sensor_effects`. At least one name.
pub fn sensor_effects_wgsl(names: &[&str]) -> String {
    let mut s = String::from("// Generated from the effect registry by crates/bpins-gpu/src/ray_dispatch.rs.\n\n");
    s += &format!("const SENSOR_COUNT: u32 = {}u;\n\n", names.len());
    s += "// Every sensor effect on the photo-signal (DN above the offset, after PRNU), in registry order.\n";
    s += "fn sensor_effects(p: array<vec4<f64>, SENSOR_COUNT>, signal_dn: f64, full_scale_dn: f64) -> f64 {\n";
    s += "    var out = signal_dn;\n";
    for (k, name) in names.iter().enumerate() {
        s += &format!("    out = {name}(p[{k}], out, full_scale_dn);\n");
    }
    s += "    return out;\n}\n";
    s
}

/// The signature every mosaic effect's WGSL twin defines (`name` its effect's name).
pub fn mosaic_signature(name: &str) -> String {
    format!("fn {name}(p: vec4<f64>, own: f64, up: f64, down: f64, left: f64, right: f64) -> f64")
}

/// The mosaic effects among WGSL `files` (file stem, source), in the order given.
pub fn mosaic_effects_in(files: &[(String, String)]) -> Vec<&str> {
    files.iter().filter(|(stem, src)| src.contains(&mosaic_signature(stem))).map(|(stem, _)| stem.as_str()).collect()
}

/// WGSL: `MOSAIC_COUNT` and `mosaic_effects`, which applies the mosaic effects `names`
/// in order, effect `k` with its vector `p[k]` (`FrameParams::mosaic_fx`); the twin of
/// `chain::mosaic_effects`. At least one name.
pub fn mosaic_effects_wgsl(names: &[&str]) -> String {
    let mut s = String::from("// Generated from the effect registry by crates/bpins-gpu/src/ray_dispatch.rs.\n\n");
    s += &format!("const MOSAIC_COUNT: u32 = {}u;\n\n", names.len());
    s += "// Every mosaic effect on a DoFP pixel's photo-signal and its edge neighbours', in registry order.\n";
    s += "fn mosaic_effects(p: array<vec4<f64>, MOSAIC_COUNT>, own: f64, up: f64, down: f64, left: f64, \
          right: f64) -> f64 {\n";
    s += "    var out = own;\n";
    for (k, name) in names.iter().enumerate() {
        s += &format!("    out = {name}(p[{k}], out, up, down, left, right);\n");
    }
    s += "    return out;\n}\n";
    s
}
