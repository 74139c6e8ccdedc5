//! Scene elements: things in the world that a robot's polarization camera sees
//! beside the clear sky — the sky's real radiance distribution, clouds, the sun's
//! disc and aureole, trees, buildings and the ground. Field conditions, as opposed to
//! the lens and sensor effects of [`crate::effects`].
//!
//! Each element is one module here with its equation, source, units, frame and
//! limits in its doc block and its tests beside it, one [`ElementDef`] and one line
//! in [`ELEMENTS`]: a catalog entry of the same shape as an effect's
//! ([`crate::catalog`]: its parameters are [`ParamSpec`]s, parsed, checked and
//! refused by the same code). A capture's choice is a [`FieldScene`] (enabled elements with
//! their values and a seed); per frame it is folded into a [`FieldFrame`] (world
//! orientation, sun, each element's constants and per-frame draws) that the chain
//! holds as `ChainFrame::field` and applies right after the sky's Stokes vector
//! through one call, [`field_stokes`] (meridional frame in and out).
//!
//! Every random draw is a pure function of the scene's seed (the project's `pcg4d`
//! hash, `noise.rs`): things fixed in the world (clouds, the skyline, textures) are
//! keyed by (seed, element); per-frame draws (a cloud's E-vector turn) by (seed,
//! element, frame). The CPU chain only: the GPU backend refuses frames with a field.

#[cfg(feature = "io")]
pub(crate) mod attitude;
pub(crate) mod clouds;
pub(crate) mod frame;
pub(crate) mod night_background;
pub(crate) mod overcast;
pub(crate) mod sky_radiance;
pub(crate) mod skyline;
pub(crate) mod sun_disc;
pub(crate) mod texture;
pub(crate) mod twilight;

#[cfg(feature = "io")]
pub use attitude::FieldAttitude;
pub use frame::Layer;
pub(crate) use frame::{field_stokes, linear_stokes, Draws, ElementContext, FieldElement, FieldFrame, FieldRay};

use crate::catalog::{self, Entry, Kind, ParamSpec, Selection};
use crate::error::Result;

/// One scene element: a catalog [`Entry`] with its parameters ([`ParamSpec`], as an
/// effect's), the [`Layer`] it sits in and how it folds itself for one frame.
#[derive(Debug)]
pub struct ElementDef {
    pub name: &'static str,
    /// One line: what it puts in the scene.
    pub summary: &'static str,
    /// Where its equations come from.
    pub source: &'static str,
    pub params: &'static [ParamSpec],
    /// Where it sits, back to front: the per-pixel call applies the layers in order
    /// (within a layer, the registry's order).
    pub layer: Layer,
    /// Its form for one frame, from its values (in `params` order) and the frame's
    /// seed, number and sun.
    pub prepare: fn(&[f64], &ElementContext) -> std::sync::Arc<dyn FieldElement>,
}

impl ElementDef {
    /// The values `--scene NAME` uses (each parameter's typical value).
    pub fn defaults(&self) -> Vec<f64> {
        self.params.iter().map(|p| p.typical).collect()
    }
}

impl Entry for ElementDef {
    const KIND: Kind = Kind::Element;
    fn registry() -> &'static [&'static Self] {
        ELEMENTS
    }
    fn name(&self) -> &'static str {
        self.name
    }
    fn summary(&self) -> &'static str {
        self.summary
    }
    fn source(&self) -> &'static str {
        self.source
    }
    fn params(&self) -> &'static [ParamSpec] {
        self.params
    }
}

/// Every scene element. [`field_stokes`] applies them back to front by [`Layer`]: the
/// sky's radiance, clouds and the overcast deck, the sun's disc, the skyline. (The
/// registry's order keys each element's seeded draws, so a new element goes last here.)
pub static ELEMENTS: &[&ElementDef] = &[
    &sky_radiance::ELEMENT,
    &clouds::ELEMENT,
    &sun_disc::ELEMENT,
    &skyline::ELEMENT,
    &overcast::ELEMENT,
    &night_background::ELEMENT,
    &twilight::ELEMENT,
];

/// Looks an element up by name.
pub fn find_element(name: &str) -> Result<&'static ElementDef> {
    catalog::find(name)
}

/// A capture's field conditions: the enabled elements with their values (the
/// catalog's [`Selection`] of scene elements), and the seed every draw of the scene is
/// keyed by. Empty: the lab-clean sky.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FieldScene {
    pub seed: u64,
    elements: Selection<ElementDef>,
    /// cd/m² per unit sky radiance of the frame's source, where known (`night_background`).
    sky_unit_cd_m2: Option<f64>,
    /// The other source's sky of the frame's time and place, where known (`twilight`).
    other_sky: Option<twilight::OtherSky>,
}

impl FieldScene {
    /// No element enabled, draws keyed by `seed`.
    pub fn new(seed: u64) -> Self {
        FieldScene { seed, elements: Selection::new(), sky_unit_cd_m2: None, other_sky: None }
    }

    /// Every element at its defaults.
    pub fn all(seed: u64) -> Self {
        let mut s = FieldScene::new(seed);
        for e in ELEMENTS {
            s.enable(e.name).expect("a registered element");
        }
        s
    }

    /// Enables `name` at its defaults (no-op when already enabled).
    pub fn enable(&mut self, name: &str) -> Result<()> {
        self.elements.enable(name)
    }

    /// Sets `element.param` to `value`, enabling the element.
    pub fn set(&mut self, element: &str, param: &str, value: f64) -> Result<()> {
        self.elements.set(element, param, value)
    }

    /// Parses `name` (defaults) or `name.param=value`, as given to `--scene`.
    pub fn parse(&mut self, spec: &str) -> Result<()> {
        self.elements.parse(spec)
    }

    /// Value of `element.param` if the element is enabled.
    pub fn get(&self, element: &str, param: &str) -> Option<f64> {
        self.elements.get(element, param)
    }

    /// The same scene without the element named `name` (unchanged where it is not enabled).
    pub fn without(&self, name: &str) -> FieldScene {
        FieldScene {
            seed: self.seed,
            elements: self.elements.without(|d| d.name == name),
            sky_unit_cd_m2: self.sky_unit_cd_m2,
            other_sky: self.other_sky,
        }
    }

    /// The same scene under a source whose sky has `unit_cd_m2` cd/m² per unit of the
    /// chain's sky radiance ([`crate::sky::radiometry::SkyLight`]): what sets the
    /// `night_background`'s glow against the moonlit or sunlit sky. Unset, the sun's at
    /// the frame's source elevation is taken.
    pub fn with_sky_unit_cd_m2(mut self, unit_cd_m2: f64) -> FieldScene {
        self.sky_unit_cd_m2 = Some(unit_cd_m2);
        self
    }

    /// The unit set by [`FieldScene::with_sky_unit_cd_m2`].
    pub fn sky_unit_cd_m2(&self) -> Option<f64> {
        self.sky_unit_cd_m2
    }

    /// The same scene with the other source's sky of the frame set (`twilight`: the
    /// capture pipeline sets it from the frame's time and place).
    #[cfg(feature = "spa")]
    pub(crate) fn with_other_sky(mut self, other: twilight::OtherSky) -> FieldScene {
        self.other_sky = Some(other);
        self
    }

    /// The other source's sky set by [`FieldScene::with_other_sky`].
    pub(crate) fn other_sky(&self) -> Option<twilight::OtherSky> {
        self.other_sky
    }

    /// Enabled elements with their values, in the order they were enabled.
    pub fn iter(&self) -> impl Iterator<Item = (&'static ElementDef, &[f64])> {
        self.elements.iter()
    }

    pub fn is_empty(&self) -> bool {
        self.elements.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_snake_case_with_units_and_documented() {
        let mut names: Vec<_> = ELEMENTS.iter().map(|e| e.name).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), ELEMENTS.len());
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/scene");
        for e in ELEMENTS {
            assert!(e.name.chars().all(|c| c.is_ascii_lowercase() || c == '_'), "{}", e.name);
            assert!(!e.summary.is_empty() && !e.source.is_empty() && !e.params.is_empty(), "{}", e.name);
            let mut pnames: Vec<_> = e.params.iter().map(|p| p.name).collect();
            pnames.sort();
            pnames.dedup();
            assert_eq!(pnames.len(), e.params.len(), "{}: duplicate parameter", e.name);
            for p in e.params {
                assert!(["deg", "1", "count", "mag/arcsec²"].contains(&p.unit), "{}.{}", e.name, p.name);
            }
            // Its file opens with the doc block: equation, source, units, frame, limits.
            let text = std::fs::read_to_string(dir.join(format!("{}.rs", e.name))).unwrap();
            assert!(text.starts_with(&format!("//! # `{}`", e.name)), "{}: doc block title", e.name);
            let doc: String = text.lines().take_while(|l| l.starts_with("//!")).collect::<Vec<_>>().join("\n");
            for word in ["Source", "Units", "Frame", "Cannot", "```text"] {
                assert!(doc.contains(word), "{}: the doc block lacks `{word}`", e.name);
            }
            assert!(text.contains("#[cfg(test)]"), "{}: no tests beside the physics", e.name);
        }
    }

    #[test]
    fn specs_parse_and_bad_ones_are_named() {
        let mut s = FieldScene::new(1);
        s.parse("clouds").unwrap();
        assert_eq!(s.get("clouds", "count"), Some(clouds::ELEMENT.params[0].typical));
        s.parse("clouds.count=3").unwrap();
        s.parse(" skyline.max_elevation_deg = 12.5 ").unwrap();
        assert_eq!(s.get("clouds", "count"), Some(3.0));
        assert_eq!(s.get("skyline", "max_elevation_deg"), Some(12.5));
        assert_eq!(s.iter().count(), 2);
        let e = s.parse("no_such").unwrap_err().to_string();
        assert!(e.contains("no_such") && e.contains("clouds") && e.contains("sun_disc"), "{e}");
        let e = s.parse("clouds.cnt=2").unwrap_err().to_string();
        assert!(e.contains("count"), "{e}");
        assert!(s.parse("clouds.count=2.5").unwrap_err().to_string().contains("whole"));
        assert!(s.parse("clouds.count=1e9").is_err());
        assert!(s.parse("clouds.count=abc").is_err());
        assert!(s.parse("clouds.count").is_err());
        assert_eq!(s.without("clouds").iter().count(), 1);
        assert_eq!(FieldScene::all(1).iter().count(), ELEMENTS.len());
    }
}
