//! The trial plan and the trials: what each trial draws, its true chain, the
//! reconstructions it is read under, and the heading errors.
//!
//! A trial is a *unit* (sun elevation, source, trial index). Its draws are keyed by
//! (seed, source index, trial index) only, so every sun elevation sees the same draws
//! (common random numbers: the difference between two elevations is the geometry's,
//! not the dice's) and a unit gives the same numbers whatever shard, thread or backend
//! batch runs it. Units are numbered elevation-major, then source, then trial; shard
//! `i` of `n` runs the contiguous block `[i·U/n, (i+1)·U/n)`.
//!
//! With the seed paper's sweep file (`examples/sweeps/paper-table3.toml`) every
//! trial is bit-identical to [`crate::montecarlo::run_trial`] (tested): the same keys,
//! the same draw indices (the error's position in the file), the same frame.

use std::ops::Range;

use rayon::prelude::*;

use super::colour::{band_columns, colour_heading_sums, fuse, BandColumn, ColourSumsJob};
use super::spec::{Known, Per, PixelNoise, SweepExtractor, SweepSpec, Target};
use crate::camera::Intrinsics;
use crate::chain::{ChainFrame, NoiseIndex, Scene};
use crate::conventions::wrap_deg_180;
use crate::effects::EffectSet;
use crate::error::Result;
use crate::heading::{Extractor, HeadingContext, HeadingSums};
use crate::noise::{stream, FrameKey};
use crate::recon::Reconstructor;
use crate::sensor::{Channel, ColourTiles, Layout, Response};
use crate::simulate::{colocated_heading_sums, mosaic_heading_sums, peak_intensity};

/// One trial of the plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Unit {
    /// Index into `sun_elevations_deg`.
    pub elevation: usize,
    /// Index into `sources`.
    pub source: usize,
    pub trial: usize,
}

/// A slice of the plan: shard `index` of `count` (0-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    pub const WHOLE: Shard = Shard { index: 0, count: 1 };

    /// Parses `I/N` (0 ≤ I < N).
    pub fn parse(s: &str) -> Option<Shard> {
        let (i, n) = s.split_once('/')?;
        let (index, count) = (i.trim().parse().ok()?, n.trim().parse().ok()?);
        (count >= 1 && index < count).then_some(Shard { index, count })
    }

    /// The units of a plan of `total` that this shard runs.
    pub fn range(&self, total: usize) -> Range<usize> {
        let at = |k: usize| ((k as u128 * total as u128) / self.count as u128) as usize;
        at(self.index)..at(self.index + 1)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// How many units the sweep has.
pub fn unit_count(spec: &SweepSpec) -> usize {
    spec.sun_elevations_deg.len() * spec.sources.len() * spec.trials
}

/// Unit number `i` (elevation-major, then source, then trial).
pub fn unit(spec: &SweepSpec, i: usize) -> Unit {
    let per_el = spec.sources.len() * spec.trials;
    Unit { elevation: i / per_el, source: (i % per_el) / spec.trials, trial: i % spec.trials }
}

/// The number of unit `u`.
pub fn unit_index(spec: &SweepSpec, u: Unit) -> usize {
    (u.elevation * spec.sources.len() + u.source) * spec.trials + u.trial
}

/// The reconstructions a source's trials are read under: `None` when none of its
/// errors is `known = "both"`, else unknown then known.
pub fn variants(spec: &SweepSpec, source: usize) -> Vec<Option<bool>> {
    if spec.has_both(source) {
        vec![Some(false), Some(true)]
    } else {
        vec![None]
    }
}

/// The columns of a source's trial record: every extractor under every variant.
pub fn columns(spec: &SweepSpec, source: usize) -> Vec<(SweepExtractor, Option<bool>)> {
    let v = variants(spec, source);
    spec.extractors.iter().flat_map(|&e| v.iter().map(move |&k| (e, k))).collect()
}

/// The columns of a source's trial record with their band: every [`columns`] entry
/// once per [`band_columns`] (`None` alone on a monochrome sensor, so its record is
/// [`columns`]; R, G, B, fused on a colour one).
pub fn record_columns(spec: &SweepSpec, source: usize) -> Vec<(SweepExtractor, Option<bool>, Option<BandColumn>)> {
    let bands = band_columns(spec);
    columns(spec, source).into_iter().flat_map(|(e, k)| bands.iter().map(move |&b| (e, k, b))).collect()
}

/// One trial's outcome.
#[derive(Clone, Debug, PartialEq)]
pub struct TrialRecord {
    pub unit: Unit,
    pub sun_azimuth_deg: f64,
    /// Heading error, degrees (NaN where the extractor gave no heading), by
    /// [`record_columns`] of the unit's source.
    pub errors_deg: Vec<f64>,
}

/// Per error, the value trial `trial` of source `source` draws (the neutral value for
/// errors outside the source; σ for per-pixel noise).
pub fn draws(spec: &SweepSpec, source: usize, trial: usize) -> Vec<f64> {
    let key = FrameKey::new(spec.seed, trial as u32, 0x5EED_0000 | source as u32);
    spec.errors
        .iter()
        .enumerate()
        .map(|(k, e)| {
            if !spec.in_source(e, source) {
                return e.target.neutral();
            }
            match e.per {
                Per::Pixel => e.distribution.sigma(),
                Per::Trial => e
                    .distribution
                    .value(key.normal(k as u32, 0, stream::TRIAL), key.uniform(k as u32, 0, stream::TRIAL)),
            }
        })
        .collect()
}

/// One reconstruction of a trial's frame: the Stokes inversion and the contexts its
/// sums are taken under (one per variant that shares this inversion).
#[derive(Clone, Debug)]
pub struct Reading {
    pub rec: Reconstructor,
    pub contexts: Vec<HeadingContext>,
}

/// Everything a trial needs before its pixels are processed; the same for every
/// backend.
#[derive(Clone, Debug)]
pub struct TrialSetup {
    pub unit: Unit,
    pub sun_azimuth_deg: f64,
    /// The true chain (drawn errors folded in).
    pub frame: ChainFrame,
    /// A colour sensor's: the true chain of each band (`frame` in the band, by
    /// [`crate::sensor::Band::index`]: [`ChainFrame::bands`]); `None` on a monochrome one.
    pub band_frames: Option<Box<[ChainFrame; 3]>>,
    pub readings: Vec<Reading>,
    /// Per variant, (reading, context) of its sums.
    slots: Vec<(usize, usize)>,
    variants: Vec<Option<bool>>,
}

/// The gain of a sun position: the nominal sensor's noise-free peak (divide the
/// wanted peak DN by it).
pub fn peak(spec: &SweepSpec, sun_el_deg: f64, sun_az_deg: f64) -> f64 {
    let (w, h) = spec.size_px();
    let scene = Scene { sun_az_deg, sun_el_deg, heading_deg: 0.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: spec.dmax };
    peak_intensity(&EffectSet::new().model(), &spec.intrinsics(), &scene, w, h, 8)
}

impl TrialSetup {
    /// Unit `u`, with `peak` = [`peak`] of its sun.
    pub fn new(spec: &SweepSpec, u: Unit, peak: f64) -> Result<TrialSetup> {
        let d = draws(spec, u.source, u.trial);
        let nominal = spec.intrinsics();
        let (w, h) = spec.size_px();
        let sun_az = spec.sun_azimuth_deg(u.trial);
        let sun_el = spec.sun_elevations_deg[u.elevation];
        let mut scene = Scene {
            sun_az_deg: sun_az,
            sun_el_deg: sun_el,
            heading_deg: 0.0,
            tilt_x_deg: 0.0,
            tilt_y_deg: 0.0,
            dmax: spec.dmax,
        };
        let mut truth = EffectSet::new();
        let mut resp = Response {
            black_level_dn: spec.sensor.black_level_dn,
            bit_depth: spec.sensor.bit_depth,
            quantize: spec.quantize,
            ..Response::ideal(spec.peak_dn / peak)
        };
        let corner_r2 = spec.corner_r2();
        for (e, &v) in spec.errors.iter().zip(&d) {
            match e.target {
                Target::Effect { effect, param } => truth.set(effect.name, effect.params[param].name, v)?,
                Target::LensRhoCorner => truth.set("lens_diattenuation", "rho2", v / corner_r2)?,
                Target::ImuTilt { axis: 0 } => scene.tilt_x_deg = v,
                Target::ImuTilt { .. } => scene.tilt_y_deg = v,
                Target::SunAzimuth | Target::SunElevation => {}
                Target::PixelNoise(PixelNoise::Dsnu) => resp.dsnu_dn = v,
                Target::PixelNoise(PixelNoise::Prnu) => resp.prnu = v,
                Target::PixelNoise(PixelNoise::ReadNoise) => resp.read_noise_dn = v,
            }
        }
        let field = spec.field_scene(u.trial);
        let model = truth.model();
        let frame = ChainFrame::new_in_field(
            &model,
            &nominal,
            &scene,
            &resp,
            NoiseIndex { seed: spec.seed, trial: u.trial as u32, frame: u.source as u32 },
            field.as_ref(),
        );
        let band_frames = spec.sensor.colour.as_ref().map(|_| Box::new(frame.bands(&model, &scene)));
        let variants = variants(spec, u.source);
        let channels = spec.channels();
        let mut readings: Vec<Reading> = Vec::new();
        let mut slots = Vec::new();
        for &variant in &variants {
            let (rec, ctx) = reading(spec, &d, variant, &nominal, w, h, sun_az, sun_el, &channels)?;
            // Variants that share the inversion share one pass over the pixels.
            match readings.iter().position(|r| r.rec == rec && r.contexts.len() < MAX_CONTEXTS) {
                Some(i) => {
                    readings[i].contexts.push(ctx);
                    slots.push((i, readings[i].contexts.len() - 1));
                }
                None => {
                    readings.push(Reading { rec, contexts: vec![ctx] });
                    slots.push((readings.len() - 1, 0));
                }
            }
        }
        Ok(TrialSetup { unit: u, sun_azimuth_deg: sun_az, frame, band_frames, readings, slots, variants })
    }

    /// Solves every extractor from the readings' sums (`sums[reading][context]`).
    pub fn finish(&self, spec: &SweepSpec, sums: &[Vec<HeadingSums>]) -> TrialRecord {
        let mut errors_deg = Vec::with_capacity(spec.extractors.len() * self.variants.len());
        for &e in &spec.extractors {
            for &(r, c) in &self.slots {
                let ctx = &self.readings[r].contexts[c];
                let heading = match e {
                    SweepExtractor::Plain(e) => sums[r][c].solve(e, ctx).ok().map(|est| est.heading_deg),
                    SweepExtractor::EdgePoint => {
                        // Started from the sun vector's answer (which half is the sun's).
                        let start = sums[r][c].solve(Extractor::SunVector, ctx).ok().map(|est| est.heading_deg);
                        let (w, h) = spec.size_px();
                        let mut used = [false; 4];
                        for ch in spec.channels() {
                            used[ch.index()] = true;
                        }
                        start.and_then(|s| {
                            super::edge_point::heading(&self.frame, w, h, used, &self.readings[r].rec, ctx, s)
                                .map(|x| x.0)
                        })
                    }
                };
                errors_deg.push(heading.map(|hd| wrap_deg_180(hd - 0.0)).unwrap_or(f64::NAN));
            }
        }
        TrialRecord { unit: self.unit, sun_azimuth_deg: self.sun_azimuth_deg, errors_deg }
    }

    /// A colour sensor's: every extractor from each band's sums
    /// (`sums[reading][context][band]`), each band's heading error then the fused one
    /// ([`record_columns`]' order). The plain extractors only (`edge_point` reads a
    /// colocated sensor, never a colour one).
    pub fn finish_colour(&self, spec: &SweepSpec, sums: &[Vec<[HeadingSums; 3]>]) -> TrialRecord {
        let mut errors_deg = Vec::with_capacity(spec.extractors.len() * self.variants.len() * BandColumn::ALL.len());
        for &e in &spec.extractors {
            for &(r, c) in &self.slots {
                let ctx = &self.readings[r].contexts[c];
                let est = sums[r][c].map(|s| match e {
                    SweepExtractor::Plain(e) => s.solve(e, ctx).ok(),
                    SweepExtractor::EdgePoint => None,
                });
                let fused = fuse(&est);
                for heading in est.iter().map(|x| x.map(|x| x.heading_deg)).chain([fused]) {
                    errors_deg.push(heading.map(|hd| wrap_deg_180(hd - 0.0)).unwrap_or(f64::NAN));
                }
            }
        }
        TrialRecord { unit: self.unit, sun_azimuth_deg: self.sun_azimuth_deg, errors_deg }
    }
}

/// The name of [`nominal_rows`]' pseudo-source: no error source drawn.
pub const NOMINAL: &str = "nominal";

/// The nominal chain's own heading error: every trial's sun and field conditions with
/// no error source drawn (every parameter at its neutral value, no pixel noise), one
/// row per extractor and sun elevation, source [`NOMINAL`]. Every source's row
/// carries this error too (the extractor on this sensor at this sun: a 2 × 2
/// superpixel's four rays read an intensity gradient as polarization, a field of view
/// that misses the sun's half of the sky, the field conditions): a source's own effect
/// is its row's mean less this one. Costs one source's trials.
pub fn nominal_rows(
    spec: &SweepSpec,
    engine: &dyn SumsEngine,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<super::stats::Row>> {
    let nominal = SweepSpec { sources: vec![NOMINAL.to_string()], combined: false, ..spec.clone() };
    let records = run_units(&nominal, 0..unit_count(&nominal), engine, progress)?;
    Ok(super::stats::summarise(&nominal, &records).rows)
}

/// Contexts one pass over the pixels may carry (the GPU's limit).
pub const MAX_CONTEXTS: usize = 2;

/// The reconstruction of `variant`: what it knows of the drawn errors `d`.
#[allow(clippy::too_many_arguments)]
fn reading(
    spec: &SweepSpec,
    d: &[f64],
    variant: Option<bool>,
    nominal: &Intrinsics,
    w: usize,
    h: usize,
    sun_az: f64,
    sun_el: f64,
    channels: &[Channel],
) -> Result<(Reconstructor, HeadingContext)> {
    let mut known = EffectSet::new();
    let mut tilt = [0.0; 2];
    let (mut az, mut el) = (sun_az, sun_el);
    let corner_r2 = spec.corner_r2();
    for (e, &v) in spec.errors.iter().zip(d) {
        let is_known = match e.known {
            Known::No => false,
            Known::Yes => true,
            Known::Both => variant == Some(true),
        };
        match (e.target, is_known) {
            (Target::SunAzimuth, false) => az = sun_az + v,
            (Target::SunElevation, false) => el = sun_el + v,
            (_, false) => {}
            (Target::Effect { effect, param }, true) => known.set(effect.name, effect.params[param].name, v)?,
            (Target::LensRhoCorner, true) => known.set("lens_diattenuation", "rho2", v / corner_r2)?,
            (Target::ImuTilt { axis }, true) => tilt[axis] = v,
            (_, true) => {}
        }
    }
    let model = known.model();
    let rec = Reconstructor::new(&model, spec.sensor.black_level_dn, channels)?;
    let mut ctx = HeadingContext::new(model.camera(nominal), w, h, az, el);
    ctx.lens_rho2 = known.get("lens_diattenuation", "rho2").unwrap_or(0.0);
    ctx.tilt_x_deg = tilt[0];
    ctx.tilt_y_deg = tilt[1];
    ctx.mount_tilt_deg =
        [known.get("mount_tilt", "tilt_x_deg").unwrap_or(0.0), known.get("mount_tilt", "tilt_y_deg").unwrap_or(0.0)];
    Ok((rec, ctx))
}

/// One pass over a trial's pixels: its frame, one inversion, the contexts.
#[derive(Clone, Copy, Debug)]
pub struct SumsJob<'a> {
    pub frame: &'a ChainFrame,
    pub rec: &'a Reconstructor,
    pub contexts: &'a [HeadingContext],
}

/// Where a sweep's pixels are processed: the heading sums of many frames at once.
/// [`CpuSums`] is the rayon reference; `bpins-gpu` implements it with the WGSL twin.
pub trait SumsEngine: Sync {
    /// `cpu`, `gpu`.
    fn name(&self) -> &str;

    /// Per job, one sums per context, for a sensor of `layout`, `w × h` px; samples
    /// with DN outside (0, `mask_full_scale_dn`) are masked (DoFP only).
    fn heading_sums(
        &self,
        jobs: &[SumsJob],
        layout: &Layout,
        w: usize,
        h: usize,
        mask_full_scale_dn: f64,
    ) -> Result<Vec<Vec<HeadingSums>>>;

    /// Whether it renders field conditions (`[sky] scene`); the GPU does not.
    fn field_scenes(&self) -> bool {
        true
    }

    /// Per job, one set of each band's sums per context (`[band][…]` by
    /// [`crate::sensor::Band::index`]), for a colour DoFP sensor of `mosaic` and `tiles`,
    /// `w × h` px ([`colour_heading_sums`]). Refused unless the engine implements it
    /// (the CPU and `bpins-gpu`'s GPU do); an engine that refuses refuses an empty
    /// `jobs` too, which [`check_engine`] asks before a sweep writes anything.
    #[allow(clippy::too_many_arguments)]
    fn colour_heading_sums(
        &self,
        jobs: &[ColourSumsJob],
        mosaic: &[[Channel; 2]; 2],
        tiles: &ColourTiles,
        w: usize,
        h: usize,
        mask_full_scale_dn: f64,
    ) -> Result<Vec<Vec<[HeadingSums; 3]>>> {
        let _ = (jobs, mosaic, tiles, w, h, mask_full_scale_dn);
        Err(crate::Error::Backend {
            backend: self.name().to_string(),
            message: "a colour-polarization sensor ([sensor] colour_tiles) is swept on the CPU backend only; use \
                      --backend cpu"
                .into(),
        })
    }

    /// Trials per call (progress is reported between calls).
    fn batch(&self) -> usize {
        64
    }
}

/// The rayon reference: trials in parallel, each fused per pixel row.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuSums;

impl SumsEngine for CpuSums {
    fn name(&self) -> &str {
        "cpu"
    }

    fn heading_sums(
        &self,
        jobs: &[SumsJob],
        layout: &Layout,
        w: usize,
        h: usize,
        mask_full_scale_dn: f64,
    ) -> Result<Vec<Vec<HeadingSums>>> {
        Ok(jobs
            .par_iter()
            .map(|j| match layout {
                Layout::Colocated { channels } => {
                    let mut used = [false; 4];
                    for c in channels {
                        used[c.index()] = true;
                    }
                    colocated_heading_sums(j.frame, w, h, used, j.rec, j.contexts)
                }
                Layout::Dofp { mosaic } => j
                    .contexts
                    .iter()
                    .map(|ctx| mosaic_heading_sums(j.frame, w, h, mosaic, j.rec, mask_full_scale_dn, ctx))
                    .collect(),
            })
            .collect())
    }

    fn colour_heading_sums(
        &self,
        jobs: &[ColourSumsJob],
        mosaic: &[[Channel; 2]; 2],
        tiles: &ColourTiles,
        w: usize,
        h: usize,
        mask_full_scale_dn: f64,
    ) -> Result<Vec<Vec<[HeadingSums; 3]>>> {
        Ok(jobs
            .par_iter()
            .map(|j| colour_heading_sums(j.frames, w, h, mosaic, tiles, j.rec, mask_full_scale_dn, j.contexts))
            .collect())
    }

    fn batch(&self) -> usize {
        4 * rayon::current_num_threads()
    }
}

/// Whether `engine` can sweep `spec`: field conditions on an engine without them, or a
/// colour sensor on one that refuses it (asked with no jobs), are refused here, before
/// any trial is set up or any output written.
pub(crate) fn check_engine(spec: &SweepSpec, engine: &dyn SumsEngine) -> Result<()> {
    if !spec.scene.is_empty() && !engine.field_scenes() {
        return Err(crate::Error::Backend {
            backend: engine.name().to_string(),
            message: "field conditions ([sky] scene) run on the CPU backend only; use --backend cpu".into(),
        });
    }
    if let (Some(tiles), Layout::Dofp { mosaic }) = (&spec.sensor.colour, &spec.sensor.layout) {
        let (w, h) = spec.size_px();
        engine.colour_heading_sums(&[], mosaic, tiles, w, h, spec.sensor.full_scale_dn())?;
    }
    Ok(())
}

/// Runs units `range` of the plan on `engine`, in order, calling `progress(done,
/// total)` after each batch.
pub fn run_units(
    spec: &SweepSpec,
    range: Range<usize>,
    engine: &dyn SumsEngine,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<TrialRecord>> {
    check_engine(spec, engine)?;
    let total = range.len();
    let units: Vec<Unit> = range.map(|i| unit(spec, i)).collect();
    let (w, h) = spec.size_px();
    // The gain depends on the sun only: one peak per (elevation, azimuth).
    let mut peaks: Vec<((usize, u64), f64)> = Vec::new();
    let mut out = Vec::with_capacity(total);
    let full = spec.sensor.full_scale_dn();
    for chunk in units.chunks(engine.batch().max(1)) {
        for u in chunk {
            let key = (u.elevation, spec.sun_azimuth_deg(u.trial).to_bits());
            if !peaks.iter().any(|(k, _)| *k == key) {
                let p = peak(spec, spec.sun_elevations_deg[u.elevation], spec.sun_azimuth_deg(u.trial));
                peaks.push((key, p));
            }
        }
        let setups = chunk
            .par_iter()
            .map(|u| {
                let key = (u.elevation, spec.sun_azimuth_deg(u.trial).to_bits());
                let p = peaks.iter().find(|(k, _)| *k == key).expect("computed above").1;
                TrialSetup::new(spec, *u, p)
            })
            .collect::<Result<Vec<_>>>()?;
        if let (Some(tiles), Layout::Dofp { mosaic }) = (&spec.sensor.colour, &spec.sensor.layout) {
            // A colour sensor: each band's sums, from the colour mosaic (colour.rs).
            let jobs: Vec<ColourSumsJob> = setups
                .iter()
                .flat_map(|t| {
                    let frames = t.band_frames.as_deref().expect("a colour sensor's setup has its bands");
                    t.readings.iter().map(move |r| ColourSumsJob { frames, rec: &r.rec, contexts: &r.contexts })
                })
                .collect();
            let mut sums = engine.colour_heading_sums(&jobs, mosaic, tiles, w, h, full)?.into_iter();
            let per_trial: Vec<Vec<Vec<[HeadingSums; 3]>>> =
                setups.iter().map(|t| sums.by_ref().take(t.readings.len()).collect()).collect();
            out.par_extend(setups.par_iter().zip(per_trial.par_iter()).map(|(t, s)| t.finish_colour(spec, s)));
            progress(out.len(), total);
            continue;
        }
        let jobs: Vec<SumsJob> = setups
            .iter()
            .flat_map(|t| t.readings.iter().map(|r| SumsJob { frame: &t.frame, rec: &r.rec, contexts: &r.contexts }))
            .collect();
        let mut sums = engine.heading_sums(&jobs, &spec.sensor.layout, w, h, full)?.into_iter();
        let per_trial: Vec<Vec<Vec<HeadingSums>>> =
            setups.iter().map(|t| sums.by_ref().take(t.readings.len()).collect()).collect();
        out.par_extend(setups.par_iter().zip(per_trial.par_iter()).map(|(t, s)| t.finish(spec, s)));
        progress(out.len(), total);
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::path::Path;

    pub(crate) fn tiny() -> SweepSpec {
        SweepSpec::parse(Path::new("tiny.toml"), super::super::spec::TINY_FOR_TESTS).unwrap()
    }

    #[test]
    fn shards_cover_the_plan_once_in_order() {
        for total in [0, 1, 7, 100] {
            for n in 1..9 {
                let mut next = 0;
                for i in 0..n {
                    let r = Shard { index: i, count: n }.range(total);
                    assert_eq!(r.start, next);
                    next = r.end;
                }
                assert_eq!(next, total);
            }
        }
        assert_eq!(Shard::parse("2/4"), Some(Shard { index: 2, count: 4 }));
        assert_eq!(Shard::parse("4/4"), None);
        assert_eq!(Shard::parse("x"), None);
        let s = tiny();
        for i in 0..unit_count(&s) {
            assert_eq!(unit_index(&s, unit(&s, i)), i);
        }
    }

    /// The nominal rows are the rows a source would have whose every error is drawn at
    /// its neutral value: the same trials, bit for bit.
    #[test]
    fn nominal_rows_are_a_source_drawn_at_neutral() {
        let s = tiny();
        let nominal = nominal_rows(&s, &CpuSums, &|_, _| {}).unwrap();
        assert_eq!(nominal.len(), s.extractors.len() * s.sun_elevations_deg.len());
        assert!(nominal.iter().all(|r| r.source == NOMINAL && r.trials + r.failed == s.trials));
        let mut neutral = s.clone();
        for e in &mut neutral.errors {
            e.distribution = super::super::spec::Distribution::Fixed { value: e.target.neutral() };
            e.per = Per::Trial;
        }
        let recs = run_units(&neutral, 0..unit_count(&neutral), &CpuSums, &|_, _| {}).unwrap();
        let rows = super::super::stats::summarise(&neutral, &recs).rows;
        for n in &nominal {
            for r in rows.iter().filter(|r| r.extractor == n.extractor && r.sun_elevation_deg == n.sun_elevation_deg) {
                assert_eq!(r.errors_deg, n.errors_deg, "{} at {}°", r.source, r.sun_elevation_deg);
            }
        }
        // An error drawn away from neutral moves the trials off the nominal ones.
        let moved =
            super::super::stats::summarise(&s, &run_units(&s, 0..unit_count(&s), &CpuSums, &|_, _| {}).unwrap());
        assert!(moved.rows.iter().any(|r| nominal.iter().all(|n| n.errors_deg != r.errors_deg)));
    }

    #[test]
    fn draws_touch_only_their_source_and_are_the_same_at_every_elevation() {
        let s = tiny();
        let d0 = draws(&s, 0, 3);
        assert!(d0[0] != 0.0 && d0[1] == 0.0);
        let d1 = draws(&s, 1, 3);
        assert!(d1[0] == 0.0 && d1[1] == 1.0);
        let c = draws(&s, 2, 3);
        assert!(c[0] != 0.0 && c[0] != d0[0] && c[1] == 1.0);
        // The same draws at both elevations: only the sun differs between their frames.
        let a = TrialSetup::new(&s, Unit { elevation: 0, source: 0, trial: 3 }, 1.0).unwrap();
        let b = TrialSetup::new(&s, Unit { elevation: 1, source: 0, trial: 3 }, 1.0).unwrap();
        assert_eq!(a.readings[0].rec, b.readings[0].rec);
        assert_eq!(a.frame.intr, b.frame.intr);
    }

    #[test]
    fn field_conditions_change_the_trials_and_vary_from_trial_to_trial() {
        let clean = tiny();
        let text = super::super::spec::TINY_FOR_TESTS.replacen(
            "trials_per_azimuth = 1",
            "trials_per_azimuth = 1\nscene = [\"clouds.count=64\", \"clouds.radius_min_deg=30\", \"clouds.radius_max_deg=45\"]",
            1,
        );
        let cloudy = SweepSpec::parse(Path::new("cloudy.toml"), &text).unwrap();
        assert_ne!(cloudy.field_scene(0), cloudy.field_scene(1));
        let a = run_units(&clean, 0..4, &CpuSums, &|_, _| {}).unwrap();
        let b = run_units(&cloudy, 0..4, &CpuSums, &|_, _| {}).unwrap();
        assert!(a.iter().zip(&b).any(|(x, y)| x.errors_deg != y.errors_deg), "clouds changed nothing");
    }

    #[test]
    fn a_unit_gives_the_same_record_alone_or_in_any_batch() {
        let s = tiny();
        let all = run_units(&s, 0..unit_count(&s), &CpuSums, &|_, _| {}).unwrap();
        let one = run_units(&s, 5..6, &CpuSums, &|_, _| {}).unwrap();
        assert_eq!(one[0], all[5]);
        // Array rotation (σ 0.1°) reaches the heading at about its own size.
        assert!(all.iter().filter(|r| r.unit.source == 0).all(|r| r.errors_deg.iter().all(|e| e.abs() < 1.0)));
    }
}
