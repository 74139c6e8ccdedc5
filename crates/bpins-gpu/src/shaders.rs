//! Assembles the WGSL modules: `shaders/common/*.wgsl`, the per-pixel effects' twins
//! from the effect registry (`EffectDef::wgsl`), then one kernel file. `build.rs` has
//! validated the same modules with naga (a test checks the two assemble the same text).

use bpins_core::effects::REGISTRY;

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

/// The full WGSL source of `kernel`; `None` for an unknown kernel name.
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
            let src = module_source(k).unwrap();
            let module = naga::front::wgsl::parse_str(&src).unwrap();
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::FLOAT64)
                .validate(&module)
                .unwrap_or_else(|e| panic!("{k}: {e:?}"));
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
