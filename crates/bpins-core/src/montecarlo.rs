//! The seed paper's Monte Carlo (§4, Tables 1 and 3), reproduced and extended.
//!
//! Setup (PAPER.md, seed Table 2): colocated sensor 1224 × 1024 px (W × H), pitch
//! 3.45 µm, f = 8 mm pinhole, nominal principal point (611.5, 511.5) px (the paper's
//! 1-based (512.5, 612.5) row, column), channels 0°, 45°, 90° (or all four), Rayleigh
//! sky with d_max = 0.6, sun elevation 5°, sun azimuth 10°…80° changed every
//! `trials_per_azimuth` trials (the paper: 20, so 160 trials per source), level camera
//! at heading 0°, peak response 153 DN. No rounding and no noise except the source
//! under test, as in the paper (its lens row is exactly 0).
//!
//! Error sources, Gaussian (μ = 0) as seed Table 1, drawn per trial:
//!
//! | source               | draw                                   | effect it sets                 |
//! |----------------------|----------------------------------------|--------------------------------|
//! | `principal_point`    | dx, dy ~ N(0, 2 px)                    | `principal_point.{dx,dy}_px`   |
//! | `array_rotation`     | dθ ~ N(0, 0.1°)                        | `array_rotation.dtheta_deg`    |
//! | `channel_response`   | per pixel and channel ~ N(0, 1 DN)     | sensor DSNU σ = 1 DN           |
//! | `lens_diattenuation` | ρ at the field corner ~ N(0, 0.2)      | `lens_diattenuation.rho2`      |
//! | `combined`           | all four at once (seed §4.2)           |                                |
//!
//! The paper's "(0.2, 0.2)" for ρ is read as σ = 0.2 of ρ at the corner of the field
//! (r² = 0.119 here), since bpins' lens diattenuation grows as r² (zero on the axis).
//! The lens row is computed with ρ known and compensated (seed eq. 13, paper: 0) and
//! unknown (not in the paper). Every extractor bpins offers gets its own rows.
//!
//! Every draw is keyed by (seed, source, trial): the result is bit-identical whatever
//! the thread count, and a trial can be re-run alone.

use crate::camera::{Intrinsics, Projection};
use crate::chain::{ChainFrame, NoiseIndex, Scene};
use crate::conventions::wrap_deg_180;
use crate::effects::EffectSet;
use crate::error::Result;
use crate::heading::{Extractor, HeadingContext, HeadingSums};
use crate::noise::{stream, FrameKey};
use crate::recon::Reconstructor;
use crate::sensor::{Channel, Response};
use crate::simulate::{colocated_heading_sums, peak_intensity};
use serde::Serialize;

/// The seed paper's error sources, and all of them combined.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    PrincipalPoint,
    ArrayRotation,
    ChannelResponse,
    LensDiattenuation,
    Combined,
}

impl Source {
    pub const ALL: [Source; 5] = [
        Source::PrincipalPoint,
        Source::ArrayRotation,
        Source::ChannelResponse,
        Source::LensDiattenuation,
        Source::Combined,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Source::PrincipalPoint => "principal_point",
            Source::ArrayRotation => "array_rotation",
            Source::ChannelResponse => "channel_response",
            Source::LensDiattenuation => "lens_diattenuation",
            Source::Combined => "combined",
        }
    }

    /// Seed Table 3 (μ, σ) in degrees; `None` where the paper gives no figure.
    pub(crate) fn paper_deg(self) -> (Option<f64>, Option<f64>) {
        match self {
            Source::PrincipalPoint => (Some(-0.0237), Some(0.2476)),
            Source::ArrayRotation => (Some(0.0018), Some(0.0812)),
            Source::ChannelResponse => (Some(0.0059), Some(0.0405)),
            Source::LensDiattenuation => (Some(0.0), Some(0.0)),
            Source::Combined => (None, Some(0.8839)),
        }
    }

    fn involves_lens(self) -> bool {
        matches!(self, Source::LensDiattenuation | Source::Combined)
    }

    fn has(self, s: Source) -> bool {
        self == s || self == Source::Combined
    }
}

/// Seed Table 1 standard deviations.
pub(crate) const SIGMA_PRINCIPAL_POINT_PX: f64 = 2.0;
pub(crate) const SIGMA_ARRAY_ROTATION_DEG: f64 = 0.1;
pub(crate) const SIGMA_GRAYSCALE_DN: f64 = 1.0;
pub(crate) const SIGMA_LENS_RHO_CORNER: f64 = 0.2;

/// The sweep's configuration; `Default` is the paper's.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepConfig {
    pub width_px: usize,
    pub height_px: usize,
    pub pixel_pitch_um: f64,
    pub focal_length_mm: f64,
    pub channels: Vec<Channel>,
    pub sun_el_deg: f64,
    pub sun_azimuths_deg: Vec<f64>,
    pub trials_per_azimuth: usize,
    pub peak_dn: f64,
    pub dmax: f64,
    pub seed: u64,
}

impl Default for SweepConfig {
    fn default() -> Self {
        SweepConfig {
            width_px: 1224,
            height_px: 1024,
            pixel_pitch_um: 3.45,
            focal_length_mm: 8.0,
            channels: vec![Channel::C0, Channel::C45, Channel::C90],
            sun_el_deg: 5.0,
            sun_azimuths_deg: (1..=8).map(|k| 10.0 * k as f64).collect(),
            trials_per_azimuth: 20,
            peak_dn: 153.0,
            dmax: 0.6,
            seed: 2023,
        }
    }
}

impl SweepConfig {
    /// The nominal camera: pinhole, principal point at the image centre — for the
    /// paper's sensor its (512.5, 612.5) 1-based row, column (tested).
    pub fn intrinsics(&self) -> Intrinsics {
        let (cx, cy) = crate::conventions::image_centre_px(self.width_px as u32, self.height_px as u32);
        Intrinsics {
            projection: Projection::Pinhole,
            f_px: self.focal_length_mm * 1000.0 / self.pixel_pitch_um,
            cx_px: cx,
            cy_px: cy,
            distortion: [0.0; 2],
        }
    }

    pub fn trials_per_source(&self) -> usize {
        self.trials_per_azimuth * self.sun_azimuths_deg.len()
    }

    /// Squared normalised radius of the field corner.
    pub(crate) fn corner_r2(&self) -> f64 {
        let i = self.intrinsics();
        let (x, y) = i.normalised(0.0, 0.0);
        let (x2, y2) = i.normalised(self.width_px as f64 - 1.0, self.height_px as f64 - 1.0);
        (x * x + y * y).max(x2 * x2 + y2 * y2)
    }
}

/// What one trial drew, for reports.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TrialDraw {
    pub sun_az_deg: f64,
    pub dx_px: f64,
    pub dy_px: f64,
    pub dtheta_deg: f64,
    pub rho_corner: f64,
    pub dsnu_dn: f64,
}

/// One trial's heading errors, by (extractor, ρ known).
#[derive(Clone, Debug, PartialEq)]
pub struct TrialResult {
    pub source: Source,
    pub trial: usize,
    pub draw: TrialDraw,
    /// (extractor, lens ρ known, error in degrees).
    pub errors: Vec<(Extractor, bool, f64)>,
}

/// A row of Table 3.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    pub source: &'static str,
    pub extractor: &'static str,
    /// Whether the inversion knew the lens ρ (seed eq. 13); `None` where no lens error.
    pub lens_rho_known: Option<bool>,
    pub mean_deg: f64,
    pub std_deg: f64,
    pub trials: usize,
    pub paper_mean_deg: Option<f64>,
    pub paper_std_deg: Option<f64>,
}

/// Draws trial `trial` of `source`.
pub fn draw(cfg: &SweepConfig, source: Source, trial: usize) -> TrialDraw {
    let key = FrameKey::new(cfg.seed, trial as u32, 0x5EED_0000 | source as u32);
    let n = |k: u32| key.normal(k, 0, stream::TRIAL);
    let az = cfg.sun_azimuths_deg[(trial / cfg.trials_per_azimuth.max(1)).min(cfg.sun_azimuths_deg.len() - 1)];
    let on = |s: Source| if source.has(s) { 1.0 } else { 0.0 };
    TrialDraw {
        sun_az_deg: az,
        dx_px: on(Source::PrincipalPoint) * SIGMA_PRINCIPAL_POINT_PX * n(0),
        dy_px: on(Source::PrincipalPoint) * SIGMA_PRINCIPAL_POINT_PX * n(1),
        dtheta_deg: on(Source::ArrayRotation) * SIGMA_ARRAY_ROTATION_DEG * n(2),
        rho_corner: on(Source::LensDiattenuation) * SIGMA_LENS_RHO_CORNER * n(3),
        dsnu_dn: on(Source::ChannelResponse) * SIGMA_GRAYSCALE_DN,
    }
}

/// Everything one trial needs before its pixels are processed, built identically for
/// both backends (the GPU twin maps the same chain over the same frame).
#[derive(Clone, Debug)]
pub struct TrialSetup {
    pub source: Source,
    pub trial: usize,
    pub draw: TrialDraw,
    pub scene: Scene,
    /// The true chain of this trial (drawn errors folded in).
    pub frame: ChainFrame,
    /// The inversion: nominal analyzers (the errors are unknown).
    pub rec: Reconstructor,
    /// Channels the sensor has (the others are not reconstructed from).
    pub used: [bool; 4],
    /// Heading contexts: lens ρ unknown, and known (eq. 13) where the source has a lens.
    pub ctx_unknown: HeadingContext,
    pub ctx_known: Option<HeadingContext>,
}

/// Largest noise-free analyzer intensity of the nominal sensor under the sun at
/// `sun_az_deg` (it sets the gain: the peak response is `cfg.peak_dn`). Depends on the
/// azimuth only, so a driver may compute it once per azimuth.
pub fn sweep_peak(cfg: &SweepConfig, sun_az_deg: f64) -> f64 {
    let scene = sweep_scene(cfg, sun_az_deg);
    peak_intensity(&Default::default(), &cfg.intrinsics(), &scene, cfg.width_px, cfg.height_px, 8)
}

fn sweep_scene(cfg: &SweepConfig, sun_az_deg: f64) -> Scene {
    Scene { sun_az_deg, sun_el_deg: cfg.sun_el_deg, heading_deg: 0.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: cfg.dmax }
}

impl TrialSetup {
    /// Trial `trial` of `source`, with `peak` = [`sweep_peak`] of its sun azimuth.
    pub fn new(cfg: &SweepConfig, source: Source, trial: usize, peak: f64) -> Result<TrialSetup> {
        let d = draw(cfg, source, trial);
        let nominal = cfg.intrinsics();
        let mut set = EffectSet::new();
        set.set("principal_point", "dx_px", d.dx_px)?;
        set.set("principal_point", "dy_px", d.dy_px)?;
        set.set("array_rotation", "dtheta_deg", d.dtheta_deg)?;
        let rho2 = d.rho_corner / cfg.corner_r2();
        set.set("lens_diattenuation", "rho2", rho2)?;
        let scene = sweep_scene(cfg, d.sun_az_deg);
        // Gain: the nominal sensor's peak response is `peak_dn` (paper: 153 DN).
        let resp = Response { dsnu_dn: d.dsnu_dn, ..Response::ideal(cfg.peak_dn / peak) };
        let frame = ChainFrame::new(
            &set.model(),
            &nominal,
            &scene,
            &resp,
            NoiseIndex { seed: cfg.seed, trial: trial as u32, frame: source as u32 },
        );
        let rec = Reconstructor::new(&Default::default(), 0.0, &cfg.channels)?;
        let ctx_unknown = HeadingContext::new(nominal, cfg.width_px, cfg.height_px, scene.sun_az_deg, scene.sun_el_deg);
        let ctx_known = source.involves_lens().then_some(HeadingContext { lens_rho2: rho2, ..ctx_unknown });
        let mut used = [false; 4];
        for c in &cfg.channels {
            used[c.index()] = true;
        }
        Ok(TrialSetup { source, trial, draw: d, scene, frame, rec, used, ctx_unknown, ctx_known })
    }

    /// The contexts the trial's sums are taken under: lens unknown, then known if any.
    pub fn contexts(&self) -> Vec<HeadingContext> {
        std::iter::once(self.ctx_unknown).chain(self.ctx_known).collect()
    }

    /// Solves every extractor from the trial's sums (`known` with ρ compensated).
    pub fn finish(&self, unknown: &HeadingSums, known: Option<&HeadingSums>) -> Result<TrialResult> {
        let mut errors = Vec::new();
        for e in Extractor::ALL {
            let est = unknown.solve(e, &self.ctx_unknown)?;
            errors.push((e, false, wrap_deg_180(est.heading_deg - self.scene.heading_deg)));
            if let (Some(ctx), Some(sums)) = (&self.ctx_known, known) {
                let est = sums.solve(e, ctx)?;
                errors.push((e, true, wrap_deg_180(est.heading_deg - self.scene.heading_deg)));
            }
        }
        Ok(TrialResult { source: self.source, trial: self.trial, draw: self.draw, errors })
    }
}

/// Runs one trial: simulate, reconstruct and extract, fused per pixel (no frame kept).
pub fn run_trial(cfg: &SweepConfig, source: Source, trial: usize) -> Result<TrialResult> {
    let peak = sweep_peak(cfg, draw(cfg, source, trial).sun_az_deg);
    let t = TrialSetup::new(cfg, source, trial, peak)?;
    let sums = colocated_heading_sums(&t.frame, cfg.width_px, cfg.height_px, t.used, &t.rec, &t.contexts());
    t.finish(&sums[0], sums.get(1))
}

/// Summarises trials into Table 3 rows: mean and sample standard deviation.
pub fn summarise(results: &[TrialResult]) -> Vec<Row> {
    let mut rows = Vec::new();
    for source in Source::ALL {
        let of_source: Vec<&TrialResult> = results.iter().filter(|r| r.source == source).collect();
        if of_source.is_empty() {
            continue;
        }
        for e in Extractor::ALL {
            let variants: &[Option<bool>] = if source.involves_lens() { &[Some(true), Some(false)] } else { &[None] };
            for &known in variants {
                let errs: Vec<f64> = of_source
                    .iter()
                    .flat_map(|r| {
                        r.errors.iter().filter(|(x, k, _)| *x == e && Some(*k) == known.or(Some(false))).map(|t| t.2)
                    })
                    .collect();
                let n = errs.len();
                let mean = errs.iter().sum::<f64>() / n as f64;
                let var =
                    if n > 1 { errs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64 } else { 0.0 };
                let (pm, ps) = paper_figures_deg(source, known);
                rows.push(Row {
                    source: source.name(),
                    extractor: e.name(),
                    lens_rho_known: known,
                    mean_deg: mean,
                    std_deg: var.sqrt(),
                    trials: n,
                    paper_mean_deg: pm,
                    paper_std_deg: ps,
                });
            }
        }
    }
    rows
}

/// Seed Table 3's (μ, σ) in degrees for a row of `source` with the lens ρ known
/// (`Some(true)`), unknown (`Some(false)`) or not involved (`None`): the paper's
/// figures are for its eq. 13 inversion, which knows ρ, so an unknown-ρ row has none.
pub fn paper_figures_deg(source: Source, lens_rho_known: Option<bool>) -> (Option<f64>, Option<f64>) {
    if lens_rho_known == Some(false) {
        (None, None)
    } else {
        source.paper_deg()
    }
}

/// Runs the whole sweep: every source, `trials_per_source` trials each, calling
/// `progress(done, total)` after each trial.
pub fn run_sweep(
    cfg: &SweepConfig,
    sources: &[Source],
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<TrialResult>> {
    let per = cfg.trials_per_source();
    let total = per * sources.len();
    let mut out = Vec::with_capacity(total);
    for (si, &s) in sources.iter().enumerate() {
        for t in 0..per {
            out.push(run_trial(cfg, s, t)?);
            progress(si * per + t + 1, total);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> SweepConfig {
        SweepConfig {
            width_px: 306,
            height_px: 256,
            pixel_pitch_um: 13.8,
            trials_per_azimuth: 2,
            sun_azimuths_deg: vec![10.0, 50.0],
            ..SweepConfig::default()
        }
    }

    #[test]
    fn paper_geometry_is_table_2() {
        let c = SweepConfig::default();
        let i = c.intrinsics();
        assert_eq!((i.cx_px, i.cy_px), (611.5, 511.5));
        assert_eq!((i.cx_px, i.cy_px), crate::conventions::xy_from_paper_row_col(512.5, 612.5));
        assert!((i.f_px - 2318.84).abs() < 0.01);
        assert_eq!(c.trials_per_source(), 160);
        assert_eq!(c.sun_azimuths_deg, vec![10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0]);
    }

    #[test]
    fn draws_touch_only_their_source_and_change_azimuth_every_block() {
        let c = SweepConfig::default();
        let d = draw(&c, Source::ArrayRotation, 0);
        assert!(d.dtheta_deg != 0.0 && d.dx_px == 0.0 && d.rho_corner == 0.0 && d.dsnu_dn == 0.0);
        let d = draw(&c, Source::Combined, 25);
        assert!(d.dtheta_deg != 0.0 && d.dx_px != 0.0 && d.rho_corner != 0.0 && d.dsnu_dn == 1.0);
        assert_eq!(d.sun_az_deg, 20.0);
        assert_eq!(draw(&c, Source::Combined, 159).sun_az_deg, 80.0);
    }

    #[test]
    fn known_lens_gives_zero_error_unknown_does_not_vanish_in_general() {
        let c = small();
        let r = run_trial(&c, Source::LensDiattenuation, 1).unwrap();
        for (e, known, err) in &r.errors {
            if *known {
                assert!(err.abs() < 1e-4, "{e:?}: known ρ should leave no error, got {err}°");
            }
        }
    }

    #[test]
    fn sweep_is_reproducible_and_thread_count_independent() {
        let c = small();
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| run_sweep(&c, &[Source::ChannelResponse], &|_, _| {}).unwrap())
        };
        let (a, b) = (run(1), run(2));
        assert_eq!(a, b);
        let rows = summarise(&a);
        assert_eq!(rows.len(), 2);
        assert!(rows.iter().all(|r| r.trials == 4 && r.std_deg > 0.0 && r.paper_std_deg == Some(0.0405)));
    }
}
