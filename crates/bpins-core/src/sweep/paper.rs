//! The shipped `examples/sweeps/paper-table3.toml` is `bpins run`'s sweep: every trial
//! gives the very errors of [`crate::montecarlo::run_trial`], bit for bit.

use std::path::Path;

use super::{run_units, summarise, unit_count, CpuSums, SweepSpec};
use crate::montecarlo::{run_trial, Source, SweepConfig};

const PAPER: &str = include_str!("../../../../examples/sweeps/paper-table3.toml");

#[test]
fn the_paper_sweep_file_is_bpins_runs_sweep_trial_for_trial() {
    let mut spec = SweepSpec::parse(Path::new("paper-table3.toml"), PAPER).unwrap();
    assert_eq!(
        spec.sources,
        ["principal_point", "array_rotation", "channel_response", "lens_diattenuation", "combined"]
    );
    for (s, src) in spec.sources.iter().zip(Source::ALL) {
        assert_eq!(s, src.name());
    }
    let cfg = SweepConfig::default();
    assert_eq!(spec.trials, cfg.trials_per_source());
    assert_eq!(spec.intrinsics(), cfg.intrinsics());
    assert_eq!(spec.corner_r2(), cfg.corner_r2());
    // Two trials per source at the full 1224 × 1024 px: the first azimuth.
    spec.trials = 2;
    let recs = run_units(&spec, 0..unit_count(&spec), &CpuSums, &|_, _| {}).unwrap();
    let mut mc_results = Vec::new();
    for r in &recs {
        let mc = run_trial(&cfg, Source::ALL[r.unit.source], r.unit.trial).unwrap();
        assert_eq!(r.sun_azimuth_deg, mc.draw.sun_az_deg);
        let theirs: Vec<u64> = mc.errors.iter().map(|e| e.2.to_bits()).collect();
        let ours: Vec<u64> = r.errors_deg.iter().map(|e| e.to_bits()).collect();
        assert_eq!(ours, theirs, "{:?}: {:?} vs {:?}", r.unit, r.errors_deg, mc.errors);
        mc_results.push(mc);
    }
    // And so are the rows `bpins run` prints from them: mean and σ, bit for bit.
    let theirs = crate::montecarlo::summarise(&mc_results);
    let ours = summarise(&spec, &recs).rows;
    assert_eq!(ours.len(), theirs.len());
    for t in &theirs {
        let o = ours
            .iter()
            .find(|o| o.source == t.source && o.extractor == t.extractor && o.known == t.lens_rho_known)
            .unwrap();
        assert_eq!(
            (o.mean_deg.to_bits(), o.std_deg.to_bits(), o.trials),
            (t.mean_deg.to_bits(), t.std_deg.to_bits(), t.trials)
        );
    }
}
