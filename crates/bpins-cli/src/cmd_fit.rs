//! `bpins fit`: fits the enabled effects and each frame's nuisances to a capture's raw
//! DN (a colour capture with no band effect named: `sky_spectrum` too, said on stderr
//! and in fit.json's `added`); prints every parameter with its 1σ, χ²/dof, AoP and
//! DoLP residual RMS and each frame's heading against its reference; writes
//! DIR/fit.json.

use crate::write_json;
use anyhow::Context;
use bpins_core::tool::fit::{fit_from, FitJson};

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    input: crate::FitInput,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let a = a.input;
    let (request, loaded) = a.load_request(true)?;
    for x in &loaded.added {
        // One line per effect the fit added (`FitRequest::model_colour_bands`; fit.json's `added`).
        say!(
            "a colour capture: {} added (each band's level and d_max; name sky_spectrum or band_response in \
             --effects to choose)",
            x.effect
        );
    }
    let names: Vec<&str> = loaded.options.effects.iter().map(|e| e.name).collect();
    say!(
        "bpins fit: {} frames of {}, effects: {}",
        loaded.frames.len(),
        a.capture.display(),
        if names.is_empty() { "none".to_string() } else { names.join(", ") }
    );
    let spinner = crate::progress::spinner("fit");
    let progress = |stage: &str, it: usize| spinner.set_message(format!("iteration {it} ({stage})"));
    let first = fit_from(&loaded.capture, &loaded.frames, &loaded.options, None, &progress).context("fitting")?;
    // A parameter the sample cannot tell from neutral but every pixel could: read
    // more of each frame and fit again (`fit::resolution`).
    let (bpins_core::tool::fit::Loaded { options: opts, capture: c, frames, added }, r) =
        request.raise_where_needed(loaded, first, &progress).context("fitting on more pixels")?;
    spinner.finish_and_clear();
    if let Some(x) = &r.raised {
        say!("{}", crate::raised_line(x, "fitted again"));
    }
    out!(
        "χ²/dof {:.4} ({:.0} / {:.0}), {} samples ({:.0} effective), {} iterations; noise σ_read {:.3} DN, K {:.4} DN/e⁻, PRNU {:.4} %",
        r.chi2_per_dof,
        r.chi2,
        r.dof,
        r.samples,
        r.n_eff,
        r.iterations,
        r.noise.read_dn,
        r.noise.k_dn_per_e,
        100.0 * r.noise.prnu
    );
    out!("AoP residual RMS {:.4}°, DoLP residual RMS {:.5}", r.aop_rms_deg, r.dolp_rms);
    out!("{}", crate::sample_line(&r.sample));
    for p in &r.params {
        out!("  {:<34} {:>+12.5} ± {:<10.5} {}", p.name, p.value, p.sigma, p.unit);
    }
    out!(
        "frame  heading (°)      ± (°)   reference (°)  error (°)  scale (DN)   d_max  radiance ±range   χ²/dof  \
         sun az/el (°) [± its 1σ], source"
    );
    for (k, f) in r.frames.iter().enumerate() {
        out!(
            "{:>5}  {:>11.4} {:>10.4} {:>15} {:>10} {:>11.2} {:>7.4} {:>14.4} {:>8.4}  {}",
            k,
            f.heading_deg,
            f.heading_sigma_deg,
            f.reference_deg.map_or("—".into(), |x| format!("{x:.4}")),
            f.heading_error_deg.map_or("—".into(), |x| format!("{x:+.4}")),
            f.scale_dn,
            f.dmax,
            f.radiance.iter().map(|c| c.abs()).sum::<f64>(),
            f.chi2_per_dof,
            r.sky.get(k).map_or("—".into(), |s| match (f.twilight_strength, f.twilight_strength_sigma) {
                // A mixed twilight: both skies fitted, the other's strength beside.
                (Some(t), Some(ts)) =>
                    format!("{}; both skies fitted, the other's at {t:.3} ± {ts:.3} × the model's", s.sun),
                _ => s.sun.clone(),
            })
        );
    }
    if let Some(h) = r.heading_rms_deg {
        out!("heading RMS against the references: {h:.4}°");
    }
    for d in &r.degenerate {
        out!("degenerate (1σ shown as inf): {d}");
    }
    let v = FitJson::new(&a.capture, &opts, &added, &r);
    let path = a.out.join("fit.json");
    write_json(&path, &v)?;
    // The calibration: the known effects as given, then the fitted ones with their 1σ.
    let known: Vec<(String, f64, f64)> = opts
        .known
        .iter()
        .flat_map(|(d, vals)| d.params.iter().zip(vals).map(move |(p, v)| (format!("{}.{}", d.name, p.name), *v, 0.0)))
        .filter(|(n, ..)| !r.params.iter().any(|p| &p.name == n))
        .collect();
    let cal = bpins_core::calibration::Calibration::from_params(
        known
            .iter()
            .map(|(n, v, s)| (n.as_str(), *v, *s))
            .chain(r.params.iter().map(|p| (p.name.as_str(), p.value, p.sigma))),
        &format!("bpins fit {}", a.capture.display()),
        Some(r.chi2_per_dof),
    )
    .context("the fitted values as a calibration")?;
    // Per-pixel maps the input calibration applied stay with the new one.
    let mut cal = cal;
    if let Some(p) = &a.calibration {
        cal.pixels = bpins_core::calibration::Calibration::load(p)?.pixels;
        cal.write_pixels(&a.out).context("writing the pixel maps beside calibration.toml")?;
    }
    let cal_path = a.out.join("calibration.toml");
    crate::write_output(&cal_path, cal.to_toml().as_bytes())?;
    say!("wrote {} (bpins heading --calibration, fit/diagnose --calibration)", cal_path.display());
    let maps = crate::progress::spinner("residual maps");
    crate::residuals::compute_and_write(&a.out, &c, &frames, &opts, &r)?;
    maps.finish_and_clear();
    say!("wrote residual maps (EXR and PNG) and sky-space profiles (CSV and SVG) to {}", a.out.display());
    say!("wrote {}", path.display());
    Ok(())
}
