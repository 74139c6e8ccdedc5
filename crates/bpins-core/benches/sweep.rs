//! Criterion benchmarks of `bpins sweep` (`cargo bench -p bpins-core --bench sweep`).
//! Figures and the machine they came from go to BENCHMARKS.md.
//!
//! * `sweep_file/paper_5_trials`: the first trial of each of the five sources of
//!   `examples/sweeps/paper-table3.toml` (1224 × 1024 colocated): ×160 is the 800-trial
//!   sweep (target ≤ 30 s, as `bpins run`'s).
//! * `sweep_file/paper_800_trials` (only with `BPINS_BENCH_SWEEP=1`: minutes): the
//!   whole paper sweep through the sweep file.
//! * `sweep_file/dofp_2448x2048_trial`: one trial of
//!   `examples/sweeps/design-2448x2048.toml` (DoFP 2448 × 2048, fisheye, 7 errors):
//!   the unit of the 10 000-trial estimate in BENCHMARKS.md.

use bpins_core::internal::sweep::{run_units, unit_count, CpuSums, SweepSpec};
use criterion::{criterion_group, criterion_main, Criterion};
use std::path::Path;
use std::time::Duration;

fn spec(name: &str) -> SweepSpec {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/sweeps").join(name);
    SweepSpec::load(&p).expect("a shipped sweep file")
}

fn sweep_file(c: &mut Criterion) {
    let mut g = c.benchmark_group("sweep_file");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    let mut paper = spec("paper-table3.toml");
    paper.trials = 1;
    g.bench_function("paper_5_trials", |b| {
        b.iter(|| run_units(&paper, 0..unit_count(&paper), &CpuSums, &|_, _| {}).unwrap())
    });
    let mut design = spec("design-2448x2048.toml");
    design.trials = 1;
    g.bench_function("dofp_2448x2048_trial", |b| b.iter(|| run_units(&design, 0..1, &CpuSums, &|_, _| {}).unwrap()));
    if std::env::var_os("BPINS_BENCH_SWEEP").is_some() {
        let full = spec("paper-table3.toml");
        g.bench_function("paper_800_trials", |b| {
            b.iter(|| run_units(&full, 0..unit_count(&full), &CpuSums, &|_, _| {}).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, sweep_file);
criterion_main!(benches);
