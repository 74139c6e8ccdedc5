//! Diagnosis under a real-looking sky (issue 16): captures simulated beneath the CIE
//! standard clear sky (type 12: brighter toward the sun and the horizon, not
//! Rayleigh's radiance) with multiplicative sensor noise (1 % PRNU). The fit's
//! radiance nuisance (`fit::radiance`) follows the sky, so: a capture with no effect
//! names nothing and fits to the noise; every effect a sky capture can separate is
//! still named first and recovered within 3σ; two hidden effects are both named; the
//! effects the capture cannot separate are listed as such, never named.

mod common;

use bpins_core::effects::{EffectSet, SkyBlindness, REGISTRY};
use bpins_core::internal::capture::{Capture, FrameData};
use bpins_core::internal::diagnose::{diagnose, inseparable, DiagnoseOptions, Diagnosis};
use bpins_core::internal::fit::FitOptions;
use common::{cie_sky, seed_of, simulate_in, small_capture, typical, DMAX};

const PRNU: f64 = 0.01;

fn run(c: &Capture, frames: &[FrameData], max_added: usize, fixed_dmax: Option<f64>) -> Diagnosis {
    let base = FitOptions { fixed_dmax, ..Default::default() };
    diagnose(c, frames, &DiagnoseOptions { base, max_added, ..Default::default() }, &|_| {}).unwrap()
}

/// What is wrong with the diagnosis of a capture hiding `set` (empty when right),
/// the effects selected in any order.
fn problems(d: &Diagnosis, set: &EffectSet, names: &[&str]) -> Vec<String> {
    common::diagnosis_problems(d, set, names, false)
}

#[test]
fn a_clean_capture_under_a_cie_sky_names_nothing_and_fits_to_the_noise() {
    let c = small_capture();
    let frames = simulate_in(&c, &EffectSet::new(), 11, &cie_sky(), PRNU);
    let t0 = std::time::Instant::now();
    let d = run(&c, &frames, 2, None);
    let fit = &d.steps.last().unwrap().fit;
    eprintln!(
        "χ²/dof {:.4}, n_eff/n {:.3}, noise {:?}, AoP RMS {:.4}°, {:.1} s; {}",
        fit.chi2_per_dof,
        fit.n_eff / fit.samples as f64,
        fit.noise,
        fit.aop_rms_deg,
        t0.elapsed().as_secs_f64(),
        d.summary()
    );
    assert!(d.selected.is_empty(), "selected {:?}", d.selected);
    assert!(fit.chi2_per_dof <= 1.1, "χ²/dof {}", fit.chi2_per_dof);
    assert!(!d.unexplained(), "{}", d.summary());
    // The multiplicative noise is read off the frames.
    assert!((fit.noise.prnu - PRNU).abs() < 0.3 * PRNU, "{:?}", fit.noise);
    // What the capture cannot tell is listed, not fitted.
    let listed: Vec<&str> = d.inseparable.iter().map(|x| x.0).collect();
    assert!(listed.contains(&"vignetting") && listed.contains(&"sky_depolarization"), "{listed:?}");
    for f in &fit.frames {
        assert!(f.heading_error_deg.unwrap().abs() < 0.05, "heading error {:?}", f.heading_error_deg);
    }
}

#[test]
fn every_separable_effect_hidden_under_a_cie_sky_is_named_first_and_recovered() {
    let c = small_capture();
    let sky = cie_sky();
    let mut failures = Vec::new();
    let listed: Vec<&str> = inseparable(&c, &FitOptions::default()).iter().map(|x| x.0).collect();
    for e in REGISTRY.iter() {
        let mut set = EffectSet::new();
        typical(&mut set, e.name);
        if set.model().bands != Default::default() {
            // A colour band's sky or response (sky_spectrum, band_response): nothing on this
            // monochrome capture; a colour capture's bands measure it (tests/colour.rs).
            continue;
        }
        let frames = simulate_in(&c, &set, 200 + seed_of(e.name), &sky, PRNU);
        let t0 = std::time::Instant::now();
        let mut d = run(&c, &frames, 1, None);
        let mut how = "";
        if listed.contains(&e.name) {
            // What the capture cannot tell is never named for it.
            if d.selected.contains(&e.name) || !d.inseparable.iter().any(|x| x.0 == e.name) {
                failures.push(format!("{}: inseparable, yet selected {:?}", e.name, d.selected));
            }
            // What blinds a sky capture to it, from its definition (`EffectDef::inseparable`).
            let when = e.inseparable.map(|i| i.when);
            if when == Some(SkyBlindness::FreeRadiance) {
                // The sky's radiance is not Rayleigh's: nothing on a sky capture separates it.
                eprintln!("{:<20} inseparable (listed, not named: selected {:?})", e.name, d.selected);
                continue;
            }
            if matches!(when, Some(SkyBlindness::Dofp | SkyBlindness::Always)) {
                // Not told from a DoLP factor by the diagnosis (crosstalk, dark_signal);
                // fitted alone with the sky's d_max given, border pixels left out, it is
                // recovered.
                let opts = FitOptions { effects: vec![e], fixed_dmax: Some(DMAX), ..Default::default() };
                let r = bpins_core::internal::fit::fit(&c, &frames, &opts, &|_, _| {}).unwrap();
                let truth = set.iter().next().expect("one effect").1[0];
                let p = &r.params[0];
                eprintln!(
                    "{:<20} inseparable; fitted alone {} = {:.5} ± {:.5} (white-noise 1σ {:.5}; truth {truth})",
                    e.name, p.name, p.value, p.sigma, p.sigma_white
                );
                if !((p.value - truth).abs() <= 3.0 * p.sigma) || r.chi2_per_dof > 1.1 {
                    failures.push(format!("{} alone: {} ± {}, χ²/dof {}", e.name, p.value, p.sigma, r.chi2_per_dof));
                }
                continue;
            }
            // A factor on the DoLP: separable once the sky's d_max is given.
            d = run(&c, &frames, 1, Some(DMAX));
            how = " (d_max given)";
        }
        let p = problems(&d, &set, &[e.name]);
        // What the residuals' correlations (the PRNU pattern the same in all frames)
        // cost each parameter's 1σ beyond the white-noise one (`Param::sigma_white`).
        let widened: Vec<String> = d
            .steps
            .last()
            .unwrap()
            .fit
            .params
            .iter()
            .filter(|q| q.name.starts_with(e.name))
            .map(|q| format!("{:.2}", q.sigma / q.sigma_white))
            .collect();
        let (first, last) = (&d.steps[0].fit, &d.steps.last().unwrap().fit);
        eprintln!(
            "{:<20} χ²/dof {:.4} → {:.4}{how}, {:.0} s (1σ / white 1σ: {}){}",
            e.name,
            first.chi2_per_dof,
            last.chi2_per_dof,
            t0.elapsed().as_secs_f64(),
            widened.join(", "),
            if p.is_empty() { String::new() } else { format!(" — {}", p.join("; ")) }
        );
        if !p.is_empty() {
            failures.push(format!("{}: {}", e.name, p.join("; ")));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn two_effects_hidden_under_a_cie_sky_are_both_named() {
    let c = small_capture();
    let mut set = EffectSet::new();
    typical(&mut set, "principal_point");
    typical(&mut set, "analyzer_angles");
    let frames = simulate_in(&c, &set, 17, &cie_sky(), PRNU);
    let d = run(&c, &frames, 3, None);
    eprintln!("selected {:?}; {}", d.selected, d.summary());
    let p = problems(&d, &set, &["analyzer_angles", "principal_point"]);
    assert!(p.iter().all(|x| x.starts_with("ranked first")), "{}", p.join("\n"));
    assert!(!d.unexplained(), "{}", d.summary());
}

#[test]
fn clouds_and_a_skyline_under_a_cie_sky_blame_no_lens_or_sensor_effect() {
    // Half the frames tilted 30° so that the skyline and the ground come into view.
    let mut c = small_capture();
    for (i, f) in c.frames.iter_mut().enumerate() {
        f.tilt_x_deg = (i % 2 == 1).then_some(30.0);
    }
    let mut field = cie_sky();
    field.parse("clouds.count=8").unwrap();
    field.parse("skyline").unwrap();
    let frames = simulate_in(&c, &EffectSet::new(), 23, &field, PRNU);
    let d = run(&c, &frames, 2, None);
    eprintln!("selected {:?}; χ²/dof {:.4}; {}", d.selected, d.steps[0].fit.chi2_per_dof, d.summary());
    assert!(d.selected.is_empty(), "the scene was blamed on {:?}", d.selected);
    assert!(d.steps[0].fit.heading_rms_deg.unwrap() < 0.1, "heading RMS {:?}", d.steps[0].fit.heading_rms_deg);
}

/// The fit's 1σ against the scatter of its estimates over seeds, for the parameters
/// whose signature is fixed in the camera (a window's tilt, a lens's diattenuation)
/// under a PRNU pattern that is the same in every frame: the RMS of
/// (estimate − truth)/1σ is ≈ 1 with the sandwich 1σ, ≈ 2 with the white-noise one.
/// Measured (2026-11-25): `window` over 40 seeds (80 values) 0.84 against 1.64 with
/// the white-noise 1σ — the sandwich is about 20 % conservative there, the white-noise
/// 1σ 64 % optimistic. Slow (two fits per seed): `cargo test --release -p bpins-core --test real_sky --
/// --ignored --nocapture`.
#[test]
#[ignore = "slow: 24 fits (12 seeds × 2 effects), a statistical check of the fit's 1σ against the scatter \
            over seeds; run with: cargo test --release -p bpins-core --test real_sky -- --ignored --nocapture \
            the_1_sigma_matches_the_scatter_over_seeds"]
fn the_1_sigma_matches_the_scatter_over_seeds() {
    let c = small_capture();
    let sky = cie_sky();
    let seeds = 12;
    for name in ["window", "lens_diattenuation"] {
        let def = REGISTRY.iter().find(|e| e.name == name).unwrap();
        let mut set = EffectSet::new();
        typical(&mut set, name);
        let truth = set.iter().next().unwrap().1.to_vec();
        let (mut z2, mut z2_white, mut n) = (0.0, 0.0, 0);
        for s in 0..seeds {
            let frames = simulate_in(&c, &set, 900 + s, &sky, PRNU);
            let opts = FitOptions { effects: vec![def], ..Default::default() };
            let r = bpins_core::internal::fit::fit(&c, &frames, &opts, &|_, _| {}).unwrap();
            for (p, t) in r.params.iter().zip(&truth) {
                z2 += ((p.value - t) / p.sigma).powi(2);
                z2_white += ((p.value - t) / p.sigma_white).powi(2);
                n += 1;
            }
        }
        let (rms, rms_white) = ((z2 / n as f64).sqrt(), (z2_white / n as f64).sqrt());
        eprintln!("{name}: RMS (estimate − truth)/1σ {rms:.2} (white-noise 1σ: {rms_white:.2}) over {n}");
        assert!(rms < 1.5 && rms < rms_white, "{name}: RMS z {rms:.2} (white-noise 1σ: {rms_white:.2})");
    }
}
