//! `bpins agree`: seeded trials over every effect on both backends, stage by stage
//! against the documented tolerances (bpins_gpu::tolerance, TOLERANCES.md); exits
//! non-zero on any excess.

use crate::write_json;
use anyhow::Context;
use bpins_gpu::agree::{agree, cases};
use serde_json::json;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Trials per case (cases: ideal, every registered effect alone, all effects);
    /// the projection cycles pinhole, equidistant, equisolid, stereographic by trial.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    trials: u32,
    /// Seed of every draw (effect parameters, sun, heading, noise).
    #[arg(long, default_value_t = 2026)]
    seed: u64,
    /// Write the stages as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let gpu = crate::backend::open_gpu_quiet()?;
    let n_cases = cases().len();
    say!(
        "bpins agree: {} cases × {} trials, 612 × 512 px, CPU (rayon) vs GPU {}, {} kernels",
        n_cases,
        a.trials,
        gpu.adapter_name(),
        gpu.precision().name()
    );
    if let Some(note) = crate::backend::cpu_adapter_note(&gpu) {
        say!("{note}");
    }
    let pb = crate::progress::bar((n_cases as u64) * a.trials as u64, "trials");
    let stages =
        agree(&gpu, a.trials, a.seed, &|done, _| pb.set_position(done as u64)).context("comparing backends")?;
    pb.finish_and_clear();
    out!("{:<16} {:>14} {:>11}  {:<19} {:<4} worst case", "stage", "max |Δ|", "tolerance", "unit", "ok");
    for s in &stages {
        out!(
            "{:<16} {:>14.3e} {:>11.1e}  {:<19} {:<4} {}",
            s.stage,
            s.max_abs_diff,
            s.tolerance,
            s.unit,
            if s.ok { "yes" } else { "NO" },
            s.worst
        );
    }
    let ok = stages.iter().all(|s| s.ok);
    if let Some(path) = &a.json {
        crate::ensure_not_in_capture(path)?;
        let v = json!({
            "adapter": gpu.adapter_name(),
            "precision": gpu.precision().name(),
            "trials": a.trials,
            "seed": a.seed,
            "cases": cases().iter().map(|c| c.name.clone()).collect::<Vec<_>>(),
            "stages": stages.iter().map(|s| json!({
                "stage": s.stage,
                // JSON has no infinity: a stage that failed outright reports null.
                "max_abs_diff": if s.max_abs_diff.is_finite() { json!(s.max_abs_diff) } else { json!(null) },
                "tolerance": s.tolerance,
                "unit": s.unit,
                "ok": s.ok,
                "worst": s.worst,
            })).collect::<Vec<_>>(),
            "ok": ok,
        });
        write_json(path, &v)?;
        say!("wrote {}", path.display());
    }
    if !ok {
        anyhow::bail!("the backends disagree beyond tolerance (stages marked NO above)");
    }
    say!("both backends agree within every tolerance");
    Ok(())
}
