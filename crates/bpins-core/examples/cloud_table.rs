//! The README's cloud table: every cloudy field condition
//! (`bpins_core::internal::field_conditions::cloudy`) under several scene seeds (where the
//! clouds lie matters more than how many frames turn under them), each extractor of
//! the field estimator: RMS error, the share of frames within 2σ, the largest
//! |error|/σ, the frames refused, and the median cloud fraction the frames report.
//!
//! ```sh
//! cargo run --release -p bpins-core --example cloud_table -- [FRAMES] [SEEDS] [SCALE]
//! ```
//! (defaults 8 frames per seed, seeds 2026…2030, full resolution: 40 frames per
//! condition, about a minute on two cores).

use bpins_core::internal::field_conditions::{cloudy, score_field_all};
use bpins_core::internal::heading::field::FieldOptions;
use bpins_core::internal::heading::Extractor;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(8);
    let seeds: u64 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(5);
    let scale: u32 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(1);
    println!("{frames} frames per seed, seeds 2026…{}, 1/{scale} resolution\n", 2026 + seeds - 1);
    println!("| condition | extractor | RMS (°) | within 2σ | max \\|err\\|/σ | median 1σ (°) | no heading | median image used | median cloud fraction |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    let names: Vec<&str> = cloudy(1, scale, 0)?.iter().map(|c| c.name).collect();
    for (k, name) in names.iter().enumerate() {
        let mut sims = Vec::new();
        let mut describe = "";
        for seed in 2026..2026 + seeds {
            let cond = cloudy(frames, scale, seed)?.swap_remove(k);
            describe = cond.describe;
            sims.push(cond.simulate(seed)?);
        }
        for e in Extractor::ALL {
            let f = score_field_all(&sims, e, &FieldOptions::default())?;
            if f.with_heading == 0 {
                println!(
                    "| `{name}` | `{}` | — | — | — | — | {} of {} | {:.0} % | {:.0} % |",
                    e.name(),
                    f.frames,
                    f.frames,
                    100.0 * f.median_used_fraction,
                    100.0 * f.median_cloud_fraction,
                );
                continue;
            }
            println!(
                "| `{name}` | `{}` | {:.3} | {:.0} % | {:.1} | {:.3} | {} of {} | {:.0} % | {:.0} % |",
                e.name(),
                f.rms_error_deg,
                100.0 * f.within_2sigma,
                f.max_error_over_sigma,
                f.median_sigma_deg,
                f.frames - f.with_heading,
                f.frames,
                100.0 * f.median_used_fraction,
                100.0 * f.median_cloud_fraction,
            );
        }
        eprintln!("{name}: {describe}");
    }
    Ok(())
}
