//! An effect's size and what the diagnosis made of it, in words, for the printed
//! table (`cmd_diagnose`) and the report (`report`): one wording for both.

use bpins_core::{Candidate, Diagnosis};

/// Each effect with its size where the diagnosis added it: "name (heading up to …°,
/// AoP … ° RMS, DoLP … RMS, … DN at the worst pixel)".
pub fn sized(d: &Diagnosis, effects: &[&'static str]) -> String {
    let words: Vec<String> = effects
        .iter()
        .map(|e| {
            // The candidate of the step that added it.
            let c = d.steps.windows(2).zip(&d.rankings).find_map(|(w, r)| {
                (w[1].model.contains(e) && !w[0].model.contains(e)).then(|| r.iter().find(|c| c.effect == *e)).flatten()
            });
            match c.and_then(|c| c.size) {
                Some(s) => format!(
                    "{e} (heading up to {}, AoP {:.4}° RMS, DoLP {:.5} RMS, {:.1} DN at the worst pixel)",
                    s.heading_change_max_deg.map_or("—".into(), |h| format!("{h:.4}°")),
                    s.aop_change_rms_deg,
                    s.dolp_change_rms,
                    s.max_change_dn
                ),
                None => e.to_string(),
            }
        })
        .collect();
    words.join(", then ")
}

/// A candidate's size in the user's units, as (heading RMS / worst frame °, AoP RMS °,
/// DoLP RMS, DN at the worst pixel); dashes where it has none.
pub fn size_cells(c: &Candidate) -> [String; 4] {
    let Some(s) = &c.size else {
        let none = if c.identifiable { "— (within the noise)" } else { "—" };
        return [none.into(), "—".into(), "—".into(), "—".into()];
    };
    let heading = match (s.heading_change_rms_deg, s.heading_change_max_deg) {
        (Some(r), Some(m)) => format!("{r:.4} / {m:.4}"),
        _ => "— (not refitted)".into(),
    };
    [
        heading,
        format!("{:.4}", s.aop_change_rms_deg),
        format!("{:.5}", s.dolp_change_rms),
        format!("{:.1}", s.max_change_dn),
    ]
}

/// What the diagnosis made of candidate `c` of step `step` (1-based), in words, and
/// whether that is a finding ("yes"), a caution ("no") or neither ("").
pub fn candidate_verdict(d: &Diagnosis, step: usize, c: &Candidate) -> (String, &'static str) {
    // The effect a step added is the one its model gained.
    let added =
        d.steps.get(step).is_some_and(|s| s.model.contains(&c.effect)) && !d.steps[step - 1].model.contains(&c.effect);
    let mut words = Vec::new();
    let mut class = "";
    if added {
        if let Some(p) = d.confusable.iter().find(|p| p.first == c.effect || p.second == c.effect) {
            let other = if p.first == c.effect { p.second } else { p.first };
            words.push(format!("confusable with {other}: not named alone"));
            class = "no";
        } else if d.negligible.contains(&c.effect) {
            words.push("detected, negligible: not named".to_string());
        } else {
            words.push("named".to_string());
            class = "yes";
        }
        if d.possibly_compensating(c.effect) {
            words.push("possibly compensating (the capture stays unexplained or a value is unphysical)".into());
            class = "no";
        }
    } else if let Some(p) = d.confusable.iter().find(|p| p.second == c.effect) {
        words.push(format!("confusable with {}", p.first));
    }
    // The step the cap stopped: searched, nothing added (`Remains::left_by_cap`).
    if let Some(cap) = d.remains.left_by_cap.as_ref().filter(|_| step == d.rankings.len()) {
        if cap.candidates.iter().any(|l| l.effect == c.effect) {
            words.push(format!("passes, left out by the cap (--max-added {})", cap.max_added));
            class = "no";
        }
    }
    // A colour band's effect: the bands it changes (`Candidate::bands_named`).
    if let Some(b) = c.bands_named().filter(|_| c.evidence.refitted()) {
        words.push(format!("bands {b}"));
    }
    if let Some(s) = c.size.filter(|_| c.evidence.refitted()) {
        let what = s.what_matters();
        words.push(if what.is_empty() {
            "below every size threshold".into()
        } else {
            format!("matters: {}", what.join(", "))
        });
    }
    for x in &c.outside_physical {
        words.push(format!("unphysical: {x}"));
        class = "no";
    }
    (words.join("; "), class)
}
