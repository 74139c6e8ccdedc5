//! Assembles the WGSL modules: `shaders/common/*.wgsl`, the effects' twins from the
//! effect registry (`EffectDef::wgsl`), the per-pixel effects' dispatch generated from
//! the registry (`ray_dispatch.rs`), then one kernel file. `build.rs` has validated the
//! same modules with naga (a test checks the two assemble the same text).

use crate::precision::Precision;
use crate::ray_dispatch::{
    analyzer_effects_wgsl, mosaic_effects_wgsl, ray_effects_wgsl, sensor_effects_wgsl, sky_effects_wgsl,
};
use bpins_core::effects::{ANALYZER_EFFECTS, MOSAIC_EFFECTS, RAY_EFFECTS, REGISTRY, SENSOR_EFFECTS, SKY_EFFECTS};

/// The shared WGSL files, in file-name order (as build.rs reads them).
const COMMON: &[(&str, &str)] = &[
    ("camera.wgsl", include_str!("../../../shaders/common/camera.wgsl")),
    ("chain.wgsl", include_str!("../../../shaders/common/chain.wgsl")),
    ("heading.wgsl", include_str!("../../../shaders/common/heading.wgsl")),
    ("math.wgsl", include_str!("../../../shaders/common/math.wgsl")),
    ("noise.wgsl", include_str!("../../../shaders/common/noise.wgsl")),
    ("recon.wgsl", include_str!("../../../shaders/common/recon.wgsl")),
    ("sky.wgsl", include_str!("../../../shaders/common/sky.wgsl")),
    ("stokes.wgsl", include_str!("../../../shaders/common/stokes.wgsl")),
];

/// The kernels: name → entry points' file.
pub const KERNELS: &[(&str, &str)] = &[
    ("render", include_str!("../../../shaders/kernels/render.wgsl")),
    ("sums", include_str!("../../../shaders/kernels/sums.wgsl")),
    ("reduce", include_str!("../../../shaders/kernels/reduce.wgsl")),
];

/// The full WGSL source of `kernel` at `precision`; `None` for an unknown kernel name.
pub fn module_source_at(kernel: &str, precision: Precision) -> Option<String> {
    module_source(kernel).map(|src| precision.source(&src))
}

/// The full WGSL source of `kernel` as written (f64); `None` for an unknown kernel name.
pub fn module_source(kernel: &str) -> Option<String> {
    let (_, body) = KERNELS.iter().find(|(k, _)| *k == kernel)?;
    let mut src = String::new();
    for (_, s) in COMMON {
        src += s;
        src.push('\n');
    }
    // Per-pixel effects, in effect-name order (as build.rs reads shaders/effects).
    let mut effects: Vec<_> = REGISTRY.iter().filter_map(|e| e.wgsl.map(|w| (e.name, w))).collect();
    effects.sort();
    for (_, s) in effects {
        src += s;
        src.push('\n');
    }
    // The per-pixel effects in chain order, each with its slot of FrameParams::ray.
    src += &ray_effects_wgsl(&RAY_EFFECTS.map(|e| e.name));
    // The analyzer effects in chain order, each with its slot of FrameParams::analyzer.
    src += &analyzer_effects_wgsl(&ANALYZER_EFFECTS.map(|e| e.name));
    // The sky, sensor and mosaic effects in chain order, each with its slot of
    // FrameParams::sky, ::sensor and ::mosaic_fx.
    src += &sky_effects_wgsl(&SKY_EFFECTS.map(|e| e.name));
    src += &sensor_effects_wgsl(&SENSOR_EFFECTS.map(|e| e.name));
    src += &mosaic_effects_wgsl(&MOSAIC_EFFECTS.map(|e| e.name));
    src += body;
    Some(src)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn runtime_modules_are_the_ones_build_rs_validated() {
        // build.rs reads every file of shaders/common and shaders/effects: the runtime
        // list must name the same files with the same text.
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
        let mut common: Vec<String> = std::fs::read_dir(root.join("common"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".wgsl"))
            .collect();
        common.sort();
        assert_eq!(common, COMMON.iter().map(|(n, _)| n.to_string()).collect::<Vec<_>>());
        for (name, text) in COMMON {
            assert_eq!(*text, std::fs::read_to_string(root.join("common").join(name)).unwrap(), "{name}");
        }
        for (k, _) in KERNELS {
            // The f64 modules with FLOAT64, the f32 ones without it: no f64 is left.
            for (p, caps) in [
                (Precision::F64, naga::valid::Capabilities::FLOAT64),
                (Precision::F32, naga::valid::Capabilities::empty()),
            ] {
                let src = module_source_at(k, p).unwrap();
                let module = naga::front::wgsl::parse_str(&src).unwrap_or_else(|e| panic!("{k} {p:?}: {e}"));
                naga::valid::Validator::new(naga::valid::ValidationFlags::all(), caps)
                    .validate(&module)
                    .unwrap_or_else(|e| panic!("{k} {p:?}: {e:?}"));
            }
        }
    }

    #[test]
    fn build_rs_finds_the_registry_per_pixel_effects() {
        // build.rs validates the dispatch over the effect files with the per-pixel
        // signature; the registry's per-pixel effects must be exactly those.
        let mut files: Vec<(String, String)> =
            REGISTRY.iter().filter_map(|e| e.wgsl.map(|w| (e.name.to_string(), w.to_string()))).collect();
        files.sort();
        let mut found = crate::ray_dispatch::ray_effects_in(&files);
        found.sort();
        let mut registry = RAY_EFFECTS.map(|e| e.name).to_vec();
        registry.sort();
        assert_eq!(found, registry);
    }

    #[test]
    fn build_rs_finds_the_registry_analyzer_effects_and_the_dispatch_calls_them_in_order() {
        let files: Vec<(String, String)> =
            REGISTRY.iter().filter_map(|e| e.wgsl.map(|w| (e.name.to_string(), w.to_string()))).collect();
        let mut found = crate::ray_dispatch::analyzer_effects_in(&files);
        found.sort();
        let mut registry = ANALYZER_EFFECTS.map(|e| e.name).to_vec();
        registry.sort();
        assert_eq!(found, registry);
        let src = module_source("render").unwrap();
        let mut at = 0;
        for (k, e) in ANALYZER_EFFECTS.iter().enumerate() {
            let call = format!("out = {}(p[{k}], site, g, out);", e.name);
            let pos = src[at..].find(&call).unwrap_or_else(|| panic!("{call} missing or out of order"));
            at += pos + call.len();
        }
        assert!(src.contains(&format!("const ANALYZER_COUNT: u32 = {}u;", ANALYZER_EFFECTS.len())));
    }

    #[test]
    fn the_dispatch_calls_every_per_pixel_effect_in_registry_order() {
        let src = module_source("render").unwrap();
        let mut at = 0;
        for (k, e) in RAY_EFFECTS.iter().enumerate() {
            let call = format!("out = {}(p[{k}], g, out);", e.name);
            let pos = src[at..].find(&call).unwrap_or_else(|| panic!("{call} missing or out of order"));
            at += pos + call.len();
        }
        assert!(src.contains(&format!("const RAY_COUNT: u32 = {}u;", RAY_EFFECTS.len())));
    }

    #[test]
    fn build_rs_finds_the_registry_stage_hooks_and_the_dispatch_calls_them_in_order() {
        use crate::ray_dispatch::{mosaic_effects_in, sensor_effects_in, sky_effects_in};
        use bpins_core::effects::EffectDef;
        let files: Vec<(String, String)> =
            REGISTRY.iter().filter_map(|e| e.wgsl.map(|w| (e.name.to_string(), w.to_string()))).collect();
        let src = module_source("render").unwrap();
        type Finder = for<'a> fn(&'a [(String, String)]) -> Vec<&'a str>;
        let kinds: [(&[&EffectDef], Finder, &str, &str); 3] = [
            (&SKY_EFFECTS, sky_effects_in, "SKY_COUNT", "sun, dmax, g, out"),
            (&SENSOR_EFFECTS, sensor_effects_in, "SENSOR_COUNT", "out, full_scale_dn"),
            (&MOSAIC_EFFECTS, mosaic_effects_in, "MOSAIC_COUNT", "out, up, down, left, right"),
        ];
        for (effects, find, count, args) in kinds {
            let mut found = find(&files);
            found.sort();
            let mut registry: Vec<&str> = effects.iter().map(|e| e.name).collect();
            registry.sort();
            assert_eq!(found, registry, "{count}");
            let mut at = 0;
            for (k, e) in effects.iter().enumerate() {
                let call = format!("out = {}(p[{k}], {args});", e.name);
                let pos = src[at..].find(&call).unwrap_or_else(|| panic!("{call} missing or out of order"));
                at += pos + call.len();
            }
            assert!(src.contains(&format!("const {count}: u32 = {}u;", effects.len())));
        }
    }

    #[test]
    fn every_effect_twin_is_in_every_kernel() {
        for e in REGISTRY.iter().filter(|e| e.wgsl.is_some()) {
            for (k, _) in KERNELS {
                assert!(module_source(k).unwrap().contains(&format!("fn {}(", e.name)), "{} in {k}", e.name);
            }
        }
    }
}
