//! The fit's scalars as typed slots: the enabled effects' parameters (global), then
//! each frame's nuisances. The nuisances are a small registry of their own
//! ([`NUISANCES`]): name, unit, bounds, difference step, how their Jacobian column is
//! formed and when they are free — one row each, read by the fit, its starting
//! guesses and its result.

use crate::effects::{EffectDef, ParamDerivative};
use crate::fit::model::radiance;
use crate::fit::FitOptions;

/// One parameter of one effect, by the registry's names (`effect.param` in files).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
pub struct EffectParam {
    pub effect: &'static str,
    pub param: &'static str,
}

impl std::fmt::Display for EffectParam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}.{}", self.effect, self.param)
    }
}

/// The kinds of per-frame nuisance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NuisanceKind {
    Heading,
    Scale,
    Dmax,
    Radiance,
    Twilight,
}

/// One per-frame nuisance: a kind, and for the radiance its basis coefficient.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Nuisance {
    /// The frame's heading, degrees.
    Heading,
    /// The radiance scale (signal at full Rayleigh radiance), DN.
    Scale,
    /// The sky's peak degree of linear polarization.
    Dmax,
    /// Coefficient `i` of the frame's radiance basis ([`radiance`]).
    Radiance(usize),
    /// The strength of a mixed twilight's second sky (`fit::input::sky`): the factor on
    /// the model's weight of the other source's sky; fixed at 1 (and without effect) on
    /// a frame one source lights.
    Twilight,
}

/// How a slot's column of the Jacobian is formed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Derivative {
    /// Central differences of the slot's step, one-sided at a bound.
    Central,
    /// A one-sided secant of the step from θ (forward, backward where θ + step is out
    /// of range): exact, at half the cost, where the model is affine in the parameter.
    Secant,
    /// The model is proportional to the parameter above the offsets:
    /// (model − offset)/value, no evaluation needed.
    Proportional,
    /// Coefficient `i` of the frame's radiance basis: (model − offset)·ψ_i/R, no
    /// evaluation needed.
    Radiance(usize),
    /// An offset added to channel `c`'s DN after everything else: 1 on that channel's
    /// samples, 0 on the others, no evaluation needed.
    Offset(usize),
}

/// A row of the nuisance registry.
pub struct NuisanceDef {
    pub kind: NuisanceKind,
    /// Name in results (`frame<k>.<name>`); the radiance's gets its coefficient index.
    pub name: &'static str,
    pub unit: &'static str,
    pub min: f64,
    pub max: f64,
    /// Difference step (unused where the column is analytic).
    pub step: f64,
    derivative: Derivative,
    /// Whether it is fitted under these options, for a frame with (`true`) or without
    /// a reference heading.
    free: fn(&FitOptions, bool) -> bool,
}

/// The per-frame nuisances, in slot order (the radiance row stands for its
/// [`radiance::N`] coefficients).
pub const NUISANCES: [NuisanceDef; 5] = [
    NuisanceDef {
        kind: NuisanceKind::Heading,
        name: "heading_deg",
        unit: "deg",
        min: -1e6,
        max: 1e6,
        step: 1e-4,
        derivative: Derivative::Central,
        free: |o, reference| !(o.trust_reference && reference),
    },
    NuisanceDef {
        kind: NuisanceKind::Scale,
        name: "scale_dn",
        unit: "DN",
        min: 1e-9,
        max: 1e12,
        step: 0.0,
        derivative: Derivative::Proportional,
        free: |_, _| true,
    },
    NuisanceDef {
        kind: NuisanceKind::Dmax,
        name: "dmax",
        unit: "1",
        min: 0.0,
        max: 1.0,
        step: 1e-6,
        // The sky's Q and U are linear in d_max, and every later stage linear in them.
        derivative: Derivative::Secant,
        free: |o, _| o.fixed_dmax.is_none(),
    },
    NuisanceDef {
        kind: NuisanceKind::Radiance,
        name: "radiance_c",
        unit: "1",
        min: -1e3,
        max: 1e3,
        step: 0.0,
        derivative: Derivative::Radiance(0),
        free: |o, _| !o.rayleigh_radiance,
    },
    NuisanceDef {
        kind: NuisanceKind::Twilight,
        name: "twilight_strength",
        unit: "1",
        // S = S_p + k·w·S_o: k ≥ 0 keeps the second sky a sky (no negative light); the
        // model's w (K&S moonlight, Patat's twilight) is good to a factor of a few, so
        // k is bounded at 4 (a physical range, not a prior: within it the data decide).
        min: 0.0,
        max: 4.0,
        step: 1e-6,
        // The sky's I, Q and U are affine in k, and every later stage linear in them.
        derivative: Derivative::Secant,
        // Freed by the problem where a frame has a second sky ([`Slots::free_twilight`]).
        free: |_, _| false,
    },
];

/// Slots per frame: heading, scale, d_max, the radiance coefficients, then the twilight's
/// strength.
pub const PER_FRAME: usize = 4 + radiance::N;

impl Nuisance {
    /// Every nuisance of a frame, in slot order.
    pub fn all() -> impl Iterator<Item = Nuisance> {
        [Nuisance::Heading, Nuisance::Scale, Nuisance::Dmax]
            .into_iter()
            .chain((0..radiance::N).map(Nuisance::Radiance))
            .chain([Nuisance::Twilight])
    }

    /// Position among the frame's slots.
    pub fn index(self) -> usize {
        match self {
            Nuisance::Heading => 0,
            Nuisance::Scale => 1,
            Nuisance::Dmax => 2,
            Nuisance::Radiance(i) => 3 + i,
            Nuisance::Twilight => 3 + radiance::N,
        }
    }

    pub fn def(self) -> &'static NuisanceDef {
        let kind = match self {
            Nuisance::Heading => NuisanceKind::Heading,
            Nuisance::Scale => NuisanceKind::Scale,
            Nuisance::Dmax => NuisanceKind::Dmax,
            Nuisance::Radiance(_) => NuisanceKind::Radiance,
            Nuisance::Twilight => NuisanceKind::Twilight,
        };
        NUISANCES.iter().find(|d| d.kind == kind).expect("every kind has its row")
    }

    /// Name in results, without the frame (`heading_deg`, `radiance_c3`).
    pub fn name(self) -> String {
        match self {
            Nuisance::Radiance(i) => format!("{}{i}", self.def().name),
            _ => self.def().name.to_string(),
        }
    }

    fn derivative(self) -> Derivative {
        match (self, self.def().derivative) {
            (Nuisance::Radiance(i), _) => Derivative::Radiance(i),
            (_, d) => d,
        }
    }
}

/// What a slot is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotId {
    Effect(EffectParam),
    Frame { frame: usize, nuisance: Nuisance },
}

impl SlotId {
    /// Name in results: `effect.param` or `frame<k>.<nuisance>`.
    pub fn name(self) -> String {
        match self {
            SlotId::Effect(p) => p.to_string(),
            SlotId::Frame { frame, nuisance } => format!("frame{frame}.{}", nuisance.name()),
        }
    }
}

/// A free or fixed scalar of the fit.
#[derive(Clone, Debug)]
pub(crate) struct Slot {
    pub id: SlotId,
    pub unit: &'static str,
    pub min: f64,
    pub max: f64,
    pub step: f64,
    pub free: bool,
    pub derivative: Derivative,
}

/// The slots of a problem: the effects' parameters, then [`PER_FRAME`] per frame.
#[derive(Clone, Debug)]
pub(crate) struct Slots {
    pub all: Vec<Slot>,
    /// Index of the first per-frame slot.
    pub n_global: usize,
}

impl Slots {
    /// The slots of `opts.effects` and of each frame (`reference[k]`: whether frame `k`
    /// has a reference heading).
    pub fn new(opts: &FitOptions, reference: &[bool]) -> Slots {
        let mut all = Vec::new();
        for e in &opts.effects {
            all.extend(effect_slots(e));
        }
        let n_global = all.len();
        for (frame, &has_ref) in reference.iter().enumerate() {
            all.extend(Nuisance::all().map(|nuisance| {
                let d = nuisance.def();
                Slot {
                    id: SlotId::Frame { frame, nuisance },
                    unit: d.unit,
                    min: d.min,
                    max: d.max,
                    step: d.step,
                    free: (d.free)(opts, has_ref),
                    derivative: nuisance.derivative(),
                }
            }));
        }
        Slots { all, n_global }
    }

    /// The slot of frame `k`'s `nuisance`.
    pub fn at(&self, k: usize, nuisance: Nuisance) -> usize {
        self.n_global + PER_FRAME * k + nuisance.index()
    }

    /// The slots of frame `k`, in [`Nuisance::all`] order.
    pub fn frame(&self, k: usize) -> [usize; PER_FRAME] {
        let b = self.n_global + PER_FRAME * k;
        std::array::from_fn(|i| b + i)
    }

    /// Frees the twilight strength of each frame `second[k]` marks (a frame with a
    /// second sky); the others keep it fixed.
    pub fn free_twilight(&mut self, second: &[bool]) {
        for (k, _) in second.iter().enumerate().filter(|(_, &s)| s) {
            let i = self.at(k, Nuisance::Twilight);
            self.all[i].free = true;
        }
    }

    /// The free slots, in order.
    pub fn free(&self) -> Vec<usize> {
        (0..self.all.len()).filter(|&i| self.all[i].free).collect()
    }

    /// The slots of one effect's parameters.
    pub fn of_effect<'a>(&'a self, effect: &'a str) -> impl Iterator<Item = usize> + 'a {
        (0..self.n_global).filter(move |&i| matches!(self.all[i].id, SlotId::Effect(p) if p.effect == effect))
    }
}

/// How an effect parameter's column is formed: as its definition says
/// ([`EffectDef::derivatives`]: central differences, except where the effect's form
/// makes the model affine in it, e.g. `channel_response`'s gains and offsets).
pub(crate) fn effect_derivative(e: &EffectDef, i: usize) -> Derivative {
    match e.derivative(i) {
        ParamDerivative::Central => Derivative::Central,
        ParamDerivative::Secant => Derivative::Secant,
        ParamDerivative::ChannelOffset(k) => Derivative::Offset(k),
    }
}

/// The slots of one effect's parameters, free, central differences of 10⁻⁶ × range
/// (a secant of it, or an analytic column, per [`effect_derivative`]).
fn effect_slots(e: &'static EffectDef) -> impl Iterator<Item = Slot> {
    e.params.iter().enumerate().map(move |(i, p)| Slot {
        id: SlotId::Effect(EffectParam { effect: e.name, param: p.name }),
        unit: p.unit,
        min: p.min,
        max: p.max,
        step: 1e-6 * (p.max - p.min),
        free: true,
        derivative: effect_derivative(e, i),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_nuisance_has_its_row_and_its_place() {
        let all: Vec<Nuisance> = Nuisance::all().collect();
        assert_eq!(all.len(), PER_FRAME);
        for (i, n) in all.iter().enumerate() {
            assert_eq!(n.index(), i);
        }
        assert_eq!(Nuisance::Radiance(3).name(), "radiance_c3");
        assert_eq!(SlotId::Frame { frame: 2, nuisance: Nuisance::Dmax }.name(), "frame2.dmax");
        let opts = FitOptions { trust_reference: true, fixed_dmax: Some(0.6), ..Default::default() };
        let s = Slots::new(&opts, &[true, false]);
        let free: Vec<SlotId> = s.free().iter().map(|&i| s.all[i].id).collect();
        assert!(!free.contains(&SlotId::Frame { frame: 0, nuisance: Nuisance::Heading }));
        assert!(free.contains(&SlotId::Frame { frame: 1, nuisance: Nuisance::Heading }));
        assert!(!free.iter().any(|id| matches!(id, SlotId::Frame { nuisance: Nuisance::Dmax, .. })));
        assert_eq!(s.at(1, Nuisance::Scale), PER_FRAME + 1);
        // The twilight's strength: fixed unless a frame has a second sky.
        assert!(!free.iter().any(|id| matches!(id, SlotId::Frame { nuisance: Nuisance::Twilight, .. })));
        let mut s = s;
        s.free_twilight(&[false, true]);
        let free: Vec<SlotId> = s.free().iter().map(|&i| s.all[i].id).collect();
        assert!(!free.contains(&SlotId::Frame { frame: 0, nuisance: Nuisance::Twilight }));
        assert!(free.contains(&SlotId::Frame { frame: 1, nuisance: Nuisance::Twilight }));
    }
}
