//! # Full resolution only where a parameter's 1σ needs it
//!
//! ```text
//! σ_full ≈ σ_s · f,   f = √(pixels per frame / frame px)      (`Sample::full_sigma_factor`)
//! needs more pixels:  |x − x₀| < 3σ_s  and  |x − x₀| ≥ 3σ_s·f   (x₀ the effect's neutral value)
//! need   = 1.25 · pixels per frame · (3σ_s / |x − x₀|)²
//! budget' = frame px / s²,  s = max(⌊√(frame px / need)⌋, ⌈√(frame px / cap)⌉)   (every pixel where s < 2)
//! ```
//!
//! What: a fit over the sample budget (`crate::fit::input::frames`) reads a stratified sample of
//! each frame; a parameter the sample measures to better than a third of its distance
//! from neutral needs nothing more, and one that every pixel could not tell from
//! neutral either is left at the sample (more pixels would not change the answer: it
//! is not there). Between the two — present at full resolution, not at the sample —
//! the sample decides nothing, so the fit is run again on a larger sample, warm from
//! the first, with the budget the 1σ needs (1σ ∝ 1/√pixels for a noise-limited
//! parameter; × 1.25 for the sample's own scatter), or on every pixel where that budget
//! reaches 80 % of the frame. The result says which parameters raised it
//! ([`Raised`]). Units: pixels per frame. Limits: one raise (the second fit's 1σ is
//! what is reported, whatever it says). A diagnosis searches on its first sample
//! and raises only its final model's fit (which effects are named is decided on the
//! sample: the evidence of a weak effect grows with the budget, `--sample-budget`);
//! that raise lives with the diagnosis, which calls [`needed_budget`] here (the fit
//! knows nothing of the diagnosis).

use crate::error::Result;
use crate::fit::input::request::{FitRequest, Loaded};
use crate::fit::{fit_from, FitResult};

/// The most pixels a frame a raise reads (4 × [`crate::fit::DEFAULT_BUDGET_PX`]: 8 MB a
/// frame held), so that a raise keeps the fit's memory bounded by the frame: a frame
/// larger than this is raised to a sample of it at most, never read whole.
pub const RAISE_CAP_PX: usize = 4 * crate::fit::DEFAULT_BUDGET_PX;

/// Significance (in 1σ) at which a parameter counts as told from its neutral value.
pub const TOLD_SIGMA: f64 = 3.0;

/// Why and how far a fit raised its sample budget.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Raised {
    /// The budget of the first fit, pixels per frame.
    pub from_budget_px: usize,
    /// The budget of the second (`null`: every pixel).
    pub to_budget_px: Option<usize>,
    /// The parameters that needed it, `effect.param`.
    pub params: Vec<String>,
}

/// The budget `r`'s parameters need (`Some(None)`: every pixel), with their names;
/// `None` when the sample already decides every parameter or every pixel was read.
pub fn needed_budget(r: &FitResult) -> Option<(Option<usize>, Vec<String>)> {
    let s = r.sample;
    let f = s.full_sigma_factor;
    if s.pixels_per_frame >= s.frame_px || f >= 1.0 {
        return None;
    }
    let mut need = 0.0f64;
    let mut names = Vec::new();
    for p in &r.params {
        let neutral = crate::effects::find(p.id.effect)
            .ok()
            .and_then(|d| d.params.iter().find(|q| q.name == p.id.param).map(|q| q.neutral));
        let (Some(x0), true) = (neutral, p.sigma.is_finite() && p.sigma > 0.0) else { continue };
        let dist = (p.value - x0).abs();
        if dist < TOLD_SIGMA * p.sigma && dist >= TOLD_SIGMA * p.sigma * f {
            need = need.max(1.25 * s.pixels_per_frame as f64 * (TOLD_SIGMA * p.sigma / dist).powi(2));
            names.push(p.name.clone());
        }
    }
    if names.is_empty() {
        return None;
    }
    // The sampler reads one block in s × s per stratum (s ≥ 2: a quarter of the
    // frame at most): the largest s whose sample holds what is needed, or every pixel;
    // never more than RAISE_CAP_PX a frame (memory stays bounded by the frame).
    let frame = s.frame_px as f64;
    let s_cap = (frame / RAISE_CAP_PX as f64).sqrt().ceil();
    let s_blocks = (frame / need).sqrt().floor().max(s_cap);
    let budget = (s_blocks >= 2.0).then(|| (frame / (s_blocks * s_blocks)).ceil() as usize);
    Some((budget, names))
}

impl FitRequest {
    /// After the first fit `first` of `loaded` (this request's frames): where a
    /// parameter needs more pixels ([`needed_budget`]), the capture is read again
    /// within the budget it needs and fitted again from `first`'s values; else
    /// `loaded` and `first` as they are. `progress(stage, iteration)` as for a fit.
    pub fn raise_where_needed(
        &self,
        loaded: Loaded,
        first: FitResult,
        progress: &dyn Fn(&str, usize),
    ) -> Result<(Loaded, FitResult)> {
        let Some((budget, params)) = needed_budget(&first) else { return Ok((loaded, first)) };
        let again = FitRequest { sample_budget_px: budget, ..self.clone() };
        let l = again.load(&|_, _| {})?;
        let mut r = fit_from(&l.capture, &l.frames, &l.options, Some(&first.state), progress)?;
        r.raised = Some(Raised { from_budget_px: first.sample.pixels_per_frame, to_budget_px: budget, params });
        Ok((l, r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::input::frames::Sample;
    use crate::fit::model::slots::EffectParam;
    use crate::fit::Param;

    fn result(value: f64, sigma: f64, ppf: usize) -> FitResult {
        let id = EffectParam { effect: "analyzer_angles", param: "d45_deg" };
        let mut r = FitResult::default();
        r.params = vec![Param::new(id, "deg", value, sigma)];
        let f = (ppf as f64 / 1e6).sqrt();
        r.sample = Sample { pixels_per_frame: ppf, frame_px: 1_000_000, full_sigma_factor: f, ..r.sample };
        r
    }

    #[test]
    fn only_a_parameter_the_sample_cannot_decide_but_every_pixel_could_raises_the_budget() {
        // A quarter of the pixels: f = 0.5. Told at the sample (5σ): nothing.
        assert_eq!(needed_budget(&result(0.05, 0.01, 250_000)), None);
        // Not told even by every pixel (1σ at the sample, 2σ at full): nothing.
        assert_eq!(needed_budget(&result(0.01, 0.01, 250_000)), None);
        // A ninth of the pixels (f = 1/3), 2.5σ at the sample, 7.5σ at full: needs
        // 1.25 × 111 111 × (3/2.5)² = 200 000 px: one block in 2 × 2, a quarter.
        let (b, names) = needed_budget(&result(0.025, 0.01, 111_111)).unwrap();
        assert_eq!((b, names), (Some(250_000), vec!["analyzer_angles.d45_deg".to_string()]));
        // A 25th (f = 0.2), 2.8σ: needs 1.25 × 40 000 × (3/2.8)² = 57 398 px: one block
        // in 4 × 4 (62 500 px).
        assert_eq!(needed_budget(&result(0.028, 0.01, 40_000)).unwrap().0, Some(62_500));
        // 2σ at a quarter: needs 703 125 px, more than a quarter: every pixel.
        assert_eq!(needed_budget(&result(0.02, 0.01, 250_000)).unwrap().0, None);
        // Every pixel already read: nothing to raise.
        assert_eq!(needed_budget(&result(0.02, 0.01, 1_000_000)), None);
        // A 20 Mpx frame (the test's frame is 1 Mpx) at a 25th: never past the cap,
        // however much the parameter needs.
        let mut big = result(0.002, 0.01, 40_000);
        big.sample.frame_px = 20_000_000;
        big.sample.full_sigma_factor = (40_000.0f64 / 20e6).sqrt();
        let b = needed_budget(&big).unwrap().0.unwrap();
        assert!(b <= RAISE_CAP_PX && b > RAISE_CAP_PX / 2, "{b}");
        // An unconstrained parameter raises nothing.
        assert_eq!(needed_budget(&result(0.02, f64::INFINITY, 250_000)), None);
    }
}
