//! Full resolution for a diagnosis's final model: the diagnosis's half of
//! `fit::input::resolution` (which decides, for any fit, which parameters need more
//! pixels and how many). The search — which effects are named — runs on the first
//! sample; only the final model's fit is raised, and it replaces the last step's
//! (with the same heading margins, `margin.rs`).

use super::Diagnosis;
use crate::error::Result;
use crate::fit::input::request::{FitRequest, Loaded};
use crate::fit::input::resolution::{needed_budget, Raised};
use crate::fit::{fit_from, FitOptions};

impl FitRequest {
    /// After a diagnosis `d` of `loaded` (this request's frames): where the final
    /// model's parameters need more pixels ([`needed_budget`]), the capture is read
    /// again within that budget and the final model fitted again from the last step's
    /// values; that fit replaces the last step's (its `raised` says so). The search
    /// itself — which effects are named — ran on the first sample.
    pub fn raise_diagnosis_where_needed(
        &self,
        loaded: Loaded,
        mut d: Diagnosis,
        progress: &dyn Fn(&str, usize),
    ) -> Result<(Loaded, Diagnosis)> {
        let Some(last) = d.steps.last_mut() else { return Ok((loaded, d)) };
        let Some((budget, params)) = needed_budget(&last.fit) else { return Ok((loaded, d)) };
        let again = FitRequest { sample_budget_px: budget, ..self.clone() };
        let l = again.load(&|_, _| {})?;
        let effects = last.model.iter().map(|n| crate::effects::find(n)).collect::<Result<Vec<_>>>()?;
        let opts = FitOptions { effects, ..l.options.clone() };
        let mut r = fit_from(&l.capture, &l.frames, &opts, Some(&last.fit.state), progress)?;
        r.raised = Some(Raised { from_budget_px: last.fit.sample.pixels_per_frame, to_budget_px: budget, params });
        last.fit = r;
        // The headings' margin for what the data cannot rule out, on the new fit.
        super::margin::carry_over(&mut last.fit, &mut d.heading_margin);
        Ok((l, d))
    }
}
