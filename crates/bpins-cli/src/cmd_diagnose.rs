//! `bpins diagnose`: fits the given model, asks every catalog effect not in it how much
//! it would explain, adds the winner while the evidence pays for it, and says so
//! plainly when a structured residual remains that no catalog effect explains.
//! Writes DIR/diagnosis.json and DIR/report.html (self-contained).

use crate::write_json;
use anyhow::Context;
use bpins_core::fit::diagnose::{diagnose, DiagnoseOptions, Diagnosis};
use bpins_core::fit::{residual_maps, FitOptions, Param};
use serde_json::{json, Map, Value};

#[derive(clap::Args)]
pub struct Args {
    /// The model to start from (and keep).
    #[command(flatten)]
    input: crate::FitInput,
    /// Most effects to add.
    #[arg(long, default_value_t = 3)]
    max_added: usize,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let max_added = a.max_added;
    let a = a.input;
    let (base, c, frames) = a.load()?;
    let opts = DiagnoseOptions { base, max_added, ..Default::default() };
    let spinner = indicatif::ProgressBar::new_spinner();
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    let t0 = std::time::Instant::now();
    let d = diagnose(&c, &frames, &opts, &|what| spinner.set_message(what.to_string())).context("diagnosing")?;
    spinner.finish_and_clear();
    print_steps(&d);
    eprintln!("diagnosed in {:.1} s", t0.elapsed().as_secs_f64());
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    write_json(&a.out.join("diagnosis.json"), &to_json(&d, &a.capture))?;
    // Residual maps of every step, side by side in the report.
    let mut maps = Vec::new();
    for (k, s) in d.steps.iter().enumerate() {
        let effects = s.model.iter().map(|n| bpins_core::effects::find(n)).collect::<Result<Vec<_>, _>>()?;
        let opts = FitOptions { effects, ..opts.base.clone() };
        let m = residual_maps(&c, &frames, &opts, &s.fit.state, s.fit.noise).context("residual maps")?;
        maps.push(crate::residuals::write(&a.out.join(format!("step{k}")), &m)?);
    }
    let html = report_html(&d, &a.capture, &maps);
    let page = a.out.join("report.html");
    crate::write_output(&page, html.as_bytes())?;
    eprintln!("wrote {} and {}", a.out.join("diagnosis.json").display(), page.display());
    Ok(())
}

fn opt(x: Option<f64>) -> String {
    x.map_or("—".into(), |v| format!("{v:.4}"))
}

fn print_steps(d: &Diagnosis) {
    println!("{:<40} {:>9} {:>10} {:>9} {:>12}", "model", "χ²/dof", "AoP RMS °", "DoLP RMS", "heading RMS °");
    for s in &d.steps {
        let m = if s.model.is_empty() { "(no effect)".to_string() } else { s.model.join(" + ") };
        println!(
            "{:<40} {:>9.4} {:>10.4} {:>9.5} {:>12}",
            m,
            s.fit.chi2_per_dof,
            s.fit.aop_rms_deg,
            s.fit.dolp_rms,
            opt(s.fit.heading_rms_deg)
        );
    }
    if let Some(first) = d.rankings.first() {
        println!("first step, candidates by ΔBIC:");
        for c in first {
            println!(
                "  {:<22} Δχ² {:>12.1}  ΔBIC {:>12.1}  {}",
                c.effect,
                c.delta_chi2,
                c.delta_bic,
                if !c.identifiable {
                    "(cannot be told from the nuisances)"
                } else if c.refitted {
                    "(refitted)"
                } else {
                    "(score test, 1/9 of the pixels)"
                }
            );
        }
    }
    println!("selected: {}", if d.selected.is_empty() { "nothing".into() } else { d.selected.join(", ") });
    for (e, why) in &d.inseparable {
        println!("inseparable on this capture (not fitted): {e}: {why}");
    }
    for (a, b) in &d.confusable {
        println!("confusable: {a} and {b} explain the data about equally well");
    }
    println!("{}", d.unexplained_summary);
}

fn params_json(ps: &[Param]) -> (Value, Value) {
    let (mut v, mut s) = (Map::new(), Map::new());
    for p in ps {
        v.insert(p.name.clone(), json!(p.value));
        s.insert(p.name.clone(), json!(p.sigma));
    }
    (Value::Object(v), Value::Object(s))
}

fn to_json(d: &Diagnosis, capture: &std::path::Path) -> Value {
    let ranking = |r: &[bpins_core::fit::diagnose::Candidate]| {
        r.iter()
            .map(|c| {
                let (params, sigmas) = params_json(&c.params);
                json!({
                    "effect": c.effect, "delta_chi2": c.delta_chi2, "delta_bic": c.delta_bic,
                    "score_delta_chi2": c.score, "refitted": c.refitted, "identifiable": c.identifiable,
                    "constrained_params": c.added_rank,
                    "params": params, "sigmas": sigmas,
                })
            })
            .collect::<Vec<_>>()
    };
    json!({
        "capture": capture.display().to_string(),
        "steps": d.steps.iter().map(|s| {
            let (params, sigmas) = params_json(&s.fit.params);
            json!({
                "model": s.model,
                "chi2_per_dof": s.fit.chi2_per_dof,
                "aop_rms_deg": s.fit.aop_rms_deg,
                "dolp_rms": s.fit.dolp_rms,
                "heading_rms_deg": s.fit.heading_rms_deg,
                "params": params,
                "sigmas": sigmas,
                "degenerate": s.fit.degenerate,
            })
        }).collect::<Vec<_>>(),
        "ranking": d.rankings.first().map(|r| ranking(r)).unwrap_or_default(),
        "rankings": d.rankings.iter().map(|r| ranking(r)).collect::<Vec<_>>(),
        "selected": d.selected,
        "confusable": d.confusable.iter().map(|(a, b)| json!([a, b])).collect::<Vec<_>>(),
        "unexplained": d.unexplained,
        "unexplained_summary": d.unexplained_summary,
        "inseparable": d.inseparable.iter().map(|(e, why)| json!({ "effect": e, "why": why })).collect::<Vec<_>>(),
        "effective_samples": d.steps.last().map(|s| s.fit.n_eff),
        "bic_threshold": bpins_core::fit::diagnose::BIC_THRESHOLD,
    })
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// A self-contained page: every step of the model with its figures, the candidates of
/// each step, what was selected, and what remains.
fn report_html(d: &Diagnosis, capture: &std::path::Path, figures: &[crate::residuals::Figures]) -> String {
    let mut h = String::new();
    h += "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>bpins diagnosis</title>\n";
    h += "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;color:#222}table{border-collapse:collapse;margin:1em 0;display:block;overflow-x:auto}td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}td:first-child,th:first-child{text-align:left}.yes{color:#070}.no{color:#a00}</style></head><body>\n";
    h += &format!("<h1>Diagnosis of <code>{}</code></h1>\n", esc(&capture.display().to_string()));
    h += "<h2>The error, step by step</h2>\n<table><tr><th>model</th><th>χ²/dof</th><th>AoP RMS (°)</th><th>DoLP RMS</th><th>heading RMS (°)</th></tr>\n";
    for s in &d.steps {
        let m = if s.model.is_empty() { "(no effect)".to_string() } else { s.model.join(" + ") };
        h += &format!(
            "<tr><td>{}</td><td>{:.4}</td><td>{:.4}</td><td>{:.5}</td><td>{}</td></tr>\n",
            esc(&m),
            s.fit.chi2_per_dof,
            s.fit.aop_rms_deg,
            s.fit.dolp_rms,
            opt(s.fit.heading_rms_deg)
        );
    }
    h += "</table>\n";
    // The residual maps of each step side by side (stacked over frames).
    h += "<h2>Where the model fails: residual maps, each step</h2>\n<p>Mean over frames of measured − model: blue below the model, white on it, red above, grey masked; each map's colour scale is symmetric, ± the value given.</p>\n<table>";
    for (k, (s, m)) in d.steps.iter().zip(figures).enumerate() {
        let name = if s.model.is_empty() { "(no effect)".to_string() } else { s.model.join(" + ") };
        h += &format!("<tr><td>step {k}<br>{}<br>χ²/dof {:.4}</td>", esc(&name), s.fit.chi2_per_dof);
        for w in &m.maps {
            h += &format!(
                "<td><img src=\"step{k}/{}\" alt=\"{} of step {k}\" style=\"width:14em;image-rendering:pixelated\"><br>{} (± {:.3} {})</td>",
                w.png, w.what, w.what, w.scale, w.unit
            );
        }
        h += "</tr>\n";
    }
    h += "</table>\n";
    // Frame by frame: a misfit that moves with the heading lives in the sky, one that
    // stays put lives in the camera.
    h += "<h2>Frame by frame</h2>\n<p>Each frame's residual (measured − model), same colours; scales ± the value given. The numbers are the layers <code>f&lt;k&gt;_…</code> of each step's <code>residual_dn.exr</code> and <code>residual_pol.exr</code>. A misfit that turns with the heading lives in the sky; one that stays put lives in the camera.</p>\n<table>";
    for (k, (s, m)) in d.steps.iter().zip(figures).enumerate() {
        let name = if s.model.is_empty() { "(no effect)".to_string() } else { s.model.join(" + ") };
        for q in 0..3 {
            let what = m.frames.first().map_or("", |f| f[q].what);
            h += &format!("<tr><td>step {k}: {}<br>{what}</td>", esc(&name));
            for (f, row) in m.frames.iter().enumerate() {
                let w = &row[q];
                h += &format!(
                    "<td><img src=\"step{k}/{}\" alt=\"frame {f} {} of step {k}\" style=\"width:6em;image-rendering:pixelated\"><br>f{f} ±{:.3}{}</td>",
                    w.png, w.what, w.scale, w.unit
                );
            }
            h += "</tr>\n";
        }
    }
    h += "</table>\n";
    // The same residuals in sky space, each step.
    h += "<h2>Where the model fails in sky space: residual profiles, each step</h2>\n<p>Over every frame, binned against scattering angle from the sun, radius from the principal point, image azimuth, mosaic position, analyzer channel and the model's DoLP: raw-DN χ² per sample − 1 (0 where the model fits), mean AoP residual and mean DoLP residual (measured − model), each strip on its own symmetric scale (± the value given). A missing effect shows as a trend along its own axis. Numbers: <code>step&lt;k&gt;/profiles.csv</code>.</p>\n";
    for (k, (s, m)) in d.steps.iter().zip(figures).enumerate() {
        let name = if s.model.is_empty() { "(no effect)".to_string() } else { s.model.join(" + ") };
        h += &format!(
            "<p>step {k}: {}</p><img src=\"step{k}/{}\" alt=\"residual profiles of step {k}\" style=\"width:100%\">\n",
            esc(&name),
            m.profiles_svg
        );
    }
    for (i, r) in d.rankings.iter().enumerate() {
        h += &format!(
            "<h2>Step {}: candidates (ΔBIC = Δχ²·n_eff/n − k ln n_eff; added above {})</h2>\n",
            i + 1,
            bpins_core::fit::diagnose::BIC_THRESHOLD
        );
        h += "<table><tr><th>effect</th><th>Δχ²</th><th>ΔBIC</th><th>how</th><th>parameters (± 1σ)</th></tr>\n";
        for c in r {
            let ps: Vec<String> =
                c.params.iter().map(|p| format!("{} = {:.5} ± {:.5} {}", p.name, p.value, p.sigma, p.unit)).collect();
            h += &format!(
                "<tr><td>{}</td><td>{:.1}</td><td class=\"{}\">{:.1}</td><td>{}</td><td>{}</td></tr>\n",
                c.effect,
                c.delta_chi2,
                if c.delta_bic > bpins_core::fit::diagnose::BIC_THRESHOLD { "yes" } else { "no" },
                c.delta_bic,
                if !c.identifiable {
                    "cannot be told from the nuisances"
                } else if c.refitted {
                    "refitted"
                } else {
                    "score test on every third row and column"
                },
                esc(&ps.join("; "))
            );
        }
        h += "</table>\n";
    }
    h += &format!(
        "<h2>Selected</h2><p>{}</p>\n",
        if d.selected.is_empty() { "No effect.".to_string() } else { d.selected.join(", then ") }
    );
    for (a, b) in &d.confusable {
        h += &format!("<p><b>Confusable:</b> {a} and {b} explain the data about equally well.</p>\n");
    }
    if !d.inseparable.is_empty() {
        h += "<h2>What this capture cannot tell</h2><p>These effects cannot be separated from the fit's nuisances (the sky's radiance and d_max of each frame) on a sky capture; they were not fitted or named:</p><ul>\n";
        for (e, why) in &d.inseparable {
            h += &format!("<li><b>{e}</b>: {}</li>\n", esc(why));
        }
        h += "</ul>\n";
    }
    h += &format!(
        "<h2>What remains</h2><p class=\"{}\">{}</p>\n",
        if d.unexplained { "no" } else { "yes" },
        esc(&d.unexplained_summary)
    );
    if let Some(last) = d.steps.last() {
        h += "<h2>Final model: frames</h2><table><tr><th>frame</th><th>heading (°)</th><th>± (°)</th><th>reference (°)</th><th>error (°)</th><th>d_max</th><th>radiance coefficients</th><th>χ²/dof</th></tr>\n";
        for (k, f) in last.fit.frames.iter().enumerate() {
            h += &format!(
                "<tr><td>{k}</td><td>{:.4}</td><td>{:.4}</td><td>{}</td><td>{}</td><td>{:.4}</td><td>{}</td><td>{:.4}</td></tr>\n",
                f.heading_deg,
                f.heading_sigma_deg,
                opt(f.reference_deg),
                opt(f.heading_error_deg),
                f.dmax,
                f.radiance.iter().map(|c| format!("{c:+.3}")).collect::<Vec<_>>().join(" "),
                f.chi2_per_dof
            );
        }
        h += "</table>\n";
    }
    // Once loaded, the page marks <body data-images-ok="decoded/all"> so that a headless
    // browser can tell that every map was found and decoded (tests/report_render.rs).
    h += "<script>addEventListener(\"load\",()=>{const i=[...document.images];document.body.dataset.imagesOk=i.filter(x=>x.complete&&x.naturalWidth>0).length+\"/\"+i.length})</script>\n";
    h += "</body></html>\n";
    h
}
