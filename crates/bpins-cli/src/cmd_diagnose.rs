//! `bpins diagnose`: fits the given model, asks every catalog effect not in it how much
//! it would explain, adds the winner while the evidence pays for it, and says so
//! plainly when a structured residual remains that no catalog effect explains.
//! Writes DIR/diagnosis.json (serialised from the library's [`Diagnosis`]) and
//! DIR/report.html (`crate::report`).

use crate::write_json;
use anyhow::Context;
use bpins_core::tool::diagnose::diagnose_frames;
use bpins_core::tool::diagnose::DiagnosisJson;
use bpins_core::FitOptions;
use bpins_core::MinSize;
use bpins_core::{DiagnoseOptions, Diagnosis, Evidence};

#[derive(clap::Args)]
pub struct Args {
    /// The model to start from (and keep).
    #[command(flatten)]
    input: crate::FitInput,
    /// Most effects to add.
    #[arg(long, default_value_t = 3)]
    max_added: usize,
    /// An added effect is named only where it moves some frame's heading by more than
    /// this (degrees), or passes --min-aop-deg or --min-dolp; else it is listed as
    /// detected, negligible. Default: twice the RMS of the frames' heading 1σ (with the
    /// misfit) of the fit with the effect.
    #[arg(long, value_name = "DEG")]
    min_heading_deg: Option<f64>,
    /// The same for the RMS change of the model's AoP (degrees). Default: a tenth of one
    /// sample's AoP noise scatter (the AoP residual RMS over √max(1, χ²/dof)).
    #[arg(long, value_name = "DEG")]
    min_aop_deg: Option<f64>,
    /// The same for the RMS change of the model's DoLP. Default: a tenth of one
    /// sample's DoLP noise scatter.
    #[arg(long, value_name = "DOLP")]
    min_dolp: Option<f64>,
    /// The same for the largest change of one pixel's model DN. Default: a tenth of one
    /// pixel's noise at the frames' radiance scale.
    #[arg(long, value_name = "DN")]
    min_dn: Option<f64>,
    /// Print where the run spent its time, stage by stage, to stderr (diagnosis.json's
    /// `timings` holds the same, in seconds, always).
    #[arg(long)]
    timings: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let max_added = a.max_added;
    let show_timings = a.timings;
    let t_run = std::time::Instant::now();
    for (flag, v) in [
        ("--min-heading-deg", a.min_heading_deg),
        ("--min-aop-deg", a.min_aop_deg),
        ("--min-dolp", a.min_dolp),
        ("--min-dn", a.min_dn),
    ] {
        if v.is_some_and(|x| !(x.is_finite() && x >= 0.0)) {
            anyhow::bail!("{flag} must be a finite number ≥ 0, not {}", v.unwrap_or_default());
        }
    }
    let min_size = MinSize { heading_deg: a.min_heading_deg, aop_deg: a.min_aop_deg, dolp: a.min_dolp, dn: a.min_dn };
    let a = a.input;
    // The search starts from the model given: no band effect added to a colour
    // capture's (`sky_spectrum` and `band_response` are scored, as a confusable pair).
    let (request, loaded) = a.load_request(false)?;
    let load_s = t_run.elapsed().as_secs_f64();
    let opts = DiagnoseOptions { base: loaded.options.clone(), max_added, min_size, ..Default::default() };
    let spinner = crate::progress::spinner("diagnose");
    let t0 = std::time::Instant::now();
    let d = diagnose_frames(&loaded.capture, &loaded.frames, &opts, &|what| spinner.set_message(what.to_string()))
        .context("diagnosing")?;
    // The final model's parameters on more pixels where the sample cannot decide them
    // but every pixel could (`fit::resolution`).
    let t_raise = std::time::Instant::now();
    let (bpins_core::tool::fit::Loaded { capture: c, frames, .. }, mut d) = request
        .raise_diagnosis_where_needed(loaded, d, &|_, it| spinner.set_message(format!("final model, iteration {it}")))
        .context("fitting the final model on more pixels")?;
    d.timings.load_s = load_s;
    d.timings.final_fit_s = t_raise.elapsed().as_secs_f64();
    let t_report = std::time::Instant::now();
    spinner.finish_and_clear();
    if let Some(x) = d.steps.last().and_then(|s| s.fit.raised.as_ref()) {
        say!("{}", crate::raised_line(x, "the final model fitted again"));
    }
    print_steps(&d)?;
    say!("diagnosed in {:.1} s", t0.elapsed().as_secs_f64());
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    // Residual maps of every step, side by side in the report.
    let mut maps = Vec::new();
    let mut ends = Vec::new();
    let pb = crate::progress::bar(d.steps.len() as u64, "residual maps of the steps");
    for (k, s) in d.steps.iter().enumerate() {
        let effects = s.model.iter().map(|n| bpins_core::effects::find(n)).collect::<Result<Vec<_>, _>>()?;
        let opts = FitOptions { effects, ..opts.base.clone() };
        let (figures, m) =
            crate::residuals::compute_and_write(&a.out.join(format!("step{k}")), &c, &frames, &opts, &s.fit)?;
        maps.push(figures);
        // The first and the last step's, for the report's before → after.
        if k == 0 || k + 1 == d.steps.len() {
            ends.push(m);
        }
        pb.inc(1);
    }
    pb.finish_and_clear();
    let (first, last) = (&ends[0], ends.last().expect("a starting step"));
    let pair = crate::residuals::before_after(&a.out.join("answer"), first, last)?;
    let html = crate::report::diagnosis(&d, &a.capture.display().to_string(), &maps, &pair)?;
    let page = a.out.join("report.html");
    crate::write_output(&page, html.as_bytes())?;
    // The JSON last, with the time the maps and the report took.
    d.timings.report_s = t_report.elapsed().as_secs_f64();
    d.timings.total_s = t_run.elapsed().as_secs_f64();
    let json = DiagnosisJson::new(&a.capture, &d);
    write_json(&a.out.join("diagnosis.json"), &json)?;
    say!("wrote {} and {}", a.out.join("diagnosis.json").display(), page.display());
    if show_timings {
        print_timings(&d.timings);
    }
    Ok(())
}

/// Where the run spent its time, stage by stage, to stderr (`--timings`).
fn print_timings(t: &bpins_core::Timings) {
    say!("{:<20}  {:>9}  {:>6}", "stage", "seconds", "share");
    let total = t.total_s.max(f64::MIN_POSITIVE);
    for (stage, s) in t.stages() {
        say!("{stage:<20}  {s:>9.2}  {:>5.1}%", 100.0 * s / total);
    }
    let between = (t.total_s - t.sum_of_stages()).max(0.0);
    say!("{:<20}  {between:>9.2}  {:>5.1}%", "between stages", 100.0 * between / total);
    say!("{:<20}  {:>9.2}", "total", t.total_s);
}

/// A left-aligned column's width: its header's or its widest entry's, in characters
/// (`{:<w$}` pads by characters, and so is each entry measured).
fn column_width<'a>(header: &str, entries: impl Iterator<Item = &'a str>) -> usize {
    entries.map(|e| e.chars().count()).chain([header.chars().count()]).max().unwrap_or(0)
}

fn opt(x: Option<f64>) -> String {
    x.map_or("—".into(), |v| format!("{v:.4}"))
}

fn print_steps(d: &Diagnosis) -> anyhow::Result<()> {
    // Two spaces between columns, each as wide as its header or its widest entry (a model
    // of several effects, an effect named `polarimetric_nonuniformity`): the columns never
    // run together.
    let models: Vec<String> = d
        .steps
        .iter()
        .map(|s| if s.model.is_empty() { "(no effect)".to_string() } else { s.model.join(" + ") })
        .collect();
    let mw = column_width("model", models.iter().map(String::as_str));
    if let Some(n) = &d.night {
        out!("the sky's source: {} ({} of {} frames moonlit)", n.source, n.moonlit_frames, n.frames);
    } else if let Some(sky) = d.steps.last().map(|s| &s.fit.sky) {
        // By day and twilight, from the frames' time and place: the first sunlit frame's,
        // as `bpins heading` says it (every frame's in diagnosis.json's `sky`).
        let sunlit = sky.iter().filter(|f| f.source == "sun").count();
        if let Some(first) = sky.iter().find(|f| f.source == "sun") {
            out!("the sky's source: the sun at {} ({sunlit} of {} frames sunlit)", first.sun, sky.len());
        }
    }
    out!("{:<mw$}  {:>9}  {:>10}  {:>9}  {:>14}", "model", "χ²/dof", "AoP RMS °", "DoLP RMS", "heading RMS °");
    for (s, m) in d.steps.iter().zip(&models) {
        out!(
            "{:<mw$}  {:>9.4}  {:>10.4}  {:>9.5}  {:>14}",
            m,
            s.fit.chi2_per_dof,
            s.fit.aop_rms_deg,
            s.fit.dolp_rms,
            opt(s.fit.heading_rms_deg)
        );
    }
    for (i, ranking) in d.rankings.iter().enumerate() {
        out!(
            "step {}, candidates by ΔBIC; size: heading change RMS / worst frame (°), AoP RMS (°), DoLP RMS, DN at the worst pixel:",
            i + 1
        );
        let ew = column_width("effect", ranking.iter().map(|c| c.effect));
        out!(
            "  {:<ew$}  {:>12}  {:>12}  {:>20}  {:>8}  {:>8}  {:>8}",
            "effect",
            "Δχ²",
            "ΔBIC",
            "heading °",
            "AoP °",
            "DoLP",
            "DN"
        );
        for c in ranking {
            let [heading, aop, dolp, dn] = crate::effect_sizes::size_cells(c);
            let (verdict, _) = crate::effect_sizes::candidate_verdict(d, i + 1, c);
            out!(
                "  {:<ew$}  {:>12.1}  {:>12.1}  {:>20}  {:>8}  {:>8}  {:>8}  {}{}",
                c.effect,
                c.delta_chi2,
                c.delta_bic,
                heading,
                aop,
                dolp,
                dn,
                if verdict.is_empty() { String::new() } else { format!("{verdict}; ") },
                if !c.identifiable {
                    "(cannot be told from the nuisances)"
                } else {
                    match c.evidence {
                        Evidence::EveryPixelScore => {
                            "(refitted on 1/9 of the pixels; its score test on every pixel stays below the threshold)"
                        }
                        Evidence::EveryPixelRefit => "(refitted)",
                        Evidence::SubsampleRefit => "(refitted on 1/9 of the pixels, clearly behind)",
                        Evidence::Score => "(score test, 1/9 of the pixels fitted)",
                    }
                }
            );
        }
    }
    if let Some(s) = d.steps.first() {
        out!("{}", crate::sample_line(&s.fit.sample));
    }
    out!(
        "named: {}",
        if d.selected.is_empty() { "nothing".into() } else { crate::effect_sizes::sized(d, &d.selected) }
    );
    if !d.negligible.is_empty() {
        out!("detected, negligible (not named): {}", crate::effect_sizes::sized(d, &d.negligible));
    }
    for e in d.selected.iter().filter(|e| d.possibly_compensating(e)) {
        let unphysical: Vec<String> = d.outside_physical(e).map(|x| x.words).collect();
        out!(
            "possibly compensating: {e}{}",
            if unphysical.is_empty() {
                " (the capture stays unexplained)".to_string()
            } else {
                format!(": {}", unphysical.join("; "))
            }
        );
    }
    for (e, why) in &d.inseparable {
        out!("inseparable on this capture (not fitted): {e}: {why}");
    }
    for p in &d.confusable {
        out!(
            "confusable: {} and {} explain the same χ² within its noise, neither is named ({} is in the model); what separates them: {}",
            p.first,
            p.second,
            p.first,
            p.separates
        );
    }
    out!("{}", d.summary());
    Ok(())
}
