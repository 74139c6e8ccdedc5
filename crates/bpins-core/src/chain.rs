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
//!   lens_diattenuation(ρ₂, r², S)    lens Mueller, meridional frame      (effects)
//!   meridional_to_image(S, 2β)       rotate to the image x frame          (stokes)
//!   analyzer_intensity(S, θ_k, ε_k)  micro-polarizer k                    (stokes)
//!   × g(1 + gain_k)                  photo-signal in DN                   (sensor)
//!   sensor_dn(signal, pixel, k)      PRNU, offsets, DSNU, read+shot noise, rounding
//! ```
//!
//! Effects enter through the frame's parameters ([`Model`] folded by the registry)
//! and, for lens effects, through their per-pixel functions called here in order.

use crate::camera::{Intrinsics, RayGeometry};
use crate::conventions::{enu_from_az_el_deg, level_from_camera, world_from_camera};
use crate::effects::lens_diattenuation::lens_diattenuation;
use crate::effects::Model;
use crate::noise::{stream, FrameKey, FIXED_PATTERN_FRAME};

use crate::sensor::{Channel, Response};
use crate::sky::sky_stokes;
use crate::stokes::{analyzer_intensity, meridional_to_image, Analyzer, Stokes};
use glam::DVec3;

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
    pub lens_rho2: f64,
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
        // True camera: nominal intrinsics with the principal point moved.
        let intr = Intrinsics {
            cx_px: nominal.cx_px + model.pp_offset_px[0],
            cy_px: nominal.cy_px + model.pp_offset_px[1],
            ..*nominal
        };
        // True orientation: the frame's, then the camera's tilt on its mount.
        let world_from_cam = world_from_camera(scene.heading_deg, scene.tilt_x_deg, scene.tilt_y_deg)
            * level_from_camera(model.mount_tilt_deg[0], model.mount_tilt_deg[1]);
        let sun_cam = world_from_cam.transpose() * enu_from_az_el_deg(scene.sun_az_deg, scene.sun_el_deg);
        let analyzers = Channel::ALL
            .map(|c| Analyzer::at(c.angle_deg(), model.analyzer_delta_deg[c.index()], model.analyzer_eps[c.index()]));
        ChainFrame {
            intr,
            sun_cam,
            dmax: scene.dmax,
            lens_rho2: model.lens_rho2,
            analyzers,
            gain_dn: model.channel_gain.map(|g| g * response.gain_dn),
            offset_dn: model.channel_offset_dn.map(|o| o + response.black_level_dn),
            response: *response,
            key: FrameKey::new(noise.seed, noise.trial, noise.frame),
            fixed_key: FrameKey::new(noise.seed, noise.trial, FIXED_PATTERN_FRAME),
        }
    }

    /// A frame with unit gain, no black level and no noise: DN = radiance behind the analyzer.
    pub fn noise_free(model: &Model, nominal: &Intrinsics, scene: &Scene) -> Self {
        let idx = NoiseIndex { seed: 0, trial: 0, frame: 0 };
        ChainFrame::new(model, nominal, scene, &Response::ideal(1.0), idx)
    }
}

/// Stokes vector (image frame) reaching the analyzer of pixel `(u, v)`, noise-free.
#[inline(always)]
pub fn pixel_stokes(f: &ChainFrame, u: f64, v: f64) -> Stokes {
    // Pixel → ray through the true camera.
    ray_stokes(f, &f.intr.geometry(u, v))
}

/// Stokes vector (image frame) arriving along the true ray `g`, noise-free.
#[inline(always)]
pub fn ray_stokes(f: &ChainFrame, g: &RayGeometry) -> Stokes {
    // Skylight along the ray, in its meridional frame.
    let s = sky_stokes(f.sun_cam, f.dmax, g.d, &g.basis);
    // Lens Mueller matrices act in the meridional frame (r² in focal lengths²).
    let s = lens_diattenuation(f.lens_rho2, g.r2, s);
    // Rotate from the meridional frame to the image x frame.
    meridional_to_image(s, g.basis.cos2b, g.basis.sin2b)
}

/// Photo-signal in DN of channel `ch` (index) for Stokes `s`: analyzer, then gain.
#[inline(always)]
pub fn pixel_signal_dn(f: &ChainFrame, s: Stokes, ch: usize) -> f64 {
    analyzer_intensity(s, &f.analyzers[ch]) * f.gain_dn[ch]
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
/// PRNU, offsets, DSNU, read + shot noise, then rounding and clipping (sensor.rs).
#[inline(always)]
pub fn sensor_dn(f: &ChainFrame, signal_dn: f64, ch: usize, n: &SensorNoise) -> f64 {
    sensor_response(&f.response, f.offset_dn[ch], signal_dn, n)
}

/// [`sensor_dn`] with the channel's offset (black level + offset_k) already looked up.
#[inline(always)]
fn sensor_response(r: &Response, offset_dn: f64, signal_dn: f64, n: &SensorNoise) -> f64 {
    // Gain non-uniformity (fixed pattern).
    let sig = signal_dn * (1.0 + r.prnu * n.prnu);
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

// ---------------------------------------------------------------------------
// Row kernels: the per-pixel functions above mapped over one row of pixels, as
// branch-free loops with small outputs that the compiler vectorizes. Each gives
// bitwise the per-pixel composition it names (tested below); the drivers call them.
// ---------------------------------------------------------------------------

/// Row kernel: `out[u] = pixel_signal_dn(f, pixel_stokes(f, u, v_px), chans[u & 1])`
/// for pixels `u = 0..out.len()` of row `v_px` (a DoFP row alternates two channels;
/// give the same channel twice for one).
pub fn signal_row(f: &ChainFrame, v_px: f64, chans: [usize; 2], out: &mut [f64]) {
    if f.lens_rho2 != 0.0 {
        signal_row_in::<true>(f, v_px, chans, out)
    } else {
        signal_row_in::<false>(f, v_px, chans, out)
    }
}

#[inline(always)]
fn signal_row_in<const LENS: bool>(f: &ChainFrame, v_px: f64, chans: [usize; 2], out: &mut [f64]) {
    let (a0, a1) = (f.analyzers[chans[0]], f.analyzers[chans[1]]);
    let (g0, g1) = (f.gain_dn[chans[0]], f.gain_dn[chans[1]]);
    // (Closures forced inline: a call in the row loop stops it vectorizing.)
    f.intr.map_row(
        v_px,
        0.0,
        1.0,
        out,
        #[inline(always)]
        |u, g| {
            let s = ray_stokes_in::<LENS>(f, g);
            let even = u & 1 == 0;
            let a = if even { a0 } else { a1 };
            // pixel_signal_dn: analyzer, then gain.
            analyzer_intensity(s, &a) * if even { g0 } else { g1 }
        },
    );
}

/// Row kernel: `out[u][ch] = pixel_signal_dn(f, pixel_stokes(f, u, v_px), ch)`, all
/// four channels (colocated).
pub fn signal4_row(f: &ChainFrame, v_px: f64, out: &mut [[f64; 4]]) {
    if f.lens_rho2 != 0.0 {
        signal4_row_in::<true>(f, v_px, out)
    } else {
        signal4_row_in::<false>(f, v_px, out)
    }
}

#[inline(always)]
fn signal4_row_in<const LENS: bool>(f: &ChainFrame, v_px: f64, out: &mut [[f64; 4]]) {
    f.intr.map_row(
        v_px,
        0.0,
        1.0,
        out,
        #[inline(always)]
        |_, g| {
            let s = ray_stokes_in::<LENS>(f, g);
            // (Spelled out: `array::map` is not always inlined, and a call stops vectorizing.)
            [pixel_signal_dn(f, s, 0), pixel_signal_dn(f, s, 1), pixel_signal_dn(f, s, 2), pixel_signal_dn(f, s, 3)]
        },
    );
}

/// [`ray_stokes`] for the row kernels, `LENS = false` only where `f.lens_rho2 == 0`.
/// Then the lens is the identity and is skipped — bitwise the same: ρ = 0·r² = 0 for
/// the finite r² of any pixel, so c = √(1 − ρ²) = 1, I + ρQ = I, ρI + Q = Q (the sky's
/// Q is never −0), c·U = U.
#[inline(always)]
fn ray_stokes_in<const LENS: bool>(f: &ChainFrame, g: &RayGeometry) -> Stokes {
    if LENS {
        return ray_stokes(f, g);
    }
    let s = sky_stokes(f.sun_cam, f.dmax, g.d, &g.basis);
    meridional_to_image(s, g.basis.cos2b, g.basis.sin2b)
}

/// Scratch rows of standard normals for [`sensor_dn_row`] and [`sensor_dn4_row`].
#[derive(Clone, Debug, Default)]
pub struct NoiseRows {
    one: [Vec<f64>; 3],
    four: [Vec<[f64; 4]>; 3],
    /// Whether `one[k]`, `four[k]` hold zeros (their stream is not drawn).
    one_zero: [bool; 3],
    four_zero: [bool; 3],
}

/// Which noise streams the response draws (temporal, DSNU, PRNU), as [`sensor_noise`].
fn streams_drawn(r: &Response) -> [bool; 3] {
    [r.read_noise_dn > 0.0 || r.system_gain_dn_per_e > 0.0, r.dsnu_dn > 0.0, r.prnu > 0.0]
}

/// The key and stream of each of [`SensorNoise`]'s draws.
fn stream_keys(f: &ChainFrame) -> [(&FrameKey, u32); 3] {
    [(&f.key, stream::TEMPORAL), (&f.fixed_key, stream::DSNU), (&f.fixed_key, stream::PRNU)]
}

/// Row kernel: `out[u] = sensor_dn(f, signal[u], ch, &sensor_noise(f, pixel0 + u, ch))`
/// with `ch = chans[u & 1]` (a DoFP row), rounded to f32.
pub fn sensor_dn_row(
    f: &ChainFrame,
    pixel0: u32,
    chans: [usize; 2],
    signal: &[f64],
    scratch: &mut NoiseRows,
    out: &mut [f32],
) {
    let n = signal.len();
    // Draw the streams the response needs; zeros elsewhere, as sensor_noise (kept
    // from row to row while the stream is off).
    for (((buf, zero), drawn), (key, st)) in
        scratch.one.iter_mut().zip(&mut scratch.one_zero).zip(streams_drawn(&f.response)).zip(stream_keys(f))
    {
        if drawn {
            buf.resize(n, 0.0);
            key.normal_row(pixel0, chans.map(|c| c as u32), st, buf);
        } else if !(*zero && buf.len() == n) {
            buf.clear();
            buf.resize(n, 0.0);
        }
        *zero = !drawn;
    }
    let [t, d, p] = &scratch.one;
    let (o0, o1) = (f.offset_dn[chans[0]], f.offset_dn[chans[1]]);
    let r = &f.response;
    let draws = t.iter().zip(d).zip(p);
    for (u, ((o, &sig), ((&temporal, &dsnu), &prnu))) in out.iter_mut().zip(signal).zip(draws).enumerate() {
        let offset = if u & 1 == 0 { o0 } else { o1 };
        *o = sensor_response(r, offset, sig, &SensorNoise { temporal, dsnu, prnu }) as f32;
    }
}

/// Row kernel: for the channels with `used[ch]`, `out[u][ch] = sensor_dn(f,
/// signal[u][ch], ch, &sensor_noise4(f, pixel0 + u)[ch])`; 0 for the others (colocated).
pub fn sensor_dn4_row(
    f: &ChainFrame,
    pixel0: u32,
    used: [bool; 4],
    signal: &[[f64; 4]],
    scratch: &mut NoiseRows,
    out: &mut [[f64; 4]],
) {
    let n = signal.len();
    for (((buf, zero), drawn), (key, st)) in
        scratch.four.iter_mut().zip(&mut scratch.four_zero).zip(streams_drawn(&f.response)).zip(stream_keys(f))
    {
        if drawn {
            buf.resize(n, [0.0; 4]);
            key.normal4_row(pixel0, st, buf);
        } else if !(*zero && buf.len() == n) {
            // Zeros, as sensor_noise4 (kept from row to row while the stream is off).
            buf.clear();
            buf.resize(n, [0.0; 4]);
        }
        *zero = !drawn;
    }
    let [t, d, p] = &scratch.four;
    let r = &f.response;
    for (o, (sig, ((t, d), p))) in out.iter_mut().zip(signal.iter().zip(t.iter().zip(d).zip(p))) {
        let dn = |ch: usize| {
            let n = SensorNoise { temporal: t[ch], dsnu: d[ch], prnu: p[ch] };
            let dn = sensor_response(r, f.offset_dn[ch], sig[ch], &n);
            if used[ch] {
                dn
            } else {
                0.0
            }
        };
        *o = [dn(0), dn(1), dn(2), dn(3)];
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::camera::Projection;
    use crate::effects::EffectSet;

    /// The sample captures' camera: 612 × 512, 13.8 µm, 8 mm pinhole.
    pub fn intrinsics() -> Intrinsics {
        Intrinsics { projection: Projection::Pinhole, f_px: 8000.0 / 13.8, cx_px: 305.5, cy_px: 255.5 }
    }

    pub fn scene() -> Scene {
        Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 }
    }

    pub fn ideal_frame(model: &Model) -> ChainFrame {
        ChainFrame::noise_free(model, &intrinsics(), &scene())
    }

    pub fn stokes_at(f: &ChainFrame, u: f64, v: f64) -> Stokes {
        pixel_stokes(f, u, v)
    }

    #[test]
    fn every_registered_effect_at_neutral_gives_bitwise_the_ideal_chain() {
        let ideal = ideal_frame(&Model::default());
        for e in crate::effects::REGISTRY {
            let mut set = EffectSet::new();
            set.enable(e.name).unwrap();
            let f = ideal_frame(&set.model());
            for (u, v) in [(0.0, 0.0), (305.5, 255.5), (611.0, 511.0), (17.0, 400.0)] {
                let (a, b) = (pixel_stokes(&f, u, v), pixel_stokes(&ideal, u, v));
                assert_eq!(a, b, "{}", e.name);
                for ch in 0..4 {
                    assert_eq!(pixel_signal_dn(&f, a, ch), pixel_signal_dn(&ideal, b, ch), "{}", e.name);
                }
            }
        }
    }

    #[test]
    fn noise_free_sensor_is_gain_plus_offset() {
        let mut set = EffectSet::new();
        set.set("channel_response", "gain45", 0.1).unwrap();
        set.set("channel_response", "offset45_dn", 2.0).unwrap();
        let resp = Response { black_level_dn: 64.0, ..Response::ideal(1000.0) };
        let f =
            ChainFrame::new(&set.model(), &intrinsics(), &scene(), &resp, NoiseIndex { seed: 1, trial: 0, frame: 0 });
        let s = pixel_stokes(&f, 100.0, 100.0);
        let sig = pixel_signal_dn(&f, s, 1);
        let want = 1000.0 * 1.1 * analyzer_intensity(s, &f.analyzers[1]);
        assert!((sig - want).abs() < 1e-9);
        assert!((sensor_dn(&f, sig, 1, &sensor_noise(&f, 7, 1)) - (want + 66.0)).abs() < 1e-9);
    }

    #[test]
    fn sensor_noise_has_the_emva_variance() {
        let resp =
            Response { read_noise_dn: 2.0, system_gain_dn_per_e: 0.5, black_level_dn: 100.0, ..Response::ideal(1.0) };
        let f = ChainFrame::new(
            &Model::default(),
            &intrinsics(),
            &scene(),
            &resp,
            NoiseIndex { seed: 3, trial: 1, frame: 2 },
        );
        let n = 100_000;
        let signal = 1000.0;
        let (mut s1, mut s2) = (0.0, 0.0);
        for p in 0..n {
            let x = sensor_dn(&f, signal, 0, &sensor_noise(&f, p, 0)) - 1100.0;
            s1 += x;
            s2 += x * x;
        }
        let var = s2 / n as f64 - (s1 / n as f64).powi(2);
        let want = 4.0 + 0.5 * signal;
        assert!((var / want - 1.0).abs() < 0.02, "variance {var} DN², want {want}");
    }

    #[test]
    fn quantization_rounds_half_up_and_clips() {
        let resp = Response { quantize: true, bit_depth: 8, ..Response::ideal(1.0) };
        let f = ChainFrame::new(
            &Model::default(),
            &intrinsics(),
            &scene(),
            &resp,
            NoiseIndex { seed: 0, trial: 0, frame: 0 },
        );
        assert_eq!(sensor_dn(&f, 2.5, 0, &SensorNoise::default()), 3.0);
        assert_eq!(sensor_dn(&f, 2.49, 0, &SensorNoise::default()), 2.0);
        assert_eq!(sensor_dn(&f, 300.0, 0, &SensorNoise::default()), 255.0);
        assert_eq!(sensor_dn(&f, -4.0, 0, &SensorNoise::default()), 0.0);
    }

    #[test]
    fn same_key_same_noise_other_frame_other_noise() {
        let resp = Response { read_noise_dn: 1.0, ..Response::ideal(1.0) };
        let mk = |frame| {
            ChainFrame::new(&Model::default(), &intrinsics(), &scene(), &resp, NoiseIndex { seed: 5, trial: 0, frame })
        };
        let dn = |frame| {
            let f = mk(frame);
            sensor_dn(&f, 10.0, 1, &sensor_noise(&f, 3, 1))
        };
        assert_eq!(dn(0), dn(0));
        assert_ne!(dn(0), dn(1));
    }

    #[test]
    fn four_channel_noise_draws_the_same_numbers_as_one_channel() {
        let resp = Response { read_noise_dn: 1.0, dsnu_dn: 2.0, prnu: 0.01, ..Response::ideal(1.0) };
        let f = ChainFrame::new(
            &Model::default(),
            &intrinsics(),
            &scene(),
            &resp,
            NoiseIndex { seed: 5, trial: 2, frame: 1 },
        );
        for p in [0, 17, 90_001] {
            let four = sensor_noise4(&f, p);
            for (ch, n) in four.iter().enumerate() {
                assert_eq!(*n, sensor_noise(&f, p, ch));
            }
        }
    }

    fn noisy_frame(quantize: bool) -> ChainFrame {
        let mut set = EffectSet::new();
        set.set("channel_response", "offset90_dn", 3.0).unwrap();
        set.set("array_rotation", "dtheta_deg", 0.3).unwrap();
        set.set("lens_diattenuation", "rho2", 0.4).unwrap();
        let resp = Response {
            black_level_dn: 64.0,
            read_noise_dn: 1.5,
            system_gain_dn_per_e: 0.2,
            dsnu_dn: 0.7,
            prnu: 0.01,
            bit_depth: 12,
            quantize,
            ..Response::ideal(3000.0)
        };
        ChainFrame::new(&set.model(), &intrinsics(), &scene(), &resp, NoiseIndex { seed: 9, trial: 4, frame: 2 })
    }

    #[test]
    fn dofp_row_kernels_are_bitwise_the_per_pixel_chain() {
        // One scratch for a noisy, a noise-free and a noisy frame again: no stale draws.
        let mut scratch = NoiseRows::default();
        for f in [noisy_frame(false), ideal_frame(&Model::default()), noisy_frame(true)] {
            let (w, v) = (612usize, 37usize);
            let mut sig = vec![0.0; w];
            let mut dn = vec![0f32; w];
            for chans in [[2, 1], [3, 0]] {
                signal_row(&f, v as f64, chans, &mut sig);
                sensor_dn_row(&f, (v * w) as u32, chans, &sig, &mut scratch, &mut dn);
                for u in 0..w {
                    let ch = chans[u & 1];
                    let want = pixel_signal_dn(&f, pixel_stokes(&f, u as f64, v as f64), ch);
                    assert_eq!(sig[u], want, "signal at {u}");
                    let p = (v * w + u) as u32;
                    assert_eq!(dn[u], sensor_dn(&f, want, ch, &sensor_noise(&f, p, ch)) as f32, "DN at {u}");
                }
            }
        }
    }

    #[test]
    fn colocated_row_kernels_are_bitwise_the_per_pixel_chain() {
        let (w, v) = (300usize, 200usize);
        let mut sig = vec![[0.0; 4]; w];
        let mut dn = vec![[0.0; 4]; w];
        let used = [true, true, false, true];
        // One scratch for a noisy, a noise-free and a noisy frame again: no stale draws.
        let mut scratch = NoiseRows::default();
        for f in [noisy_frame(false), ideal_frame(&Model::default()), noisy_frame(true)] {
            signal4_row(&f, v as f64, &mut sig);
            sensor_dn4_row(&f, (v * w) as u32, used, &sig, &mut scratch, &mut dn);
            for u in 0..w {
                let s = pixel_stokes(&f, u as f64, v as f64);
                let noise = sensor_noise4(&f, (v * w + u) as u32);
                for ch in 0..4 {
                    assert_eq!(sig[u][ch], pixel_signal_dn(&f, s, ch));
                    let want = if used[ch] { sensor_dn(&f, sig[u][ch], ch, &noise[ch]) } else { 0.0 };
                    assert_eq!(dn[u][ch], want);
                }
            }
        }
    }
}
