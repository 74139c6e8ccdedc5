//! `docs/adding-an-effect.md` end to end: its worked effect, `lens_depolarization`,
//! hidden at its typical strength in a simulated capture. Diagnosed with the catalog
//! as it was before the walk added it, the residual is reported unexplained (a catalog
//! effect may be named as a partial explanation — `lens_retardance` turns part of the
//! linear polarization circular, which looks like depolarization in one meridional
//! component — but none brings the error to the noise); with the effect in the
//! catalog it alone is named, recovered, and the residual falls to the noise.

mod common;

use bpins_core::effects::EffectSet;
use bpins_core::internal::diagnose::{diagnose, DiagnoseOptions};
use bpins_core::internal::fit::output::profiles::{Axis, Quantity};
use common::{simulate, small_capture, typical};

#[test]
fn the_worked_effect_is_unexplained_without_it_and_noise_with_it() {
    let c = small_capture();
    let mut set = EffectSet::new();
    typical(&mut set, "lens_depolarization");
    let frames = simulate(&c, &set, 11);

    let before = DiagnoseOptions { max_added: 2, exclude: vec!["lens_depolarization"], ..Default::default() };
    let d = diagnose(&c, &frames, &before, &|_| {}).unwrap();
    eprintln!("without it: selected {:?}; {}", d.selected, d.summary());
    assert!(d.unexplained(), "{}", d.summary());
    let misfit = d.steps.last().unwrap().fit.chi2_per_dof;
    assert!(misfit > 1.05, "χ²/dof {misfit}");
    // Described as what it is: the data less polarized than the model toward the edge.
    let trend = d.remains.trend(Quantity::DolpResidual).map(|t| t.axis);
    assert_eq!(trend, Some(Axis::Radius), "{}", d.summary());
    if !d.selected.is_empty() {
        let partial = &d.remains.unexplained.as_ref().unwrap().partial;
        assert_eq!(partial, &d.selected, "{}", d.summary());
    }

    let after = DiagnoseOptions { max_added: 2, ..Default::default() };
    let d = diagnose(&c, &frames, &after, &|_| {}).unwrap();
    eprintln!("with it: selected {:?}; {}", d.selected, d.summary());
    assert_eq!(d.selected, ["lens_depolarization"]);
    assert!(!d.unexplained(), "{}", d.summary());
    let fit = &d.steps.last().unwrap().fit;
    assert!(fit.chi2_per_dof < 1.02 && fit.chi2_per_dof < misfit, "{} vs {misfit}", fit.chi2_per_dof);
    let p = fit.params.iter().find(|p| p.name == "lens_depolarization.p2").unwrap();
    assert!((p.value - 0.1).abs() < 3.0 * p.sigma, "p2 = {} ± {}", p.value, p.sigma);
}
