//! `bpins effects`: the registry, as a table or JSON.

use bpins_core::effects::REGISTRY;
use serde_json::json;

#[derive(clap::Args)]
pub struct Args {
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if a.json {
        let v: Vec<_> = REGISTRY
            .iter()
            .map(|e| {
                json!({
                    "name": e.name, "summary": e.summary, "source": e.source, "stage": e.stage.name(),
                    "params": e.params.iter().map(|p| json!({"name": p.name, "unit": p.unit, "neutral": p.neutral, "typical": p.typical, "min": p.min, "max": p.max, "doc": p.doc})).collect::<Vec<_>>(),
                })
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    for e in REGISTRY {
        println!("{:<20} [{}] {}  ({})", e.name, e.stage.name(), e.summary, e.source);
        for p in e.params {
            println!(
                "    {:<14} {:>4}  neutral {:<6} typical {:<6} range [{}, {}]  {}",
                p.name, p.unit, p.neutral, p.typical, p.min, p.max, p.doc
            );
        }
    }
    Ok(())
}
