//! The seed paper's Monte Carlo on the GPU: the very trials of
//! `bpins_core::montecarlo` (same draws, same frames, same noise), their pixels
//! processed in batches of trials per dispatch, their sums solved on the host.

use crate::device::Gpu;
use crate::sums::{SampleLayout, SumsJob};
use crate::Result;
use bpins_core::twin::{draw, sweep_peak, Source, SweepConfig, TrialResult, TrialSetup};

/// Trials per call of [`Gpu::heading_sums`] (each call then splits further if the
/// device's buffers require it); progress is reported between calls.
const TRIALS_PER_CALL: usize = 64;

/// Runs the sweep of [`bpins_core::twin::run_sweep`] on `gpu`: every source,
/// `trials_per_source` trials each, in the same order, calling `progress(done, total)`.
pub fn run_sweep(
    gpu: &Gpu,
    cfg: &SweepConfig,
    sources: &[Source],
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<TrialResult>> {
    let per = cfg.trials_per_source();
    let all: Vec<(Source, usize)> = sources.iter().flat_map(|&s| (0..per).map(move |t| (s, t))).collect();
    // The gain depends on the sun azimuth only: one peak per azimuth.
    let mut peaks: Vec<(f64, f64)> = Vec::new();
    let mut out = Vec::with_capacity(all.len());
    for chunk in all.chunks(TRIALS_PER_CALL) {
        let mut setups = Vec::with_capacity(chunk.len());
        for &(s, t) in chunk {
            let az = draw(cfg, s, t).sun_az_deg;
            let peak = match peaks.iter().find(|(a, _)| *a == az) {
                Some(&(_, p)) => p,
                None => {
                    let p = sweep_peak(cfg, az);
                    peaks.push((az, p));
                    p
                }
            };
            setups.push(TrialSetup::new(cfg, s, t, peak)?);
        }
        let jobs: Vec<SumsJob> = setups
            .iter()
            .map(|t| SumsJob { frame: &t.frame, rec: &t.rec, mask_full_scale_dn: 0.0, contexts: t.contexts() })
            .collect();
        let sums = gpu.heading_sums(&jobs, cfg.width_px, cfg.height_px, SampleLayout::Colocated)?;
        for (t, s) in setups.iter().zip(&sums) {
            out.push(t.finish(&s[0], s.get(1))?);
        }
        progress(out.len(), all.len());
    }
    Ok(out)
}
