//! Row kernels: the per-pixel functions of [`super`] mapped over one row of pixels,
//! as branch-free loops with small outputs that the compiler vectorizes (x86-64-v3,
//! `.cargo/config.toml`). Each gives bitwise the per-pixel composition it names
//! (tested below); the drivers in `simulate.rs` and `montecarlo.rs` call them.

use super::*;

/// Row kernel: `out[u] = site_signal_dn(f, s, g, u, v_px, chans[u & 1])` with `g` pixel
/// (u, v_px)'s ray and `s = ray_stokes(f, g)`, for pixels `u = 0..out.len()` of row
/// `v_px` (a whole number; a DoFP row alternates two channels; give the same channel
/// twice for one). Without analyzer effects, `pixel_signal_dn` (bitwise the same).
pub(crate) fn signal_row(f: &ChainFrame, v_px: f64, chans: [usize; 2], out: &mut [f64]) {
    match (f.has_pixel_effects(), f.field.is_some(), f.has_analyzer_effects()) {
        (_, false, true) => signal_row_in::<true, false, true>(f, v_px, chans, out),
        (_, true, true) => signal_row_in::<true, true, true>(f, v_px, chans, out),
        (false, _, false) => signal_row_in::<false, false, false>(f, v_px, chans, out),
        (true, false, false) => signal_row_in::<true, false, false>(f, v_px, chans, out),
        (true, true, false) => signal_row_in::<true, true, false>(f, v_px, chans, out),
    }
}

#[inline(always)]
fn signal_row_in<const LENS: bool, const FIELD: bool, const ANALYZER: bool>(
    f: &ChainFrame,
    v_px: f64,
    chans: [usize; 2],
    out: &mut [f64],
) {
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
            let s = ray_stokes_in::<LENS, FIELD>(f, g);
            let even = u & 1 == 0;
            if ANALYZER {
                // site_signal_dn: the pixel's own analyzer, then gain.
                return site_signal_dn(f, s, g, u as u32, v_px as u32, chans[u & 1]);
            }
            let a = if even { a0 } else { a1 };
            // pixel_signal_dn: analyzer, then gain.
            analyzer_intensity(s, &a) * if even { g0 } else { g1 }
        },
    );
}

/// Row kernel: `out[u][ch] = site_signal_dn(f, s, g, u, v_px, ch)` as [`signal_row`], all
/// four channels (colocated).
pub(crate) fn signal4_row(f: &ChainFrame, v_px: f64, out: &mut [[f64; 4]]) {
    match (f.has_pixel_effects(), f.field.is_some(), f.has_analyzer_effects()) {
        (_, false, true) => signal4_row_in::<true, false, true>(f, v_px, out),
        (_, true, true) => signal4_row_in::<true, true, true>(f, v_px, out),
        (false, _, false) => signal4_row_in::<false, false, false>(f, v_px, out),
        (true, false, false) => signal4_row_in::<true, false, false>(f, v_px, out),
        (true, true, false) => signal4_row_in::<true, true, false>(f, v_px, out),
    }
}

#[inline(always)]
fn signal4_row_in<const LENS: bool, const FIELD: bool, const ANALYZER: bool>(
    f: &ChainFrame,
    v_px: f64,
    out: &mut [[f64; 4]],
) {
    f.intr.map_row(
        v_px,
        0.0,
        1.0,
        out,
        #[inline(always)]
        |u, g| {
            let s = ray_stokes_in::<LENS, FIELD>(f, g);
            if ANALYZER {
                let (u, v) = (u as u32, v_px as u32);
                let sig = |ch| site_signal_dn(f, s, g, u, v, ch);
                return [sig(0), sig(1), sig(2), sig(3)];
            }
            // (Spelled out: `array::map` is not always inlined, and a call stops vectorizing.)
            [pixel_signal_dn(f, s, 0), pixel_signal_dn(f, s, 1), pixel_signal_dn(f, s, 2), pixel_signal_dn(f, s, 3)]
        },
    );
}

/// Row kernel: `[aop[u], dolp[u], aoe[u]] = sky_angles(pixel_stokes(f, u, v_px), u, v_px,
/// principal point)` for `u = 0..aop.len()`: the light reaching the analyzers,
/// noise-free, as f32. One branch-free loop (the angles through `math::atan2`), so it
/// vectorizes like the chain. CPU twin of WGSL `sky_maps` (`render.wgsl`), whose
/// angles come from the WGSL `sky_angles` (`common/chain.wgsl`).
pub(crate) fn angles_row(f: &ChainFrame, v_px: f64, aop: &mut [f32], dolp: &mut [f32], aoe: &mut [f32]) {
    match (f.has_pixel_effects(), f.field.is_some()) {
        (false, _) => angles_row_in::<false, false>(f, v_px, aop, dolp, aoe),
        (true, false) => angles_row_in::<true, false>(f, v_px, aop, dolp, aoe),
        (true, true) => angles_row_in::<true, true>(f, v_px, aop, dolp, aoe),
    }
}

#[inline(always)]
fn angles_row_in<const LENS: bool, const FIELD: bool>(
    f: &ChainFrame,
    v_px: f64,
    aop: &mut [f32],
    dolp: &mut [f32],
    aoe: &mut [f32],
) {
    let n = aop.len().min(dolp.len()).min(aoe.len());
    let (aop, dolp, aoe) = (&mut aop[..n], &mut dolp[..n], &mut aoe[..n]);
    let c = (f.intr.cx_px, f.intr.cy_px);
    f.intr.for_row(
        v_px,
        0.0,
        1.0,
        n,
        #[inline(always)]
        |u, g| {
            let [a, d, e] = sky_angles(ray_stokes_in::<LENS, FIELD>(f, g), u as f64, v_px, c);
            aop[u] = a;
            dolp[u] = d;
            aoe[u] = e;
        },
    );
}

/// The AoP (degrees, (−90°, 90°], image frame), DoLP (1) and AoE (AoP − β, β the image
/// angle of pixel `(u, v)` about the principal point `c`; degrees, (−90°, 90°]) of the
/// image-frame Stokes vector `s`, as f32; pure and branch-free. Equal to
/// `Stokes::aop_rad`, `Stokes::dolp` and `conventions::image_angle_rad` with libm's
/// atan2 to within a few ulp before the rounding to f32 (tested).
#[inline(always)]
pub fn sky_angles(s: Stokes, u_px: f64, v_px: f64, c: (f64, f64)) -> [f32; 3] {
    use crate::math::{atan2, wrap_deg_90_near};
    // AoP α = ½ atan2(U, Q), in (−90°, 90°].
    let a = 0.5 * atan2(s.u, s.q);
    let a = if a <= -std::f64::consts::FRAC_PI_2 { a + std::f64::consts::PI } else { a };
    let a_deg = a.to_degrees();
    // DoLP √(Q² + U²)/I, 0 where no light arrives.
    let d = if s.i > 0.0 { (s.q * s.q + s.u * s.u).sqrt() / s.i } else { 0.0 };
    // β: the image angle of the pixel about the principal point (CCW as displayed).
    let beta_deg = atan2(-(v_px - c.1), u_px - c.0).to_degrees();
    [wrap_deg_90_near(a_deg) as f32, d as f32, wrap_deg_90_near(a_deg - beta_deg) as f32]
}

/// [`ray_stokes`] for the row kernels, `LENS = false` only where no per-pixel
/// effect is on (the sky is Rayleigh, no scene elements) ([`ChainFrame::has_pixel_effects`]);
/// `FIELD = false` only where the frame has no field. Then the lens is the identity and
/// is skipped — bitwise the same: ρ = 0·r² = 0 for the finite r² of any pixel, so
/// c = √(1 − ρ²) = 1, I + ρQ = I, ρI + Q = Q (the sky's Q is never −0), c·U = U; δ = 0
/// gives cos δ = 1, sin δ = 0, U·1 + 0·V = U; the depolarizer keeps a = 1; the
/// vignetting factor is 1.
#[inline(always)]
fn ray_stokes_in<const LENS: bool, const FIELD: bool>(f: &ChainFrame, g: &RayGeometry) -> Stokes {
    if LENS {
        return ray_stokes_field::<FIELD>(f, g);
    }
    let s = sky_stokes(f.sun_cam, f.dmax, g.d, &g.basis);
    meridional_to_image(s, g.basis.cos2b, g.basis.sin2b)
}

/// Scratch rows of standard normals for [`sensor_dn_row`] and [`sensor_dn4_row`].
#[derive(Clone, Debug, Default)]
pub(crate) struct NoiseRows {
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
pub(crate) fn sensor_dn_row(
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
        *o = sensor_response(r, &f.sensor, offset, sig, &SensorNoise { temporal, dsnu, prnu }) as f32;
    }
}

/// Row kernel: for the channels with `used[ch]`, `out[u][ch] = sensor_dn(f,
/// signal[u][ch], ch, &sensor_noise4(f, pixel0 + u)[ch])`; 0 for the others (colocated).
pub(crate) fn sensor_dn4_row(
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
            let dn = sensor_response(r, &f.sensor, f.offset_dn[ch], sig[ch], &n);
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
mod tests {
    use super::*;
    use crate::chain::tests::{ideal_frame, intrinsics, scene};
    use crate::effects::EffectSet;

    fn noisy_frame(quantize: bool) -> ChainFrame {
        let mut set = EffectSet::new();
        set.set("channel_response", "offset90_dn", 3.0).unwrap();
        set.set("array_rotation", "dtheta_deg", 0.3).unwrap();
        set.set("lens_diattenuation", "rho2", 0.4).unwrap();
        // An analyzer effect: every pixel's own analyzer (the rows' per-site path).
        set.set("polarimetric_nonuniformity", "angle_sigma_deg", 0.5).unwrap();
        set.set("polarimetric_nonuniformity", "gain_sigma", 0.01).unwrap();
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

    /// A noisy frame with every scene element, tilted 75° toward the sun: the sun,
    /// clouds, skyline and ground all in view.
    fn field_frame() -> ChainFrame {
        let mut field = crate::scene::FieldScene::all(4);
        field.set("clouds", "count", 40.0).unwrap();
        let resp = Response { read_noise_dn: 1.0, quantize: true, bit_depth: 12, ..Response::ideal(3000.0) };
        let tilted = Scene { heading_deg: 40.0, tilt_x_deg: 75.0, ..scene() };
        let idx = NoiseIndex { seed: 9, trial: 0, frame: 1 };
        let f = ChainFrame::new_in_field(&Model::default(), &intrinsics(), &tilted, &resp, idx, Some(&field));
        assert!(f.has_pixel_effects());
        f
    }

    #[test]
    fn dofp_row_kernels_are_bitwise_the_per_pixel_chain() {
        // One scratch for a noisy, a noise-free and a noisy frame again: no stale draws.
        let mut scratch = NoiseRows::default();
        for f in [noisy_frame(false), ideal_frame(&Model::default()), field_frame(), noisy_frame(true)] {
            let (w, v) = (612usize, 37usize);
            let mut sig = vec![0.0; w];
            let mut dn = vec![0f32; w];
            for chans in [[2, 1], [3, 0]] {
                signal_row(&f, v as f64, chans, &mut sig);
                sensor_dn_row(&f, (v * w) as u32, chans, &sig, &mut scratch, &mut dn);
                for u in 0..w {
                    let ch = chans[u & 1];
                    let g = f.intr.geometry(u as f64, v as f64);
                    let want = site_signal_dn(&f, ray_stokes(&f, &g), &g, u as u32, v as u32, ch);
                    assert_eq!(sig[u], want, "signal at {u}");
                    if !f.has_analyzer_effects() {
                        assert_eq!(want, pixel_signal_dn(&f, pixel_stokes(&f, u as f64, v as f64), ch));
                    }
                    let p = (v * w + u) as u32;
                    assert_eq!(dn[u], sensor_dn(&f, want, ch, &sensor_noise(&f, p, ch)) as f32, "DN at {u}");
                }
            }
        }
    }

    #[test]
    fn angle_row_kernel_is_bitwise_the_per_pixel_chain_and_libm_to_f32() {
        use crate::conventions::{image_angle_rad, wrap_deg_90};
        let (w, v) = (612usize, 37usize);
        let (mut aop, mut dolp, mut aoe) = (vec![0f32; w], vec![0f32; w], vec![0f32; w]);
        for f in [noisy_frame(false), ideal_frame(&Model::default()), field_frame()] {
            let c = (f.intr.cx_px, f.intr.cy_px);
            angles_row(&f, v as f64, &mut aop, &mut dolp, &mut aoe);
            for u in 0..w {
                let s = pixel_stokes(&f, u as f64, v as f64);
                assert_eq!([aop[u], dolp[u], aoe[u]], sky_angles(s, u as f64, v as f64, c), "at {u}");
                // With libm's atan2 and the remainder wrap: the same to f32 rounding.
                let a = s.aop_rad().to_degrees();
                let beta = image_angle_rad(u as f64 - c.0, v as f64 - c.1).to_degrees();
                let near = |x: f32, y: f64| (wrap_deg_90(x as f64 - y)).abs() <= 1e-5;
                assert!(near(aop[u], wrap_deg_90(a)), "AoP at {u}: {} vs {} ({s:?})", aop[u], wrap_deg_90(a));
                assert!(near(aoe[u], wrap_deg_90(a - beta)), "AoE at {u}: {} vs {}", aoe[u], wrap_deg_90(a - beta));
                assert_eq!(dolp[u], s.dolp() as f32, "DoLP at {u}");
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
        for f in [noisy_frame(false), ideal_frame(&Model::default()), field_frame(), noisy_frame(true)] {
            signal4_row(&f, v as f64, &mut sig);
            sensor_dn4_row(&f, (v * w) as u32, used, &sig, &mut scratch, &mut dn);
            for u in 0..w {
                let g = f.intr.geometry(u as f64, v as f64);
                let s = ray_stokes(&f, &g);
                let noise = sensor_noise4(&f, (v * w + u) as u32);
                for ch in 0..4 {
                    assert_eq!(sig[u][ch], site_signal_dn(&f, s, &g, u as u32, v as u32, ch));
                    let want = if used[ch] { sensor_dn(&f, sig[u][ch], ch, &noise[ch]) } else { 0.0 };
                    assert_eq!(dn[u][ch], want);
                }
            }
        }
    }
}
