//! A colour band effect's candidate, by band: what its fitted values do to each band's
//! level and modulation relative to green's, so that the diagnosis of a colour capture
//! names the band (a blue-only weak grid is `band_response` in B).
//!
//! ```text
//! sky_spectrum:   level_b = r_b,                          DoLP_b = f_b
//! band_response:  level_b = q_b (1 + ε_b)/(1 + ε_G),      DoLP_b = m(ε_b)/m(ε_G),  m(ε) = (1 − ε)/(1 + ε)
//! ```
//!
//! (I_k = ½ g [(1 + ε) I + (1 − ε)(Q cos 2θ_k + U sin 2θ_k)]: an analyzer's ε raises the
//! band's unpolarized level by (1 + ε) and scales its modulation by m(ε).) Relative to
//! green, which is the reference of both effects, these are the two numbers a sky
//! capture measures of each band (`docs/colour.md`): a common ε of every band trades
//! against each frame's d_max and scale, and cancels here. Units: ratios, 1.

use crate::diagnose::Candidate;
use crate::sensor::Band;

/// One band's level and modulation relative to green's under a candidate's values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandChange {
    pub band: Band,
    /// The band's level (unpolarized DN) over green's, relative to the model without it.
    pub level: f64,
    /// The band's DoLP over green's, likewise.
    pub dolp: f64,
}

/// A band's factors departing from 1 by less than this are not named: one part in 10³,
/// a few times what a colour sky capture of a few small frames measures a band's level
/// and DoLP to (a few parts in 10⁴, `docs/colour.md`).
pub const BAND_NAMED_ABOVE: f64 = 1e-3;

impl Candidate {
    /// What this candidate's fitted values do to the red and blue bands relative to
    /// green (module doc); empty for an effect that is not a colour band's or a
    /// candidate without values.
    pub fn band_changes(&self) -> Vec<BandChange> {
        let v = |n: &str| self.params.iter().find(|p| p.id.param == n).map(|p| p.value);
        let m = |e: f64| (1.0 - e) / (1.0 + e);
        let per_band = |b: &str| -> Option<(f64, f64)> {
            match self.effect {
                "sky_spectrum" => Some((v(&format!("radiance_{b}"))?, v(&format!("dmax_{b}"))?)),
                "band_response" => {
                    let (q, e, g) = (v(&format!("qe_{b}"))?, v(&format!("eps_{b}"))?, v("eps_g")?);
                    Some((q * (1.0 + e) / (1.0 + g), m(e) / m(g)))
                }
                _ => None,
            }
        };
        [(Band::R, "r"), (Band::B, "b")]
            .into_iter()
            .filter_map(|(band, b)| per_band(b).map(|(level, dolp)| BandChange { band, level, dolp }))
            .collect()
    }

    /// The bands this candidate changes (more than [`BAND_NAMED_ABOVE`] in level or
    /// DoLP), in words: "B: level ×1.0500, DoLP ×0.9048 of G's"; `None` where none.
    pub fn bands_named(&self) -> Option<String> {
        let words: Vec<String> = self
            .band_changes()
            .iter()
            .filter(|c| (c.level - 1.0).abs() > BAND_NAMED_ABOVE || (c.dolp - 1.0).abs() > BAND_NAMED_ABOVE)
            .map(|c| format!("{}: level ×{:.4}, DoLP ×{:.4} of G's", c.band.name(), c.level, c.dolp))
            .collect();
        (!words.is_empty()).then(|| words.join("; "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::Param;

    fn cand(effect: &'static str, values: &[(&'static str, f64)]) -> Candidate {
        let def = crate::effects::find(effect).unwrap();
        let params = values
            .iter()
            .map(|&(n, x)| {
                let p = def.params.iter().find(|p| p.name == n).unwrap();
                Param::new(crate::fit::model::slots::EffectParam { effect: def.name, param: p.name }, p.unit, x, 0.001)
            })
            .collect();
        Candidate {
            effect: def.name,
            score: 0.0,
            delta_chi2: 0.0,
            delta_bic: 0.0,
            evidence: crate::diagnose::Evidence::EveryPixelRefit,
            identifiable: true,
            added_rank: 4,
            params,
            size: None,
            outside_physical: Vec::new(),
        }
    }

    #[test]
    fn a_blue_only_grid_names_the_blue_band_and_a_common_eps_names_none() {
        let grid = [("qe_r", 1.0), ("qe_b", 1.0), ("eps_r", 0.002), ("eps_g", 0.002), ("eps_b", 0.052)];
        let c = cand("band_response", &grid);
        let ch = c.band_changes();
        assert_eq!(ch.len(), 2);
        let (r, b) = (ch[0], ch[1]);
        assert_eq!((r.band, b.band), (Band::R, Band::B));
        assert!((r.level - 1.0).abs() < 1e-12 && (r.dolp - 1.0).abs() < 1e-12, "{r:?}");
        assert!((b.level - 1.052 / 1.002).abs() < 1e-12 && (b.dolp - (0.948 / 1.052) / (0.998 / 1.002)).abs() < 1e-12);
        let named = c.bands_named().unwrap();
        assert!(named.starts_with("B: level ×1.0499") && !named.contains("R:"), "{named}");
        // The same blue band as a sky less polarized and brighter there.
        let sky = cand("sky_spectrum", &[("radiance_r", 1.0), ("radiance_b", 1.05), ("dmax_r", 1.0), ("dmax_b", 0.9)]);
        assert!(sky.bands_named().unwrap().starts_with("B: level ×1.0500, DoLP ×0.9000"));
        // A common ε of every band changes no band against green; a mono effect has no band.
        let common = [("qe_r", 1.0), ("qe_b", 1.0), ("eps_r", 0.03), ("eps_g", 0.03), ("eps_b", 0.03)];
        assert_eq!(cand("band_response", &common).bands_named(), None);
        assert!(cand("extinction_ratio", &[("eps0", 0.01)]).band_changes().is_empty());
    }
}
