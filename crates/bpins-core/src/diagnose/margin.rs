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
//! What the search's cap left out is another matter: a candidate the data clearly
//! want (it passes the rule for adding an effect, `Remains::left_by_cap`) is not
//! within what the data allow, and freeing it does not measure it. Its heading shift
//! does: the heading the model would reach with it added, refitted on every pixel,
//! differs from the final one by Δh_k on frame k, and each frame's 1σ carries it:
//!
//! ```text
//! σ_k ← √((σ_k · max_c w_{c,k})² + Δh_k²)   Δh_k = max over the left-out candidates of
//!                                           |heading_k(final + c) − heading_k(final)|, degrees
//! ```
//!
//! The largest shift, not the sum: the candidates that pass the rule are rivals for
//! the same misfit (the next step adds one of them, the best), so the heading the
//! next step reaches differs by one shift; a pair that passes only together is one
//! refit and one shift. In quadrature, since the shift is a bias beside the fit's
//! statistical 1σ. Measured (release, this machine): `samples/lab-flawed-sensor/sky`
//! capped at two effects leaves out `analyzer_angles` (docs/diagnose.md). Cannot: what
//! a search past the next step would add after it.
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
    /// The heading shift of what the search's cap left out, added in quadrature
    /// (absent where the cap left nothing out).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub left_by_cap: Option<CapShift>,
}

/// A frame's heading shift with a candidate the cap left out added.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CapShift {
    /// The candidate (the pair's leader where only two together pass).
    pub effect: &'static str,
    /// |Δh_k|, degrees.
    pub shift_deg: f64,
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
                    HeadingMargin { fit_sigma_deg, widen: w, by: Some(by), left_by_cap: None }
                }
                None => HeadingMargin { fit_sigma_deg, widen: 1.0, by: None, left_by_cap: None },
            }
        })
        .collect()
}

/// Adds to each frame's (widened) heading 1σ of `fit` the largest heading shift of
/// the candidates the cap left out, `left` (candidate, |Δh| per frame, degrees), in
/// quadrature (module doc); a frame without a finite shift is left as it is.
pub fn carry_left_out(fit: &mut FitResult, margins: &mut [HeadingMargin], left: &[(&'static str, Vec<f64>)]) {
    for (k, (f, m)) in fit.frames.iter_mut().zip(margins.iter_mut()).enumerate() {
        let largest = left
            .iter()
            .filter_map(|(e, h)| h.get(k).map(|x| x.abs()).filter(|x| x.is_finite()).map(|x| (*e, x)))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((effect, shift_deg)) = largest {
            f.heading_sigma_deg = f.heading_sigma_deg.hypot(shift_deg);
            m.left_by_cap = Some(CapShift { effect, shift_deg });
        }
    }
}

/// The same widenings on a refit of the final model (`raise.rs`: the final model
/// fitted again on more pixels replaces the last step's fit): each frame's new 1σ
/// times its factor, with the cap's shift in quadrature, `fit_sigma_deg` the new fit's.
pub fn carry_over(fit: &mut FitResult, margins: &mut [HeadingMargin]) {
    for (f, m) in fit.frames.iter_mut().zip(margins.iter_mut()) {
        m.fit_sigma_deg = f.heading_sigma_deg;
        f.heading_sigma_deg *= m.widen;
        if let Some(c) = &m.left_by_cap {
            f.heading_sigma_deg = f.heading_sigma_deg.hypot(c.shift_deg);
        }
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

    #[test]
    fn a_shift_the_cap_left_out_joins_each_frame_in_quadrature_the_largest_standing() {
        let mut f = fit(&[0.03, 0.02, 0.01]);
        let mut m = widen_headings(&mut f, &[("principal_point", vec![2.0, 1.0, 1.0])]);
        // Two rivals the cap left out: the larger shift of each frame stands (signs do
        // not matter); a frame neither moves keeps its 1σ.
        let left =
            vec![("analyzer_angles", vec![0.08, -0.5, f64::NAN]), ("extinction_ratio", vec![0.01, 0.2, f64::NAN])];
        carry_left_out(&mut f, &mut m, &left);
        let s: Vec<f64> = f.frames.iter().map(|x| x.heading_sigma_deg).collect();
        assert!((s[0] - 0.1).abs() < 1e-12, "{s:?}"); // √(0.06² + 0.08²)
        assert!((s[1] - (0.02f64.powi(2) + 0.25).sqrt()).abs() < 1e-12, "{s:?}");
        assert_eq!(s[2], 0.01);
        assert_eq!(m[1].left_by_cap, Some(CapShift { effect: "analyzer_angles", shift_deg: 0.5 }));
        assert_eq!((m[0].widen, m[2].left_by_cap.clone()), (2.0, None));
        // A refit of the final model carries both: its factor, then the shift.
        let mut raised = fit(&[0.015, 0.02, 0.01]);
        carry_over(&mut raised, &mut m);
        assert!((raised.frames[0].heading_sigma_deg - 0.03f64.hypot(0.08)).abs() < 1e-12);
        assert_eq!(raised.frames[2].heading_sigma_deg, 0.01);
        // Nothing left out: nothing changes.
        let mut g = fit(&[0.03]);
        let mut n = widen_headings(&mut g, &[]);
        carry_left_out(&mut g, &mut n, &[]);
        assert_eq!((g.frames[0].heading_sigma_deg, n[0].left_by_cap.clone()), (0.03, None));
    }
}
