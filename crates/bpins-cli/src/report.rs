//! `report.html` of `bpins diagnose`: the page is `templates/diagnosis.html`
//! (minijinja, HTML autoescaping on), this module the values it shows — numbers
//! formatted with their units, file names of the figures. It opens with the answer
//! (what is missing, its parameters ± 1σ, χ²/dof and heading RMS before → after, the
//! DN residual before and after), then each step's sky-space profiles, maps, frames
//! and candidates.

use crate::effect_sizes::{candidate_verdict, size_cells, sized};
use crate::residuals::{Figures, Written};
use bpins_core::Param;
use bpins_core::{Candidate, Diagnosis, Evidence};
use serde::Serialize;

const TEMPLATE: &str = include_str!("templates/diagnosis.html");

/// The page: what the template reads.
#[derive(Serialize)]
struct Page {
    capture: String,
    answer: Answer,
    steps: Vec<StepView>,
    remains: Verdict,
    confusable: Vec<bpins_core::Confusable>,
    negligible: String,
    rankings: Vec<RankingView>,
    bic_threshold: f64,
    selected: String,
    inseparable: Vec<Why>,
    frames: Vec<FrameRow>,
    /// What of each frame the fits read (the sample budget), in words.
    sample: String,
}

#[derive(Serialize)]
struct Answer {
    verdict: String,
    class: &'static str,
    params: Vec<ParamRow>,
    before_label: String,
    after_label: String,
    rows: Vec<BeforeAfter>,
    figures: Vec<Figure>,
    figure_note: String,
}

#[derive(Serialize)]
struct ParamRow {
    name: String,
    value: String,
    unit: &'static str,
}

#[derive(Serialize)]
struct BeforeAfter {
    what: &'static str,
    before: String,
    after: String,
}

#[derive(Serialize)]
struct Figure {
    src: String,
    alt: String,
    caption: String,
}

#[derive(Serialize)]
struct StepView {
    k: usize,
    name: String,
    chi2_per_dof: String,
    aop_rms_deg: String,
    dolp_rms: String,
    heading_rms_deg: String,
    profiles_src: String,
    maps: Vec<Figure>,
    frames: Vec<FramesRow>,
}

#[derive(Serialize)]
struct FramesRow {
    what: &'static str,
    cells: Vec<Figure>,
}

#[derive(Serialize)]
struct Verdict {
    class: &'static str,
    text: String,
}

#[derive(Serialize)]
struct RankingView {
    step: usize,
    rows: Vec<CandidateRow>,
}

#[derive(Serialize)]
struct CandidateRow {
    effect: &'static str,
    delta_chi2: String,
    delta_bic: String,
    /// The effect's size: heading change RMS / worst frame (°), AoP RMS (°), DoLP RMS,
    /// DN at the worst pixel; and what the diagnosis made of it.
    heading: String,
    aop: String,
    dolp: String,
    dn: String,
    verdict: String,
    verdict_class: &'static str,
    class: &'static str,
    how: &'static str,
    params: String,
}

#[derive(Serialize)]
struct Why {
    effect: &'static str,
    why: String,
}

#[derive(Serialize)]
struct FrameRow {
    k: usize,
    heading_deg: String,
    sigma_deg: String,
    sigma_stat_deg: String,
    reference_deg: String,
    error_deg: String,
    dmax: String,
    radiance: String,
    chi2_per_dof: String,
}

/// The report of `d`, whose steps' figures are `figures` (in `step<k>/`).
/// `before_after`: the χ² excess of the first and the last step on one scale.
pub fn diagnosis(
    d: &Diagnosis,
    capture: &str,
    figures: &[Figures],
    before_after: &[Written; 2],
) -> anyhow::Result<String> {
    let steps: Vec<StepView> = d.steps.iter().zip(figures).enumerate().map(|(k, (s, f))| step(k, s, f)).collect();
    let page = Page {
        capture: capture.to_string(),
        answer: answer(d, before_after),
        steps,
        remains: Verdict { class: if d.unexplained() { "no" } else { "yes" }, text: d.summary() },
        confusable: d.confusable.clone(),
        negligible: d.negligible.join(", "),
        rankings: d.rankings.iter().enumerate().map(|(i, r)| ranking(d, i + 1, r)).collect(),
        bic_threshold: d.bic_threshold,
        selected: if d.selected.is_empty() { "No effect.".into() } else { d.selected.join(", then ") },
        inseparable: d.inseparable.iter().map(|(effect, why)| Why { effect, why: why.clone() }).collect(),
        frames: d.steps.last().map_or(Vec::new(), |s| frame_rows(&s.fit)),
        sample: d.steps.first().map_or(String::new(), |s| crate::sample_line(&s.fit.sample)),
    };
    Ok(bpins_core::tool::output::render_html("diagnosis.html", TEMPLATE, &page)?)
}

/// A radiance coefficient: 3 decimals, a small one in scientific notation rather
/// than a `+0.000` or `-0.000` that says nothing, an exact zero as `0`.
fn coefficient(c: f64) -> String {
    if c == 0.0 {
        "0".into()
    } else if c.abs() < 5e-4 {
        format!("{c:+.1e}")
    } else {
        format!("{c:+.3}")
    }
}

fn model_name(model: &[&str]) -> String {
    if model.is_empty() {
        "(no effect)".to_string()
    } else {
        model.join(" + ")
    }
}

fn opt(x: Option<f64>) -> String {
    x.map_or("—".into(), |v| format!("{v:.4}"))
}

/// `value ± σ`, the σ "unconstrained" where the data cannot tell it.
fn plus_minus(p: &Param) -> String {
    if p.sigma.is_finite() {
        format!("{:.5} ± {:.5}", p.value, p.sigma)
    } else {
        format!("{:.5} (unconstrained)", p.value)
    }
}

/// What is missing, its parameters, the error before and after, the DN residual before
/// and after.
fn answer(d: &Diagnosis, pair: &[Written; 2]) -> Answer {
    let (first, last) = (&d.steps[0], d.steps.last().expect("a starting step"));
    let mut verdict = match (d.selected.is_empty(), d.unexplained()) {
        // The cap stopped the search with a candidate the data still show: said, never
        // "nothing is missing" (`Remains::left_by_cap`).
        (none, false) if d.remains.left_by_cap.is_some() => {
            let cap = d.remains.left_by_cap.as_ref().expect("checked").to_string();
            if none {
                let mut cap = cap;
                cap[..1].make_ascii_uppercase();
                cap
            } else {
                format!("Missing: {}; {cap}", sized(d, &d.selected))
            }
        }
        (false, false) => format!("Missing: {}. With it the residual is at the noise.", sized(d, &d.selected)),
        // At the noise, but only with values no real instrument or sky has.
        (false, true) if d.remains.unexplained.is_none() => format!(
            "{} bring{} the residual to the noise only with values no real instrument or sky has (below): possibly \
             compensating for something outside the catalog, not a finding.",
            sized(d, &d.selected),
            if d.selected.len() == 1 { "s" } else { "" }
        ),
        (false, true) => format!(
            "{} explain{} part of the misfit, possibly compensating for what is missing; the rest no catalog \
             effect explains.",
            sized(d, &d.selected),
            if d.selected.len() == 1 { "s" } else { "" }
        ),
        (true, false) if d.confusable.is_empty() && d.night.as_ref().is_some_and(|n| n.beyond_reach) => {
            "Nothing named: the model explains the data to the noise of this signal.".into()
        }
        (true, false) if d.confusable.is_empty() => {
            "Nothing that matters is missing: the model explains the data to the noise.".into()
        }
        (true, false) => "The residual is at the noise with the pair below in the model.".into(),
        (true, true) => "No catalog effect explains the misfit (see what remains).".into(),
    };
    for p in &d.confusable {
        verdict.push_str(&format!(
            " {} or {}: the capture cannot tell which (neither is named); what separates them: {}.",
            sized(d, &[p.first]),
            p.second,
            p.separates
        ));
    }
    if !d.negligible.is_empty() {
        verdict.push_str(&format!(" Detected but negligible (not named): {}.", sized(d, &d.negligible)));
    }
    if let Some(n) = &d.night {
        verdict.push_str(&format!(" The sky's source: {}. {n}", n.source));
    }
    for e in &d.selected {
        for x in d.outside_physical(e) {
            verdict.push_str(&format!(" Unphysical: {x}."));
        }
    }
    let params = last
        .fit
        .params
        .iter()
        .filter(|p| d.selected.contains(&p.id.effect) || d.confusable.iter().any(|c| c.first == p.id.effect))
        .map(|p| ParamRow { name: p.name.clone(), value: plus_minus(p), unit: p.unit })
        .collect();
    let (b, a) = (&first.fit, &last.fit);
    let rows = vec![
        BeforeAfter {
            what: "χ²/dof",
            before: format!("{:.4}", b.chi2_per_dof),
            after: format!("{:.4}", a.chi2_per_dof),
        },
        BeforeAfter { what: "heading RMS (°)", before: opt(b.heading_rms_deg), after: opt(a.heading_rms_deg) },
        BeforeAfter {
            what: "AoP RMS (°)",
            before: format!("{:.4}", b.aop_rms_deg),
            after: format!("{:.4}", a.aop_rms_deg),
        },
        BeforeAfter { what: "DoLP RMS", before: format!("{:.5}", b.dolp_rms), after: format!("{:.5}", a.dolp_rms) },
    ];
    // The χ² excess of the first and the last step, on one scale.
    let last_k = d.steps.len() - 1;
    let shown: &[(usize, &Written, &str)] = if last_k == 0 {
        &[(0, &pair[0], "the model")]
    } else {
        &[(0, &pair[0], "before"), (last_k, &pair[1], "after")]
    };
    let figures = shown
        .iter()
        .map(|&(k, w, when)| {
            let name = model_name(&d.steps[k].model);
            Figure {
                src: w.png.clone(),
                alt: format!("{} {when}: {name}", w.what),
                caption: format!("{when}: {name} — {} (± {:.3})", w.what, w.scale),
            }
        })
        .collect();
    let figure_note = if last_k == 0 {
        "Nothing was added. The map: χ² per sample − 1 over the sensor, mean over frames (white where the model fits \
         to the noise, red where the data stray from it more than noise does, blue less)."
    } else {
        "χ² per sample − 1 over the sensor, mean over frames, before and after on one colour scale: white where the \
         model fits to the noise, red where the data stray from it more than noise does, blue less."
    };
    Answer {
        verdict,
        class: if d.unexplained() { "no" } else { "yes" },
        params,
        before_label: format!("before: {}", model_name(&first.model)),
        after_label: format!("after: {}", model_name(&last.model)),
        rows,
        figures,
        figure_note: figure_note.into(),
    }
}

fn figure(k: usize, w: &Written, alt: String, caption: String) -> Figure {
    Figure { src: format!("step{k}/{}", w.png), alt, caption }
}

fn step(k: usize, s: &bpins_core::Step, f: &Figures) -> StepView {
    let maps = f
        .maps
        .iter()
        .map(|w| figure(k, w, format!("{} of step {k}", w.what), format!("{} (± {:.3} {})", w.what, w.scale, w.unit)))
        .collect();
    let frames = (0..3)
        .map(|q| FramesRow {
            what: f.frames.first().map_or("", |r| r[q].what),
            cells: f
                .frames
                .iter()
                .enumerate()
                .map(|(n, row)| {
                    let w = &row[q];
                    let alt = format!("frame {n} {} of step {k}", w.what);
                    figure(k, w, alt, format!("f{n} ± {:.3} {}", w.scale, w.unit))
                })
                .collect(),
        })
        .filter(|r| !r.cells.is_empty())
        .collect();
    StepView {
        k,
        name: model_name(&s.model),
        chi2_per_dof: format!("{:.4}", s.fit.chi2_per_dof),
        aop_rms_deg: format!("{:.4}", s.fit.aop_rms_deg),
        dolp_rms: format!("{:.5}", s.fit.dolp_rms),
        heading_rms_deg: opt(s.fit.heading_rms_deg),
        profiles_src: format!("step{k}/{}", f.profiles_svg),
        maps,
        frames,
    }
}

fn ranking(d: &Diagnosis, step: usize, r: &[Candidate]) -> RankingView {
    let threshold = d.bic_threshold;
    let rows = r
        .iter()
        .map(|c| (c, size_cells(c), candidate_verdict(d, step, c)))
        .map(|(c, [heading, aop, dolp, dn], (verdict, verdict_class))| CandidateRow {
            effect: c.effect,
            delta_chi2: format!("{:.1}", c.delta_chi2),
            delta_bic: format!("{:.1}", c.delta_bic),
            heading,
            aop,
            dolp,
            dn,
            verdict,
            verdict_class,
            class: if c.delta_bic > threshold { "yes" } else { "no" },
            how: if !c.identifiable {
                "cannot be told from the nuisances"
            } else {
                match c.evidence {
                    Evidence::EveryPixelScore => "refitted on every third row and column; scored on every pixel, below the threshold even at twice that Δχ² (not converged)",
                    Evidence::EveryPixelRefit => "refitted on every pixel",
                    Evidence::SubsampleRefit => "refitted on every third row and column (clearly behind the leader)",
                    Evidence::Score => "score test on every third row and column",
                }
            },
            params: c
                .params
                .iter()
                .map(|p| format!("{} = {} {}", p.name, plus_minus(p), p.unit))
                .collect::<Vec<_>>()
                .join("; "),
        })
        .collect();
    RankingView { step, rows }
}

fn frame_rows(fit: &bpins_core::FitResult) -> Vec<FrameRow> {
    fit.frames
        .iter()
        .enumerate()
        .map(|(k, f)| FrameRow {
            k,
            heading_deg: format!("{:.4}", f.heading_deg),
            sigma_deg: format!("{:.4}", f.heading_sigma_deg),
            sigma_stat_deg: format!("{:.5}", f.heading_sigma_stat_deg),
            reference_deg: opt(f.reference_deg),
            error_deg: opt(f.heading_error_deg),
            dmax: format!("{:.4}", f.dmax),
            radiance: f.radiance.iter().map(|&c| coefficient(c)).collect::<Vec<_>>().join(" "),
            chi2_per_dof: format!("{:.4}", f.chi2_per_dof),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_escaped_quotes_included() {
        #[derive(Serialize)]
        struct P {
            capture: &'static str,
        }
        let html = bpins_core::tool::output::render_html(
            "t.html",
            "<p title=\"{{ capture }}\">{{ capture }}</p>",
            &P { capture: "a\"<b>&'c/d" },
        )
        .unwrap();
        assert_eq!(html, "<p title=\"a&quot;&lt;b&gt;&amp;&#39;c/d\">a&quot;&lt;b&gt;&amp;&#39;c/d</p>\n");
    }

    #[test]
    fn backticked_names_become_code_and_the_rest_stays_escaped() {
        #[derive(Serialize)]
        struct P {
            why: &'static str,
        }
        let html = bpins_core::tool::output::render_html(
            "t.html",
            "{{ why | code }}",
            &P { why: "a lab flat field (then `--calibration FILE` holds it) <b> `odd" },
        )
        .unwrap();
        assert_eq!(html, "a lab flat field (then <code>--calibration FILE</code> holds it) &lt;b&gt; `odd\n");
    }

    #[test]
    fn radiance_coefficients_never_read_plus_or_minus_zero() {
        assert_eq!(coefficient(0.0), "0");
        assert_eq!(coefficient(-0.0), "0");
        assert_eq!(coefficient(2.3e-5), "+2.3e-5");
        assert_eq!(coefficient(-0.25), "-0.250");
        for c in [1e-4, -1e-4, 4e-4, -4.9e-4] {
            let t = coefficient(c);
            assert!(!t.contains("0.000"), "{c}: {t}");
        }
    }
}
