//! The final headings' 1σ with what the data cannot rule out (issue 46 item 3).
//!
//! ```text
//! w_{c,k} = σ_k(base + c) / σ_k(base)        c a candidate the search did not add, k a frame:
//!                                            the heading's 1σ with c freed over the model's own,
//!                                            from the score test's joint system (same samples),
//!                                            c held to its physical range where the data hold
//!                                            it more loosely (`fit::uncertainty::prior`)
//! σ_k    ← σ_k · max_c w_{c,k}               the final fit's heading 1σ (`heading_sigma_deg`)
//! ```
//!
//! Why: a diagnosis that names nothing has not shown that nothing is there; it has
//! shown that what is there stays within what the data allow. A camera detail the
//! data can pin only loosely (the principal point to a fraction of a pixel, a common
//! turn of the analyzers against the heading) still moves the heading within that
//! allowance, and the final model's 1σ, which holds such a detail at its nominal
//! value, does not see it: on frames another simulator rendered end to end the
//! headings were off by 3–5 of their 1σ with nothing named. Freeing the candidate in
//! the joint system is the profile of the heading over the candidate's allowed range
//! (its Gauss–Newton linearization: the candidate's own 1σ from the data, carried into
//! the heading by their correlation). Where the data leave a direction of the
//! candidate free, or hold it more loosely than its physical range
//! (`ParamSpec::physical`, as a uniform: half-width/√3), that range holds it instead,
//! and the heading's shift across the range joins the 1σ (before, a direction
//! through the heading that the data do not constrain left the heading not estimable
//! in the joint system and counted as no widening). Each candidate alone: the largest
//! widening stands, as the least a user must allow for; where the candidates are
//! several and independent, this is below their sum.
//!
//! Measured (release, this machine): `samples/clean` widens by 2.0–2.1 (analyzer
//! angles), its eight headings then within 1.4σ and the 1σ 1.6× their RMS error;
//! the PySkyLumos peer Rayleigh sky by 1.6–2.3 (its 1σ then 2.3× the RMS error, 1.3×
//! before). The widening is the full fit's: `bpins fit --effects analyzer_angles` on
//! that sky gives each frame a statistical 1σ 1.16–2.30× the model's, as the score's
//! subsample does (to 1 %). On the repo's captures no candidate has a direction
//! through the heading that the data leave free (equal extinction ratios trade against
//! scale and d_max; `analyzer_incidence`'s e2 has no column at c = 0): the physical
//! ranges change no widening by more than 0.005.
//!
//! Units: the widening is a ratio, the 1σ degrees. Cannot: effects outside the
//! catalog; a physical range the registry states too narrow.

use crate::fit::FitResult;

/// How one frame's heading 1σ was widened, and by which candidate.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct HeadingMargin {
    /// The final fit's 1σ before the widening, degrees.
    pub fit_sigma_deg: f64,
    /// The factor (≥ 1) and the candidate it comes from (`None`: none widens it).
    pub widen: f64,
    pub by: Option<&'static str>,
}

/// Widens each frame's heading 1σ of `fit` by the largest of the candidates'
/// widenings `widen` (candidate, per frame) and says by which.
pub fn widen_headings(fit: &mut FitResult, widen: &[(&'static str, Vec<f64>)]) -> Vec<HeadingMargin> {
    fit.frames
        .iter_mut()
        .enumerate()
        .map(|(k, f)| {
            let best = widen
                .iter()
                .filter_map(|(e, w)| w.get(k).filter(|x| x.is_finite()).map(|&x| (*e, x)))
                .max_by(|a, b| a.1.total_cmp(&b.1));
            let fit_sigma_deg = f.heading_sigma_deg;
            match best.filter(|b| b.1 > 1.0) {
                Some((by, w)) => {
                    f.heading_sigma_deg *= w;
                    HeadingMargin { fit_sigma_deg, widen: w, by: Some(by) }
                }
                None => HeadingMargin { fit_sigma_deg, widen: 1.0, by: None },
            }
        })
        .collect()
}

/// The same widenings on a refit of the final model (`raise.rs`: the final model
/// fitted again on more pixels replaces the last step's fit): each frame's new 1σ
/// times its factor, `fit_sigma_deg` the new fit's.
pub fn carry_over(fit: &mut FitResult, margins: &mut [HeadingMargin]) {
    for (f, m) in fit.frames.iter_mut().zip(margins.iter_mut()) {
        m.fit_sigma_deg = f.heading_sigma_deg;
        f.heading_sigma_deg *= m.widen;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::output::result::FrameFit;

    fn fit(sigmas: &[f64]) -> FitResult {
        FitResult {
            frames: sigmas
                .iter()
                .map(|&s| FrameFit {
                    heading_deg: 10.0,
                    heading_sigma_deg: s,
                    heading_sigma_stat_deg: s,
                    reference_deg: None,
                    heading_error_deg: None,
                    scale_dn: 1.0,
                    dmax: 0.5,
                    radiance: Default::default(),
                    twilight_strength: None,
                    twilight_strength_sigma: None,
                    chi2_per_dof: 1.0,
                })
                .collect(),
            ..Default::default()
        }
    }

    #[test]
    fn the_largest_widening_of_each_frame_stands_and_none_narrows() {
        let mut f = fit(&[0.01, 0.02, 0.03]);
        let w = vec![("principal_point", vec![1.5, 0.9, f64::NAN]), ("analyzer_angles", vec![1.2, 0.8, 1.0])];
        let m = widen_headings(&mut f, &w);
        assert_eq!(f.frames.iter().map(|x| x.heading_sigma_deg).collect::<Vec<_>>(), vec![0.015, 0.02, 0.03]);
        assert_eq!((m[0].widen, m[0].by), (1.5, Some("principal_point")));
        assert_eq!((m[1].widen, m[1].by, m[1].fit_sigma_deg), (1.0, None, 0.02));
        assert_eq!(m[2].by, None);
        // The statistical part is the fit's own.
        assert_eq!(f.frames[0].heading_sigma_stat_deg, 0.01);
        // A refit of the final model keeps each frame's factor.
        let mut m = m;
        let mut raised = fit(&[0.004, 0.01, 0.02]);
        carry_over(&mut raised, &mut m);
        assert_eq!(raised.frames[0].heading_sigma_deg, 0.004 * 1.5);
        assert_eq!((raised.frames[1].heading_sigma_deg, m[0].fit_sigma_deg), (0.01, 0.004));
    }
}
