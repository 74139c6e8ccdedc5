//! The catalog: what a user can put between the sky and the DN values, in one shape.
//!
//! Two registries hold it, each entry one module with its physics and tests beside it:
//! the lens and sensor **effects** ([`crate::effects::REGISTRY`], each an
//! [`EffectDef`](crate::effects::EffectDef)) and the **scene elements** of the field
//! ([`crate::scene::ELEMENTS`], each an [`ElementDef`](crate::scene::ElementDef)).
//! Both are [`Entry`]s: a name, a one-line summary, a source and parameters of one
//! type, [`ParamSpec`]. What a user picks is a [`Selection`] of either kind, parsed
//! from `name.param=value` by the same code, checked against the same ranges and
//! refused with the same errors ([`Error::UnknownEntry`], [`Error::UnknownParam`],
//! [`Error::BadParam`], naming the kind). [`markdown`] renders both registries as the
//! README's tables.

mod markdown;

pub use markdown::{markdown, readme_copy, README_BEGIN, README_END};

use crate::error::{Error, Result};

/// One parameter of a catalog entry (an effect's or a scene element's).
#[derive(Debug, PartialEq)]
pub struct ParamSpec {
    /// Name as used in files and on the command line, unit as suffix.
    pub name: &'static str,
    /// Unit: "px", "deg", "DN", "1" (dimensionless) or "count" (a whole number).
    pub unit: &'static str,
    /// The value at which the entry vanishes: an effect at all its neutral values
    /// leaves the chain exactly as the ideal one; a scene element's first parameter
    /// at its neutral value takes the element out of the scene (its other parameters,
    /// which shape it, have their typical value here).
    pub neutral: f64,
    /// A realistic strength, as real sensors and skies show it: what the hidden-effect
    /// tests simulate and `bpins effects` lists for an effect; what `--scene NAME`
    /// puts in the scene for an element.
    pub typical: f64,
    /// The allowed values (inclusive); for an effect, the fit's bounds: wide enough
    /// that a fit is never stopped short of what the data say.
    pub min: f64,
    pub max: f64,
    /// The range a real sensor, lens or sky can have where it is narrower than
    /// [`min`](Self::min)..[`max`](Self::max) (`None`: those bounds are that range). A
    /// fitted value outside it is flagged by the diagnosis: the parameter stands in for
    /// something else.
    pub physical: Option<(f64, f64)>,
    pub doc: &'static str,
}

impl ParamSpec {
    /// A parameter whose neutral value is its typical one (a scene element's shape
    /// parameters): name, unit, typical, range, doc.
    pub const fn shape(
        name: &'static str,
        unit: &'static str,
        typical: f64,
        min: f64,
        max: f64,
        doc: &'static str,
    ) -> Self {
        ParamSpec { name, unit, neutral: typical, typical, min, max, physical: None, doc }
    }

    /// The same parameter with `neutral` as the value that takes its entry away.
    pub const fn vanishing_at(self, neutral: f64) -> Self {
        ParamSpec { neutral, ..self }
    }

    /// The range a real instrument or sky can have ([`ParamSpec::physical`], else the
    /// bounds).
    pub fn physical_range(&self) -> (f64, f64) {
        self.physical.unwrap_or((self.min, self.max))
    }

    /// Whether the value must be a whole number (unit "count").
    pub fn is_count(&self) -> bool {
        self.unit == "count"
    }
}

/// Which registry an entry belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A lens or sensor effect (`--effect name.param=value`), enabled at its
    /// neutral values.
    Effect,
    /// A scene element of the field (`--scene name` or `--scene name.param=value`),
    /// enabled at its typical values.
    Element,
}

impl Kind {
    /// How messages name one entry of this kind.
    pub fn noun(self) -> &'static str {
        match self {
            Kind::Effect => "effect",
            Kind::Element => "scene element",
        }
    }

    /// How messages name the entries of this kind.
    pub fn plural(self) -> &'static str {
        match self {
            Kind::Effect => "effects",
            Kind::Element => "scene elements",
        }
    }

    /// The value a parameter takes when its entry is enabled by name alone.
    fn enabled_value(self, p: &ParamSpec) -> f64 {
        match self {
            Kind::Effect => p.neutral,
            Kind::Element => p.typical,
        }
    }
}

/// One entry of a registry: what the listings, the parser and the registry-wide tests
/// read of an effect or a scene element.
pub trait Entry: std::fmt::Debug + Sync + 'static {
    /// Which registry.
    const KIND: Kind;
    /// Every entry of the registry, in its order.
    fn registry() -> &'static [&'static Self];
    /// Name on the command line and in files (snake case).
    fn name(&self) -> &'static str;
    /// One line: what it does.
    fn summary(&self) -> &'static str;
    /// Where its equations come from.
    fn source(&self) -> &'static str;
    fn params(&self) -> &'static [ParamSpec];

    /// Index of parameter `name`.
    fn param_index(&self, name: &str) -> Option<usize> {
        self.params().iter().position(|p| p.name == name)
    }
}

/// Looks an entry up by name in its registry.
pub fn find<E: Entry>(name: &str) -> Result<&'static E> {
    E::registry().iter().copied().find(|e| e.name() == name).ok_or_else(|| Error::UnknownEntry {
        kind: E::KIND.noun(),
        kinds: E::KIND.plural(),
        name: name.to_string(),
        known: E::registry().iter().map(|e| e.name()).collect::<Vec<_>>().join(", "),
    })
}

/// Entries of one registry with their values (in `params` order), in the order they
/// were enabled.
#[derive(Debug)]
pub struct Selection<E: Entry> {
    entries: Vec<(&'static E, Vec<f64>)>,
}

impl<E: Entry> Default for Selection<E> {
    fn default() -> Self {
        Selection { entries: Vec::new() }
    }
}

impl<E: Entry> Clone for Selection<E> {
    fn clone(&self) -> Self {
        Selection { entries: self.entries.clone() }
    }
}

impl<E: Entry> PartialEq for Selection<E> {
    fn eq(&self, other: &Self) -> bool {
        self.entries.len() == other.entries.len()
            && self.entries.iter().zip(&other.entries).all(|((a, x), (b, y))| a.name() == b.name() && x == y)
    }
}

impl<E: Entry> Selection<E> {
    /// Nothing enabled.
    pub fn new() -> Self {
        Selection::default()
    }

    /// Enables `name` with its kind's starting values (no-op when already enabled).
    pub fn enable(&mut self, name: &str) -> Result<()> {
        let def = find::<E>(name)?;
        if !self.entries.iter().any(|(d, _)| d.name() == def.name()) {
            self.entries.push((def, def.params().iter().map(|p| E::KIND.enabled_value(p)).collect()));
        }
        Ok(())
    }

    /// Sets `entry.param` to `value`, enabling the entry; the value must lie in the
    /// parameter's range (and be whole for a count).
    pub fn set(&mut self, entry: &str, param: &str, value: f64) -> Result<()> {
        let def = find::<E>(entry)?;
        let idx = def.param_index(param).ok_or_else(|| Error::UnknownParam {
            kind: E::KIND.noun(),
            entry: entry.to_string(),
            param: param.to_string(),
            known: def.params().iter().map(|p| p.name).collect::<Vec<_>>().join(", "),
        })?;
        let spec = &def.params()[idx];
        let bad = |message: String| Error::BadParam {
            kind: E::KIND.noun(),
            spec: format!("{entry}.{param}={value}"),
            message,
        };
        if !value.is_finite() || value < spec.min || value > spec.max {
            return Err(bad(format!("must lie in [{}, {}] {}", spec.min, spec.max, spec.unit)));
        }
        if spec.is_count() && value.fract() != 0.0 {
            return Err(bad("must be a whole number".into()));
        }
        self.enable(entry)?;
        let slot = self.entries.iter_mut().find(|(d, _)| d.name() == def.name()).expect("just enabled");
        slot.1[idx] = value;
        Ok(())
    }

    /// Parses `name.param=value` and applies it; a bare `name` enables a scene
    /// element at its typical values (an effect needs a value).
    pub fn parse(&mut self, spec: &str) -> Result<()> {
        let noun = E::KIND.noun();
        let bad = |m: String| Error::BadParam { kind: noun, spec: spec.to_string(), message: m };
        let expected = || {
            bad(match E::KIND {
                Kind::Effect => "expected effect.param=value".into(),
                Kind::Element => "expected element or element.param=value".into(),
            })
        };
        match spec.split_once('=') {
            None if E::KIND == Kind::Element && !spec.contains('.') => self.enable(spec.trim()),
            None => Err(expected()),
            Some((lhs, rhs)) => {
                let (entry, param) = lhs.trim().split_once('.').ok_or_else(expected)?;
                let value: f64 = rhs.trim().parse().map_err(|_| bad("the value is not a number".into()))?;
                self.set(entry.trim(), param.trim(), value)
            }
        }
    }

    /// Value of `entry.param` if the entry is enabled.
    pub fn get(&self, entry: &str, param: &str) -> Option<f64> {
        let (def, vals) = self.entries.iter().find(|(d, _)| d.name() == entry)?;
        def.param_index(param).map(|i| vals[i])
    }

    /// Enabled entries with their values, in the order they were enabled.
    pub fn iter(&self) -> impl Iterator<Item = (&'static E, &[f64])> {
        self.entries.iter().map(|(d, v)| (*d, v.as_slice()))
    }

    /// The same selection without the entries `drop` picks.
    pub fn without(&self, drop: impl Fn(&E) -> bool) -> Self {
        Selection { entries: self.entries.iter().filter(|(d, _)| !drop(d)).cloned().collect() }
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

#[cfg(test)]
mod tests;
