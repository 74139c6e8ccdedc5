//! `bpins run`: the seed paper's Monte Carlo sweep, Table 3 side by side with the paper.
//! A shortcut to `bpins sweep examples/sweeps/paper-table3.toml` (the file is built
//! in): the same trials, bit for bit, printed as Table 3 with the paper's figures.

use crate::progress::bar;
use crate::{write_json, Backend};
use anyhow::Context;
use bpins_core::compass::Extractor;
use bpins_core::sensor::{Channel, Layout};
use bpins_core::tool::montecarlo::{paper_figures_deg, Row, Source};
use bpins_core::tool::sweep::{run_units, summarise, unit_count};
use bpins_core::SweepSpec;
use serde_json::json;
use std::path::{Path, PathBuf};

/// The paper's sweep file, as shipped.
const PAPER_SWEEP: &str = include_str!("../../../examples/sweeps/paper-table3.toml");

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

/// The built-in paper sweep with `trials_per_azimuth` trials per sun azimuth.
pub(crate) fn paper_spec(trials_per_azimuth: u32, seed: u64) -> anyhow::Result<SweepSpec> {
    let mut spec = SweepSpec::parse(Path::new("examples/sweeps/paper-table3.toml"), PAPER_SWEEP)
        .context("the built-in paper sweep")?;
    spec.trials_per_azimuth = trials_per_azimuth as usize;
    spec.trials = spec.trials_per_azimuth * spec.sun_azimuths_deg.len();
    spec.seed = seed;
    Ok(spec)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let mut spec = paper_spec(a.trials_per_azimuth, a.seed)?;
    if a.channels == 4 {
        spec.sensor.layout = Layout::Colocated { channels: Channel::ALL.to_vec() };
    }
    let channels = spec.channels();
    let total = unit_count(&spec) as u64;
    let (w, h) = spec.size_px();
    say!(
        "bpins run: {} trials on the {} backend ({} per source), {}×{} px colocated, {} channels, seed {}",
        total,
        a.backend.name(),
        spec.trials,
        w,
        h,
        channels.len(),
        spec.seed
    );
    let mut gpu = None;
    let engine = crate::backend::sums_engine(a.backend, &mut gpu)?;
    let pb = bar(total, "trials");
    let t0 = std::time::Instant::now();
    let records = run_units(&spec, 0..unit_count(&spec), engine, &|done, _| pb.set_position(done as u64))
        .context("Monte Carlo sweep")?;
    pb.finish_and_clear();
    let rows = table3(&spec, &records);
    print_table(&rows)?;
    say!("{} trials in {:.1} s", total, t0.elapsed().as_secs_f64());
    if let Some(path) = &a.json {
        let v = json!({
            "backend": a.backend.name(),
            "seed": spec.seed,
            "trials_per_azimuth": spec.trials_per_azimuth,
            "sun_azimuths_deg": spec.sun_azimuths_deg,
            "sun_elevation_deg": spec.sun_elevations_deg[0],
            "channels_deg": channels.iter().map(|c| c.angle_deg()).collect::<Vec<_>>(),
            "rows": rows,
        });
        write_json(path, &v)?;
        say!("wrote {}", path.display());
    }
    Ok(())
}

/// The sweep's rows as Table 3: the paper's figures beside, ρ known before unknown.
fn table3(spec: &SweepSpec, records: &[bpins_core::tool::sweep::TrialRecord]) -> Vec<Row> {
    let summary = summarise(spec, records);
    let mut rows: Vec<(usize, Row)> = Vec::new();
    for r in summary.rows {
        let Some(si) = Source::ALL.iter().position(|s| s.name() == r.source) else { continue };
        let source = Source::ALL[si];
        let Some(e) = Extractor::from_name(&r.extractor) else { continue };
        let (pm, ps) = paper_figures_deg(source, r.known);
        let order = (si * Extractor::ALL.len() + Extractor::ALL.iter().position(|x| *x == e).unwrap_or(0)) * 2
            + usize::from(r.known == Some(false));
        rows.push((
            order,
            Row {
                source: source.name(),
                extractor: e.name(),
                lens_rho_known: r.known,
                mean_deg: r.mean_deg,
                std_deg: r.std_deg,
                trials: r.trials,
                paper_mean_deg: pm,
                paper_std_deg: ps,
            },
        ));
    }
    rows.sort_by_key(|(k, _)| *k);
    rows.into_iter().map(|(_, r)| r).collect()
}

fn opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:+.4}")).unwrap_or_else(|| "—".into())
}

fn print_table(rows: &[Row]) -> anyhow::Result<()> {
    out!("Azimuth error over the trials, degrees (seed paper Table 3 beside; — where it gives none)");
    out!(
        "{:<19} {:<14} {:<8} {:>10} {:>9} {:>7} {:>12} {:>11}",
        "source",
        "extractor",
        "lens ρ",
        "mean (°)",
        "σ (°)",
        "trials",
        "paper μ (°)",
        "paper σ (°)"
    );
    for r in rows {
        let known = match r.lens_rho_known {
            Some(true) => "known",
            Some(false) => "unknown",
            None => "—",
        };
        out!(
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
    Ok(())
}
