//! The README's field table: every standard field condition
//! (`bpins_core::field_conditions`), each extractor, the plain and the field
//! estimator: RMS error, the share of frames within 2σ, the largest |error|/σ.
//!
//! ```sh
//! cargo run --release -p bpins-core --example field_table -- [FRAMES] [SEED]
//! ```
//! (defaults 24 frames per condition, seed 2026; a few minutes on two cores).

use bpins_core::internal::field_conditions::{score_field, score_plain, standard};
use bpins_core::internal::heading::field::FieldOptions;
use bpins_core::internal::heading::Extractor;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let frames: usize = args.next().map(|a| a.parse()).transpose()?.unwrap_or(24);
    let seed: u64 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(2026);
    println!("{frames} frames per condition, seed {seed}\n");
    println!("| condition | extractor | plain RMS (°) | plain within 2σ | field RMS (°) | field within 2σ | field max \\|err\\|/σ | field median 1σ (°) | no heading | median image used |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for cond in standard(frames, 1, seed)? {
        let sim = cond.simulate(seed)?;
        for e in Extractor::ALL {
            let p = score_plain(&sim, e)?;
            let f = score_field(&sim, e, &FieldOptions::default())?;
            let plain = if p.with_heading == 0 {
                "refused | —".to_string()
            } else {
                format!("{:.3} | {:.0} %", p.rms_error_deg, 100.0 * p.within_2sigma)
            };
            println!(
                "| `{}` | `{}` | {plain} | {:.3} | {:.0} % | {:.1} | {:.3} | {} of {} | {:.0} % |",
                cond.name,
                e.name(),
                f.rms_error_deg,
                100.0 * f.within_2sigma,
                f.max_error_over_sigma,
                f.median_sigma_deg,
                f.frames - f.with_heading,
                f.frames,
                100.0 * f.median_used_fraction
            );
        }
        eprintln!("{}: {}", cond.name, cond.describe);
    }
    Ok(())
}
