//! The sample budget (`fit::frames`): a frame within the budget is fitted exactly as
//! every pixel; a frame over it through a sample of whole 2 × 2 tiles recovers the
//! full fit's parameters within 3 of the sample's 1σ, with the 1σ grown as the result
//! states (× 1/full_sigma_factor), the noise still read off every pixel, and a
//! colocated sensor sampled as well.

mod common;

use bpins_core::effects::{find, EffectSet};
use bpins_core::internal::capture::{Capture, FrameData};
use bpins_core::internal::fit::{fit, fit_from, FitFrames, FitOptions, FitResult};
use std::path::Path;

fn sample(name: &str) -> (Capture, Vec<FrameData>) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../samples").join(name);
    let c = Capture::load(&dir).unwrap();
    let frames = (0..c.frames.len()).map(|i| c.read_frame(i).unwrap()).collect();
    (c, frames)
}

fn fit_budget(c: &Capture, frames: &[FrameData], opts: &FitOptions, budget: usize) -> FitResult {
    let ff = FitFrames::sampled(c, frames, Some(budget), opts).unwrap();
    fit_from(c, &ff, opts, None, &|_, _| {}).unwrap()
}

#[test]
fn a_frame_within_the_budget_is_fitted_as_every_pixel() {
    let (c, frames) = sample("clean");
    let opts = FitOptions::default();
    let all = fit(&c, &frames, &opts, &|_, _| {}).unwrap();
    let b = fit_budget(&c, &frames, &opts, 612 * 512);
    assert_eq!((b.chi2, b.samples, b.iterations), (all.chi2, all.samples, all.iterations));
    assert_eq!(b.frames, all.frames);
    assert_eq!(b.sample.budget_px, Some(612 * 512));
    assert_eq!((b.sample.pixels_per_frame, b.sample.full_sigma_factor), (612 * 512, 1.0));
}

#[test]
fn the_sampled_fit_recovers_the_full_fits_parameters_within_its_stated_sigma() {
    let (c, frames) = sample("hidden-analyzer-angles");
    let opts = FitOptions { effects: vec![find("analyzer_angles").unwrap()], ..Default::default() };
    let all = fit(&c, &frames, &opts, &|_, _| {}).unwrap();
    // A quarter of the pixels: s = 2, one 8 × 8 block per 16 × 16 stratum.
    let budget = 612 * 512 / 4;
    let r = fit_budget(&c, &frames, &opts, budget);
    let s = r.sample;
    assert_eq!((s.block_px, s.stratum_px, s.frame_px), (8, 16, 612 * 512));
    assert!(s.pixels_per_frame <= budget && s.pixels_per_frame > budget * 9 / 10, "{s:?}");
    assert!((s.full_sigma_factor - (s.pixels_per_frame as f64 / s.frame_px as f64).sqrt()).abs() < 1e-12);
    assert!(r.samples < all.samples / 3, "{} of {} samples", r.samples, all.samples);
    assert!((r.chi2_per_dof - 1.0).abs() < 0.03, "χ²/dof {}", r.chi2_per_dof);
    // The noise is read off every pixel of every frame either way.
    assert!((r.noise.k_dn_per_e / all.noise.k_dn_per_e - 1.0).abs() < 1e-6, "{:?} vs {:?}", r.noise, all.noise);
    for (p, q) in r.params.iter().zip(&all.params) {
        assert_eq!(p.name, q.name);
        // The sampled estimate scatters about the full one by √(σ_s² − σ_f²) ≈ 0.87 σ_s
        // (nested samples), correlated between the four angles: within 3 σ_s (measured
        // 0.9, 2.1, 0.7, 2.7 σ_s), and the truth (samples/README.md) within 3 σ_s too.
        assert!(
            (p.value - q.value).abs() < 3.0 * p.sigma,
            "{}: {} ± {} sampled, {} ± {} full",
            p.name,
            p.value,
            p.sigma,
            q.value,
            q.sigma
        );
        // The 1σ grows as the result says: full ≈ sampled × factor.
        let predicted = p.sigma * s.full_sigma_factor;
        assert!(
            (predicted / q.sigma - 1.0).abs() < 0.25,
            "{}: σ {} × {:.3} against {}",
            p.name,
            p.sigma,
            s.full_sigma_factor,
            q.sigma
        );
    }
    let truth = [0.0, 1.0, 0.0, -0.6];
    for (p, t) in r.params.iter().zip(truth) {
        assert!((p.value - t).abs() < 3.0 * p.sigma, "{}: {} ± {}, truth {t}", p.name, p.value, p.sigma);
    }
    for (f, g) in r.frames.iter().zip(&all.frames) {
        assert!((f.heading_deg - g.heading_deg).abs() < 3.0 * f.heading_sigma_deg.max(1e-4), "{f:?} vs {g:?}");
    }
}

#[test]
fn a_colocated_sensor_is_sampled_and_fits_at_the_noise_floor() {
    let c = common::small_colocated_capture();
    let frames = common::simulate(&c, &EffectSet::new(), 5);
    let opts = FitOptions::default();
    let r = fit_budget(&c, &frames, &opts, 153 * 128 / 4);
    assert!(r.sample.pixels_per_frame < 153 * 128 / 4, "{:?}", r.sample);
    // Every channel of the sampled pixels, less the border and the sky mask's leavings.
    let read = 8 * 4 * r.sample.pixels_per_frame;
    assert!(r.samples <= read && r.samples > read * 3 / 4, "{} of {read} samples fitted", r.samples);
    assert!((r.chi2_per_dof - 1.0).abs() < 0.05, "χ²/dof {}", r.chi2_per_dof);
    for f in &r.frames {
        assert!(f.heading_error_deg.unwrap().abs() < 0.05, "{f:?}");
    }
}
