//! The effect registry: every physical effect between the sky and the DN values is
//! one module here, one [`EffectDef`] and one line in [`REGISTRY`].
//!
//! An effect declares its parameters (name with unit suffix, unit, neutral value,
//! range) and folds its values into the chain's parameter block [`Model`]; effects
//! that act per pixel also expose a pure function that the chain calls at a fixed
//! place (`chain::pixel_stokes`) — the same name as its WGSL twin. From this registry
//! come the CLI listing (`bpins effects`), the `--effect name.param=value` parser, the
//! parameter list of a fit and the registry-wide tests below. At neutral values every
//! effect leaves the chain exactly as the ideal one (tested for all).
//!
//! Catalog: docs/spec/EFFECTS.md, every effect of it.

pub mod analyzer_angles;
pub mod array_rotation;
pub mod channel_response;
pub mod crosstalk;
pub mod extinction_ratio;
pub mod focal_length;
pub mod lens_depolarization;
pub mod lens_diattenuation;
pub mod lens_retardance;
pub mod mount_tilt;
pub mod principal_point;
pub mod radial_distortion;
pub mod sky_depolarization;
pub mod sky_neutral_points;
pub mod vignetting;

use crate::error::{Error, Result};

/// Where in the chain an effect acts (for listings and documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Camera geometry: which ray a pixel sees.
    Geometry,
    /// The sky pattern itself.
    Sky,
    /// Lens Mueller matrix, in each ray's meridional frame.
    Lens,
    /// The micro-polarizer analyzers.
    Analyzer,
    /// The CMOS response.
    Sensor,
}

impl Stage {
    pub fn name(self) -> &'static str {
        match self {
            Stage::Geometry => "geometry",
            Stage::Sky => "sky",
            Stage::Lens => "lens",
            Stage::Analyzer => "analyzer",
            Stage::Sensor => "sensor",
        }
    }
}

/// One parameter of an effect.
#[derive(Debug, PartialEq)]
pub struct ParamSpec {
    /// Name as used in files and on the command line, unit as suffix.
    pub name: &'static str,
    /// Unit: "px", "deg", "DN" or "1" (dimensionless).
    pub unit: &'static str,
    /// The value at which the effect vanishes.
    pub neutral: f64,
    /// A realistic strength, as real sensors show it: what the hidden-effect tests
    /// simulate (and `bpins effects` lists), so a new effect is tested by being here.
    pub typical: f64,
    /// Physically meaningful range (inclusive).
    pub min: f64,
    pub max: f64,
    pub doc: &'static str,
}

/// One physical effect.
#[derive(Debug)]
pub struct EffectDef {
    pub name: &'static str,
    /// One line: what it does.
    pub summary: &'static str,
    /// Where the equation comes from.
    pub source: &'static str,
    pub stage: Stage,
    pub params: &'static [ParamSpec],
    /// Adds this effect's parameter `values` (in `params` order) into `model`.
    pub apply: fn(values: &[f64], model: &mut Model),
    /// The WGSL twin of the effect's per-pixel functions (`shaders/effects/<name>.wgsl`,
    /// same function names), from which the GPU crate assembles its chain; `None` for
    /// an effect that acts only through the frame's parameters (folded by `apply` on
    /// the host, identically for both backends), which runs nothing per pixel.
    pub wgsl: Option<&'static str>,
}

impl EffectDef {
    pub(crate) fn param_index(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name == name)
    }

    pub(crate) fn neutral_values(&self) -> Vec<f64> {
        self.params.iter().map(|p| p.neutral).collect()
    }
}

/// Every effect bpins knows, in chain order. Adding an effect: one module, one line here.
pub static REGISTRY: &[&EffectDef] = &[
    &principal_point::EFFECT,
    &focal_length::EFFECT,
    &radial_distortion::EFFECT,
    &mount_tilt::EFFECT,
    &sky_depolarization::EFFECT,
    &sky_neutral_points::EFFECT,
    &lens_diattenuation::EFFECT,
    &lens_retardance::EFFECT,
    &lens_depolarization::EFFECT,
    &vignetting::EFFECT,
    &array_rotation::EFFECT,
    &analyzer_angles::EFFECT,
    &extinction_ratio::EFFECT,
    &channel_response::EFFECT,
    &crosstalk::EFFECT,
];

/// Looks an effect up by name.
pub fn find(name: &str) -> Result<&'static EffectDef> {
    REGISTRY.iter().copied().find(|e| e.name == name).ok_or_else(|| Error::UnknownEffect {
        name: name.to_string(),
        known: REGISTRY.iter().map(|e| e.name).collect::<Vec<_>>().join(", "),
    })
}

/// The chain's parameter block: the ideal chain plus what enabled effects fold in.
/// `Model::default()` is the ideal chain. Angles in degrees, offsets in DN and px.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// True principal point minus nominal, (x, y) px.
    pub pp_offset_px: [f64; 2],
    /// True focal length = nominal · (1 + focal_scale).
    pub focal_scale: f64,
    /// Radial distortion (k1, k2) of the normalised coordinates.
    pub distortion: [f64; 2],
    /// Factor on the scene's sky d_max (1: as the scene says).
    pub sky_dmax_factor: f64,
    /// Separation of each pair of the sky's neutral points, degrees (0: Rayleigh).
    pub neutral_separation_deg: f64,
    /// Lens retardance δ = lens_delta2_deg · r², degrees, meridional frame.
    pub lens_delta2_deg: f64,
    /// Lens depolarization: Q, U, V × (1 − p2 r²).
    pub lens_depol_p2: f64,
    /// Vignetting (v2, v4): intensity × (1 + v2 r² + v4 r⁴).
    pub vignetting: [f64; 2],
    /// Camera tilt on its mount about camera x then y, degrees.
    pub mount_tilt_deg: [f64; 2],
    /// Lens diattenuation ρ = rho2 · r² (r in focal lengths), meridional frame.
    pub lens_rho2: f64,
    /// Each analyzer's angle minus nominal, degrees, by channel index (0, 45, 90, 135).
    pub analyzer_delta_deg: [f64; 4],
    /// Each analyzer's ε = 1/ER.
    pub analyzer_eps: [f64; 4],
    /// Relative gain of each channel (1 + gain_k); channel 0 is the reference.
    pub channel_gain: [f64; 4],
    /// Offset of each channel, DN, added to the black level.
    pub channel_offset_dn: [f64; 4],
    /// DoFP crosstalk: the fraction of its signal a pixel gives each edge neighbour.
    pub crosstalk: f64,
}

impl Default for Model {
    fn default() -> Self {
        Model {
            pp_offset_px: [0.0; 2],
            focal_scale: 0.0,
            distortion: [0.0; 2],
            sky_dmax_factor: 1.0,
            neutral_separation_deg: 0.0,
            lens_delta2_deg: 0.0,
            lens_depol_p2: 0.0,
            vignetting: [0.0; 2],
            mount_tilt_deg: [0.0; 2],
            lens_rho2: 0.0,
            analyzer_delta_deg: [0.0; 4],
            analyzer_eps: [0.0; 4],
            channel_gain: [1.0; 4],
            channel_offset_dn: [0.0; 4],
            crosstalk: 0.0,
        }
    }
}

impl Model {
    /// The camera `nominal` with this model's geometry folded in: principal point
    /// moved, focal length scaled, radial distortion added. The chain's true camera,
    /// and the camera a heading extractor assumes when the model is a calibration.
    pub fn camera(&self, nominal: &crate::camera::Intrinsics) -> crate::camera::Intrinsics {
        crate::camera::Intrinsics {
            f_px: nominal.f_px * (1.0 + self.focal_scale),
            distortion: [nominal.distortion[0] + self.distortion[0], nominal.distortion[1] + self.distortion[1]],
            cx_px: nominal.cx_px + self.pp_offset_px[0],
            cy_px: nominal.cy_px + self.pp_offset_px[1],
            ..*nominal
        }
    }
}

/// A set of enabled effects with their values.
#[derive(Clone, Debug, Default)]
pub struct EffectSet {
    entries: Vec<(&'static EffectDef, Vec<f64>)>,
}

impl EffectSet {
    pub fn new() -> Self {
        EffectSet::default()
    }

    /// Enables `name` at neutral values (no-op when already enabled).
    pub fn enable(&mut self, name: &str) -> Result<()> {
        let def = find(name)?;
        if !self.entries.iter().any(|(d, _)| d.name == def.name) {
            self.entries.push((def, def.neutral_values()));
        }
        Ok(())
    }

    /// Sets `effect.param` to `value`, enabling the effect.
    pub fn set(&mut self, effect: &str, param: &str, value: f64) -> Result<()> {
        let def = find(effect)?;
        let idx = def.param_index(param).ok_or_else(|| Error::UnknownParam {
            effect: effect.to_string(),
            param: param.to_string(),
            known: def.params.iter().map(|p| p.name).collect::<Vec<_>>().join(", "),
        })?;
        let spec = &def.params[idx];
        if !value.is_finite() || value < spec.min || value > spec.max {
            return Err(Error::BadParam {
                spec: format!("{effect}.{param}={value}"),
                message: format!("must lie in [{}, {}] {}", spec.min, spec.max, spec.unit),
            });
        }
        self.enable(effect)?;
        let entry = self.entries.iter_mut().find(|(d, _)| d.name == def.name).expect("just enabled");
        entry.1[idx] = value;
        Ok(())
    }

    /// Parses `effect.param=value` (as given to `--effect`) and applies it.
    pub fn parse_assignment(&mut self, spec: &str) -> Result<()> {
        let bad = |m: &str| Error::BadParam { spec: spec.to_string(), message: m.to_string() };
        let (lhs, rhs) = spec.split_once('=').ok_or_else(|| bad("expected effect.param=value"))?;
        let (effect, param) = lhs.trim().split_once('.').ok_or_else(|| bad("expected effect.param=value"))?;
        let value: f64 = rhs.trim().parse().map_err(|_| bad("the value is not a number"))?;
        self.set(effect.trim(), param.trim(), value)
    }

    /// Value of `effect.param` if the effect is enabled.
    pub fn get(&self, effect: &str, param: &str) -> Option<f64> {
        let (def, vals) = self.entries.iter().find(|(d, _)| d.name == effect)?;
        def.param_index(param).map(|i| vals[i])
    }

    /// Enabled effects with their values, in the order they were enabled.
    pub fn iter(&self) -> impl Iterator<Item = (&'static EffectDef, &[f64])> {
        self.entries.iter().map(|(d, v)| (*d, v.as_slice()))
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The chain's parameter block with every enabled effect folded in.
    pub fn model(&self) -> Model {
        let mut m = Model::default();
        for (def, vals) in &self.entries {
            (def.apply)(vals, &mut m);
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            match e.wgsl {
                Some(src) => {
                    assert!(src.contains(&format!("fn {}(", e.name)), "{}: WGSL lacks fn {}", e.name, e.name);
                    let on_disk = std::fs::read_to_string(dir.join(format!("{}.wgsl", e.name))).unwrap();
                    assert_eq!(src, on_disk, "{}: registry WGSL is not shaders/effects/{}.wgsl", e.name, e.name);
                    twins.push(format!("{}.wgsl", e.name));
                }
                None => assert_ne!(e.stage, Stage::Lens, "{}: a per-pixel effect needs its WGSL twin", e.name),
            }
        }
        twins.sort();
        assert_eq!(files, twins);
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
                let v =
                    if p.max > p.neutral { p.neutral + 0.5 * (p.max - p.neutral).min(1.0) } else { p.neutral - 0.5 };
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
}
