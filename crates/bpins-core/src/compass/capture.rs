//! A capture's frames through the compass: `bpins heading`'s road to a heading is a
//! robot's ([`Compass::heading`]). The compass is made from `capture.toml`'s camera,
//! sensor and layout (DoFP, or colocated planes); each frame's sun and reference
//! attitude come from its `[[frames]]` entry; the cells, the context and the estimator
//! are the compass's own.

use super::*;
use crate::calibration::Calibration;
use crate::capture::{Capture, FrameData, FrameSpec};
use crate::sensor::{Layout, DEFAULT_MOSAIC};

impl Compass {
    /// A compass for the frames of capture `c` (`capture.toml`: its camera, sensor
    /// and layout, DoFP or colocated), compensating `calibration`, with the field
    /// estimator's `options` and `extractor`: `bpins heading`'s road to a heading,
    /// the same as a robot's ([`Compass::capture_frame`] per frame).
    pub fn for_capture(
        c: &Capture,
        calibration: Calibration,
        options: FieldOptions,
        extractor: Extractor,
    ) -> Result<Compass, CompassError> {
        let known = calibration.model();
        Compass::for_capture_known(c, calibration, known, options, extractor)
    }

    /// [`Compass::for_capture`] with the known effects as a parameter block (the fit's,
    /// the locator's and `pipeline`'s callers hold a [`Model`]).
    pub(crate) fn for_capture_known(
        c: &Capture,
        calibration: Calibration,
        known: Model,
        options: FieldOptions,
        extractor: Extractor,
    ) -> Result<Compass, CompassError> {
        let s = &c.sensor;
        let g = &s.geometry;
        let mosaic = match &s.layout {
            Layout::Dofp { mosaic } => *mosaic,
            Layout::Colocated { .. } => DEFAULT_MOSAIC,
        };
        let cfg = CompassConfig {
            camera: c.intrinsics(),
            width_px: g.width_px as usize,
            height_px: g.height_px as usize,
            mosaic,
            bit_depth: s.bit_depth,
            black_level_dn: s.black_level_dn,
            calibration,
            options,
            extractor,
            colour: s.colour.clone(),
        };
        let mut compass = Compass::with_known(cfg, known)?;
        if let Layout::Colocated { channels } = &s.layout {
            if compass.cfg.calibration.pixels.is_some() {
                return Err(CompassError::Config(
                    "per-pixel maps are for a dofp mosaic; this capture is colocated".into(),
                ));
            }
            // Colocated cells are not bound to a 2 × 2 tile: the size as given.
            let cell_px = (compass.cfg.options.cell_px)
                .unwrap_or_else(|| Cells::default_cell_px(compass.cfg.width_px, compass.cfg.height_px));
            let rec = Reconstructor::new(&compass.known, s.black_level_dn, channels)?;
            compass.colocated = Some(Colocated { rec, cell_px });
        }
        Ok(compass)
    }

    /// The field headings of frame `f` of the capture this compass was made for
    /// ([`Compass::for_capture`]), its pixels `data` in memory, with each of
    /// `extractors` (the robust loop runs once): the sun and the reference tilt with
    /// their 1σ as the frame's entry gives them; each reading's source is the entry's
    /// (the sun or the moon with their shares where it has a time and place).
    pub fn capture_frame(
        &mut self,
        data: &FrameData,
        f: &FrameSpec,
        extractors: &[Extractor],
    ) -> Result<Vec<FieldHeading>, CompassError> {
        let sun = Sun::Angles {
            azimuth_deg: f.sun.azimuth_deg,
            elevation_deg: f.sun.elevation_deg,
            sigma_deg: f.sun_sigma_deg.unwrap_or(0.0),
        };
        let attitude = Attitude {
            tilt_x_deg: f.tilt_x_deg.unwrap_or(0.0),
            tilt_y_deg: f.tilt_y_deg.unwrap_or(0.0),
            sigma_deg: f.tilt_sigma_deg.unwrap_or(0.0),
        };
        let mut hs = self.capture_headings(data, sun, attitude, extractors)?;
        // The entry's angles are given to the compass; which source they are is the entry's.
        #[cfg(feature = "spa")]
        let source = crate::sky::SkySource::of(&f.sun);
        #[cfg(not(feature = "spa"))]
        let source = crate::sky::SkySource::Given;
        for h in &mut hs {
            h.source = source;
        }
        Ok(hs)
    }

    /// The field headings of a capture's frame `data` (a DoFP mosaic or colocated
    /// planes, as [`Capture::read_frame`] gives them) under `sun` at `attitude`, with
    /// each of `extractors`: [`Compass::headings`] for the frames of a capture, whose
    /// sun and attitude the caller took from the frame's entry or elsewhere.
    pub fn capture_headings(
        &mut self,
        data: &FrameData,
        sun: Sun,
        attitude: Attitude,
        extractors: &[Extractor],
    ) -> Result<Vec<FieldHeading>, CompassError> {
        if self.cfg.colour.is_some() {
            return Ok(self.capture_colour_headings(data, sun, attitude, extractors)?.fused);
        }
        let sun = resolve_sun(sun)?;
        check_attitude(&attitude)?;
        if let Some(refused) = sun.refused(extractors) {
            return Ok(refused);
        }
        self.fill_capture_cells(data)?;
        let ctx = field_context(self.intr, &self.known, sun.angles, &attitude);
        // A mixed twilight: both sources (`two_sources.rs`).
        if let Some(second) = &sun.second {
            let opts = &self.cfg.options;
            return Ok(sun.stamped(field::estimate_two(
                &self.cells,
                &ctx,
                second,
                opts,
                extractors,
                &mut self.scratch,
            )));
        }
        let hs = field::estimate_many_with(&self.cells, &ctx, &self.cfg.options, extractors, &mut self.scratch);
        Ok(sun.stamped(hs))
    }

    /// [`Compass::colour_headings`] of a colour capture's frame `data` (its DoFP mosaic).
    pub fn capture_colour_headings(
        &mut self,
        data: &FrameData,
        sun: Sun,
        attitude: Attitude,
        extractors: &[Extractor],
    ) -> Result<ColourFix, CompassError> {
        let (w, h) = data.size_px();
        match data {
            FrameData::Mosaic { dn, .. } => {
                self.colour_headings(RawImage::packed(dn.as_slice(), w as usize, h as usize), sun, attitude, extractors)
            }
            _ => Err(CompassError::Config("a colour-polarization frame is a DoFP mosaic".into())),
        }
    }

    /// The cells of a capture's frame `data`, the known effects undone, as the
    /// compass reads them (the fit's and the locator's cells).
    pub(crate) fn capture_cells(&mut self, data: &FrameData) -> Result<Cells, CompassError> {
        self.fill_capture_cells(data)?;
        Ok(std::mem::take(&mut self.cells))
    }

    /// Fills `self.cells` from a capture's frame: a mosaic of a DoFP capture, or the
    /// planes of a colocated one; anything else is refused with its sizes.
    fn fill_capture_cells(&mut self, data: &FrameData) -> Result<(), CompassError> {
        let (w, h) = data.size_px();
        let (w, h) = (w as usize, h as usize);
        match (data, &self.colocated) {
            (FrameData::Mosaic { dn, .. }, None) => {
                let img = RawImage::packed(dn.as_slice(), w, h);
                self.check_size(&img)?;
                self.fill_mosaic_cells(&img);
                Ok(())
            }
            (FrameData::Colocated { channels, .. }, Some(co)) => {
                let mut planes = Vec::with_capacity(channels.len());
                for (ch, p) in channels {
                    let img = RawImage::packed(p.as_slice(), w, h);
                    self.check_size(&img)?;
                    planes.push((*ch, img));
                }
                self.cells = Cells::from_colocated(&planes, &co.rec, self.full_scale_dn, co.cell_px);
                Ok(())
            }
            _ => Err(CompassError::Config("frame data does not match the capture's sensor layout".into())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::frame;
    use super::*;
    use crate::camera::Projection;

    /// One road: a capture's frame read through [`Compass::for_capture`] (what `bpins
    /// heading` and `pipeline::field_headings_of` do) is bit for bit the robot's
    /// [`Compass::heading`] on the same pixels, sun and attitude; a frame of another
    /// size is refused with its sizes, not read.
    #[test]
    fn a_captures_frame_reads_as_the_robots_frame() {
        use crate::capture::{Capture, FrameData, FrameSpec, LensSpec, SensorSpec};
        use crate::effects::EffectSet;
        use crate::sensor::Geometry;
        use crate::sky::sun::SunPosition;
        // A sensor whose array is turned by 0.2°, and its calibration.
        let mut cal = EffectSet::new();
        cal.set("array_rotation", "dtheta_deg", 0.2).unwrap();
        let (raw, lens) = frame(&cal.model(), [2.0, -1.0]);
        let capture = Capture {
            dir: "/nowhere".into(),
            sensor: SensorSpec {
                colour: None,
                layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
                geometry: Geometry { width_px: 306, height_px: 256, pixel_pitch_um: 27.6 },
                bit_depth: 12,
                black_level_dn: 64.0,
            },
            lens: LensSpec {
                projection: Projection::Pinhole,
                focal_length_mm: 8.0,
                principal_point_px: (152.5, 127.5),
            },
            frames: vec![FrameSpec {
                heading_deg: Some(30.0),
                tilt_x_deg: Some(2.0),
                tilt_y_deg: Some(-1.0),
                tilt_sigma_deg: Some(0.1),
                sun_sigma_deg: Some(0.02),
                ..FrameSpec::new("f.png", SunPosition::given(40.0, 25.0))
            }],
        };
        assert_eq!(capture.intrinsics(), lens);
        let data = FrameData::Mosaic { width_px: 306, height_px: 256, dn: raw.iter().map(|&x| x as f32).collect() };
        let calibration = Calibration { effects: cal, ..Default::default() };
        let extractors = [Extractor::SunVector, Extractor::MeridianLine];
        let mut road =
            Compass::for_capture(&capture, calibration.clone(), FieldOptions::default(), Extractor::SunVector).unwrap();
        let read = road.capture_frame(&data, &capture.frames[0], &extractors).unwrap();
        for (e, got) in extractors.iter().zip(&read) {
            let cfg = CompassConfig {
                calibration: calibration.clone(),
                extractor: *e,
                ..CompassConfig::dofp(lens, 306, 256, 12, 64.0)
            };
            let robot = Compass::new(cfg).unwrap().heading(
                RawImage::packed(&raw, 306, 256),
                Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.02 },
                Attitude { tilt_x_deg: 2.0, tilt_y_deg: -1.0, sigma_deg: 0.1 },
            );
            assert_eq!(got, &robot.unwrap(), "{}", e.name());
        }
        let (h, sigma) = (read[0].heading_deg().unwrap(), read[0].sigma_deg().unwrap());
        assert!((h - 30.0).abs() < 2.0 * sigma, "{h} ± {sigma}");
        let small = FrameData::Mosaic { width_px: 300, height_px: 256, dn: vec![100.0; 300 * 256] };
        let m = road.capture_frame(&small, &capture.frames[0], &extractors).unwrap_err().to_string();
        assert!(m.contains("300 × 256") && m.contains("306 × 256"), "{m}");
    }
}
