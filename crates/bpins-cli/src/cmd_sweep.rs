//! `bpins sweep` and `bpins merge`: user-defined Monte Carlo sweeps (a
//! `bpins-sweep/1` file, `bpins_core::sweep`), one slice at a time, and the union
//! of slices.

use crate::progress::bar;
use crate::Backend;
use anyhow::Context;
use bpins_core::tool::sweep::{describe, merge, nominal_rows, unit_count, NOMINAL};
use bpins_core::{run_to_dir, Outcome, Row, Shard, Summary, SweepSpec};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The sweep file (bpins-sweep/1; examples/sweeps/ holds some).
    spec: PathBuf,
    /// Output folder: summary.json, summary.csv, budget.csv, report.html, trials.csv,
    /// shard.toml. A folder that already holds this slice complete is left as it is.
    #[arg(long)]
    out: PathBuf,
    /// Trials per source and sun elevation (overrides the file's `trials`).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=10_000_000))]
    trials: Option<u64>,
    /// Run slice I of N (0-based), e.g. `--shard 3/8`; `bpins merge` joins the slices.
    #[arg(long, value_name = "I/N", value_parser = parse_shard)]
    shard: Option<Shard>,
    /// Compute backend.
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    backend: Backend,
}

fn parse_shard(s: &str) -> Result<Shard, String> {
    Shard::parse(s).ok_or_else(|| format!("`{s}`: expected I/N with 0 ≤ I < N, e.g. 0/4"))
}

/// `bpins merge`.
#[derive(clap::Args)]
pub struct MergeArgs {
    /// Output folder for the merged sweep (the same files as an unsharded run).
    #[arg(long)]
    out: PathBuf,
    /// The slices' output folders (every slice of one sweep, once each).
    #[arg(required = true)]
    shards: Vec<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let mut spec = SweepSpec::load(&a.spec)?;
    if let Some(n) = a.trials {
        spec.trials = n as usize;
    }
    crate::ensure_not_in_capture(&a.out)?;
    let shard = a.shard.unwrap_or(Shard::WHOLE);
    let units = shard.range(unit_count(&spec)).len();
    let (w, h) = spec.size_px();
    say!(
        "bpins sweep {}: slice {shard} = {units} of {} trials ({} per source and sun elevation; {} sources × {} sun elevations) on the {} backend, {w}×{h} px, seed {}",
        a.spec.display(),
        unit_count(&spec),
        spec.trials,
        spec.sources.len(),
        spec.sun_elevations_deg.len(),
        a.backend.name(),
        spec.seed
    );
    let mut gpu = None;
    let engine = crate::backend::sums_engine(a.backend, &mut gpu)?;
    let pb = bar(units as u64, "trials");
    let t0 = std::time::Instant::now();
    let outcome = run_to_dir(&spec, shard, engine, &a.out, &|done, _| pb.set_position(done as u64))
        .with_context(|| format!("sweep {} into {}", a.spec.display(), a.out.display()))?;
    pb.finish_and_clear();
    match outcome {
        Outcome::AlreadyComplete => {
            say!("{}: slice {shard} is already complete (shard.toml); nothing recomputed", a.out.display())
        }
        Outcome::Computed(s) => {
            let secs = t0.elapsed().as_secs_f64();
            // The nominal chain's own error, for a whole sweep (a slice's table is partial).
            let nominal = if shard == Shard::WHOLE {
                let n = spec.sun_elevations_deg.len() * spec.trials;
                let pb = bar(n as u64, "nominal");
                let rows = nominal_rows(&spec, engine, &|done, _| pb.set_position(done as u64))
                    .context("the nominal chain's trials")?;
                pb.finish_and_clear();
                rows
            } else {
                Vec::new()
            };
            print_rows(&s, &nominal)?;
            say!(
                "{units} trials in {secs:.1} s ({:.1} trials/s); wrote {}",
                units as f64 / secs.max(1e-9),
                a.out.join("summary.json").display()
            );
        }
    }
    Ok(())
}

pub fn run_merge(a: MergeArgs) -> anyhow::Result<()> {
    crate::ensure_not_in_capture(&a.out)?;
    let s = merge(&a.shards, &a.out).with_context(|| format!("merging into {}", a.out.display()))?;
    print_rows(&s, &[])?;
    say!("merged {} slices; wrote {}", a.shards.len(), a.out.join("summary.json").display());
    Ok(())
}

/// The paired difference of a row's errors from the nominal chain's on the same trials
/// (same sun, same field conditions): its mean and that mean's 1σ, degrees.
fn against_nominal(r: &Row, nominal: &[Row]) -> Option<(f64, f64)> {
    let n = nominal
        .iter()
        .find(|n| n.extractor == r.extractor && n.sun_elevation_deg == r.sun_elevation_deg && n.band == r.band)?;
    if n.errors_deg.len() != r.errors_deg.len() {
        return None;
    }
    let d: Vec<f64> = r.errors_deg.iter().zip(&n.errors_deg).map(|(a, b)| a - b).collect();
    let ([mean, std, ..], count, _) = describe(&d);
    (count > 1).then(|| (mean, std / (count as f64).sqrt()))
}

/// The extractor cell: a colour sensor's with its band (`sun_vector R`, `sun_vector
/// fused`), a monochrome one's as it was.
fn extractor_cell(extractor: &str, band: &Option<String>) -> String {
    match band {
        Some(b) => format!("{extractor} {b}"),
        None => extractor.to_string(),
    }
}

/// The table, the nominal chain's own error (where it was computed: not on `merge`) and
/// the budget.
fn print_rows(s: &Summary, nominal: &[Row]) -> anyhow::Result<()> {
    out!("Heading error, degrees ({} trials per source and sun elevation)", s.trials_per_source);
    let colour = s.rows.iter().any(|r| r.band.is_some());
    // The extractor column's width: a colour sensor's cells carry the band.
    let xw = if colour { 20 } else { 14 };
    if colour {
        out!(
            "colour sensor: a row per band (R, G, B: each from its own superpixels) and `fused` (their \
             inverse-variance mean on each extractor's 1σ)"
        );
    }
    out!(
        "{:<20} {:<xw$} {:>8} {:<8} {:>10} {:>9} {:>9} {:>9} {:>9} {:>7}  {}",
        "source",
        if colour { "extractor band" } else { "extractor" },
        "sun (°)",
        "known",
        "mean (°)",
        "±1σ (°)",
        "σ (°)",
        "RMS (°)",
        "p95 (°)",
        "trials",
        if nominal.is_empty() { "" } else { "mean less nominal (°)" }
    );
    for r in nominal.iter().chain(&s.rows) {
        let own = if r.source == NOMINAL {
            "(the chain's own error)".to_string()
        } else {
            // A paired difference beyond twice its 1σ: the source moves the mean.
            against_nominal(r, nominal).map_or(String::new(), |(m, se)| {
                format!("{m:+.4} ± {se:.4}{}", if m.abs() > 2.0 * se { "  bias" } else { "" })
            })
        };
        out!(
            "{:<20} {:<xw$} {:>8} {:<8} {:>+10.4} {:>9.4} {:>9.4} {:>9.4} {:>9.4} {:>7}  {}",
            r.source,
            extractor_cell(&r.extractor, &r.band),
            r.sun_elevation_deg,
            r.known.map(|k| if k { "known" } else { "unknown" }).unwrap_or("—"),
            r.mean_deg,
            r.mean_sigma_deg,
            r.std_deg,
            r.rms_deg,
            r.p95_deg,
            r.trials,
            own
        );
    }
    out!("±1σ: the mean's own 1σ (σ/√trials); a mean within twice it is the trials' scatter, not a bias.");
    if !nominal.is_empty() {
        out!(
            "nominal: the same suns and sky with no error source drawn; every row's mean carries its error (a sweep \
             reads 2×2 superpixels, as the seed paper does: their four rays let the intensity's gradient toward the \
             sun leak into S1 and S2, more the nearer the sun and the coarser the pixel). `mean less nominal` is a \
             source's own bias, trial by trial; `bias` marks one beyond twice its 1σ."
        );
    }
    for b in &s.budget {
        let shares: Vec<String> =
            b.shares.iter().map(|x| format!("{} {:.0} %", x.source, 100.0 * x.share_of_sum)).collect();
        out!(
            "budget {} at sun {}°{}: {} of Σσ²; σ combined {:.4}°, √Σσ² {:.4}° ({}); each σ ± {:.0} % from {} trials",
            extractor_cell(&b.extractor, &b.band),
            b.sun_elevation_deg,
            b.known.map(|k| if k { " (known)" } else { " (unknown)" }).unwrap_or(""),
            shares.join(", "),
            b.combined_std_deg,
            b.root_sum_square_deg,
            if b.adds_in_quadrature { "adds in quadrature" } else { "does not add in quadrature" },
            100.0 * b.sigma_relative_uncertainty,
            s.trials_per_source
        );
    }
    Ok(())
}
