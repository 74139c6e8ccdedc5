//! `bpins run`: the seed paper's Monte Carlo sweep, Table 3 side by side with the paper.

use crate::progress::bar;
use crate::{write_json, Backend};
use anyhow::Context;
use bpins_core::montecarlo::{summarise, Row, Source, SweepConfig};
use bpins_core::sensor::Channel;
use serde_json::json;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Compute backend.
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    backend: Backend,
    /// Trials per sun azimuth (8 azimuths, 10°…80°); the paper uses 20 (160 per source).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    trials_per_azimuth: u32,
    /// Seed of every random draw; the same seed gives bit-identical results.
    #[arg(long, default_value_t = 2023)]
    seed: u64,
    /// Analyzer channels of the colocated sensor: 3 (0°, 45°, 90°, as the paper) or 4.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u8).range(3..=4))]
    channels: u8,
    /// Write the rows (and the configuration) as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let cfg = SweepConfig {
        trials_per_azimuth: a.trials_per_azimuth as usize,
        seed: a.seed,
        channels: if a.channels == 4 { Channel::ALL.to_vec() } else { vec![Channel::C0, Channel::C45, Channel::C90] },
        ..SweepConfig::default()
    };
    let total = (cfg.trials_per_source() * Source::ALL.len()) as u64;
    eprintln!(
        "bpins run: {} trials on the {} backend ({} per source), {}×{} px colocated, {} channels, seed {}",
        total,
        a.backend.name(),
        cfg.trials_per_source(),
        cfg.width_px,
        cfg.height_px,
        cfg.channels.len(),
        cfg.seed
    );
    let engine = crate::backend::open(a.backend)?;
    let pb = bar(total, "trials");
    let t0 = std::time::Instant::now();
    let results =
        engine.run_sweep(&cfg, &Source::ALL, &|done, _| pb.set_position(done as u64)).context("Monte Carlo sweep")?;
    pb.finish_and_clear();
    let rows = summarise(&results);
    print_table(&rows);
    eprintln!("{} trials in {:.1} s", total, t0.elapsed().as_secs_f64());
    if let Some(path) = &a.json {
        let v = json!({
            "backend": a.backend.name(),
            "seed": cfg.seed,
            "trials_per_azimuth": cfg.trials_per_azimuth,
            "sun_azimuths_deg": cfg.sun_azimuths_deg,
            "sun_elevation_deg": cfg.sun_el_deg,
            "channels_deg": cfg.channels.iter().map(|c| c.angle_deg()).collect::<Vec<_>>(),
            "rows": rows,
        });
        write_json(path, &v)?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:+.4}")).unwrap_or_else(|| "—".into())
}

fn print_table(rows: &[Row]) {
    println!("Azimuth error over the trials, degrees (seed paper Table 3 beside; — where it gives none)");
    println!(
        "{:<19} {:<14} {:<8} {:>10} {:>9} {:>7} {:>12} {:>11}",
        "source", "extractor", "lens ρ", "mean (°)", "σ (°)", "trials", "paper μ (°)", "paper σ (°)"
    );
    for r in rows {
        let known = match r.lens_rho_known {
            Some(true) => "known",
            Some(false) => "unknown",
            None => "—",
        };
        println!(
            "{:<19} {:<14} {:<8} {:>+10.4} {:>9.4} {:>7} {:>12} {:>11}",
            r.source,
            r.extractor,
            known,
            r.mean_deg,
            r.std_deg,
            r.trials,
            opt(r.paper_mean_deg),
            opt(r.paper_std_deg).trim_start_matches('+')
        );
    }
}
