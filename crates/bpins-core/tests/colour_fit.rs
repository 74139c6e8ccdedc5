//! The fit and the diagnosis of a colour-polarization capture (IMX250MYR's RGGB
//! tiles over the small capture's sensor): each pixel is modelled through its own
//! band, as `simulate` renders it, so the band block's parameters (`sky_spectrum`,
//! `band_response`) are fitted and a per-band effect is named as one: a blue-only weak
//! grid is `band_response` (ε_B), not a weak grid (`extinction_ratio`).

mod common;
use bpins_core::effects::{find, EffectSet};
use bpins_core::internal::capture::{Capture, FrameData};
use bpins_core::internal::diagnose::{diagnose, DiagnoseOptions};
use bpins_core::internal::fit::{fit, FitOptions, FitResult};
use bpins_core::sensor::ColourTiles;
use common::*;

/// The small capture's sky and sensor (306 × 256, pinhole, sun at 40°/25°, d_max 0.6)
/// under an RGGB colour filter, four frames a quarter turn apart.
fn colour_capture() -> Capture {
    let mut c = small_capture();
    c.sensor.colour = Some(ColourTiles::imx250myr());
    c.frames.truncate(4);
    for (i, f) in c.frames.iter_mut().enumerate() {
        f.heading_deg = Some(10.0 + 90.0 * i as f64);
    }
    c
}

fn fitted<'a>(r: &'a FitResult, name: &str) -> &'a bpins_core::internal::fit::Param {
    r.params.iter().find(|p| p.name == name).unwrap_or_else(|| panic!("{name} not fitted: {:?}", r.params))
}

/// `set`'s parameters of `effect`, fitted on `frames` of `c` under `opts`: χ²/dof ≈ 1 and
/// each within 4σ of its truth, with 1σ below `max_sigma`.
fn recovers(c: &Capture, frames: &[FrameData], set: &EffectSet, effect: &str, opts: FitOptions, max_sigma: f64) {
    let e = find(effect).unwrap();
    let r = fit(c, frames, &FitOptions { effects: vec![e], ..opts }, &|_, _| {}).unwrap();
    assert!((r.chi2_per_dof - 1.0).abs() < 0.03, "{effect}: χ²/dof {}", r.chi2_per_dof);
    let truth = set.iter().find(|(d, _)| d.name == effect).expect("hidden").1.to_vec();
    for (p, t) in e.params.iter().zip(truth) {
        let f = fitted(&r, &format!("{effect}.{}", p.name));
        eprintln!("{}: {:.5} ± {:.5} (truth {t}); χ²/dof {:.4}", f.name, f.value, f.sigma, r.chi2_per_dof);
        assert!(f.sigma < max_sigma, "{}: 1σ {}", f.name, f.sigma);
        assert!((f.value - t).abs() < 4.0 * f.sigma, "{}: {} ± {} against {t}", f.name, f.value, f.sigma);
    }
    // Every frame's heading stays on its reference (hundredths of a degree).
    assert!(r.heading_rms_deg.unwrap() < 0.03, "{effect}: heading RMS {:?}", r.heading_rms_deg);
}

#[test]
fn a_colour_captures_band_parameters_are_fitted_and_recovered() {
    let c = colour_capture();
    // A clear blue sky: bluer, less polarized in the blue (the colour sample's values).
    let mut sky = EffectSet::new();
    typical(&mut sky, "sky_spectrum");
    let frames = simulate(&c, &sky, 41);
    // Without the band block, the bands' levels and DoLP differ from the model.
    let r = fit(&c, &frames, &FitOptions::default(), &|_, _| {}).unwrap();
    assert!(r.chi2_per_dof > 10.0, "χ²/dof {} with the bands unmodelled", r.chi2_per_dof);
    recovers(&c, &frames, &sky, "sky_spectrum", FitOptions::default(), 2e-3);
    // The sensor's bands: QE and ε per band. A common ε of every band trades against
    // each frame's d_max and scale (as a common extinction ratio does on a monochrome
    // sensor), so the sky's d_max is given, as a lab would give it.
    let mut sensor = EffectSet::new();
    typical(&mut sensor, "band_response");
    let frames = simulate(&c, &sensor, 42);
    recovers(&c, &frames, &sensor, "band_response", FitOptions { fixed_dmax: Some(DMAX), ..Default::default() }, 1e-3);
}

#[test]
fn each_bands_neutral_points_are_fitted_apart() {
    // A Berry sky (neutral points 20° apart in green) whose pairs split wider in the
    // blue and narrower in the red (sky_neutral_spectrum at its typical 1.25 and 0.8).
    let c = colour_capture();
    let mut set = EffectSet::new();
    set.set("sky_neutral_points", "separation_deg", 20.0).unwrap();
    typical(&mut set, "sky_neutral_spectrum");
    let frames = simulate(&c, &set, 44);
    let effects = vec![find("sky_neutral_points").unwrap(), find("sky_neutral_spectrum").unwrap()];
    // One separation for every band leaves the red and blue skies unexplained.
    let one = fit(&c, &frames, &FitOptions { effects: vec![effects[0]], ..Default::default() }, &|_, _| {}).unwrap();
    let r = fit(&c, &frames, &FitOptions { effects, ..Default::default() }, &|_, _| {}).unwrap();
    assert!((r.chi2_per_dof - 1.0).abs() < 0.03, "χ²/dof {}", r.chi2_per_dof);
    assert!(one.chi2_per_dof > r.chi2_per_dof + 0.05, "one separation: χ²/dof {}", one.chi2_per_dof);
    for (name, t) in [
        ("sky_neutral_points.separation_deg", 20.0),
        ("sky_neutral_spectrum.separation_r", 0.8),
        ("sky_neutral_spectrum.separation_b", 1.25),
    ] {
        let f = fitted(&r, name);
        eprintln!("{name}: {:.4} ± {:.4} (truth {t}); χ²/dof {:.4}", f.value, f.sigma, r.chi2_per_dof);
        assert!(
            (f.value - t).abs() < 4.0 * f.sigma && f.sigma < 0.1 * t,
            "{name}: {} ± {} against {t}",
            f.value,
            f.sigma
        );
    }
}

#[test]
fn a_blue_only_weak_grid_is_a_band_response_not_an_extinction_ratio() {
    let c = colour_capture();
    // ER 20 in the blue band alone (the sky neutral in every band).
    let mut set = EffectSet::new();
    set.set("band_response", "eps_b", 0.05).unwrap();
    let frames = simulate(&c, &set, 43);
    let d = diagnose(&c, &frames, &DiagnoseOptions { max_added: 1, ..Default::default() }, &|_| {}).unwrap();
    // Neither inseparable on a colour capture (on a monochrome one both are).
    assert!(!d.inseparable.iter().any(|(e, _)| *e == "sky_spectrum"), "{:?}", d.inseparable);
    let step = &d.rankings[0];
    let rank = |e: &str| step.iter().position(|x| x.effect == e);
    let (band, grid) = (rank("band_response").expect("scored"), rank("extinction_ratio").expect("scored"));
    assert!(band < grid, "band_response ranked {band}, extinction_ratio {grid}");
    assert!(!d.selected.contains(&"extinction_ratio"), "selected {:?}", d.selected);
    // A band's ε and its sky's d_max factor are one number on any sky (with its
    // radiance, its level): sky_spectrum explains the same Δχ², and the pair is said to
    // be confusable rather than either named alone.
    let named = d.selected.contains(&"band_response")
        || d.confusable.iter().any(|p| [p.first, p.second].contains(&"band_response"));
    assert!(named, "selected {:?}, confusable {:?}", d.selected, d.confusable);
    // band_response's refit puts the weak grid in the blue band alone: the bands' ε
    // relative to green's are what a sky with d_max free measures (a common ε trades
    // against each frame's d_max and scale; its 1σ is infinite).
    let cand = &step[band];
    let eps = |n: &str| cand.params.iter().find(|p| p.name == format!("band_response.{n}")).unwrap().value;
    let (blue, red) = (eps("eps_b") - eps("eps_g"), eps("eps_r") - eps("eps_g"));
    assert!((blue - 0.05).abs() < 0.002 && red.abs() < 0.002, "ε_B − ε_G {blue}, ε_R − ε_G {red}");
    // …and the diagnosis names that band: B's level up by 1 + ε_B, its DoLP down by m(ε_B).
    let named = cand.bands_named().expect("a band named");
    assert!(named.starts_with("B:") && !named.contains("R:"), "{named}");
    let b = cand.band_changes()[1];
    assert!((b.level - 1.05).abs() < 0.003 && (b.dolp - 0.95 / 1.05).abs() < 0.003, "{b:?}");
    eprintln!("band_response: {named}; sky_spectrum: {:?}", step[rank("sky_spectrum").unwrap()].bands_named());
    // The model it leaves is noise.
    let last = &d.steps.last().unwrap().fit;
    assert!((last.chi2_per_dof - 1.0).abs() < 0.03, "χ²/dof {}", last.chi2_per_dof);
}

/// `FitRequest::model_colour_bands` (`bpins fit`'s default, docs/colour.md): a colour
/// capture whose fitted effects name no band effect, and whose calibration holds no
/// `sky_spectrum`, is fitted with `sky_spectrum` too, named in `Loaded::added`; a named
/// band effect, a calibration's `sky_spectrum`, a monochrome capture or the flag off
/// (a diagnosis) add nothing.
#[test]
fn a_fit_request_adds_sky_spectrum_to_a_colour_capture_only_where_no_band_is_modelled() {
    use bpins_core::tool::fit::{FitRequest, MIN_BUDGET_PX};
    let sample = |name: &str| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../samples").join(name);
    let tmp = tempfile::tempdir().unwrap();
    let cal = tmp.path().join("calibration.toml");
    let c =
        bpins_core::calibration::Calibration::from_params([("sky_spectrum.dmax_b", 0.9, 0.0)], "test", None).unwrap();
    std::fs::write(&cal, c.to_toml()).unwrap();
    let load = |capture: &str, effects: &[&str], calibration: Option<&std::path::Path>, on: bool| {
        let request = FitRequest {
            capture: sample(capture),
            effects: effects.iter().map(|e| e.to_string()).collect(),
            calibration: calibration.map(|p| p.to_path_buf()),
            sample_budget_px: Some(MIN_BUDGET_PX),
            model_colour_bands: on,
            ..Default::default()
        };
        let l = request.load(&|_, _| {}).unwrap();
        let names: Vec<&str> = l.options.effects.iter().map(|e| e.name).collect();
        (names, l.added.iter().map(|a| a.effect).collect::<Vec<_>>())
    };
    let (names, added) = load("colour-clear", &[], None, true);
    assert_eq!((names, added), (vec!["sky_spectrum"], vec!["sky_spectrum"]));
    let (names, added) = load("colour-clear", &["analyzer_angles"], None, true);
    assert_eq!((names, added), (vec!["analyzer_angles", "sky_spectrum"], vec!["sky_spectrum"]));
    for (capture, effects, calibration, on) in [
        ("colour-clear", &["band_response"][..], None, true),
        ("colour-clear", &["sky_spectrum"][..], None, true),
        ("colour-clear", &[][..], Some(cal.as_path()), true),
        ("colour-clear", &[][..], None, false),
        ("clean", &[][..], None, true),
    ] {
        let (names, added) = load(capture, effects, calibration, on);
        assert!(added.is_empty(), "{capture} {effects:?} {calibration:?} {on}: added {added:?}");
        assert_eq!(names, effects.to_vec(), "{capture} {effects:?} {calibration:?} {on}");
    }
}
