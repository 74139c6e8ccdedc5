//! What is constant over one frame of the chain, computed once on the host: the
//! [`Scene`] it looks at, the [`ChainFrame`] the per-pixel functions read (the model
//! folded into the nominal camera and the scene; the WGSL twin is `FrameParams` and
//! `chain_frame` in `shaders/common/chain.wgsl`), and which effects are on
//! ([`ActiveEffects`]).

use super::*;

/// What one frame looks at: the sun, the camera's orientation and the sky's d_max.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scene {
    /// Sun azimuth from North toward East, degrees.
    pub sun_az_deg: f64,
    /// Sun elevation above the horizon, degrees.
    pub sun_el_deg: f64,
    /// Camera heading ψ (azimuth of the image top), degrees.
    pub heading_deg: f64,
    /// Frame tilt about camera x then y, degrees.
    pub tilt_x_deg: f64,
    pub tilt_y_deg: f64,
    /// Peak degree of linear polarization of the sky (Rayleigh d_max).
    pub dmax: f64,
}

/// Which draw of the noise a frame uses: (seed, trial, frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NoiseIndex {
    pub seed: u64,
    pub trial: u32,
    pub frame: u32,
}

/// Everything the per-pixel chain needs that is constant over one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainFrame {
    /// The camera as it really is (nominal + geometry effects).
    pub intr: Intrinsics,
    /// Unit sun direction in the true camera frame.
    pub sun_cam: DVec3,
    pub dmax: f64,
    /// Each sky effect's vector, in registry order (`Model::sky`), completed with the
    /// frame's context where an effect asks for it.
    pub sky: [SkyParams; SKY_COUNT],
    /// Each per-pixel effect's vector, in registry order (`Model::ray`); the ideal
    /// chain has every slot at its effect's neutral vector.
    pub ray: [RayParams; RAY_COUNT],
    /// Each analyzer effect's vector, in registry order (`Model::analyzer`).
    pub analyzer: [AnalyzerParams; ANALYZER_COUNT],
    /// Each sensor effect's vector, in registry order (`Model::sensor`).
    pub sensor: [SensorParams; SENSOR_COUNT],
    /// Each mosaic effect's vector, in registry order (`Model::mosaic`).
    pub mosaic: [SensorParams; MOSAIC_COUNT],
    /// Which of `sky`, `ray`, `analyzer` and `mosaic` are off their effect's neutral
    /// vector: the per-pixel path skips the others (set by [`ChainFrame::new`]; after
    /// changing them by hand, set it again with [`ActiveEffects::of`]).
    pub active: ActiveEffects,
    /// The scene elements of a field capture (`scene`), folded for this frame; `None`
    /// for the lab-clean sky. The GPU backend refuses frames that have one.
    pub field: Option<FieldFrame>,
    /// True analyzers by channel index (0, 45, 90, 135).
    pub analyzers: [Analyzer; 4],
    /// DN per unit radiance of each channel: g·(1 + gain_k).
    pub gain_dn: [f64; 4],
    /// Black level plus each channel's offset, DN.
    pub offset_dn: [f64; 4],
    pub response: Response,
    /// Temporal noise key of this frame; fixed-pattern key of this trial.
    pub key: FrameKey,
    pub fixed_key: FrameKey,
}

impl ChainFrame {
    /// Builds the frame: folds `model` into the nominal camera and the scene.
    pub fn new(model: &Model, nominal: &Intrinsics, scene: &Scene, response: &Response, noise: NoiseIndex) -> Self {
        // True camera: nominal intrinsics with the principal point moved, the focal
        // length scaled and the lens's radial distortion.
        let intr = model.camera(nominal);
        let world_from_cam = true_world_from_camera(model, scene);
        let sun_cam = world_from_cam.transpose() * enu_from_az_el_deg(scene.sun_az_deg, scene.sun_el_deg);
        let analyzers = Channel::ALL.map(|c| {
            Analyzer::at(
                c.angle_deg(),
                model.channels.analyzer_delta_deg[c.index()],
                model.channels.analyzer_eps[c.index()],
            )
        });
        let context = FrameContext { sun_cam, world_from_cam, multiple_scattering: 1.0 };
        ChainFrame {
            intr,
            sun_cam,
            // The sky's true peak DoLP (sky_depolarization), at most 1.
            dmax: (scene.dmax * model.sky_block.dmax_factor).min(1.0),
            // Sky and per-pixel vectors, completed with the frame's context (the sun,
            // the camera's axes) where an effect asks for it.
            sky: frame_sky_params(&model.sky, &context),
            ray: frame_ray_params(&model.ray, &context),
            analyzer: model.analyzer,
            sensor: model.sensor,
            mosaic: model.mosaic,
            active: ActiveEffects::of(model),
            field: None,
            analyzers,
            gain_dn: model.channels.gain.map(|g| g * response.gain_dn),
            offset_dn: model.channels.offset_dn.map(|o| o + response.black_level_dn),
            response: *response,
            key: FrameKey::new(noise.seed, noise.trial, noise.frame),
            fixed_key: FrameKey::new(noise.seed, noise.trial, FIXED_PATTERN_FRAME),
        }
    }

    /// [`ChainFrame::new`] in the field: with the scene elements of `field` (none
    /// when `None`) folded for this frame (`noise.frame` keys their per-frame draws).
    pub fn new_in_field(
        model: &Model,
        nominal: &Intrinsics,
        scene: &Scene,
        response: &Response,
        noise: NoiseIndex,
        field: Option<&FieldScene>,
    ) -> Self {
        let mut f = ChainFrame::new(model, nominal, scene, response, noise);
        if let Some(field) = field.filter(|s| !s.is_empty()) {
            let sun_world = enu_from_az_el_deg(scene.sun_az_deg, scene.sun_el_deg);
            f.field = Some(FieldFrame::new(field, true_world_from_camera(model, scene), sun_world, noise.frame));
        }
        f
    }

    /// The frame as the pixels under colour band `b` of a colour-polarization sensor
    /// see it (`model.bands`, [`BandBlock`](crate::effects::BandBlock)): the sky's
    /// d_max times the band's factor, every channel's gain times the band's sky
    /// radiance and response (the chain is linear up to the photo-signal, so a radiance
    /// scale is a gain), each analyzer's ε plus the band's; the scene's white light
    /// (clouds, the sun's disc) over the band's sky by 1/r_b; the sky effects' vectors
    /// completed for the band's multiple scattering (the neutral points' separation).
    /// Everything else (the camera, the other effects, the offsets, the noise keys) is
    /// the frame's, so the bands' frames draw the same noise at a pixel. At a neutral
    /// band block, bitwise `self`.
    pub fn in_band(mut self, model: &Model, scene: &Scene, b: crate::sensor::Band) -> Self {
        let k = b.index();
        let bands = &model.bands;
        // The band's peak DoLP, at most 1 (as ChainFrame::new's).
        self.dmax = (scene.dmax * model.sky_block.dmax_factor * bands.dmax_factor[k]).min(1.0);
        // Radiance × response of the band: DN per unit (green) radiance.
        let scale = bands.radiance[k] * bands.gain[k];
        self.gain_dn = self.gain_dn.map(|g| g * scale);
        // White light (clouds, the sun's disc) is not the sky's colour: the scene's
        // elements scale what they add by 1/r_b, so the band's gain leaves it white.
        if let Some(f) = self.field.as_mut() {
            f.white_over_sky = 1.0 / bands.radiance[k];
        }
        // The sky effects that model multiple scattering, completed for the band's.
        if bands.multiple_scattering[k] != 1.0 {
            let world_from_cam = true_world_from_camera(model, scene);
            let context = FrameContext {
                sun_cam: self.sun_cam,
                world_from_cam,
                multiple_scattering: bands.multiple_scattering[k],
            };
            self.sky = frame_sky_params(&model.sky, &context);
        }
        // Each channel's analyzer with the band's ε added.
        self.analyzers = Channel::ALL.map(|c| {
            Analyzer::at(
                c.angle_deg(),
                model.channels.analyzer_delta_deg[c.index()],
                model.channels.analyzer_eps[c.index()] + bands.eps[k],
            )
        });
        self
    }

    /// The three band frames of a colour-polarization sensor, by
    /// [`Band::index`](crate::sensor::Band::index) ([`ChainFrame::in_band`]).
    pub fn bands(&self, model: &Model, scene: &Scene) -> [ChainFrame; 3] {
        crate::sensor::Band::ALL.map(|b| self.clone().in_band(model, scene, b))
    }

    /// Whether any per-pixel step is on: a sky effect, scene elements, or a per-pixel
    /// effect off its neutral vector (the row kernels skip them otherwise).
    pub fn has_pixel_effects(&self) -> bool {
        self.active.sky.contains(&true) || self.field.is_some() || self.ray != *neutral_ray_params()
    }

    /// Whether any mosaic effect is on: each DoFP pixel's signal then mixes its
    /// neighbours' ([`mosaic_pixel_signal_dn`]).
    pub fn has_mosaic_effects(&self) -> bool {
        self.active.mosaic.contains(&true)
    }

    /// Whether any analyzer effect is off its neutral vector (the row kernels use the
    /// channel's analyzer for every pixel otherwise).
    pub fn has_analyzer_effects(&self) -> bool {
        self.analyzer != *neutral_analyzer_params()
    }

    /// A frame with unit gain, no black level and no noise: DN = radiance behind the analyzer.
    pub fn noise_free(model: &Model, nominal: &Intrinsics, scene: &Scene) -> Self {
        let idx = NoiseIndex { seed: 0, trial: 0, frame: 0 };
        ChainFrame::new(model, nominal, scene, &Response::ideal(1.0), idx)
    }
}

/// The true camera axes in ENU (columns): the frame's orientation, then the camera's
/// tilt on its mount.
fn true_world_from_camera(model: &Model, scene: &Scene) -> DMat3 {
    world_from_camera(scene.heading_deg, scene.tilt_x_deg, scene.tilt_y_deg)
        * level_from_camera(model.geometry.mount_tilt_deg[0], model.geometry.mount_tilt_deg[1])
}

/// Which sky, per-pixel, analyzer and mosaic effects of the registry are on in a
/// frame: off their neutral vector. Each effect is the identity, bitwise, at its neutral vector
/// (`every_registered_effect_at_neutral_gives_bitwise_the_ideal_chain`), so the
/// per-pixel path ([`ray_stokes`], [`pixel_analyzer`]) skips the ones that are off —
/// the same numbers, without a neutral effect's work (a die's seeded draws, a
/// window's Fresnel terms) at every pixel of every fit's every evaluation. The row
/// kernels skip them together instead (`rows.rs`); the GPU leaves out, per dispatch,
/// those no frame of it has on (`bpins-gpu`, `masks.rs`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ActiveEffects {
    pub sky: [bool; SKY_COUNT],
    pub ray: [bool; RAY_COUNT],
    pub analyzer: [bool; ANALYZER_COUNT],
    pub mosaic: [bool; MOSAIC_COUNT],
}

impl ActiveEffects {
    /// The effects of `model` (registry order) off their neutral vector, the vectors
    /// as the model gives them: a frame's context completes a vector only where its
    /// effect is on. (Sensor effects are applied at every pixel: no mask.)
    pub fn of(model: &Model) -> Self {
        let (ns, nr, na, nm) =
            (neutral_sky_params(), neutral_ray_params(), neutral_analyzer_params(), neutral_mosaic_params());
        ActiveEffects {
            sky: std::array::from_fn(|k| model.sky[k] != ns[k]),
            ray: std::array::from_fn(|k| model.ray[k] != nr[k]),
            analyzer: std::array::from_fn(|k| model.analyzer[k] != na[k]),
            mosaic: std::array::from_fn(|k| model.mosaic[k] != nm[k]),
        }
    }

    /// Every effect applied (as the row kernels and the GPU apply them).
    pub fn all() -> Self {
        ActiveEffects {
            sky: [true; SKY_COUNT],
            ray: [true; RAY_COUNT],
            analyzer: [true; ANALYZER_COUNT],
            mosaic: [true; MOSAIC_COUNT],
        }
    }
}
