//! What a designer reads: per source, extractor, sun elevation (and, for sources with
//! `known = "both"` errors, with and without them known) the mean, σ, RMS and 95th
//! percentile of the heading error; and the error budget: each source's share of the
//! combined variance, and whether the sources add in quadrature.
//!
//! Every statistic is computed from the trials in trial order, so the same trials give
//! the same bits however they were sharded.

use serde::{Deserialize, Serialize};

use super::run::{record_columns, TrialRecord};
use super::spec::{SweepSpec, COMBINED};

/// The summary's format name.
pub const SUMMARY_FORMAT: &str = "bpins-sweep-summary/1";

/// One row: the heading error of one source under one extractor at one sun elevation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub source: String,
    pub extractor: String,
    pub sun_elevation_deg: f64,
    /// Whether the source's `known = "both"` errors were known to the reconstruction;
    /// absent where it has none.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub known: Option<bool>,
    /// A colour sensor's band (`R`, `G`, `B`) or `fused` (their inverse-variance
    /// mean); absent on a monochrome sensor.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub band: Option<String>,
    pub mean_deg: f64,
    /// The mean's own 1σ, σ/√n: a mean within about twice it is the trials' scatter,
    /// not a bias (absent in summaries written before it was added).
    #[serde(default)]
    pub mean_sigma_deg: f64,
    /// Sample standard deviation (n − 1).
    pub std_deg: f64,
    pub rms_deg: f64,
    /// 95th percentile of |error| (linear between order statistics).
    pub p95_deg: f64,
    pub max_abs_deg: f64,
    /// Trials with a heading.
    pub trials: usize,
    /// Trials the extractor gave no heading for.
    pub failed: usize,
    /// The trials' errors, in trial order (for the report's histograms); not written.
    #[serde(skip)]
    pub errors_deg: Vec<f64>,
}

/// One source's part of the budget.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Share {
    pub source: String,
    pub variance_deg2: f64,
    /// Its variance over the combined row's. Each σ is estimated from a finite number
    /// of trials, so this can exceed 1 (a single source's σ drawn high, the combined
    /// row's low) where the sources do add in quadrature: read it with
    /// [`Budget::sigma_relative_uncertainty`].
    pub share_of_combined: f64,
    /// Its variance over Σσ² of the single sources: the shares sum to 1 (absent in
    /// summaries written before it was added).
    #[serde(default)]
    pub share_of_sum: f64,
}

/// The error budget of one extractor at one sun elevation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Budget {
    pub extractor: String,
    pub sun_elevation_deg: f64,
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub known: Option<bool>,
    /// A colour sensor's band or `fused`, as [`Row::band`]; absent on a monochrome one.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub band: Option<String>,
    pub shares: Vec<Share>,
    pub combined_std_deg: f64,
    /// √(Σ σ²) over the single sources: the combined σ if they add in quadrature.
    pub root_sum_square_deg: f64,
    /// root_sum_square_deg / combined_std_deg.
    pub quadrature_ratio: f64,
    /// The relative 1σ of each σ in the budget, 1/√(2(n − 1)) for n trials (a normal
    /// sample's standard deviation): how far a share can stray from its true value
    /// (absent in summaries written before it was added).
    #[serde(default)]
    pub sigma_relative_uncertainty: f64,
    /// Whether the ratio is within two standard errors of 1: the ratio of two
    /// independent σ estimates from n trials each has a relative standard error of
    /// about 1/√(n − 1), so the test is |ratio − 1| ≤ 2/√(n − 1).
    pub adds_in_quadrature: bool,
}

/// `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub format: String,
    pub title: String,
    /// The sweep file's name.
    pub sweep: String,
    pub seed: u64,
    pub trials_per_source: usize,
    pub sun_elevations_deg: Vec<f64>,
    pub rows: Vec<Row>,
    pub budget: Vec<Budget>,
}

/// Mean, σ, RMS, p95 of |x|, max |x| of `x` (NaN ignored); `(stats, n, failed)`.
pub fn describe(x: &[f64]) -> ([f64; 5], usize, usize) {
    let ok: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    let n = ok.len();
    let failed = x.len() - n;
    if n == 0 {
        return ([f64::NAN; 5], 0, failed);
    }
    let mean = ok.iter().sum::<f64>() / n as f64;
    let var = if n > 1 { ok.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64 } else { 0.0 };
    let rms = (ok.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    let mut abs: Vec<f64> = ok.iter().map(|v| v.abs()).collect();
    abs.sort_by(f64::total_cmp);
    let p95 = percentile_sorted(&abs, 0.95);
    ([mean, var.sqrt(), rms, p95, abs[n - 1]], n, failed)
}

/// The `q` quantile of sorted `x`, linear between order statistics (the crate's one
/// definition, [`crate::stats::quantile_sorted`]).
pub fn percentile_sorted(x: &[f64], q: f64) -> f64 {
    crate::stats::quantile_sorted(x, q)
}

/// Summarises trial records (any order; they are sorted by unit) into rows and budget.
pub fn summarise(spec: &SweepSpec, records: &[TrialRecord]) -> Summary {
    let mut recs: Vec<&TrialRecord> = records.iter().collect();
    recs.sort_by_key(|r| r.unit);
    let mut rows = Vec::new();
    for (ei, &el) in spec.sun_elevations_deg.iter().enumerate() {
        for (si, source) in spec.sources.iter().enumerate() {
            let mine: Vec<&&TrialRecord> =
                recs.iter().filter(|r| r.unit.elevation == ei && r.unit.source == si).collect();
            if mine.is_empty() {
                continue;
            }
            for (ci, (e, known, band)) in record_columns(spec, si).into_iter().enumerate() {
                let errs: Vec<f64> = mine.iter().map(|r| r.errors_deg[ci]).collect();
                let ([mean, std, rms, p95, max], n, failed) = describe(&errs);
                rows.push(Row {
                    source: source.clone(),
                    extractor: e.name().to_string(),
                    sun_elevation_deg: el,
                    known,
                    band: band.map(|b| b.name().to_string()),
                    mean_deg: mean,
                    mean_sigma_deg: if n > 0 { std / (n as f64).sqrt() } else { f64::NAN },
                    std_deg: std,
                    rms_deg: rms,
                    p95_deg: p95,
                    max_abs_deg: max,
                    trials: n,
                    failed,
                    errors_deg: errs,
                });
            }
        }
    }
    let budget = budget(spec, &rows);
    Summary {
        format: SUMMARY_FORMAT.to_string(),
        title: spec.title.clone(),
        sweep: spec.path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(),
        seed: spec.seed,
        trials_per_source: spec.trials,
        sun_elevations_deg: spec.sun_elevations_deg.clone(),
        rows,
        budget,
    }
}

fn budget(spec: &SweepSpec, rows: &[Row]) -> Vec<Budget> {
    if !spec.combined {
        return Vec::new();
    }
    let mut out = Vec::new();
    for c in rows.iter().filter(|r| r.source == COMBINED) {
        // A single source without the combined row's variant is read as its plain row.
        let single = |s: &str| {
            rows.iter()
                .find(|r| {
                    r.source == s
                        && r.extractor == c.extractor
                        && r.sun_elevation_deg == c.sun_elevation_deg
                        && (r.known == c.known || r.known.is_none())
                        && r.band == c.band
                })
                .cloned()
        };
        let mut shares = Vec::new();
        let mut sum_var = 0.0;
        for s in spec.sources.iter().filter(|s| *s != COMBINED) {
            if let Some(r) = single(s) {
                let v = r.std_deg * r.std_deg;
                sum_var += v;
                shares.push(Share {
                    source: s.clone(),
                    variance_deg2: v,
                    share_of_combined: v / (c.std_deg * c.std_deg),
                    share_of_sum: 0.0,
                });
            }
        }
        for sh in &mut shares {
            sh.share_of_sum = if sum_var > 0.0 { sh.variance_deg2 / sum_var } else { f64::NAN };
        }
        let rss = sum_var.sqrt();
        let ratio = rss / c.std_deg;
        let tol = if c.trials > 1 { 2.0 / ((c.trials - 1) as f64).sqrt() } else { f64::INFINITY };
        out.push(Budget {
            extractor: c.extractor.clone(),
            sun_elevation_deg: c.sun_elevation_deg,
            known: c.known,
            band: c.band.clone(),
            shares,
            combined_std_deg: c.std_deg,
            root_sum_square_deg: rss,
            quadrature_ratio: ratio,
            sigma_relative_uncertainty: if c.trials > 1 {
                1.0 / (2.0 * (c.trials - 1) as f64).sqrt()
            } else {
                f64::INFINITY
            },
            adds_in_quadrature: (ratio - 1.0).abs() <= tol,
        });
    }
    out
}

/// A colour sensor's CSV column after `known`: `band,` in the header and each line;
/// nothing on a monochrome sensor (its files are what they were).
fn band_cell(colour: bool, band: &Option<String>) -> String {
    if colour {
        format!("{},", band.as_deref().unwrap_or_default())
    } else {
        String::new()
    }
}

impl Summary {
    /// Whether the rows are a colour sensor's (they carry a band).
    fn colour(&self) -> bool {
        self.rows.iter().any(|r| r.band.is_some())
    }

    /// The rows as CSV (one header line; `known` empty where it does not apply; a
    /// colour sensor's with a `band` column after it: R, G, B or fused).
    pub fn rows_csv(&self) -> String {
        let colour = self.colour();
        let mut s = format!(
            "source,extractor,sun_elevation_deg,known,{}mean_deg,std_deg,rms_deg,p95_deg,max_abs_deg,trials,failed,mean_sigma_deg\n",
            if colour { "band," } else { "" }
        );
        for r in &self.rows {
            s += &format!(
                "{},{},{},{},{}{},{},{},{},{},{},{},{}\n",
                r.source,
                r.extractor,
                r.sun_elevation_deg,
                r.known.map(|k| k.to_string()).unwrap_or_default(),
                band_cell(colour, &r.band),
                r.mean_deg,
                r.std_deg,
                r.rms_deg,
                r.p95_deg,
                r.max_abs_deg,
                r.trials,
                r.failed,
                r.mean_sigma_deg
            );
        }
        s
    }

    /// The budget as CSV, one line per (extractor, elevation, known, source); a colour
    /// sensor's per band too (a `band` column after `known`).
    pub fn budget_csv(&self) -> String {
        let colour = self.colour();
        let mut s = format!(
            "extractor,sun_elevation_deg,known,{}source,variance_deg2,share_of_combined,combined_std_deg,root_sum_square_deg,adds_in_quadrature,share_of_sum\n",
            if colour { "band," } else { "" }
        );
        for b in &self.budget {
            for sh in &b.shares {
                s += &format!(
                    "{},{},{},{}{},{},{},{},{},{},{}\n",
                    b.extractor,
                    b.sun_elevation_deg,
                    b.known.map(|k| k.to_string()).unwrap_or_default(),
                    band_cell(colour, &b.band),
                    sh.source,
                    sh.variance_deg2,
                    sh.share_of_combined,
                    b.combined_std_deg,
                    b.root_sum_square_deg,
                    b.adds_in_quadrature,
                    sh.share_of_sum
                );
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_of_a_known_sample() {
        let x: Vec<f64> = (1..=20).map(|k| k as f64).collect();
        let ([mean, std, rms, p95, max], n, failed) = describe(&x);
        assert_eq!((mean, n, failed, max), (10.5, 20, 0, 20.0));
        assert!((std - 5.916079783099616).abs() < 1e-12);
        assert!((rms - (2870.0f64 / 20.0).sqrt()).abs() < 1e-12);
        // 0.95 · 19 = 18.05: between the 19th and 20th values.
        assert!((p95 - 19.05).abs() < 1e-12);
        let (_, n, failed) = describe(&[1.0, f64::NAN, -1.0]);
        assert_eq!((n, failed), (2, 1));
    }

    #[test]
    fn independent_sources_add_in_quadrature_in_the_budget() {
        let spec = super::super::run::tests::tiny();
        let recs = super::super::run::run_units(
            &spec,
            0..super::super::run::unit_count(&spec),
            &super::super::run::CpuSums,
            &|_, _| {},
        )
        .unwrap();
        let s = summarise(&spec, &recs);
        assert_eq!(s.rows.len(), 2 * 3 * 2);
        assert!(s.rows.iter().all(|r| r.trials == 4 && r.failed == 0));
        assert_eq!(s.budget.len(), 2 * 2);
        for b in &s.budget {
            let total: f64 = b.shares.iter().map(|x| x.share_of_combined).sum();
            assert!(total > 0.0 && b.quadrature_ratio.is_finite(), "{b:?}");
            // The shares of Σσ² sum to one, whatever the trials drew.
            let sum: f64 = b.shares.iter().map(|x| x.share_of_sum).sum();
            assert!((sum - 1.0).abs() < 1e-12, "{b:?}");
            assert!((b.sigma_relative_uncertainty - 1.0 / 6f64.sqrt()).abs() < 1e-12, "4 trials: {b:?}");
        }
        for r in &s.rows {
            assert!((r.mean_sigma_deg - r.std_deg / 2.0).abs() < 1e-15, "σ/√4: {r:?}");
        }
        let csv = s.rows_csv();
        assert_eq!(csv.lines().count(), 1 + s.rows.len());
    }
}
