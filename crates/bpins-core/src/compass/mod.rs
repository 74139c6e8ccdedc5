//! The front door for a robot: a [`Compass`] built once from the camera, the sensor
//! and a calibration; per frame it takes the raw mosaic as the camera delivers it
//! (borrowed `u8`, `u16` or `f32` with a row stride, no copy), the sun (angles, or a
//! Unix time and a place: the sun through NREL SPA by day, the moon at night where it
//! lights the sky, as `bpins heading` reads a capture) and the attitude with its 1σ,
//! and returns the heading with an honest 1σ, how much of the sky it used and which
//! source lit it ([`FieldHeading::source`]), or why there is none (the field
//! estimator, [`crate::heading::field`]).
//!
//! ```
//! use bpins_core::compass::{Attitude, Compass, CompassConfig, Sun};
//! use bpins_core::camera::{Intrinsics, Projection};
//! use bpins_core::compass::RawImage;
//! # use bpins_core::twin::{ChainFrame, NoiseIndex, Scene};
//! # use bpins_core::sensor::{Response, DEFAULT_MOSAIC};
//! # let (w, h) = (306, 256);
//! # let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
//! # let scene = Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 2.0, tilt_y_deg: -1.0, dmax: 0.6 };
//! # let f = ChainFrame::new(&Default::default(), &lens, &scene, &Response::samples(2400.0), NoiseIndex { seed: 1, trial: 0, frame: 0 });
//! # let raw: Vec<u16> = bpins_core::twin::render_mosaic(&f, w, h, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect();
//! // Once: the camera (an IMX250MZR-like DoFP sensor behind an 8 mm lens, binned) and
//! // its calibration (here none: `Calibration::load("calibration.toml")` for a real one).
//! let mut compass = Compass::new(CompassConfig::dofp(
//!     Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5),
//!     306, 256, 12, 64.0,
//! ))?;
//! // Per frame: the camera's buffer, the sun, the IMU's attitude.
//! let fix = compass.heading(
//!     RawImage { data: &raw, width_px: 306, height_px: 256, stride: 306 },
//!     Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 },
//!     Attitude { tilt_x_deg: 2.0, tilt_y_deg: -1.0, sigma_deg: 0.1 },
//! )?;
//! let (heading_deg, sigma_deg) = (fix.heading_deg().unwrap(), fix.sigma_deg().unwrap());
//! assert!((heading_deg - 30.0).abs() < 2.0 * sigma_deg);
//! # Ok::<(), bpins_core::compass::CompassError>(())
//! ```
//!
//! Frame: the camera's (CONVENTIONS.md); the attitude is the frame's tilt about the
//! camera's x then y axis (an IMU's roll and pitch in that convention), the heading
//! the azimuth of the image top, degrees from North toward East in [0°, 360°).
//! Errors are typed ([`CompassError`]); nothing here panics on input or aborts the
//! host: buffers that do not match the sensor are refused with their sizes.
//!
//! Where things live: this file, the [`Compass`] itself (built once, one call per live
//! frame) and the one place a frame's heading context is made; `inputs.rs`, what it is
//! given and how it refuses it ([`CompassConfig`], [`Sun`], [`Attitude`],
//! [`CompassError`]); `capture.rs`, a capture's frames through the same compass;
//! `tests.rs`, the tests.

/// The sun one frame's sky shows, with 1σ (what `bpins_core::measure` reads for `locate`).
pub use crate::heading::field::SkySun;
pub use crate::heading::field::{
    FieldHeading, FieldOptions, FieldQuality, FittedShare, NoHeading, RawDn, RawImage, SecondSource, SigmaParts,
};
pub use crate::heading::Extractor;
pub use crate::sky::twilight::{Dominant, Shares};
pub use crate::sky::SkySource;
pub use colour::ColourFix;
pub use inputs::{Attitude, CompassConfig, CompassError, Sun};

use crate::camera::Intrinsics;
use crate::effects::Model;
use crate::heading::field::{self, Cells, FieldContext, FieldScratch};
use crate::pixel_analyzers::CellAnalyzers;
use crate::recon::Reconstructor;
use crate::sensor::{Band, Channel, ColourTiles};
#[cfg(feature = "spa")]
use crate::sky::{moon::MOON_POSITION_SIGMA_DEG, Refusal, SunAndMoon};
use inputs::{check_attitude, check_sun};

mod colour;
mod inputs;

/// A colocated capture's planes: their inversion and the cell size (`capture.rs`).
#[cfg_attr(not(feature = "io"), allow(dead_code))]
struct Colocated {
    rec: Reconstructor,
    cell_px: usize,
}

/// Live frames in, headings out: build once, then one call per frame (the module's
/// example shows a whole frame). Holds its buffers between frames, so a warm compass
/// (monochrome or colour) allocates nothing in [`Compass::heading`], its sun given by
/// angles or by clock and place, when its loop runs on a rayon pool's worker
/// (`pool.install(|| loop { .. })`); called from another thread, rayon's global job
/// queue allocates a 1.5 KB block per 63 parallel steps, a few per hundred frames
/// (`tests/allocations.rs`). One compass per camera and thread (it is `Send`).
///
/// ```
/// # use bpins_core::camera::{Intrinsics, Projection};
/// # use bpins_core::compass::{Attitude, Compass, CompassConfig, CompassError, Sun};
/// # use bpins_core::compass::RawImage;
/// # let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
/// # let scene = bpins_core::twin::Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
/// # let f = bpins_core::twin::ChainFrame::new(&Default::default(), &lens, &scene, &bpins_core::sensor::Response::samples(2400.0), bpins_core::twin::NoiseIndex { seed: 1, trial: 0, frame: 0 });
/// # let raw: Vec<u16> = bpins_core::twin::render_mosaic(&f, 306, 256, &bpins_core::sensor::DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect();
/// let mut compass = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0))?;
/// let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
/// let fix = compass.heading(RawImage::packed(&raw, 306, 256), sun, Attitude::default())?;
/// match &fix.result {
///     Ok((heading_deg, sigma)) => assert!((heading_deg - 30.0).abs() < 3.0 * sigma.total_deg()),
///     Err(why) => panic!("no heading: {why}"),
/// }
/// fn shared<T: Send>(_: &T) {}
/// shared(&compass);
/// # Ok::<(), CompassError>(())
/// ```
pub struct Compass {
    cfg: CompassConfig,
    known: Model,
    intr: Intrinsics,
    rec: Reconstructor,
    full_scale_dn: f64,
    cell_px: usize,
    /// Each cell's own reconstruction where the calibration has per-pixel maps.
    cell_analyzers: Option<CellAnalyzers>,
    /// A colour sensor's: each band's cells' own (by `Band::index`), from its pixels' maps.
    band_analyzers: [Option<CellAnalyzers>; 3],
    /// A colocated capture's reconstruction (`None`: DoFP; `capture.rs`).
    #[cfg_attr(not(feature = "io"), allow(dead_code))]
    colocated: Option<Colocated>,
    /// The last frame's cells and the estimator's buffers, reused: no allocation per
    /// frame once they have grown to the sensor's grid.
    cells: Cells,
    /// A colour frame's cells per band (by `Band::index`) and their band ratio.
    band_cells: [Cells; 3],
    tint: Vec<f64>,
    scratch: FieldScratch,
}

impl Compass {
    /// Checks the configuration and prepares what every frame shares.
    pub fn new(cfg: CompassConfig) -> Result<Compass, CompassError> {
        let known = cfg.calibration.model();
        Compass::with_known(cfg, known)
    }

    /// [`Compass::new`] with the known effects given as the chain's parameter block
    /// rather than as `cfg.calibration`'s (whose per-pixel maps are still used).
    fn with_known(cfg: CompassConfig, known: Model) -> Result<Compass, CompassError> {
        let bad = |m: String| Err(CompassError::Config(m));
        if cfg.width_px < 4 || cfg.height_px < 4 {
            return bad(format!("sensor of {} × {} px: at least 4 × 4", cfg.width_px, cfg.height_px));
        }
        if !(1..=16).contains(&cfg.bit_depth) {
            return bad(format!("bit depth {} outside 1…16", cfg.bit_depth));
        }
        let full_scale_dn = ((1u32 << cfg.bit_depth) - 1) as f64;
        if !(cfg.black_level_dn >= 0.0 && cfg.black_level_dn < full_scale_dn) {
            return bad(format!("black level {} DN outside [0, {full_scale_dn})", cfg.black_level_dn));
        }
        let c = &cfg.camera;
        if !(c.f_px > 0.0 && c.f_px.is_finite()) {
            return bad(format!(
                "focal length {} px must be a finite number > 0 (the lens's focal length over the pixel pitch)",
                c.f_px
            ));
        }
        if !(c.cx_px.is_finite() && c.cy_px.is_finite()) {
            return bad(format!(
                "principal point ({}, {}) px must be finite (usually near the image centre)",
                c.cx_px, c.cy_px
            ));
        }
        let intr = known.camera(c);
        let rec = Reconstructor::new(&known, cfg.black_level_dn, &Channel::ALL)?;
        let cell_px = cfg.options.cell_px.unwrap_or_else(|| Cells::default_cell_px(cfg.width_px, cfg.height_px));
        let cell_px = (cell_px.max(2) + 1) & !1;
        // A colour sensor's cells are whole 4 × 4 superpixels, so that each holds every
        // band, and at least two of them each way, so that each channel of a band has
        // the places to fit the plane that moves its mean to the cell's centre (in one
        // superpixel R's and B's channels have one pixel each, a pixel off the centre).
        let cell_px = if cfg.colour.is_some() { cell_px.div_ceil(4).max(2) * 4 } else { cell_px };
        let (mut cell_analyzers, mut band_analyzers) = (None, <[Option<CellAnalyzers>; 3]>::default());
        if let Some(px) = &cfg.calibration.pixels {
            if let Some(m) = cfg.calibration.pixels_conflict() {
                return bad(m);
            }
            px.check_sensor(cfg.width_px, cfg.height_px, &cfg.mosaic).map_err(CompassError::Config)?;
            match &cfg.colour {
                // A colour sensor's bands each through their own pixels' maps, on the band's grid.
                Some(colour) => {
                    for b in colour.bands() {
                        let cal = px.cell_analyzers_band(colour.classes(b), cell_px, cfg.black_level_dn);
                        band_analyzers[b.index()] = Some(cal);
                    }
                }
                None => cell_analyzers = Some(px.cell_analyzers(cell_px, cfg.black_level_dn)),
            }
        }
        Ok(Compass {
            cfg,
            known,
            intr,
            rec,
            full_scale_dn,
            cell_px,
            cell_analyzers,
            band_analyzers,
            colocated: None,
            cells: Cells::default(),
            band_cells: Default::default(),
            tint: Vec::new(),
            scratch: FieldScratch::default(),
        })
    }

    /// The heading of one raw DoFP frame under `sun` at `attitude`.
    pub fn heading<T: RawDn>(
        &mut self,
        frame: RawImage<T>,
        sun: Sun,
        attitude: Attitude,
    ) -> Result<FieldHeading, CompassError> {
        self.check_size(&frame)?;
        let sun = resolve_sun(sun)?;
        check_attitude(&attitude)?;
        if let Some(mut refused) = sun.refused(&[self.cfg.extractor]) {
            return Ok(refused.remove(0));
        }
        let ctx = field_context(self.intr, &self.known, sun.angles, &attitude);
        let mut h = if self.cfg.colour.is_some() {
            // Band by band, with both sources in a mixed twilight (`colour.rs`).
            self.band_heading(&frame, &ctx, sun.second.as_ref())
        } else if let Some(second) = &sun.second {
            // A mixed twilight: read with both sources on the compass's buffers (no
            // allocation once warm).
            self.fill_mosaic_cells(&frame);
            let opts = &self.cfg.options;
            field::estimate_two_with(&self.cells, &ctx, second, opts, self.cfg.extractor, &mut self.scratch)
        } else {
            self.fill_mosaic_cells(&frame);
            field::estimate_with(&self.cells, &ctx, &self.cfg.options, self.cfg.extractor, &mut self.scratch)
        };
        h.source = sun.source;
        Ok(h)
    }

    /// [`Compass::heading`] with each of `extractors` (the robust loop runs once; each
    /// extractor solves on its final weights), in their order: `bpins heading
    /// --extractor all` on any frame source.
    pub fn headings<T: RawDn>(
        &mut self,
        frame: RawImage<T>,
        sun: Sun,
        attitude: Attitude,
        extractors: &[Extractor],
    ) -> Result<Vec<FieldHeading>, CompassError> {
        self.check_size(&frame)?;
        let sun = resolve_sun(sun)?;
        check_attitude(&attitude)?;
        if let Some(refused) = sun.refused(extractors) {
            return Ok(refused);
        }
        let ctx = field_context(self.intr, &self.known, sun.angles, &attitude);
        if self.cfg.colour.is_some() {
            return Ok(sun.stamped(self.bands(&frame, &ctx, extractors, sun.second.as_ref()).fused));
        }
        if let Some(hs) = self.mixed(&frame, &sun, &ctx, extractors) {
            return Ok(hs);
        }
        self.fill_mosaic_cells(&frame);
        let hs = field::estimate_many_with(&self.cells, &ctx, &self.cfg.options, extractors, &mut self.scratch);
        Ok(sun.stamped(hs))
    }

    /// A colour-polarization frame's headings: each band's from its own pixels, with
    /// each of `extractors`, and their fused heading ([`ColourFix`]; `colour.rs`). A
    /// monochrome compass (`CompassConfig::colour` `None`) refuses.
    pub fn colour_headings<T: RawDn>(
        &mut self,
        frame: RawImage<T>,
        sun: Sun,
        attitude: Attitude,
        extractors: &[Extractor],
    ) -> Result<ColourFix, CompassError> {
        if self.cfg.colour.is_none() {
            return Err(CompassError::Config(
                "colour headings of a monochrome sensor: give CompassConfig::colour (the sensor's colour_tiles)".into(),
            ));
        }
        self.check_size(&frame)?;
        let sun = resolve_sun(sun)?;
        check_attitude(&attitude)?;
        let bands = self.cfg.colour.as_ref().map_or_else(Vec::new, |c| c.bands());
        if let Some(refused) = sun.refused(extractors) {
            let bands = bands.into_iter().map(|b| (b, refused.clone())).collect();
            return Ok(ColourFix { bands, fused: refused });
        }
        let ctx = field_context(self.intr, &self.known, sun.angles, &attitude);
        let fix = self.bands(&frame, &ctx, extractors, sun.second.as_ref());
        let bands = fix.bands.into_iter().map(|(b, hs)| (b, sun.stamped(hs))).collect();
        Ok(ColourFix { bands, fused: sun.stamped(fix.fused) })
    }

    /// Whether the sensor is a colour-polarization one (bands read apart and fused).
    pub fn is_colour(&self) -> bool {
        self.cfg.colour.is_some()
    }

    /// The extractor [`Compass::heading`] reads with.
    pub fn extractor(&self) -> Extractor {
        self.cfg.extractor
    }

    /// Each band's cells and headings, and the fused headings (a colour compass); a
    /// mixed twilight's (`second` set) each band read with both sources, its own share
    /// fitted (`colour.rs`).
    fn bands<T: RawDn>(
        &mut self,
        frame: &RawImage<T>,
        ctx: &FieldContext,
        extractors: &[Extractor],
        second: Option<&SecondSource>,
    ) -> ColourFix {
        let colour = self.fill_bands(frame);
        let mut bands = Vec::new();
        for b in colour.bands() {
            let cells = &mut self.band_cells[b.index()];
            let (opts, scratch) = (&self.cfg.options, &mut self.scratch);
            let hs = match second {
                Some(s) => field::estimate_two(cells, ctx, s, opts, extractors, scratch),
                None => field::estimate_many_with(cells, ctx, opts, extractors, scratch),
            };
            bands.push((b, hs));
        }
        let fused = (0..extractors.len()).map(|i| colour::fuse_bands(extractors[i], &bands, i)).collect();
        ColourFix { bands, fused }
    }

    /// [`Compass::bands`]' fused heading of the compass's one extractor, without a list:
    /// each band's heading on the stack (R, G, B by `Band::index`), fused in place, the
    /// green band's fitted share where the fused reading has a heading (`fuse_bands`).
    /// The same numbers, bit for bit; nothing allocated once warm (`Compass::heading`).
    fn band_heading<T: RawDn>(
        &mut self,
        frame: &RawImage<T>,
        ctx: &FieldContext,
        second: Option<&SecondSource>,
    ) -> FieldHeading {
        let colour = self.fill_bands(frame);
        let extractor = self.cfg.extractor;
        let mut hs: [Option<FieldHeading>; 3] = [None, None, None];
        for b in Band::ALL.into_iter().filter(|&b| colour.has(b)) {
            let cells = &mut self.band_cells[b.index()];
            let (opts, scratch) = (&self.cfg.options, &mut self.scratch);
            hs[b.index()] = Some(match second {
                Some(s) => field::estimate_two_with(cells, ctx, s, opts, extractor, scratch),
                None => field::estimate_with(cells, ctx, opts, extractor, scratch),
            });
        }
        let present = hs.iter().flatten();
        let first = present.clone().next().expect("a colour sensor has bands");
        let mut refs = [first; 3];
        let n = present.zip(refs.iter_mut()).map(|(h, r)| *r = h).count();
        let mut fused = colour::fuse(extractor, &refs[..n]);
        if fused.result.is_ok() {
            fused.fitted_share = hs[Band::G.index()].as_ref().and_then(|h| h.fitted_share);
        }
        fused
    }

    /// Each band's cells of `frame` from its own pixels, every band's cloud tests given
    /// the frame's red-to-blue ratio; the sensor's colour tiles.
    fn fill_bands<T: RawDn>(&mut self, frame: &RawImage<T>) -> ColourTiles {
        let colour = self.cfg.colour.clone().expect("a colour compass");
        for b in Band::ALL.into_iter().filter(|&b| colour.has(b)) {
            let (cells, classes) = (&mut self.band_cells[b.index()], colour.classes(b));
            match &self.band_analyzers[b.index()] {
                Some(cal) => cells.fill_from_mosaic_band_calibrated(
                    frame,
                    &self.cfg.mosaic,
                    classes,
                    cal,
                    self.full_scale_dn,
                    &mut self.scratch.cells,
                ),
                None => cells.fill_from_mosaic_band(
                    frame,
                    &self.cfg.mosaic,
                    classes,
                    &self.rec,
                    self.full_scale_dn,
                    self.cell_px,
                    &mut self.scratch.cells,
                ),
            }
        }
        // Every band's cloud tests see the frame's red-to-blue ratio (white clouds).
        let [r, _, bl] = &self.band_cells;
        Cells::tint_of(r, bl, &mut self.tint);
        for cells in &mut self.band_cells {
            cells.tint.clone_from(&self.tint);
        }
        colour
    }

    /// Whether `frame` is a buffer of the sensor's size: refused with its sizes if not.
    fn check_size<T>(&self, frame: &RawImage<T>) -> Result<(), CompassError> {
        let (w, h) = (self.cfg.width_px, self.cfg.height_px);
        if frame.width_px != w || frame.height_px != h || !frame.is_consistent() {
            return Err(CompassError::FrameSize {
                got_w: frame.width_px,
                got_h: frame.height_px,
                stride: frame.stride,
                len: frame.data.len(),
                want_w: w,
                want_h: h,
            });
        }
        Ok(())
    }

    /// A mixed twilight's readings (`sun.second` set) of a monochrome frame: its cells
    /// read with both sources (`heading::field::two_sources`); `None` where the sky has
    /// one source (a colour frame's: [`Compass::bands`]).
    fn mixed<T: RawDn>(
        &mut self,
        frame: &RawImage<T>,
        sun: &Resolved,
        ctx: &FieldContext,
        extractors: &[Extractor],
    ) -> Option<Vec<FieldHeading>> {
        let second = sun.second.as_ref()?;
        self.fill_mosaic_cells(frame);
        let hs = field::estimate_two(&self.cells, ctx, second, &self.cfg.options, extractors, &mut self.scratch);
        Some(sun.stamped(hs))
    }

    /// Fills `self.cells` from a DoFP frame of the sensor's size (checked by the caller).
    fn fill_mosaic_cells<T: RawDn>(&mut self, frame: &RawImage<T>) {
        match &self.cell_analyzers {
            Some(cal) => self.cells.fill_from_mosaic_calibrated(
                frame,
                &self.cfg.mosaic,
                cal,
                self.full_scale_dn,
                &mut self.scratch.cells,
            ),
            None => self.cells.fill_from_mosaic(
                frame,
                &self.cfg.mosaic,
                &self.rec,
                self.full_scale_dn,
                self.cell_px,
                &mut self.scratch.cells,
            ),
        }
    }
}

/// A frame's sun as the estimator takes it, the source that lit the sky, and why the
/// sky cannot be read where it cannot.
pub(super) struct Resolved {
    /// Azimuth, elevation and 1σ, degrees.
    pub angles: (f64, f64, f64),
    pub source: SkySource,
    /// A time and place whose sky is not read (a dark night).
    pub refusal: Option<NoHeading>,
    /// A mixed twilight's other source, read beside the frame's (`two_sources.rs`).
    pub second: Option<SecondSource>,
}

impl Resolved {
    /// Each extractor's reading of a frame that is not read, with the reason, or `None`
    /// where it is read.
    fn refused(&self, extractors: &[Extractor]) -> Option<Vec<FieldHeading>> {
        let why = self.refusal.as_ref()?;
        let no = |&extractor: &Extractor| FieldHeading {
            extractor,
            result: Err(why.clone()),
            quality: FieldQuality::default(),
            source: self.source,
            fitted_share: None,
        };
        Some(extractors.iter().map(no).collect())
    }

    /// `hs`, each saying which source lit the sky.
    fn stamped(&self, mut hs: Vec<FieldHeading>) -> Vec<FieldHeading> {
        for h in &mut hs {
            h.source = self.source;
        }
        hs
    }
}

/// `sun` checked, with its source. Angles are given ([`SkySource::Given`]); a time and
/// a place go through the capture reader's rule on numbers (`sky::SunAndMoon`, the
/// computation `sky::source_and_shares_from_unix_time` and `sky::refusal` wrap): the
/// sun by day and in a twilight it dominates, the moon at night where it is up and
/// its sky gives ≥ 99 % of the light (its 1σ the caller's ⊕ the ephemeris's
/// [`MOON_POSITION_SIGMA_DEG`]), a twilight lit by both read with both
/// ([`Resolved::second`], `Shares::reads_both`), a dark night refused
/// ([`NoHeading::DarkNight`]).
pub(super) fn resolve_sun(sun: Sun) -> Result<Resolved, CompassError> {
    match sun {
        Sun::Angles { azimuth_deg, elevation_deg, sigma_deg } => {
            check_sun(azimuth_deg, elevation_deg, sigma_deg)?;
            let angles = (azimuth_deg, elevation_deg, sigma_deg);
            Ok(Resolved { angles, source: SkySource::Given, refusal: None, second: None })
        }
        #[cfg(feature = "spa")]
        Sun::UnixTime { time_s, latitude_deg, longitude_deg, sigma_deg } => {
            // Both bodies and their shares as numbers, each ephemeris run once and no
            // timestamp text built: nothing allocated per frame. A clock or place refused
            // builds its error's text (not the per-frame path).
            let both = SunAndMoon::at_unix_time(time_s, latitude_deg, longitude_deg)
                .map_err(|e| CompassError::Sun(e.to_string()))?;
            let ((azimuth_deg, elevation_deg), shares) = (both.source_deg(), both.shares);
            check_sun(azimuth_deg, elevation_deg, sigma_deg)?;
            // A twilight lit by both is read with both sources (the other body from the
            // same clock and place); a dark night refused.
            let (refusal, second) = match both.refusal() {
                Some(Refusal::Dark(shares)) => (Some(NoHeading::DarkNight { shares }), None),
                _ if shares.reads_both() => (None, Some(second_source(&both))),
                _ => (None, None),
            };
            let (source, sigma_deg) = if both.moon_is_source() {
                (SkySource::Moon(shares), sigma_deg.hypot(MOON_POSITION_SIGMA_DEG))
            } else {
                (SkySource::Sun(shares), sigma_deg)
            };
            Ok(Resolved { angles: (azimuth_deg, elevation_deg, sigma_deg), source, refusal, second })
        }
    }
}

/// The other source of a mixed twilight, beside the frame's source (`both`'s): its
/// azimuth and elevation, and the frame's source's share of the two skies' polarized
/// radiance ([`Shares::sun_unit_share`]).
#[cfg(feature = "spa")]
fn second_source(both: &SunAndMoon) -> SecondSource {
    let (shares, w_sun) = (both.shares, both.shares.sun_unit_share());
    if both.moon_is_source() {
        let (azimuth_deg, elevation_deg) = (both.sun_azimuth_deg, both.sun_elevation_deg);
        SecondSource { azimuth_deg, elevation_deg, share: 1.0 - w_sun, shares }
    } else {
        let (azimuth_deg, elevation_deg) = (both.moon.azimuth_deg, both.moon.elevation_deg);
        SecondSource { azimuth_deg, elevation_deg, share: w_sun, shares }
    }
}

/// What the field estimator knows about a frame: the camera `intr` as calibrated, the
/// known lens diattenuation and mount tilt of `known`, the sun `(azimuth, elevation,
/// 1σ)` in degrees and the reference attitude. The one place a heading's context is
/// made: the compass's frames, a capture's (`bpins heading`), the fit's masks and the
/// locator's sun all take theirs from here.
pub(crate) fn field_context(
    intr: Intrinsics,
    known: &Model,
    sun: (f64, f64, f64),
    attitude: &Attitude,
) -> FieldContext {
    FieldContext {
        intr,
        lens_rho2: crate::effects::lens_diattenuation::rho2(known),
        sun_az_deg: sun.0,
        sun_el_deg: sun.1,
        sun_sigma_deg: sun.2,
        tilt_x_deg: attitude.tilt_x_deg,
        tilt_y_deg: attitude.tilt_y_deg,
        tilt_sigma_deg: attitude.sigma_deg,
        mount_tilt_deg: known.geometry.mount_tilt_deg,
    }
}

#[cfg(feature = "io")]
mod capture;
#[cfg(test)]
mod tests;
