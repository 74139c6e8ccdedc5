//! Registry-wide tests: names, units, WGSL twins, the per-pixel tables, neutral identity.

use super::*;
use crate::stokes::{Analyzer, Stokes};

#[test]
fn names_are_unique_snake_case_with_units() {
    let mut names: Vec<_> = REGISTRY.iter().map(|e| e.name).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), REGISTRY.len());
    for e in REGISTRY {
        assert!(e.name.chars().all(|c| c.is_ascii_lowercase() || c == '_'), "{}", e.name);
        assert!(!e.summary.is_empty() && !e.source.is_empty(), "{}: doc", e.name);
        assert!(!e.params.is_empty(), "{}", e.name);
        for p in e.params {
            assert!(["px", "deg", "DN", "1"].contains(&p.unit), "{}.{}", e.name, p.name);
            let suffix_ok = match p.unit {
                "px" => p.name.ends_with("_px"),
                "deg" => p.name.ends_with("_deg"),
                "DN" => p.name.ends_with("_dn"),
                _ => true,
            };
            assert!(suffix_ok, "{}.{} lacks its unit suffix", e.name, p.name);
            assert!(p.min <= p.neutral && p.neutral <= p.max && !p.doc.is_empty());
            // The typical strength lies in range and (unless zero is typical for one
            // of several parameters) away from neutral, so the hidden-effect test
            // exercises the effect.
            assert!(p.min <= p.typical && p.typical <= p.max, "{}.{} typical", e.name, p.name);
            // A real instrument's range lies within the fit's bounds and holds neutral
            // and typical.
            let (lo, hi) = p.physical_range();
            assert!(p.min <= lo && lo <= hi && hi <= p.max, "{}.{} physical", e.name, p.name);
            assert!((lo..=hi).contains(&p.neutral) && (lo..=hi).contains(&p.typical), "{}.{}", e.name, p.name);
        }
        assert!(e.params.iter().any(|p| p.typical != p.neutral), "{}: typical = neutral", e.name);
    }
}

#[test]
fn per_pixel_effects_have_their_wgsl_twin_and_only_they() {
    // A per-pixel (lens) effect must carry its WGSL twin, defining a function of its
    // own name; the files in shaders/effects are exactly the registry's twins.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders/effects");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".wgsl"))
        .collect();
    files.sort();
    let mut twins = Vec::new();
    for e in REGISTRY {
        if e.apply.is_ray() {
            // The per-pixel signature the generated WGSL dispatch calls.
            let sig = format!("fn {}(p: vec4<f64>, g: RayGeometry, s: Stokes) -> Stokes", e.name);
            assert!(e.wgsl.is_some_and(|w| w.contains(&sig)), "{}: its WGSL twin must define `{sig}`", e.name);
        }
        if e.apply.is_analyzer() {
            // The analyzer signature the generated WGSL `analyzer_effects` calls.
            let sig = format!(
                "fn {}(p: array<vec4<f64>, 2>, site: PixelSite, g: RayGeometry, a: PixelAnalyzer) -> PixelAnalyzer",
                e.name
            );
            assert!(e.wgsl.is_some_and(|w| w.contains(&sig)), "{}: its WGSL twin must define `{sig}`", e.name);
        }
        // The stage hooks' signatures the generated WGSL `sky_effects`, `sensor_effects`
        // and `mosaic_effects` call.
        let hook = match e.apply {
            Apply::Sky { .. } => {
                Some("p: array<vec4<f64>, 5>, sun: vec3<f64>, dmax: f64, g: RayGeometry, s: Stokes) -> Stokes")
            }
            Apply::Sensor { .. } => Some("p: vec4<f64>, signal_dn: f64, full_scale_dn: f64) -> f64"),
            Apply::Mosaic { .. } => Some("p: vec4<f64>, own: f64, up: f64, down: f64, left: f64, right: f64) -> f64"),
            _ => None,
        };
        if let Some(args) = hook {
            let sig = format!("fn {}({args}", e.name);
            assert!(e.wgsl.is_some_and(|w| w.contains(&sig)), "{}: its WGSL twin must define `{sig}`", e.name);
        }
        match e.wgsl {
            Some(src) => {
                assert!(src.contains(&format!("fn {}(", e.name)), "{}: WGSL lacks fn {}", e.name, e.name);
                let on_disk = std::fs::read_to_string(dir.join(format!("{}.wgsl", e.name))).unwrap();
                assert_eq!(src, on_disk, "{}: registry WGSL is not shaders/effects/{}.wgsl", e.name, e.name);
                twins.push(format!("{}.wgsl", e.name));
            }
            None => {
                assert_ne!(e.stage, Stage::Lens, "{}: a lens effect acts per pixel: it needs its WGSL twin", e.name)
            }
        }
    }
    twins.sort();
    assert_eq!(files, twins);
}

#[test]
fn per_pixel_tables_are_the_registry_in_order() {
    let rays: Vec<_> = REGISTRY.iter().filter(|e| e.apply.is_ray()).map(|e| e.name).collect();
    assert_eq!(RAY_EFFECTS.map(|e| e.name).to_vec(), rays);
    assert!(RAY_COUNT > 0 && RAY_COUNT == rays.len());
    let g = crate::camera::Intrinsics::new(crate::camera::Projection::Equidistant, 40.0, 31.5, 23.5).geometry(3.0, 5.0);
    let s = Stokes::new(1.3, 0.2, -0.4, 0.01);
    for (k, e) in RAY_EFFECTS.iter().enumerate() {
        assert_eq!(ray_slot(e), Some(k));
        // Slot k's function is the effect's own (same output at its typical strength).
        let Apply::Ray { params, pixel, .. } = e.apply else { unreachable!() };
        let p = params(&e.params.iter().map(|p| p.typical).collect::<Vec<_>>());
        assert_eq!(RAY_FNS[k](&p, &g, s), pixel(&p, &g, s), "{}: slot {k} calls another function", e.name);
        assert_ne!(pixel(&p, &g, s), s, "{}: typical strength changes nothing", e.name);
        // Lens effects act per pixel; the others of the registry fold into the frame.
        assert_eq!(e.stage, Stage::Lens, "{}", e.name);
    }
    assert!(ray_slot(&array_rotation::EFFECT).is_none());
}

#[test]
fn analyzer_tables_are_the_registry_in_order_and_neutral_is_exactly_the_identity() {
    let names: Vec<_> = REGISTRY.iter().filter(|e| e.apply.is_analyzer()).map(|e| e.name).collect();
    assert_eq!(ANALYZER_EFFECTS.map(|e| e.name).to_vec(), names);
    assert!(ANALYZER_COUNT > 0 && ANALYZER_COUNT == names.len());
    let g = crate::camera::Intrinsics::new(crate::camera::Projection::Equidistant, 40.0, 31.5, 23.5).geometry(3.0, 5.0);
    let a = PixelAnalyzer { analyzer: Analyzer::at(135.0, 0.3, 0.02), gain: 1.07 };
    for (k, e) in ANALYZER_EFFECTS.iter().enumerate() {
        assert_eq!(analyzer_slot(e), Some(k));
        assert_eq!(e.stage, Stage::Analyzer, "{}", e.name);
        let Apply::Analyzer { params, pixel } = e.apply else { unreachable!() };
        let p = params(&e.params.iter().map(|p| p.typical).collect::<Vec<_>>());
        for (u, v, ch) in [(0, 0, 0), (31, 23, 3), (1000, 7, 1)] {
            let site = PixelSite { u, v, ch, x_px: u as f64 - 31.5, y_px: v as f64 - 23.5 };
            // Slot k's function is the effect's own; it changes something at typical
            // strength (off the principal point) and nothing at neutral.
            assert_eq!(ANALYZER_FNS[k](&p, &site, &g, a), pixel(&p, &site, &g, a), "{}", e.name);
            assert_eq!(ANALYZER_FNS[k](&neutral_analyzer_params()[k], &site, &g, a), a, "{} at ({u}, {v})", e.name);
            if u > 0 {
                assert_ne!(pixel(&p, &site, &g, a), a, "{}: typical strength changes nothing", e.name);
            }
        }
    }
    assert!(analyzer_slot(&extinction_ratio::EFFECT).is_none());
}

#[test]
fn each_per_pixel_effect_at_neutral_is_exactly_the_identity() {
    use crate::camera::{Intrinsics, Projection};
    let intr = Intrinsics::new(Projection::Equidistant, 40.0, 31.5, 23.5);
    let s = Stokes::new(1.3, 0.2, -0.4, 0.01);
    for (k, e) in RAY_EFFECTS.iter().enumerate() {
        for (u, v) in [(0.0, 0.0), (31.5, 23.5), (63.0, 7.0)] {
            let g = intr.geometry(u, v);
            assert_eq!(RAY_FNS[k](&neutral_ray_params()[k], &g, s), s, "{} at ({u}, {v})", e.name);
        }
    }
}

#[test]
fn every_effect_at_neutral_is_the_ideal_model() {
    for e in REGISTRY {
        let mut set = EffectSet::new();
        set.enable(e.name).unwrap();
        assert_eq!(set.model(), Model::default(), "{}", e.name);
    }
}

#[test]
fn every_effect_away_from_neutral_changes_the_model() {
    for e in REGISTRY {
        for p in e.params {
            let mut set = EffectSet::new();
            let v = if p.max > p.neutral { p.neutral + 0.5 * (p.max - p.neutral).min(1.0) } else { p.neutral - 0.5 };
            set.set(e.name, p.name, v).unwrap();
            assert_ne!(set.model(), Model::default(), "{}.{}", e.name, p.name);
        }
    }
}

#[test]
fn assignments_parse_and_bad_ones_are_named() {
    let mut set = EffectSet::new();
    set.parse_assignment("array_rotation.dtheta_deg=0.3").unwrap();
    assert_eq!(set.get("array_rotation", "dtheta_deg"), Some(0.3));
    let e = set.parse_assignment("no_such.x=1").unwrap_err().to_string();
    assert!(e.contains("no_such") && e.contains("array_rotation"), "{e}");
    let e = set.parse_assignment("array_rotation.dtheta=1").unwrap_err().to_string();
    assert!(e.contains("dtheta_deg"), "{e}");
    assert!(set.parse_assignment("array_rotation.dtheta_deg=abc").is_err());
    assert!(set.parse_assignment("array_rotation.dtheta_deg=1e9").is_err());
}

#[test]
fn what_the_fit_and_the_diagnosis_know_of_an_effect_is_in_its_definition() {
    for e in REGISTRY {
        // One derivative kind per parameter, or none (central differences for all).
        assert!(e.derivatives.is_empty() || e.derivatives.len() == e.params.len(), "{}: derivatives", e.name);
        for (i, d) in e.derivatives.iter().enumerate() {
            assert_eq!(e.derivative(i), *d);
            if let ParamDerivative::ChannelOffset(k) = d {
                // An offset column is 1 on its channel: the parameter is a DN offset.
                assert!(*k < 4 && e.params[i].unit == "DN", "{}.{}", e.name, e.params[i].name);
            }
        }
        assert_eq!(e.derivative(e.params.len()), ParamDerivative::Central);
        // What a sky capture cannot separate says why and what measures it instead.
        if let Some(i) = e.inseparable {
            for fixed in [false, true] {
                assert!((i.why)(fixed).len() > 40, "{}: why", e.name);
            }
        }
    }
}
