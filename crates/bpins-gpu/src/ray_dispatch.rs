//! The WGSL dispatch of the registry's hooks (sky, per-pixel, analyzer, sensor and
//! mosaic effects), generated from their names: the twins of `sky_effects`,
//! `ray_effects`, … in `crates/bpins-core/src/chain/mod.rs`, which call the same
//! functions in the same (registry) order.
//!
//! Each stage's dispatch calls effect `k` only where bit `k` of the stage's pipeline
//! constant (`SKY_ON`, `RAY_ON`, `ANALYZER_ON`, `SENSOR_ON`, `MOSAIC_ON`: [`MASKS`]) is
//! set. The host sets a bit where some frame of the dispatch has that effect off its
//! neutral vector (`masks.rs`), so a neutral effect, the identity there (bitwise, as
//! on the CPU: `chain::ActiveEffects`), costs no work per pixel: the driver drops its
//! call at compile time, where a test of the frame's vector at run time would be work
//! at every pixel (llvmpipe even runs both sides of a uniform branch).
//!
//! Shared by `build.rs` (which has no registry: it finds the effects among
//! `shaders/effects/*.wgsl` by their signature, to validate the kernels with naga) and
//! `shaders.rs` (which takes them from the registry, `bpins_core::effects::RAY_EFFECTS`,
//! …, in chain order). A test checks that both find the same effects.

/// The pipeline constants of the stages' masks, in the order sky, per-pixel (ray),
/// analyzer, sensor, mosaic; each `u32`, every bit set by default (every effect run).
pub const MASKS: [&str; 5] = ["SKY_ON", "RAY_ON", "ANALYZER_ON", "SENSOR_ON", "MOSAIC_ON"];

/// Most effects one stage may have: one bit each in its mask.
pub const MAX_STAGE_EFFECTS: usize = 32;

/// One stage's dispatch: `const {count}`, `override {mask}` and the function `header`
/// (which names its first value `first`), calling `name(p[k], {args})` on `out` for
/// each effect of `names` whose bit is set.
fn stage_wgsl(names: &[&str], count: &str, mask: &str, doc: &str, header: &str, first: &str, args: &str) -> String {
    assert!(
        !names.is_empty() && names.len() <= MAX_STAGE_EFFECTS,
        "{count}: {} effects (WGSL has no empty arrays; the mask has {MAX_STAGE_EFFECTS} bits)",
        names.len()
    );
    let mut s = String::from("// Generated from the effect registry by crates/bpins-gpu/src/ray_dispatch.rs.\n\n");
    s += &format!("const {count}: u32 = {}u;\n\n", names.len());
    s += "// Pipeline constant: bit k set where effect k of this stage is on in some frame of the\n";
    s += "// dispatch (crates/bpins-gpu/src/masks.rs); the others, the identity at neutral, are\n";
    s += "// left out at compile time. Every bit by default.\n";
    s += &format!("override {mask}: u32 = 0xffffffffu;\n\n");
    s += &format!("// {doc}\n");
    s += &format!("{header} {{\n");
    s += &format!("    var out = {first};\n");
    for (k, name) in names.iter().enumerate() {
        s += &format!("    if (({mask} & {:#x}u) != 0u) {{\n", 1u32 << k);
        s += &format!("        out = {name}(p[{k}], {args});\n");
        s += "    }\n";
    }
    s += "    return out;\n}\n";
    s
}

/// The signature every per-pixel effect's WGSL twin defines (`name` its effect's name).
pub fn ray_signature(name: &str) -> String {
    format!("fn {name}(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes")
}

/// The per-pixel effects among WGSL `files` (file stem, source): those whose source
/// defines [`ray_signature`] of their stem, in the order given.
pub fn ray_effects_in(files: &[(String, String)]) -> Vec<&str> {
    files.iter().filter(|(stem, src)| src.contains(&ray_signature(stem))).map(|(stem, _)| stem.as_str()).collect()
}

/// WGSL: `RAY_COUNT`, `RAY_ON` and `ray_effects`, which applies the effects `names` in
/// order, effect `k` with its vector `p[k]` (`FrameParams::ray`) where bit `k` of
/// `RAY_ON` is set. At least one name (WGSL has
/// no empty arrays; the registry test keeps one).
pub fn ray_effects_wgsl(names: &[&str]) -> String {
    stage_wgsl(
        names,
        "RAY_COUNT",
        MASKS[1],
        "Every per-pixel effect on the ray g's meridional-frame Stokes vector, in registry order \
         (CPU twin: `ray_effects` in crates/bpins-core/src/chain/mod.rs).",
        "fn ray_effects(p: array<vec4<f64>, RAY_COUNT>, g: RayGeometry, s: Stokes) -> Stokes",
        "s",
        "g, out",
    )
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

/// WGSL: `ANALYZER_COUNT`, `ANALYZER_ON` and `analyzer_effects`, which applies the
/// analyzer effects `names` in order, effect `k` with its vectors `p[k]`
/// (`FrameParams::analyzer`) where bit `k` of `ANALYZER_ON` is set; the twin of
/// `chain::analyzer_effects`. At least one name (WGSL has no empty arrays).
pub fn analyzer_effects_wgsl(names: &[&str]) -> String {
    stage_wgsl(
        names,
        "ANALYZER_COUNT",
        MASKS[2],
        "Every analyzer effect on pixel site's analyzer a (ray g), in registry order.",
        "fn analyzer_effects(p: array<array<vec4<f64>, 2>, ANALYZER_COUNT>, site: PixelSite, g: RayGeometry, \
         a: PixelAnalyzer) -> PixelAnalyzer",
        "a",
        "site, g, out",
    )
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

/// WGSL: `SKY_COUNT`, `SKY_ON` and `sky_effects`, which applies the sky effects `names`
/// in order, effect `k` with its vectors `p[k]` (`FrameParams::sky`) where bit `k` of
/// `SKY_ON` is set; the twin of `chain::sky_effects`. At least one name (WGSL has no empty arrays).
pub fn sky_effects_wgsl(names: &[&str]) -> String {
    stage_wgsl(
        names,
        "SKY_COUNT",
        MASKS[0],
        "Every sky effect on the sky's meridional-frame Stokes vector s along the ray g, in registry order.",
        "fn sky_effects(p: array<array<vec4<f64>, 5>, SKY_COUNT>, sun: vec3<f64>, dmax: f64, g: RayGeometry, \
         s: Stokes) -> Stokes",
        "s",
        "sun, dmax, g, out",
    )
}

/// The signature every sensor effect's WGSL twin defines (`name` its effect's name).
pub fn sensor_signature(name: &str) -> String {
    format!("fn {name}(p: vec4<f64>, signal_dn: f64, full_scale_dn: f64) -> f64")
}

/// The sensor effects among WGSL `files` (file stem, source), in the order given.
pub fn sensor_effects_in(files: &[(String, String)]) -> Vec<&str> {
    files.iter().filter(|(stem, src)| src.contains(&sensor_signature(stem))).map(|(stem, _)| stem.as_str()).collect()
}

/// WGSL: `SENSOR_COUNT`, `SENSOR_ON` and `sensor_effects`, which applies the sensor
/// effects `names` in order, effect `k` with its vector `p[k]` (`FrameParams::sensor`)
/// where bit `k` of `SENSOR_ON` is set; the twin of `chain::sensor_effects`. At least one name.
pub fn sensor_effects_wgsl(names: &[&str]) -> String {
    stage_wgsl(
        names,
        "SENSOR_COUNT",
        MASKS[3],
        "Every sensor effect on the photo-signal (DN above the offset, after PRNU), in registry order.",
        "fn sensor_effects(p: array<vec4<f64>, SENSOR_COUNT>, signal_dn: f64, full_scale_dn: f64) -> f64",
        "signal_dn",
        "out, full_scale_dn",
    )
}

/// The signature every mosaic effect's WGSL twin defines (`name` its effect's name).
pub fn mosaic_signature(name: &str) -> String {
    format!("fn {name}(p: vec4<f64>, own: f64, up: f64, down: f64, left: f64, right: f64) -> f64")
}

/// The mosaic effects among WGSL `files` (file stem, source), in the order given.
pub fn mosaic_effects_in(files: &[(String, String)]) -> Vec<&str> {
    files.iter().filter(|(stem, src)| src.contains(&mosaic_signature(stem))).map(|(stem, _)| stem.as_str()).collect()
}

/// WGSL: `MOSAIC_COUNT`, `MOSAIC_ON` and `mosaic_effects`, which applies the mosaic
/// effects `names` in order, effect `k` with its vector `p[k]` (`FrameParams::mosaic_fx`)
/// where bit `k` of `MOSAIC_ON` is set; the twin of `chain::mosaic_effects`. At least one name.
pub fn mosaic_effects_wgsl(names: &[&str]) -> String {
    stage_wgsl(
        names,
        "MOSAIC_COUNT",
        MASKS[4],
        "Every mosaic effect on a DoFP pixel's photo-signal and its edge neighbours', in registry order.",
        "fn mosaic_effects(p: array<vec4<f64>, MOSAIC_COUNT>, own: f64, up: f64, down: f64, left: f64, \
         right: f64) -> f64",
        "own",
        "out, up, down, left, right",
    )
}
