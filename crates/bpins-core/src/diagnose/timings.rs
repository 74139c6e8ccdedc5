//! Where a diagnosis spent its time: wall seconds per stage, measured as it runs
//! ([`Timings`], `diagnosis.json`'s `timings`, `bpins diagnose --timings`). The
//! library fills the search's stages; a caller adds its own (reading the capture, the
//! final model on more pixels, the maps and the report) in the same type, so that one
//! table says where a run went. Units: seconds of wall time (with the machine's other
//! load in them: a figure to compare stages of one run, not machines).

use std::time::Instant;

/// Wall seconds per stage of one diagnosis (0 where a stage did not run).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Timings {
    /// Reading the capture (the caller's).
    pub load_s: f64,
    /// Finding the sky in each frame, once for every fit.
    pub sky_masks_s: f64,
    /// The starting model's fit on every sample.
    pub baseline_fit_s: f64,
    /// Every step's score tests of the candidates (the scoring subsample).
    pub scoring_s: f64,
    /// Every step's base model and strongest candidates refitted on the subsample.
    pub subsample_refits_s: f64,
    /// The refits' score tests on every pixel (where the subsample cannot decide).
    pub every_pixel_scores_s: f64,
    /// The leader and any candidate close to it converged on every pixel.
    pub every_pixel_refits_s: f64,
    /// The runner-up converged on every pixel where the leader explains less than half
    /// alone, and the best two refitted together (the pairs).
    pub pair_refits_s: f64,
    /// The candidates' sizes in the user's units (`sizes`) and their physical ranges.
    pub sizes_s: f64,
    /// Describing a residual that remains (its maps and profiles).
    pub residual_s: f64,
    /// The final model fitted again on more pixels (the caller's,
    /// `raise_diagnosis_where_needed`).
    pub final_fit_s: f64,
    /// The residual maps of every step, the JSON and the report (the caller's).
    pub report_s: f64,
    /// The whole run, from the first stage timed to the last.
    pub total_s: f64,
}

impl Timings {
    /// Each stage by name (its field's, without `_s`) and seconds, in the order a run
    /// goes through them; `total_s` not among them.
    pub fn stages(&self) -> [(&'static str, f64); 12] {
        [
            ("load", self.load_s),
            ("sky_masks", self.sky_masks_s),
            ("baseline_fit", self.baseline_fit_s),
            ("scoring", self.scoring_s),
            ("subsample_refits", self.subsample_refits_s),
            ("every_pixel_scores", self.every_pixel_scores_s),
            ("every_pixel_refits", self.every_pixel_refits_s),
            ("pair_refits", self.pair_refits_s),
            ("sizes", self.sizes_s),
            ("residual", self.residual_s),
            ("final_fit", self.final_fit_s),
            ("report", self.report_s),
        ]
    }

    /// The sum of the stages (what `total_s` is less the time between them).
    pub fn sum_of_stages(&self) -> f64 {
        self.stages().iter().map(|(_, s)| s).sum()
    }
}

/// Runs `f`, adding its wall seconds to `*stage`.
pub(crate) fn timed<T>(stage: &mut f64, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let out = f();
    *stage += t0.elapsed().as_secs_f64();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_timed_stage_adds_its_seconds_and_the_stages_sum() {
        let mut t = Timings::default();
        let x = timed(&mut t.sizes_s, || {
            std::thread::sleep(std::time::Duration::from_millis(20));
            7
        });
        assert_eq!(x, 7);
        assert!(t.sizes_s >= 0.02 && t.sizes_s < 5.0, "{}", t.sizes_s);
        t.load_s = 1.0;
        assert!((t.sum_of_stages() - (1.0 + t.sizes_s)).abs() < 1e-12);
        assert_eq!(t.stages().iter().filter(|(_, s)| *s > 0.0).count(), 2);
        let json = serde_json::to_value(t).unwrap();
        assert_eq!(json["load_s"], 1.0);
        assert!(json.as_object().unwrap().keys().all(|k| k.ends_with("_s")));
    }
}
