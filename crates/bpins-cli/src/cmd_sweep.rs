//! `bpins sweep` and `bpins merge`: user-defined Monte Carlo sweeps (a
//! `bpins-sweep/1` file, `bpins_core::sweep`), one slice at a time, and the union
//! of slices.

use crate::progress::bar;
use crate::Backend;
use anyhow::Context;
use bpins_core::internal::sweep::{merge, run_to_dir, unit_count, Outcome, Shard, Summary, SweepSpec};
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
            print_rows(&s)?;
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
    print_rows(&s)?;
    say!("merged {} slices; wrote {}", a.shards.len(), a.out.join("summary.json").display());
    Ok(())
}

fn print_rows(s: &Summary) -> anyhow::Result<()> {
    out!("Heading error, degrees ({} trials per source and sun elevation)", s.trials_per_source);
    out!(
        "{:<20} {:<14} {:>8} {:<8} {:>10} {:>9} {:>9} {:>9} {:>7}",
        "source",
        "extractor",
        "sun (°)",
        "known",
        "mean (°)",
        "σ (°)",
        "RMS (°)",
        "p95 (°)",
        "trials"
    );
    for r in &s.rows {
        out!(
            "{:<20} {:<14} {:>8} {:<8} {:>+10.4} {:>9.4} {:>9.4} {:>9.4} {:>7}",
            r.source,
            r.extractor,
            r.sun_elevation_deg,
            r.known.map(|k| if k { "known" } else { "unknown" }).unwrap_or("—"),
            r.mean_deg,
            r.std_deg,
            r.rms_deg,
            r.p95_deg,
            r.trials
        );
    }
    for b in &s.budget {
        let shares: Vec<String> =
            b.shares.iter().map(|x| format!("{} {:.0} %", x.source, 100.0 * x.share_of_combined)).collect();
        out!(
            "budget {} at sun {}°{}: {}; σ combined {:.4}°, √Σσ² {:.4}° ({})",
            b.extractor,
            b.sun_elevation_deg,
            b.known.map(|k| if k { " (known)" } else { " (unknown)" }).unwrap_or(""),
            shares.join(", "),
            b.combined_std_deg,
            b.root_sum_square_deg,
            if b.adds_in_quadrature { "adds in quadrature" } else { "does not add in quadrature" }
        );
    }
    Ok(())
}
