//! The per-pixel measurement chain: sky → camera ray → lens → analyzer → sensor.
//!
//! Every function here is pure and per pixel — the CPU reference of the WGSL chain,
//! with the same names and argument order (`shaders/chain.wgsl` in the GPU issue).
//! [`ChainFrame`] holds what is constant over one frame (computed once on the host);
//! the drivers in [`crate::simulate`] map these functions over pixels with rayon.
//!
//! ```text
//! pixel (u, v) ─ true intrinsics ─▶ ray d, meridional basis (p, s), 2β       camera frame
//!   ray_stokes(frame, ray):
//!   sky_stokes(sun, d_max, d)        Rayleigh, meridional frame          (sky::rayleigh)
//!   sky_effects(p, sun, d_max, g, S) every sky effect of the registry,   (effects)
//!                                    in its order: sky_neutral_points (the
//!                                    quartic sky), sky_dolp_shape, …
//!   field_stokes(field, d, basis, S) scene elements: CIE radiance, clouds, (scene)
//!                                    sun disc, skyline — CPU only
//!   ray_effects(ray, g, S)           every per-pixel effect of the registry, (effects)
//!                                    in its order: lens_diattenuation, lens_retardance,
//!                                    lens_depolarization, stray_light (the
//!                                    sun from the frame), vignetting, …
//!   meridional_to_image(S, 2β)       rotate to the image x frame          (stokes)
//!   analyzer_effects(site, g, A_k)   the pixel's own analyzer: every analyzer (effects)
//!                                    effect of the registry, in its order:
//!                                    polarimetric_nonuniformity, …
//!   analyzer_intensity(S, θ_p, ε_p)  micro-polarizer of the pixel          (stokes)
//!   × g(1 + gain_k)·G_p              photo-signal in DN                   (sensor)
//!   mosaic_effects(p, S, neighbours) DoFP: every mosaic effect (crosstalk) (effects)
//!   sensor_dn(signal, pixel, k)      PRNU, sensor_effects (every sensor    (effects)
//!                                    effect: sensor_nonlinearity, …), offsets,
//!                                    DSNU, read+shot noise, rounding
//! ```
//!
//! Where things live: this file, the per-pixel functions (function for function the
//! twin of `shaders/common/chain.wgsl`); `frame.rs`, what is constant over a frame
//! ([`Scene`], [`ChainFrame`], [`ActiveEffects`]); `rows.rs` maps these functions over
//! a row of pixels as loops the compiler vectorizes, bitwise equal to calling them
//! pixel by pixel (tested there); `tests.rs`, the chain's tests and the helpers the
//! effects' tests share (`chain::tests::ideal_frame`, …).
//!
//! Effects enter through the frame's parameters ([`Model`] folded by the registry)
//! and through the stage hooks: [`sky_effects`], [`ray_effects`], [`analyzer_effects`],
//! [`mosaic_effects`] and [`sensor_effects`], each the registry's functions of its kind
//! in registry order, each fed its slot of the frame's array ([`ChainFrame::sky`],
//! `ray`, `analyzer`, `mosaic`, `sensor`). Nothing here names an effect; the WGSL twins
//! of the hooks are generated from the same registry by `bpins-gpu`.

use crate::camera::{Intrinsics, RayGeometry};
use crate::conventions::{enu_from_az_el_deg, level_from_camera, world_from_camera};
use crate::effects::{
    frame_ray_params, frame_sky_params, neutral_analyzer_params, neutral_mosaic_params, neutral_ray_params,
    neutral_sky_params, AnalyzerParams, FrameContext, Model, PixelAnalyzer, PixelSite, RayParams, SensorParams,
    SkyParams, ANALYZER_COUNT, ANALYZER_FNS, MOSAIC_COUNT, MOSAIC_FNS, RAY_COUNT, RAY_FNS, SENSOR_COUNT, SENSOR_FNS,
    SKY_COUNT, SKY_FNS,
};
use crate::noise::{stream, FrameKey, FIXED_PATTERN_FRAME};
use crate::scene::{field_stokes, FieldFrame, FieldScene};

use crate::sensor::{Channel, Response};
use crate::sky::sky_stokes;
use crate::stokes::{analyzer_intensity, meridional_to_image, Analyzer, Stokes};
use glam::{DMat3, DVec3};

mod frame;
mod rows;
pub use frame::{ActiveEffects, ChainFrame, NoiseIndex, Scene};
pub(crate) use rows::*;

/// Stokes vector (image frame) reaching the analyzer of pixel `(u, v)`, noise-free.
#[inline(always)]
pub fn pixel_stokes(f: &ChainFrame, u: f64, v: f64) -> Stokes {
    // Pixel → ray through the true camera.
    ray_stokes(f, &f.intr.geometry(u, v))
}

/// Stokes vector (image frame) arriving along the true ray `g`, noise-free: the
/// per-pixel path, the frame's neutral effects skipped ([`ActiveEffects`]).
#[inline(always)]
pub fn ray_stokes(f: &ChainFrame, g: &RayGeometry) -> Stokes {
    lens_to_image(f, g, sky_along::<true>(f, g))
}

/// The lens on the sky's meridional-frame Stokes vector `s` along the ray `g`: the
/// per-pixel effects that are on ([`ActiveEffects`]), then the rotation to the image
/// x frame — [`ray_stokes`] after the sky ([`sky_along`]).
#[inline(always)]
pub(crate) fn lens_to_image(f: &ChainFrame, g: &RayGeometry, s: Stokes) -> Stokes {
    // Per-pixel effects that are on, meridional frame, in registry order.
    let s = ray_effects_where(&f.ray, &f.active.ray, g, s);
    // Rotate from the meridional frame to the image x frame.
    meridional_to_image(s, g.basis.cos2b, g.basis.sin2b)
}

/// [`ray_stokes`] with the scene elements' step compiled out at `FIELD = false`:
/// bitwise the same for a frame without a field. For the row kernels, which choose
/// once per row: a branch on the field inside the pixel loop costs the lens path
/// about a tenth of its speed.
#[inline(always)]
pub(crate) fn ray_stokes_field<const FIELD: bool>(f: &ChainFrame, g: &RayGeometry) -> Stokes {
    let s = sky_along::<FIELD>(f, g);
    // Per-pixel effects (lens Mueller matrices, falloff), meridional frame, in registry order.
    let s = ray_effects(&f.ray, g, s);
    // Rotate from the meridional frame to the image x frame.
    meridional_to_image(s, g.basis.cos2b, g.basis.sin2b)
}

/// The sky's Stokes vector along the true ray `g`, in its meridional frame: Rayleigh,
/// the sky effects that are on ([`ActiveEffects`]), and (`FIELD`) the frame's scene
/// elements.
#[inline(always)]
pub(crate) fn sky_along<const FIELD: bool>(f: &ChainFrame, g: &RayGeometry) -> Stokes {
    // Skylight along the ray, in its meridional frame (Rayleigh).
    let s = sky_stokes(f.sun_cam, f.dmax, g.d, &g.basis);
    // Sky effects that are on (the quartic sky, the DoLP shape, …), in registry order.
    let s = sky_effects_where(&f.sky, &f.active.sky, f.sun_cam, f.dmax, g, s);
    // Field conditions: the scene's radiance, clouds, sun and skyline (world-fixed).
    match &f.field {
        Some(field) if FIELD => field_stokes(field, g.d, &g.basis, s),
        _ => s,
    }
}

/// Every sky effect of the registry on the sky's meridional-frame Stokes vector `s`
/// along the ray `g` (the sun `sun`, peak DoLP `dmax`), in registry order, effect `k`
/// with its vector `p[k]`. WGSL twin: `sky_effects`, generated from the registry
/// (`bpins-gpu`, `ray_dispatch.rs`).
#[inline(always)]
pub fn sky_effects(p: &[SkyParams; SKY_COUNT], sun: DVec3, dmax: f64, g: &RayGeometry, s: Stokes) -> Stokes {
    sky_effects_where(p, &[true; SKY_COUNT], sun, dmax, g, s)
}

/// [`sky_effects`], effect `k` applied where `on[k]` ([`ActiveEffects::sky`]).
#[inline(always)]
fn sky_effects_where(
    p: &[SkyParams; SKY_COUNT],
    on: &[bool; SKY_COUNT],
    sun: DVec3,
    dmax: f64,
    g: &RayGeometry,
    s: Stokes,
) -> Stokes {
    let mut s = s;
    for k in 0..SKY_COUNT {
        if on[k] {
            s = SKY_FNS[k](&p[k], sun, dmax, g, s);
        }
    }
    s
}

/// Every per-pixel effect of the registry on the ray `g`'s meridional-frame Stokes
/// vector, in registry order, effect `k` with its vector `ray[k]`. WGSL twin:
/// `ray_effects`, generated from the registry (`bpins-gpu`, `shaders.rs`).
#[inline(always)]
pub fn ray_effects(ray: &[RayParams; RAY_COUNT], g: &RayGeometry, s: Stokes) -> Stokes {
    ray_effects_where(ray, &[true; RAY_COUNT], g, s)
}

/// [`ray_effects`], effect `k` applied where `on[k]` ([`ActiveEffects::ray`]; every
/// effect for `ray_effects` itself, where the constant mask folds away).
#[inline(always)]
fn ray_effects_where(ray: &[RayParams; RAY_COUNT], on: &[bool; RAY_COUNT], g: &RayGeometry, s: Stokes) -> Stokes {
    // A constant table of functions: the loop unrolls and each call inlines, so the
    // row kernels still vectorize.
    let mut s = s;
    for k in 0..RAY_COUNT {
        if on[k] {
            s = RAY_FNS[k](&ray[k], g, s);
        }
    }
    s
}

/// Photo-signal in DN of channel `ch` (index) for Stokes `s`: the channel's analyzer,
/// then gain (no analyzer effect: [`site_signal_dn`] where the pixel is known).
#[inline(always)]
pub fn pixel_signal_dn(f: &ChainFrame, s: Stokes, ch: usize) -> f64 {
    analyzer_intensity(s, &f.analyzers[ch]) * f.gain_dn[ch]
}

/// Every analyzer effect of the registry on pixel `site`'s analyzer `a` (its ray `g`),
/// in registry order, effect `k` with its vector `p[k]`. WGSL twin: `analyzer_effects`,
/// generated from the registry (`bpins-gpu`, `ray_dispatch.rs`).
#[inline(always)]
pub fn analyzer_effects(
    p: &[AnalyzerParams; ANALYZER_COUNT],
    site: &PixelSite,
    g: &RayGeometry,
    a: PixelAnalyzer,
) -> PixelAnalyzer {
    analyzer_effects_where(p, &[true; ANALYZER_COUNT], site, g, a)
}

/// [`analyzer_effects`], effect `k` applied where `on[k]` ([`ActiveEffects::analyzer`];
/// every effect for `analyzer_effects` itself).
#[inline(always)]
fn analyzer_effects_where(
    p: &[AnalyzerParams; ANALYZER_COUNT],
    on: &[bool; ANALYZER_COUNT],
    site: &PixelSite,
    g: &RayGeometry,
    a: PixelAnalyzer,
) -> PixelAnalyzer {
    let mut a = a;
    for k in 0..ANALYZER_COUNT {
        if on[k] {
            a = ANALYZER_FNS[k](&p[k], site, g, a);
        }
    }
    a
}

/// The analyzer of channel `ch` at pixel column `u`, row `v` (ray `g`) and the gain
/// behind it: the channel's, changed by the analyzer effects.
#[inline(always)]
pub fn pixel_analyzer(f: &ChainFrame, g: &RayGeometry, u: u32, v: u32, ch: usize) -> PixelAnalyzer {
    let a = PixelAnalyzer { analyzer: f.analyzers[ch], gain: f.gain_dn[ch] };
    let site = PixelSite { u, v, ch: ch as u32, x_px: u as f64 - f.intr.cx_px, y_px: v as f64 - f.intr.cy_px };
    // The analyzer effects that are on ([`ActiveEffects`]).
    analyzer_effects_where(&f.analyzer, &f.active.analyzer, &site, g, a)
}

/// Photo-signal in DN of channel `ch` at pixel (u, v), whose ray is `g`, for Stokes `s`:
/// the pixel's own analyzer ([`pixel_analyzer`]), then gain. Bitwise
/// [`pixel_signal_dn`] where no analyzer effect is on.
#[inline(always)]
pub fn site_signal_dn(f: &ChainFrame, s: Stokes, g: &RayGeometry, u: u32, v: u32, ch: usize) -> f64 {
    let a = pixel_analyzer(f, g, u, v, ch);
    analyzer_intensity(s, &a.analyzer) * a.gain
}

/// Every mosaic effect of the registry on a DoFP pixel's photo-signal `own` and its
/// edge neighbours' (DN, 0 outside the sensor), in registry order, effect `k` with its
/// vector `p[k]` where `on[k]`. WGSL twin: `mosaic_effects`, generated from the
/// registry (`bpins-gpu`, `ray_dispatch.rs`), which applies those some frame of the
/// dispatch has on.
#[inline(always)]
pub fn mosaic_effects(
    p: &[SensorParams; MOSAIC_COUNT],
    on: &[bool; MOSAIC_COUNT],
    own: f64,
    [up, down, left, right]: [f64; 4],
) -> f64 {
    let mut out = own;
    for k in 0..MOSAIC_COUNT {
        if on[k] {
            out = MOSAIC_FNS[k](&p[k], out, up, down, left, right);
        }
    }
    out
}

/// Every sensor effect of the registry on the photo-signal `signal_dn` (DN above the
/// offset, after PRNU; ADC full scale `full_scale_dn`), in registry order, effect `k`
/// with its vector `p[k]`. WGSL twin: `sensor_effects`, generated from the registry.
#[inline(always)]
pub fn sensor_effects(p: &[SensorParams; SENSOR_COUNT], signal_dn: f64, full_scale_dn: f64) -> f64 {
    let mut s = signal_dn;
    for k in 0..SENSOR_COUNT {
        s = SENSOR_FNS[k](&p[k], s, full_scale_dn);
    }
    s
}

/// Photo-signal in DN of DoFP pixel `(u, v)` of a `w × h` mosaic: its own ray and
/// analyzer (the analyzer effects at its site), then the mosaic effects with its edge
/// neighbours (each through its own ray and analyzer; 0 outside the sensor) where the
/// frame has any.
pub fn mosaic_pixel_signal_dn(
    f: &ChainFrame,
    u: usize,
    v: usize,
    w: usize,
    h: usize,
    mosaic: &[[crate::sensor::Channel; 2]; 2],
) -> f64 {
    mosaic_signal_through(|_, _| f, u, v, w, h, mosaic)
}

/// [`mosaic_pixel_signal_dn`] on a colour-polarization sensor: each pixel, and each of
/// its neighbours, through the frame of the band over it (`frames` by
/// [`Band::index`](crate::sensor::Band::index), [`ChainFrame::bands`]; CONVENTIONS.md
/// `colour_tiles`), so crosstalk between neighbouring tiles mixes bands as they are.
/// The mosaic effects' vectors are the frames' (the same in every band). WGSL twin:
/// `colour_pixel_signal_dn` in `shaders/kernels/render.wgsl` (the frames read from its
/// buffer).
pub fn colour_pixel_signal_dn(
    frames: &[ChainFrame; 3],
    tiles: &crate::sensor::ColourTiles,
    u: usize,
    v: usize,
    w: usize,
    h: usize,
    mosaic: &[[crate::sensor::Channel; 2]; 2],
) -> f64 {
    mosaic_signal_through(|u, v| &frames[tiles.band_at(u, v).index()], u, v, w, h, mosaic)
}

/// The photo-signal of DoFP pixel `(u, v)`, each pixel through the frame `frame_of(u, v)`.
#[inline(always)]
fn mosaic_signal_through<'a>(
    frame_of: impl Fn(usize, usize) -> &'a ChainFrame,
    u: usize,
    v: usize,
    w: usize,
    h: usize,
    mosaic: &[[crate::sensor::Channel; 2]; 2],
) -> f64 {
    let signal = |u: usize, v: usize| {
        let f = frame_of(u, v);
        let ch = crate::sensor::Layout::dofp_channel(mosaic, u, v).index();
        let g = f.intr.geometry(u as f64, v as f64);
        site_signal_dn(f, ray_stokes(f, &g), &g, u as u32, v as u32, ch)
    };
    let own = signal(u, v);
    let f = frame_of(u, v);
    if !f.has_mosaic_effects() {
        return own;
    }
    let up = if v > 0 { signal(u, v - 1) } else { 0.0 };
    let down = if v + 1 < h { signal(u, v + 1) } else { 0.0 };
    let left = if u > 0 { signal(u - 1, v) } else { 0.0 };
    let right = if u + 1 < w { signal(u + 1, v) } else { 0.0 };
    mosaic_effects(&f.mosaic, &f.active.mosaic, own, [up, down, left, right])
}

/// The standard normal draws one sensor sample uses (0 where the response has no
/// such noise, so nothing is drawn for it).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SensorNoise {
    pub temporal: f64,
    pub dsnu: f64,
    pub prnu: f64,
}

/// Draws the noise of channel `ch` at linear pixel index `pixel`.
#[inline(always)]
pub fn sensor_noise(f: &ChainFrame, pixel: u32, ch: usize) -> SensorNoise {
    let r = &f.response;
    let c = ch as u32;
    SensorNoise {
        temporal: if r.read_noise_dn > 0.0 || r.system_gain_dn_per_e > 0.0 {
            f.key.normal(pixel, c, stream::TEMPORAL)
        } else {
            0.0
        },
        dsnu: if r.dsnu_dn > 0.0 { f.fixed_key.normal(pixel, c, stream::DSNU) } else { 0.0 },
        prnu: if r.prnu > 0.0 { f.fixed_key.normal(pixel, c, stream::PRNU) } else { 0.0 },
    }
}

/// [`sensor_noise`] for all four channels of one pixel: the same numbers, two
/// Box–Muller transforms per stream instead of four.
#[inline(always)]
pub fn sensor_noise4(f: &ChainFrame, pixel: u32) -> [SensorNoise; 4] {
    let r = &f.response;
    let mut n = [SensorNoise::default(); 4];
    let mut fill = |key: &crate::noise::FrameKey, st: u32, set: fn(&mut SensorNoise, f64)| {
        for pair in 0..2 {
            let (a, b) = key.normal_pair(pixel, pair, st);
            set(&mut n[2 * pair as usize], a);
            set(&mut n[2 * pair as usize + 1], b);
        }
    };
    if r.read_noise_dn > 0.0 || r.system_gain_dn_per_e > 0.0 {
        fill(&f.key, stream::TEMPORAL, |s, x| s.temporal = x);
    }
    if r.dsnu_dn > 0.0 {
        fill(&f.fixed_key, stream::DSNU, |s, x| s.dsnu = x);
    }
    if r.prnu > 0.0 {
        fill(&f.fixed_key, stream::PRNU, |s, x| s.prnu = x);
    }
    n
}

/// The sensor's output DN for `signal_dn` on channel `ch` with the draws `n`:
/// PRNU, the sensor effects (`sensor_nonlinearity`, …), offsets, DSNU, read + shot
/// noise, then rounding and clipping (sensor.rs).
#[inline(always)]
pub fn sensor_dn(f: &ChainFrame, signal_dn: f64, ch: usize, n: &SensorNoise) -> f64 {
    sensor_response(&f.response, &f.sensor, f.offset_dn[ch], signal_dn, n)
}

/// [`sensor_dn`] with the frame's sensor effects' vectors and the channel's offset
/// (black level + offset_k) already looked up.
#[inline(always)]
fn sensor_response(
    r: &Response,
    sensor: &[SensorParams; SENSOR_COUNT],
    offset_dn: f64,
    signal_dn: f64,
    n: &SensorNoise,
) -> f64 {
    // Gain non-uniformity (fixed pattern).
    let sig = signal_dn * (1.0 + r.prnu * n.prnu);
    // Sensor effects (the non-linear response, …), each the identity at neutral.
    let sig = sensor_effects(sensor, sig, r.full_scale_dn());
    // Black level, channel offset and offset non-uniformity (fixed pattern).
    let mut dn = sig + offset_dn + r.dsnu_dn * n.dsnu;
    // Temporal noise: read noise plus shot noise of variance K·signal.
    let var = r.read_noise_dn * r.read_noise_dn + r.system_gain_dn_per_e * sig.max(0.0);
    dn += var.sqrt() * n.temporal;
    // Rounding (half up, as WGSL floor(x + 0.5)) and clipping to the ADC range
    // (max/min rather than clamp: branch-free, so row loops vectorize).
    if r.quantize {
        dn = (dn + 0.5).floor().max(0.0).min(r.full_scale_dn());
    }
    dn
}
#[cfg(test)]
pub(crate) mod tests;
