//! The per-stage tables derived from the registry at compile time: for each kind of
//! hook (sky, ray, analyzer, sensor, mosaic), how many effects carry it, which (in
//! chain order), their functions, each effect's slot in [`Model`]'s and `ChainFrame`'s
//! arrays, the frame completion of their vectors, and their neutral vectors (the
//! ideal chain's).

#[cfg(doc)]
use super::Model;
use super::{AnalyzerFn, AnalyzerParams, FrameContext, MosaicFn, PixelAnalyzer, PixelSite, RayFn, RayParams};
use super::{Apply, EffectDef, ALL};
use super::{SensorFn, SensorParams, SkyFn, SkyParams};
use crate::camera::RayGeometry;
use crate::stokes::Stokes;
use glam::DVec3;

impl EffectDef {
    /// The per-pixel vector at neutral values (`None` for a frame effect).
    fn neutral_ray_params(&self) -> Option<RayParams> {
        match self.apply {
            Apply::Ray { params, .. } => Some(params(&self.neutral_values())),
            _ => None,
        }
    }

    /// The analyzer vector at neutral values (`None` for another kind of effect).
    fn neutral_analyzer_params(&self) -> Option<AnalyzerParams> {
        match self.apply {
            Apply::Analyzer { params, .. } => Some(params(&self.neutral_values())),
            _ => None,
        }
    }

    /// The vector of a sky, sensor or mosaic effect at neutral values (`None` for another
    /// kind of effect).
    fn neutral_stage_params(&self) -> Option<StageParams> {
        let v = self.neutral_values();
        match self.apply {
            Apply::Sky { params, .. } => Some(StageParams::Sky(params(&v))),
            Apply::Sensor { params, .. } | Apply::Mosaic { params, .. } => Some(StageParams::Vec4(params(&v))),
            _ => None,
        }
    }
}

/// A stage hook's vector at neutral values ([`EffectDef::neutral_stage_params`]).
enum StageParams {
    Sky(SkyParams),
    Vec4(SensorParams),
}

/// How many effects act per pixel ([`Apply::Ray`]): the length of [`Model::ray`].
pub const RAY_COUNT: usize = {
    let mut n = 0;
    let mut i = 0;
    while i < ALL.len() {
        if ALL[i].apply.is_ray() {
            n += 1;
        }
        i += 1;
    }
    n
};

/// The per-pixel effects in chain order: slot `k` of [`Model::ray`] is `RAY_EFFECTS[k]`.
pub static RAY_EFFECTS: [&EffectDef; RAY_COUNT] = {
    let mut out = [ALL[0]; RAY_COUNT];
    let (mut i, mut k) = (0, 0);
    while i < ALL.len() {
        if ALL[i].apply.is_ray() {
            out[k] = ALL[i];
            k += 1;
        }
        i += 1;
    }
    out
};

/// The per-pixel functions in chain order, as constants the chain calls directly
/// (`chain::ray_effects`; a constant table lets the compiler inline each call).
pub(crate) const RAY_FNS: [RayFn; RAY_COUNT] = {
    let mut out: [RayFn; RAY_COUNT] = [identity_ray; RAY_COUNT];
    let (mut i, mut k) = (0, 0);
    while i < ALL.len() {
        if let Apply::Ray { pixel, .. } = ALL[i].apply {
            out[k] = pixel;
            k += 1;
        }
        i += 1;
    }
    out
};

fn identity_ray(_: &RayParams, _: &RayGeometry, s: Stokes) -> Stokes {
    s
}

/// How many effects act on each pixel's analyzer ([`Apply::Analyzer`]): the length of
/// [`Model::analyzer`].
pub const ANALYZER_COUNT: usize = {
    let mut n = 0;
    let mut i = 0;
    while i < ALL.len() {
        if ALL[i].apply.is_analyzer() {
            n += 1;
        }
        i += 1;
    }
    n
};

/// The analyzer effects in chain order: slot `k` of [`Model::analyzer`] is `ANALYZER_EFFECTS[k]`.
pub static ANALYZER_EFFECTS: [&EffectDef; ANALYZER_COUNT] = {
    let mut out = [ALL[0]; ANALYZER_COUNT];
    let (mut i, mut k) = (0, 0);
    while i < ALL.len() {
        if ALL[i].apply.is_analyzer() {
            out[k] = ALL[i];
            k += 1;
        }
        i += 1;
    }
    out
};

/// The analyzer effects' functions in chain order (`chain::analyzer_effects`).
pub(crate) const ANALYZER_FNS: [AnalyzerFn; ANALYZER_COUNT] = {
    let mut out: [AnalyzerFn; ANALYZER_COUNT] = [identity_analyzer; ANALYZER_COUNT];
    let (mut i, mut k) = (0, 0);
    while i < ALL.len() {
        if let Apply::Analyzer { pixel, .. } = ALL[i].apply {
            out[k] = pixel;
            k += 1;
        }
        i += 1;
    }
    out
};

fn identity_analyzer(_: &AnalyzerParams, _: &PixelSite, _: &RayGeometry, a: PixelAnalyzer) -> PixelAnalyzer {
    a
}

/// The slot of analyzer effect `def` in [`Model::analyzer`] (`None` for another kind).
pub fn analyzer_slot(def: &EffectDef) -> Option<usize> {
    ANALYZER_EFFECTS.iter().position(|e| e.name == def.name)
}

/// Every analyzer effect at its neutral vector: the ideal chain's [`Model::analyzer`].
pub fn neutral_analyzer_params() -> &'static [AnalyzerParams; ANALYZER_COUNT] {
    static NEUTRAL: std::sync::LazyLock<[AnalyzerParams; ANALYZER_COUNT]> = std::sync::LazyLock::new(|| {
        ANALYZER_EFFECTS.map(|e| e.neutral_analyzer_params().expect("ANALYZER_EFFECTS holds analyzer effects only"))
    });
    &NEUTRAL
}

/// The slot of per-pixel effect `def` in [`Model::ray`] (`None` for a frame effect).
pub fn ray_slot(def: &EffectDef) -> Option<usize> {
    RAY_EFFECTS.iter().position(|e| e.name == def.name)
}

/// The per-pixel effects' frame completions, slot by slot (`Apply::Ray::frame`).
const RAY_FRAME_FNS: [Option<fn(RayParams, &FrameContext) -> RayParams>; RAY_COUNT] = {
    let mut out: [Option<fn(RayParams, &FrameContext) -> RayParams>; RAY_COUNT] = [None; RAY_COUNT];
    let (mut i, mut k) = (0, 0);
    while i < ALL.len() {
        if let Apply::Ray { frame, .. } = ALL[i].apply {
            out[k] = frame;
            k += 1;
        }
        i += 1;
    }
    out
};

/// The frame's per-pixel vectors: `ray` (`Model::ray`) with each effect's frame
/// completion applied under `context` (`ChainFrame::ray`).
pub fn frame_ray_params(ray: &[RayParams; RAY_COUNT], context: &FrameContext) -> [RayParams; RAY_COUNT] {
    let mut out = *ray;
    for (p, f) in out.iter_mut().zip(RAY_FRAME_FNS) {
        if let Some(f) = f {
            *p = f(*p, context);
        }
    }
    out
}

/// Every per-pixel effect at its neutral vector: the ideal chain's [`Model::ray`].
pub fn neutral_ray_params() -> &'static [RayParams; RAY_COUNT] {
    static NEUTRAL: std::sync::LazyLock<[RayParams; RAY_COUNT]> = std::sync::LazyLock::new(|| {
        RAY_EFFECTS.map(|e| e.neutral_ray_params().expect("RAY_EFFECTS holds per-pixel effects only"))
    });
    &NEUTRAL
}

/// How many effects of the registry `$is` selects (an `Apply::is_*`), at compile time.
macro_rules! count_of {
    ($is:ident) => {{
        let (mut n, mut i) = (0, 0);
        while i < ALL.len() {
            if ALL[i].apply.$is() {
                n += 1;
            }
            i += 1;
        }
        n
    }};
}

/// The `$n` effects of the registry `$is` selects, in chain order, at compile time.
macro_rules! effects_of {
    ($is:ident, $n:expr) => {{
        let mut out = [ALL[0]; $n];
        let (mut i, mut k) = (0, 0);
        while i < ALL.len() {
            if ALL[i].apply.$is() {
                out[k] = ALL[i];
                k += 1;
            }
            i += 1;
        }
        out
    }};
}

/// How many effects act on the sky ([`Apply::Sky`]): the length of [`Model::sky`].
pub const SKY_COUNT: usize = count_of!(is_sky);

/// The sky effects in chain order: slot `k` of [`Model::sky`] is `SKY_EFFECTS[k]`.
pub static SKY_EFFECTS: [&EffectDef; SKY_COUNT] = effects_of!(is_sky, SKY_COUNT);

/// The sky effects' functions in chain order (`chain::sky_effects`).
pub(crate) const SKY_FNS: [SkyFn; SKY_COUNT] = {
    let mut out: [SkyFn; SKY_COUNT] = [identity_sky; SKY_COUNT];
    let (mut i, mut k) = (0, 0);
    while i < ALL.len() {
        if let Apply::Sky { pixel, .. } = ALL[i].apply {
            out[k] = pixel;
            k += 1;
        }
        i += 1;
    }
    out
};

fn identity_sky(_: &SkyParams, _: DVec3, _: f64, _: &RayGeometry, s: Stokes) -> Stokes {
    s
}

/// The sky effects' frame completions, slot by slot (`Apply::Sky::frame`).
const SKY_FRAME_FNS: [Option<fn(SkyParams, &FrameContext) -> SkyParams>; SKY_COUNT] = {
    let mut out: [Option<fn(SkyParams, &FrameContext) -> SkyParams>; SKY_COUNT] = [None; SKY_COUNT];
    let (mut i, mut k) = (0, 0);
    while i < ALL.len() {
        if let Apply::Sky { frame, .. } = ALL[i].apply {
            out[k] = frame;
            k += 1;
        }
        i += 1;
    }
    out
};

/// The frame's sky vectors: `sky` (`Model::sky`) with each effect's frame completion
/// applied under `context` (`ChainFrame::sky`).
pub fn frame_sky_params(sky: &[SkyParams; SKY_COUNT], context: &FrameContext) -> [SkyParams; SKY_COUNT] {
    let mut out = *sky;
    for (p, f) in out.iter_mut().zip(SKY_FRAME_FNS) {
        if let Some(f) = f {
            *p = f(*p, context);
        }
    }
    out
}

/// How many effects act on the photo-signal ([`Apply::Sensor`]): the length of [`Model::sensor`].
pub const SENSOR_COUNT: usize = count_of!(is_sensor);

/// The sensor effects in chain order: slot `k` of [`Model::sensor`] is `SENSOR_EFFECTS[k]`.
pub static SENSOR_EFFECTS: [&EffectDef; SENSOR_COUNT] = effects_of!(is_sensor, SENSOR_COUNT);

/// The sensor effects' functions in chain order (`chain::sensor_effects`).
pub(crate) const SENSOR_FNS: [SensorFn; SENSOR_COUNT] = {
    let mut out: [SensorFn; SENSOR_COUNT] = [identity_sensor; SENSOR_COUNT];
    let (mut i, mut k) = (0, 0);
    while i < ALL.len() {
        if let Apply::Sensor { pixel, .. } = ALL[i].apply {
            out[k] = pixel;
            k += 1;
        }
        i += 1;
    }
    out
};

fn identity_sensor(_: &SensorParams, signal_dn: f64, _: f64) -> f64 {
    signal_dn
}

/// How many effects mix neighbouring DoFP pixels ([`Apply::Mosaic`]): the length of
/// [`Model::mosaic`].
pub const MOSAIC_COUNT: usize = count_of!(is_mosaic);

/// The mosaic effects in chain order: slot `k` of [`Model::mosaic`] is `MOSAIC_EFFECTS[k]`.
pub static MOSAIC_EFFECTS: [&EffectDef; MOSAIC_COUNT] = effects_of!(is_mosaic, MOSAIC_COUNT);

/// The mosaic effects' functions in chain order (`chain::mosaic_effects`).
pub(crate) const MOSAIC_FNS: [MosaicFn; MOSAIC_COUNT] = {
    let mut out: [MosaicFn; MOSAIC_COUNT] = [identity_mosaic; MOSAIC_COUNT];
    let (mut i, mut k) = (0, 0);
    while i < ALL.len() {
        if let Apply::Mosaic { pixel, .. } = ALL[i].apply {
            out[k] = pixel;
            k += 1;
        }
        i += 1;
    }
    out
};

fn identity_mosaic(_: &SensorParams, own: f64, _: f64, _: f64, _: f64, _: f64) -> f64 {
    own
}

/// The slot of a sky, sensor or mosaic effect `def` in its stage's array of [`Model`]
/// (`Model::sky`, `Model::sensor`, `Model::mosaic`; `None` for another kind).
pub fn stage_slot(def: &EffectDef) -> Option<usize> {
    let table: &[&EffectDef] = match def.apply {
        Apply::Sky { .. } => &SKY_EFFECTS,
        Apply::Sensor { .. } => &SENSOR_EFFECTS,
        Apply::Mosaic { .. } => &MOSAIC_EFFECTS,
        _ => return None,
    };
    table.iter().position(|e| e.name == def.name)
}

/// Every sky effect at its neutral vector: the ideal chain's [`Model::sky`].
pub fn neutral_sky_params() -> &'static [SkyParams; SKY_COUNT] {
    static NEUTRAL: std::sync::LazyLock<[SkyParams; SKY_COUNT]> = std::sync::LazyLock::new(|| {
        SKY_EFFECTS.map(|e| match e.neutral_stage_params() {
            Some(StageParams::Sky(p)) => p,
            _ => unreachable!("SKY_EFFECTS holds sky effects only"),
        })
    });
    &NEUTRAL
}

/// The neutral vectors of `effects` (sensor or mosaic effects).
fn neutral_vec4_params<const N: usize>(effects: &[&EffectDef; N]) -> [SensorParams; N] {
    effects.map(|e| match e.neutral_stage_params() {
        Some(StageParams::Vec4(p)) => p,
        _ => unreachable!("a sensor or mosaic effect has a 4-vector"),
    })
}

/// Every sensor effect at its neutral vector: the ideal chain's [`Model::sensor`].
pub fn neutral_sensor_params() -> &'static [SensorParams; SENSOR_COUNT] {
    static NEUTRAL: std::sync::LazyLock<[SensorParams; SENSOR_COUNT]> =
        std::sync::LazyLock::new(|| neutral_vec4_params(&SENSOR_EFFECTS));
    &NEUTRAL
}

/// Every mosaic effect at its neutral vector: the ideal chain's [`Model::mosaic`].
pub fn neutral_mosaic_params() -> &'static [SensorParams; MOSAIC_COUNT] {
    static NEUTRAL: std::sync::LazyLock<[SensorParams; MOSAIC_COUNT]> =
        std::sync::LazyLock::new(|| neutral_vec4_params(&MOSAIC_EFFECTS));
    &NEUTRAL
}
