//! `bpins effects`: the registry, as a table or JSON; then the scene elements
//! (field conditions of `bpins simulate --scene`) in their own section of the table.

use bpins_core::effects::REGISTRY;
use bpins_core::scene::ELEMENTS;
use serde_json::json;

#[derive(clap::Args)]
pub struct Args {
    /// Print the effects as JSON instead of a table (the JSON lists effects only).
    #[arg(long, conflicts_with = "markdown")]
    json: bool,
    /// Print the README's catalog tables (effects and scene elements) as Markdown.
    #[arg(long)]
    markdown: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    if a.markdown {
        out!("{}", bpins_core::catalog::markdown().trim_end());
        return Ok(());
    }
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
        out!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(());
    }
    for e in REGISTRY {
        out!("{:<20} [{}] {}  ({})", e.name, e.stage.name(), e.summary, e.source);
        for p in e.params {
            out!(
                "    {:<14} {:>4}  neutral {:<6} typical {:<6} range [{}, {}]  {}",
                p.name,
                p.unit,
                p.neutral,
                p.typical,
                p.min,
                p.max,
                p.doc
            );
        }
    }
    out!();
    out!("scene elements (field conditions; bpins simulate --scene NAME or NAME.PARAM=VALUE; CPU backend only)");
    for e in ELEMENTS {
        out!("{:<20} {}  ({})", e.name, e.summary, e.source);
        for p in e.params {
            out!("    {:<18} {:>4}  default {:<8} range [{}, {}]  {}", p.name, p.unit, p.typical, p.min, p.max, p.doc);
        }
    }
    Ok(())
}
