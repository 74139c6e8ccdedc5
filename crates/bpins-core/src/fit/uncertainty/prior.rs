//! A candidate's physical range as prior information in its score test's joint
//! system, so that the heading's 1σ with the candidate freed (`score::heading_widen`)
//! is bounded where the data leave the candidate loose or free (issue 46 item 3).
//!
//! ```text
//! σ_p,j = (hi_j − lo_j) / (2√3)          1σ of a value uniform over the physical range
//!                                        [lo_j, hi_j] (`ParamSpec::physical`, else the
//!                                        fit's bounds), the parameter's unit
//! A_jj ← A_jj + q² / σ_p,j²              the joint system on the score's subsample, whose
//!                                        (JᵀWJ)⁺ is the fit's covariance / q² (q: the fit's
//!                                        heading 1σ over the subsample's, ≈ √(n_sub/n_eff))
//! ```
//!
//! The heading's variance in the joint system is then, by the Schur complement over
//! the candidate c (sensitivity g = ∂ψ/∂c with the model's other parameters
//! following it),
//!
//! ```text
//! σ_ψ² = σ_ψ,model² + gᵀ (Σ_data⁻¹ + Σ_phys⁻¹)⁻¹ g
//! ```
//!
//! the Gaussian combination of what the data allow (Σ_data, infinite along a
//! direction they do not constrain) and the physical range (Σ_phys): where the data
//! say nothing, the heading's shift across the range, |g|·σ_p; where they pin the
//! candidate well inside it, the data's; in between, below the smaller of the two
//! (by at most √2 in one direction). Without it a candidate the data cannot tell from
//! the model (a null direction of the joint system through the heading) left the
//! heading not estimable and was counted as no widening at all.
//!
//! Units: σ_p in the parameter's unit, q a ratio. Assumes: the heading linear in the
//! candidate over its physical range (the score's secant column); a uniform range,
//! replaced by its variance. Cannot: a range the registry states too wide or too
//! narrow (most are engineering bounds, see docs/diagnose.md).

use crate::effects::ParamSpec;
use crate::fit::solver::block::BlockSystem;

/// The 1σ of a value uniform over the parameter's physical range (the fit's bounds
/// where the registry gives none), in its unit: half-width / √3.
pub(crate) fn physical_sigma(p: &ParamSpec) -> f64 {
    let (lo, hi) = p.physical.unwrap_or((p.min, p.max));
    (hi - lo) / (2.0 * 3f64.sqrt())
}

/// `sys` with each global `at + j` given prior information `q2 / sigmas[j]²` (its
/// physical 1σ at the system's noise scale, see the module's notes). A non-finite or
/// non-positive 1σ or `q2` adds nothing.
pub(crate) fn with_prior(sys: &BlockSystem, at: usize, sigmas: &[f64], q2: f64) -> BlockSystem {
    let mut out = sys.clone();
    let n_g = out.n_g;
    for (j, s) in sigmas.iter().enumerate() {
        let info = q2 / (s * s);
        if info.is_finite() && info > 0.0 && at + j < n_g {
            out.a_gg[(at + j) * n_g + at + j] += info;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::solver::schur::BlockInverse;

    /// A candidate c (global 0) against one frame's heading ψ: the data see ψ + c
    /// with information `a` and, beside it, c alone with information `own`.
    fn joint(a: f64, own: f64) -> BlockSystem {
        BlockSystem::from_dense(&[a + own, a, a, a], &[0.0, 0.0], 1, &[1])
    }

    #[test]
    fn a_direction_the_data_do_not_constrain_gets_its_physical_range() {
        let (a, q2, sigma_p): (f64, f64, f64) = (400.0, 9.0, 0.2);
        // The model alone: σ_ψ = 1/√a. Joint, no prior: c trades exactly against ψ, the
        // heading is not estimable (the widening had nothing to take).
        let base = 1.0 / a.sqrt();
        let free = joint(a, 0.0);
        assert!(!BlockInverse::new(&free).sigma(1).is_finite());
        // With the physical range: σ_ψ² = 1/a + σ_p²/q² (∂ψ/∂c = −1, the range's 1σ at
        // the system's noise scale).
        let s = BlockInverse::new(&with_prior(&free, 0, &[sigma_p], q2)).sigma(1);
        let want = (base * base + sigma_p * sigma_p / q2).sqrt();
        assert!((s - want).abs() < 1e-9 * want, "{s} vs {want}");
        // 1σ 0.05 and the range's 0.2/3 at this scale: a widening of 5/3 (was 1).
        assert!((s / base - 5.0 / 3.0).abs() < 1e-9, "widening {}", s / base);
        // A candidate without influence at all (no column) widens nothing.
        let none = BlockSystem::from_dense(&[0.0, 0.0, 0.0, a], &[0.0, 0.0], 1, &[1]);
        let s = BlockInverse::new(&with_prior(&none, 0, &[sigma_p], q2)).sigma(1);
        assert!((s - base).abs() < 1e-12, "{s} vs {base}");
    }

    #[test]
    fn a_candidate_the_data_pin_well_inside_its_range_keeps_the_datas_widening() {
        // c pinned by its own information (σ_c = 1/√own ≪ σ_p/q): the prior moves the
        // heading's joint 1σ by well under a percent; and never above the data's alone.
        let (a, own, q2): (f64, f64, f64) = (400.0, 2500.0, 9.0);
        let free = joint(a, own);
        let data = BlockInverse::new(&free).sigma(1);
        let both = BlockInverse::new(&with_prior(&free, 0, &[5.0 / 3f64.sqrt()], q2)).sigma(1);
        assert!(both <= data && (data - both) / data < 1e-3, "{both} vs {data}");
        // A loose one: the prior binds, the joint 1σ falls toward the range's.
        let loose = joint(a, 1e-4);
        let data = BlockInverse::new(&loose).sigma(1);
        let both = BlockInverse::new(&with_prior(&loose, 0, &[0.01], q2)).sigma(1);
        let bound = (1.0 / a + 0.01f64.powi(2) / q2).sqrt();
        assert!(both < 0.1 * data && both <= bound * (1.0 + 1e-9), "{both}, data {data}, bound {bound}");
    }

    #[test]
    fn the_physical_sigma_is_the_uniform_ranges() {
        let p = ParamSpec {
            name: "d_deg",
            unit: "deg",
            neutral: 0.0,
            typical: 0.3,
            min: -45.0,
            max: 45.0,
            physical: Some((-5.0, 5.0)),
            doc: "",
        };
        assert!((physical_sigma(&p) - 5.0 / 3f64.sqrt()).abs() < 1e-12);
        assert!((physical_sigma(&ParamSpec { physical: None, ..p }) - 45.0 / 3f64.sqrt()).abs() < 1e-12);
    }
}
