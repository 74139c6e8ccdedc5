//! Issue 31's partial explanations, rebuilt: captures with glare whose shape is not the
//! catalog's (`stray_light` is a spread about the sun; these are smooth veils centred
//! off-axis, wherever the sun is) and a capture with a lens ghost (an attenuated copy of
//! the image mirrored through the centre). Each is this project's renderer (the CIE
//! clear sky, the small capture of `common`, no PRNU) with the extra light, and its shot
//! noise, added to the DN after rendering: no catalog effect describes either. What a
//! sensor engineer reading the diagnosis must see: the capture is unexplained; whatever
//! it names is marked as possibly compensating; a fitted value no real sensor or sky has
//! is flagged; nothing is named alone as a clean finding — also where the catalog brings
//! the residual to the noise, but only with such a value (a veil read as channel offsets
//! of +144 DN). Issue 31's own glare capture (another simulator's) gave offsets of
//! −176 DN; this renderer's off-axis glare pulls them to about −950 DN.

mod common;

use bpins_core::effects::EffectSet;
use bpins_core::internal::capture::{Capture, FrameData};
use bpins_core::internal::diagnose::{diagnose, DiagnoseOptions, Diagnosis};
use bpins_core::internal::noise::{stream, FrameKey};
use common::{cie_sky, simulate_in, small_capture};

/// No PRNU: the light added after rendering would not carry the rendered light's.
const PRNU: f64 = 0.0;

/// `frames` with `extra(dn, u, v)` DN of light added to every pixel (u, v) of the mosaic
/// `dn`, with the shot noise of its photo-electrons (variance K·extra, K the simulated
/// sensor's DN per electron, seeded), rounded and clipped to the ADC's range as a
/// sensor would.
fn add_light(c: &Capture, frames: &[FrameData], extra: impl Fn(&[f32], usize, usize) -> f64) -> Vec<FrameData> {
    let full = c.sensor.full_scale_dn();
    let k_dn_per_e = common::sim_sensor(0, PRNU).system_gain_dn_per_e;
    frames
        .iter()
        .enumerate()
        .map(|(i, f)| match f {
            FrameData::Mosaic { width_px, height_px, dn } => {
                // Draws of their own (a key seeded apart from the rendering's noise).
                let key = FrameKey::new(0x6c69_6768_74, 0, i as u32);
                let w = *width_px as usize;
                let out = (0..dn.len())
                    .map(|p| {
                        let x = extra(dn, p % w, p / w);
                        let shot = (k_dn_per_e * x).sqrt() * key.normal(p as u32, 0, stream::TRIAL);
                        (dn[p] as f64 + x + shot).round().clamp(0.0, full) as f32
                    })
                    .collect();
                FrameData::Mosaic { width_px: *width_px, height_px: *height_px, dn: out }
            }
            FrameData::Colocated { .. } => unreachable!("the small capture is DoFP"),
        })
        .collect()
}

/// A veiling glare: unpolarized (the same DN on every channel), smooth, centred at
/// (0.8 W, 0.25 H) — off the axis, and fixed on the sensor while the sun turns with the
/// frames — falling as a Lorentzian of half width `half_w`·W, `peak_dn` at its centre.
fn glare(c: &Capture, frames: &[FrameData], peak_dn: f64, half_w: f64) -> Vec<FrameData> {
    let (w, h) = (c.sensor.geometry.width_px as f64, c.sensor.geometry.height_px as f64);
    let (x0, y0, half) = (0.8 * w, 0.25 * h, half_w * w);
    add_light(c, frames, |_, u, v| {
        let r2 = ((u as f64 - x0).powi(2) + (v as f64 - y0).powi(2)) / (half * half);
        peak_dn / (1.0 + r2)
    })
}

/// A lens ghost: `fraction` of the image (above the black level) reflected through the
/// centre — each superpixel's four channels land, channel for channel, on the
/// superpixel mirrored through the image centre (a ghost is an image: its light passes
/// the analyzers where it lands as the scene's does; a 180° turn keeps every image-frame
/// angle of polarization).
fn ghost(c: &Capture, frames: &[FrameData], fraction: f64) -> Vec<FrameData> {
    let (w, h) = (c.sensor.geometry.width_px as usize, c.sensor.geometry.height_px as usize);
    let black = c.sensor.black_level_dn;
    add_light(c, frames, |dn, u, v| {
        let (mu, mv) = (w - 2 - (u - u % 2) + u % 2, h - 2 - (v - v % 2) + v % 2);
        fraction * (dn[mv * w + mu] as f64 - black).max(0.0)
    })
}

fn run(c: &Capture, frames: &[FrameData]) -> Diagnosis {
    let opts = DiagnoseOptions { max_added: 2, ..Default::default() };
    diagnose(c, frames, &opts, &|_| {}).unwrap()
}

fn show(what: &str, d: &Diagnosis) {
    let last = &d.steps.last().unwrap().fit;
    let params: Vec<String> =
        last.params.iter().map(|p| format!("{} = {:.4} ± {:.4}", p.name, p.value, p.sigma)).collect();
    let ranked: Vec<String> = d
        .rankings
        .iter()
        .map(|r| {
            r.iter()
                .take(3)
                .map(|c| {
                    format!(
                        "{} (Δχ² {:.0}, ΔBIC {:.0}, unphysical {:?})",
                        c.effect, c.delta_chi2, c.delta_bic, c.outside_physical
                    )
                })
                .collect::<Vec<_>>()
                .join("; ")
        })
        .collect();
    eprintln!(
        "{what}: χ²/dof {:.3} → {:.3}; named {:?}, negligible {:?}, pairs {:?}; {}\n  rankings: {}\n  {}",
        d.steps[0].fit.chi2_per_dof,
        last.chi2_per_dof,
        d.selected,
        d.negligible,
        d.confusable.iter().map(|p| (p.first, p.second)).collect::<Vec<_>>(),
        params.join(", "),
        ranked.join(" | "),
        d.summary()
    );
}

/// What a sensor engineer needs of a capture outside the catalog (module doc); returns
/// what is wrong (empty when right).
fn partial_only(d: &Diagnosis) -> Vec<String> {
    let mut out = Vec::new();
    if !d.unexplained() {
        out.push(format!("not reported unexplained: {}", d.summary()));
    }
    let named = d.selected.iter().copied().chain(d.confusable.iter().map(|p| p.first));
    for e in named {
        if !d.possibly_compensating(e) {
            out.push(format!("{e} named as a clean finding"));
        }
    }
    let partial = ["no more than a partial explanation", "nothing named is a finding"];
    if !d.selected.is_empty() && !partial.iter().any(|w| d.summary().contains(w)) {
        out.push(format!("the summary does not call {:?} partial: {}", d.selected, d.summary()));
    }
    out
}

/// The candidates of every step named `effect` whose fitted offsets are negative and
/// flagged unphysical.
fn negative_offsets_flagged(d: &Diagnosis, effect: &str) -> bool {
    d.rankings.iter().flatten().filter(|c| c.effect == effect).any(|c| {
        let negative = c.params.iter().filter(|p| p.name.contains("offset") && p.value < -50.0).count();
        negative == 4 && c.outside_physical.iter().filter(|w| w.name.contains("offset")).count() == 4
    })
}

#[test]
fn an_off_axis_glare_is_unexplained_and_the_offsets_it_pulls_negative_are_flagged() {
    // Measured (2026-11-27): χ²/dof 5.07 → 1.97; sky_dolp_shape named (t = 0.75) as a
    // partial explanation; channel_response refitted at the next step with offsets of
    // −950 to −955 DN on all four channels (a black level far below zero), not named.
    let c = small_capture();
    let frames = glare(&c, &simulate_in(&c, &EffectSet::new(), 51, &cie_sky(), PRNU), 900.0, 1.5);
    let d = run(&c, &frames);
    show("glare 900 DN", &d);
    let problems = partial_only(&d);
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(negative_offsets_flagged(&d, "channel_response"), "no negative offsets flagged");
}

#[test]
fn a_veil_brought_to_the_noise_only_by_unphysical_offsets_is_unexplained() {
    // A broad, nearly uniform veil (150 DN at its centre, 135–150 DN over the frame):
    // channel offsets of +144 DN bring χ²/dof 1.49 to 1.008, within the noise (≤ 1.02)
    // — measured 2026-11-27. Before the diagnosis weighed physical ranges, that read
    // "within the noise once channel_response is modelled: nothing else structured
    // remains", a clean finding; no real sensor's channel offsets are 144 DN.
    let c = small_capture();
    let frames = glare(&c, &simulate_in(&c, &EffectSet::new(), 51, &cie_sky(), PRNU), 150.0, 3.0);
    let d = run(&c, &frames);
    show("uniform veil 150 DN", &d);
    let last = &d.steps.last().unwrap().fit;
    assert!(last.chi2_per_dof <= d.remains.noise_limit, "not at the noise: χ²/dof {}", last.chi2_per_dof);
    assert!(d.remains.unexplained.is_none(), "a structured residual remains: {}", d.summary());
    assert!(d.remains.unphysical.iter().any(|w| w.name.starts_with("channel_response.offset")), "{:?}", d.remains);
    let problems = partial_only(&d);
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn a_lens_ghost_is_unexplained_and_what_it_names_is_possibly_compensating() {
    // Measured (2026-11-27): a 5 % ghost; χ²/dof 2.74 → 1.58, sky_dolp_shape named (t =
    // 0.32) as a partial explanation; focal_length scored at 9 % off (beyond ±5 %) and
    // channel_response at +156…+172 DN, both flagged.
    let c = small_capture();
    let frames = ghost(&c, &simulate_in(&c, &EffectSet::new(), 51, &cie_sky(), PRNU), 0.05);
    let d = run(&c, &frames);
    show("ghost 5 %", &d);
    let problems = partial_only(&d);
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(!d.selected.is_empty(), "nothing named: the test no longer checks what is named");
    let flagged = |e: &str| d.rankings.iter().flatten().any(|c| c.effect == e && !c.outside_physical.is_empty());
    assert!(flagged("focal_length"), "no unphysical focal length flagged");
}
