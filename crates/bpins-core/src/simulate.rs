//! Drivers: map the per-pixel chain ([`crate::chain`]) over a frame with rayon.
//!
//! Rows are independent and every random draw is keyed by its pixel, so the output is
//! bit-identical whatever the thread count.

use crate::camera::Intrinsics;
use crate::chain::{
    angles_row, pixel_signal_dn, pixel_stokes, sensor_dn4_row, sensor_dn_row, signal4_row, signal_row, ChainFrame,
    NoiseRows, Scene,
};
use crate::effects::Model;
use crate::heading::{HeadingContext, HeadingSums, RowScratch};
use crate::recon::{superpixel_stokes_row, Reconstructor};
use crate::sensor::{Channel, ColourTiles, Layout};
use crate::stokes::Stokes;
use rayon::prelude::*;

/// Renders a DoFP mosaic (`w × h`, row-major DN): each pixel its own ray and analyzer.
pub fn render_mosaic(f: &ChainFrame, w: usize, h: usize, mosaic: &[[Channel; 2]; 2]) -> Vec<f32> {
    let mut out = vec![0f32; w * h];
    render_mosaic_into(f, w, h, mosaic, &mut out);
    out
}

/// [`render_mosaic`] into the caller's buffer `out` (`w × h`, row-major; rows past
/// `h` are left alone): bitwise the same DN, no allocation but the row buffers.
pub fn render_mosaic_into(f: &ChainFrame, w: usize, h: usize, mosaic: &[[Channel; 2]; 2], out: &mut [f32]) {
    let out = &mut out[..w * h];
    out.par_chunks_mut(w.max(1)).enumerate().for_each_init(
        || (vec![0.0; w], NoiseRows::default(), CrosstalkRows::default()),
        |(signal, scratch, xt), (v, row)| {
            let chans = [0, 1].map(|u| Layout::dofp_channel(mosaic, u, v).index());
            // Sky → lens → analyzer → photo-signal along each true ray (and crosstalk).
            mosaic_signal_row(f, v, h, mosaic, xt, &mut signal[..row.len()]);
            // Sensor: non-uniformities, offsets, noise, rounding.
            sensor_dn_row(f, (v * w) as u32, chans, &signal[..row.len()], scratch, row);
        },
    );
}

/// Renders a colour-polarization DoFP mosaic (`w × h`, row-major DN;
/// CONVENTIONS.md `colour_tiles`): each pixel its own ray and analyzer through the frame
/// of the band over it (`frames` by [`Band::index`](crate::sensor::Band::index),
/// [`ChainFrame::bands`]), the mosaic effects with its neighbours as their bands see
/// them; bitwise `chain::colour_pixel_signal_dn` then the sensor (tested). The bands'
/// frames share their sensor, offsets and noise keys, so the sensor stage is theirs.
pub fn render_colour_mosaic(
    frames: &[ChainFrame; 3],
    w: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    tiles: &ColourTiles,
) -> Vec<f32> {
    let mut out = vec![0f32; w * h];
    out.par_chunks_mut(w.max(1)).enumerate().for_each_init(
        || (vec![0.0; w], NoiseRows::default(), CrosstalkRows::default()),
        |(signal, scratch, xt), (v, row)| {
            let chans = [0, 1].map(|u| Layout::dofp_channel(mosaic, u, v).index());
            // Sky → lens → analyzer → photo-signal, each pixel in its band (and crosstalk).
            colour_signal_row(frames, tiles, v, h, mosaic, xt, &mut signal[..row.len()]);
            // Sensor: non-uniformities, offsets, noise, rounding (the same in every band).
            sensor_dn_row(&frames[0], (v * w) as u32, chans, &signal[..row.len()], scratch, row);
        },
    );
    out
}

/// Row `v` of a colour sensor's photo-signal (DN), `out[u] =
/// chain::colour_pixel_signal_dn(frames, tiles, u, v, out.len(), h, mosaic)` bitwise.
fn colour_signal_row(
    frames: &[ChainFrame; 3],
    tiles: &ColourTiles,
    v: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    xt: &mut CrosstalkRows,
    out: &mut [f64],
) {
    let w = out.len();
    // Every pixel of row r through its band's frame: the row kernel of the row's first
    // tile's band, then, where the row's other tile has another band, that band's row
    // kernel for its pixels (each pixel's signal is its own: bitwise per pixel).
    let band_row = |r: usize, other: &mut Vec<f64>, out: &mut [f64]| {
        let chans = [0, 1].map(|u| Layout::dofp_channel(mosaic, u, r).index());
        let [b0, b1] = tiles.tiles[(r >> 1) & 1];
        signal_row(&frames[b0.index()], r as f64, chans, out);
        if b1 != b0 {
            other.clear();
            other.resize(out.len(), 0.0);
            signal_row(&frames[b1.index()], r as f64, chans, other);
            for (u, o) in out.iter_mut().enumerate().filter(|(u, _)| (u >> 1) & 1 == 1) {
                *o = other[u];
            }
        }
    };
    let f = &frames[0];
    if !f.has_mosaic_effects() {
        band_row(v, &mut xt.other, out);
        return;
    }
    let CrosstalkRows { own, up, down, other } = xt;
    for (buf, row) in [(own, Some(v)), (up, v.checked_sub(1)), (down, Some(v + 1).filter(|&r| r < h))] {
        buf.clear();
        buf.resize(w, 0.0);
        if let Some(r) = row {
            band_row(r, other, buf);
        }
    }
    for (u, o) in out.iter_mut().enumerate() {
        let left = if u > 0 { xt.own[u - 1] } else { 0.0 };
        let right = if u + 1 < w { xt.own[u + 1] } else { 0.0 };
        *o = crate::chain::mosaic_effects(&f.mosaic, &f.active.mosaic, xt.own[u], [xt.up[u], xt.down[u], left, right]);
    }
}

/// Heading sums of a DoFP frame (`w × h`) reconstructed as 2 × 2 superpixels, fused:
/// bitwise `HeadingSums::from_image(&superpixels(&render_mosaic(f, w, h, mosaic), w, h,
/// mosaic, rec, full_scale_dn), ctx)`, without the mosaic or the Stokes image.
///
/// Per tile row (in parallel, each with its own small row buffers): the two pixel
/// rows' DN as [`render_mosaic`] renders them, that row's superpixels, then its sums;
/// the rows' sums are added in row order (bit-identical whatever the thread count).
/// An odd last row or column belongs to no tile and is not rendered.
pub fn mosaic_heading_sums(
    f: &ChainFrame,
    w: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    rec: &Reconstructor,
    full_scale_dn: f64,
    ctx: &HeadingContext,
) -> HeadingSums {
    let (tw, th) = (w / 2, h / 2);
    let cos_2band = HeadingSums::cos_2band(ctx);
    HeadingSums::sum_rows(th, FusedRows::default, |s, j| {
        s.signal.resize(w, 0.0);
        for (dv, dn) in s.dn.iter_mut().enumerate() {
            // As render_mosaic's row v.
            let v = 2 * j + dv;
            let chans = [0, 1].map(|u| Layout::dofp_channel(mosaic, u, v).index());
            dn.resize(w, 0.0);
            mosaic_signal_row(f, v, h, mosaic, &mut s.crosstalk, &mut s.signal);
            sensor_dn_row(f, (v * w) as u32, chans, &s.signal, &mut s.noise, dn);
        }
        // As superpixels' row j, read back as from_image does.
        s.stokes.resize(tw, Stokes::default());
        superpixel_stokes_row(&s.dn[0], &s.dn[1], mosaic, rec, full_scale_dn, &mut s.stokes);
        // As PolImage::position_px(0, j) of a superpixel image.
        let (x0, step) = (0.5, 2.0);
        let y = 0.5 + step * j as f64;
        let mut acc = HeadingSums::default();
        acc.accumulate_row(ctx, cos_2band, y, x0, step, &s.stokes, &mut s.heading);
        acc
    })
}

/// Row buffers of [`mosaic_heading_sums`] (one set per rayon job).
#[derive(Default)]
struct FusedRows {
    signal: Vec<f64>,
    noise: NoiseRows,
    dn: [Vec<f32>; 2],
    stokes: Vec<Stokes>,
    heading: RowScratch,
    crosstalk: CrosstalkRows,
}

/// Neighbour rows of [`mosaic_signal_row`].
#[derive(Default)]
struct CrosstalkRows {
    own: Vec<f64>,
    up: Vec<f64>,
    down: Vec<f64>,
    /// A colour row's second band ([`colour_signal_row`]).
    other: Vec<f64>,
}

/// Row `v` of a DoFP frame's photo-signal (DN), `out[u] = chain::mosaic_pixel_signal_dn(f,
/// u, v, out.len(), h, mosaic)` bitwise: the row kernel, then, where the frame has
/// crosstalk, the rows above and below and the mix with the four edge neighbours.
fn mosaic_signal_row(
    f: &ChainFrame,
    v: usize,
    h: usize,
    mosaic: &[[Channel; 2]; 2],
    xt: &mut CrosstalkRows,
    out: &mut [f64],
) {
    let chans = |v: usize| [0, 1].map(|u| Layout::dofp_channel(mosaic, u, v).index());
    let w = out.len();
    if !f.has_mosaic_effects() {
        signal_row(f, v as f64, chans(v), out);
        return;
    }
    for (buf, row) in
        [(&mut xt.own, Some(v)), (&mut xt.up, v.checked_sub(1)), (&mut xt.down, Some(v + 1).filter(|&r| r < h))]
    {
        buf.clear();
        buf.resize(w, 0.0);
        if let Some(r) = row {
            signal_row(f, r as f64, chans(r), buf);
        }
    }
    for (u, o) in out.iter_mut().enumerate() {
        let left = if u > 0 { xt.own[u - 1] } else { 0.0 };
        let right = if u + 1 < w { xt.own[u + 1] } else { 0.0 };
        *o = crate::chain::mosaic_effects(&f.mosaic, &f.active.mosaic, xt.own[u], [xt.up[u], xt.down[u], left, right]);
    }
}

/// Heading sums of a colocated frame (`w × h`), one per context of `contexts`, fused
/// per pixel row (no frame kept): every channel's DN (f64, unmasked: the Monte Carlo's
/// sensor does not clip), the Stokes inversion `rec` of the `used` channels, then the
/// sums along each context's assumed rays. Rows are added in row order (bit-identical
/// whatever the thread count).
pub fn colocated_heading_sums(
    f: &ChainFrame,
    w: usize,
    h: usize,
    used: [bool; 4],
    rec: &Reconstructor,
    contexts: &[HeadingContext],
) -> Vec<HeadingSums> {
    let rows: Vec<Vec<HeadingSums>> = (0..h)
        .into_par_iter()
        .map_init(
            || {
                (
                    vec![[0.0; 4]; w],
                    vec![[0.0; 4]; w],
                    vec![Stokes::default(); w],
                    NoiseRows::default(),
                    RowScratch::default(),
                )
            },
            |(signal, dn, stokes, noise, scratch), v| {
                let y = v as f64;
                // Sky → analyzers along each true ray (vectorized row kernels).
                signal4_row(f, y, signal);
                // Sensor response with noise, then the Stokes inversion.
                sensor_dn4_row(f, (v * w) as u32, used, signal, noise, dn);
                for (out, dn) in stokes.iter_mut().zip(dn.iter()) {
                    *out = rec.stokes(dn);
                }
                // Heading sums along each context's assumed rays.
                contexts
                    .iter()
                    .map(|ctx| {
                        let mut acc = HeadingSums::default();
                        acc.accumulate_row(ctx, HeadingSums::cos_2band(ctx), y, 0.0, 1.0, stokes, scratch);
                        acc
                    })
                    .collect()
            },
        )
        .collect();
    let mut total = vec![HeadingSums::default(); contexts.len()];
    for row in rows {
        for (t, r) in total.iter_mut().zip(row) {
            *t += r;
        }
    }
    total
}

/// Renders a colocated frame: one `w × h` plane per channel in `channels`.
pub fn render_colocated(f: &ChainFrame, w: usize, h: usize, channels: &[Channel]) -> Vec<Vec<f32>> {
    let mut used = [false; 4];
    for c in channels {
        used[c.index()] = true;
    }
    let rows: Vec<Vec<[f64; 4]>> = (0..h)
        .into_par_iter()
        .map_init(
            || (vec![[0.0; 4]; w], NoiseRows::default()),
            |(signal, scratch), v| {
                let mut dn = vec![[0.0; 4]; w];
                signal4_row(f, v as f64, signal);
                sensor_dn4_row(f, (v * w) as u32, used, signal, scratch, &mut dn);
                dn
            },
        )
        .collect();
    let mut planes = vec![vec![0f32; w * h]; channels.len()];
    for (v, row) in rows.iter().enumerate() {
        for (u, dn) in row.iter().enumerate() {
            for (plane, c) in planes.iter_mut().zip(channels) {
                plane[v * w + u] = dn[c.index()] as f32;
            }
        }
    }
    planes
}

/// The sky as a camera sees it: per pixel (row-major, `width_px × height_px`), the
/// polarization of the light reaching the analyzers, noise-free and before any DN is
/// rendered. Image frame and angles as CONVENTIONS.md; NaN nowhere (an unpolarized
/// pixel has DoLP 0 and the angle atan2 gives).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkyMaps {
    pub width_px: usize,
    pub height_px: usize,
    /// Angle of polarization α, degrees, (−90°, 90°], counter-clockwise from image +x as displayed.
    pub aop_deg: Vec<f32>,
    /// Degree of linear polarization, 1.
    pub dolp: Vec<f32>,
    /// Angle of the E-vector to the local meridian φ = α − β (β: the pixel's image angle
    /// about the frame's true principal point), degrees, (−90°, 90°].
    pub aoe_deg: Vec<f32>,
}

/// The AoP, DoLP and AoE maps of frame `f` (camera, sun, attitude and effects as
/// [`ChainFrame::noise_free`] or [`ChainFrame::new`] fold them) on a `w × h` sensor,
/// without rendering DN: the per-pixel chain up to the analyzers, rows in parallel.
/// The GPU backend's `sky_maps` runs the WGSL twin (`chain_maps`).
///
/// ```
/// use bpins_core::camera::{Intrinsics, Projection};
/// use bpins_core::twin::{ChainFrame, Scene};
/// let intr = Intrinsics::new(Projection::Equidistant, 40.0, 31.5, 31.5);
/// let scene = Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 0.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
/// let maps = bpins_core::twin::sky_maps(&ChainFrame::noise_free(&Default::default(), &intr, &scene), 64, 64);
/// // Rayleigh: the DoLP peaks (at d_max) 90° from the sun.
/// let peak = maps.dolp.iter().cloned().fold(0.0f32, f32::max);
/// assert!((peak - 0.6).abs() < 0.01);
/// ```
pub fn sky_maps(f: &ChainFrame, w: usize, h: usize) -> SkyMaps {
    let n = w * h;
    let (mut aop, mut dolp, mut aoe) = (vec![0f32; n], vec![0f32; n], vec![0f32; n]);
    if w > 0 {
        aop.par_chunks_mut(w)
            .zip(dolp.par_chunks_mut(w))
            .zip(aoe.par_chunks_mut(w))
            .enumerate()
            .for_each(|(v, ((a, d), e))| angles_row(f, v as f64, a, d, e));
    }
    SkyMaps { width_px: w, height_px: h, aop_deg: aop, dolp, aoe_deg: aoe }
}

/// Largest noise-free analyzer intensity (sky radiance units, gain 1) over the frame,
/// sampled on a grid of `stride_px` plus the last row and column: divide the wanted
/// peak DN by it to get the sensor gain.
pub fn peak_intensity(model: &Model, nominal: &Intrinsics, scene: &Scene, w: usize, h: usize, stride_px: usize) -> f64 {
    peak_signal(&ChainFrame::noise_free(model, nominal, scene), w, h, stride_px)
}

/// Largest noise-free photo-signal of any channel of frame `f` (`w × h`), sampled on a
/// grid of `stride_px` plus the last row and column.
pub(crate) fn peak_signal(f: &ChainFrame, w: usize, h: usize, stride_px: usize) -> f64 {
    let grid = |n: usize| -> Vec<usize> {
        let mut g: Vec<usize> = (0..n).step_by(stride_px.max(1)).collect();
        if g.last() != Some(&(n - 1)) {
            g.push(n - 1);
        }
        g
    };
    let (us, vs) = (grid(w), grid(h));
    vs.par_iter()
        .map(|&v| {
            let mut m: f64 = 0.0;
            for &u in &us {
                let s = pixel_stokes(f, u as f64, v as f64);
                for ch in 0..4 {
                    m = m.max(pixel_signal_dn(f, s, ch));
                }
            }
            m
        })
        .reduce(|| 0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::tests::{intrinsics, scene};
    use crate::chain::NoiseIndex;
    use crate::sensor::{Response, DEFAULT_MOSAIC};

    #[test]
    fn sky_maps_are_the_per_pixel_chain_and_the_aoe_rule() {
        use crate::conventions::{image_angle_rad, wrap_deg_90};
        let f = ChainFrame::noise_free(&Model::default(), &intrinsics(), &scene());
        let (w, h) = (61, 47);
        let m = sky_maps(&f, w, h);
        assert_eq!(
            (m.width_px, m.height_px, m.aop_deg.len(), m.dolp.len(), m.aoe_deg.len()),
            (w, h, w * h, w * h, w * h)
        );
        for (u, v) in [(0, 0), (w - 1, h - 1), (30, 20), (5, 46)] {
            let k = v * w + u;
            let s = pixel_stokes(&f, u as f64, v as f64);
            let d = wrap_deg_90(m.aop_deg[k] as f64 - s.aop_rad().to_degrees());
            assert!(d.abs() < 1e-5, "AoP at ({u}, {v}) off by {d} deg");
            assert_eq!(m.dolp[k], s.dolp() as f32);
            // AoE = AoP − β about the principal point (CONVENTIONS.md), within f32 rounding.
            let beta = image_angle_rad(u as f64 - f.intr.cx_px, v as f64 - f.intr.cy_px).to_degrees();
            let d = wrap_deg_90(m.aoe_deg[k] as f64 - (m.aop_deg[k] as f64 - beta));
            assert!(d.abs() < 1e-4, "AoE at ({u}, {v}) off the rule by {d} deg");
        }
        assert_eq!(sky_maps(&f, 0, 5).aop_deg.len(), 0);
    }

    /// Every band effect at its typical value, a lens effect and (where `crosstalk`)
    /// crosstalk: the colour model with work in each stage.
    fn colour_model(crosstalk: bool) -> Model {
        let mut set = crate::effects::EffectSet::new();
        for name in ["sky_spectrum", "band_response"] {
            for p in crate::effects::find(name).unwrap().params {
                set.set(name, p.name, p.typical).unwrap();
            }
        }
        set.set("lens_diattenuation", "rho2", 0.3).unwrap();
        if crosstalk {
            set.set("crosstalk", "c", 0.02).unwrap();
        }
        set.model()
    }

    #[test]
    fn colour_mosaic_is_each_pixel_through_its_band_with_crosstalk_across_bands() {
        let tiles = ColourTiles::imx250myr();
        let sc = scene();
        let (w, h) = (37, 23);
        for crosstalk in [false, true] {
            let model = colour_model(crosstalk);
            let frames = ChainFrame::noise_free(&model, &intrinsics(), &sc).bands(&model, &sc);
            let dn = render_colour_mosaic(&frames, w, h, &DEFAULT_MOSAIC, &tiles);
            for v in 0..h {
                for u in 0..w {
                    let want = crate::chain::colour_pixel_signal_dn(&frames, &tiles, u, v, w, h, &DEFAULT_MOSAIC);
                    assert_eq!(dn[v * w + u], want as f32, "({u}, {v}), crosstalk {crosstalk}");
                }
            }
            // The bands differ: a red pixel's signal is not the green frame's.
            let g = crate::chain::mosaic_pixel_signal_dn(&frames[1], 0, 0, w, h, &DEFAULT_MOSAIC);
            assert!((dn[0] as f64 / g - 0.625 * 0.8).abs() < 0.05, "{} vs {g}", dn[0]);
        }
    }

    #[test]
    fn a_colour_mosaic_at_neutral_bands_is_the_monochrome_mosaic_bitwise() {
        let resp = Response {
            read_noise_dn: 1.0,
            system_gain_dn_per_e: 0.1,
            quantize: true,
            bit_depth: 12,
            ..Response::ideal(3000.0)
        };
        let mut set = crate::effects::EffectSet::new();
        set.set("crosstalk", "c", 0.02).unwrap();
        let (model, sc) = (set.model(), scene());
        let f = ChainFrame::new(&model, &intrinsics(), &sc, &resp, NoiseIndex { seed: 3, trial: 0, frame: 1 });
        let frames = f.bands(&model, &sc);
        assert!(frames.iter().all(|b| *b == f));
        let colour = render_colour_mosaic(&frames, 64, 40, &DEFAULT_MOSAIC, &ColourTiles::imx250myr());
        assert_eq!(colour, render_mosaic(&f, 64, 40, &DEFAULT_MOSAIC));
    }

    #[test]
    fn mosaic_is_bit_identical_whatever_the_thread_count() {
        let resp = Response {
            read_noise_dn: 1.0,
            system_gain_dn_per_e: 0.1,
            quantize: true,
            bit_depth: 12,
            ..Response::ideal(3000.0)
        };
        let f = ChainFrame::new(
            &Model::default(),
            &intrinsics(),
            &scene(),
            &resp,
            NoiseIndex { seed: 11, trial: 0, frame: 0 },
        );
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| render_mosaic(&f, 612, 64, &DEFAULT_MOSAIC))
        };
        assert_eq!(run(1), run(3));
    }

    #[test]
    fn fused_heading_sums_are_bitwise_the_mosaic_path_whatever_the_thread_count() {
        use crate::heading::{HeadingContext, HeadingSums};
        use crate::recon::superpixels;
        let resp = Response {
            gain_dn: 3000.0,
            black_level_dn: 64.0,
            read_noise_dn: 1.0,
            system_gain_dn_per_e: 0.1,
            quantize: true,
            bit_depth: 12,
            ..Response::ideal(1.0)
        };
        let mut set = crate::effects::EffectSet::new();
        set.set("lens_diattenuation", "rho2", 0.8).unwrap();
        let mirrored = [[Channel::C45, Channel::C90], [Channel::C0, Channel::C135]];
        let noise = NoiseIndex { seed: 11, trial: 0, frame: 0 };
        for (model, mosaic, rho2, (w, h)) in [
            (Model::default(), DEFAULT_MOSAIC, 0.0, (612, 512)),
            (Model::default(), DEFAULT_MOSAIC, 0.0, (611, 301)),
            (set.model(), mirrored, 0.8, (612, 512)),
            (Model::default(), DEFAULT_MOSAIC, 0.0, (1, 7)),
        ] {
            let f = ChainFrame::new(&model, &intrinsics(), &scene(), &resp, noise);
            let rec = Reconstructor::new(&model, 64.0, &Channel::ALL).unwrap();
            let ctx = HeadingContext { lens_rho2: rho2, ..HeadingContext::new(intrinsics(), w, h, 40.0, 25.0) };
            let fs = resp.full_scale_dn();
            let reference =
                HeadingSums::from_image(&superpixels(&render_mosaic(&f, w, h, &mosaic), w, h, &mosaic, &rec, fs), &ctx);
            let run = |threads| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| mosaic_heading_sums(&f, w, h, &mosaic, &rec, fs, &ctx))
            };
            assert_eq!(run(1), reference, "{w} × {h}");
            assert_eq!(run(3), reference, "{w} × {h}");
            if w > 2 {
                assert!(reference.n > 0.0 && reference.line.iter().map(|l| l[6]).sum::<f64>() > 10.0);
            }
        }
    }

    #[test]
    fn colocated_planes_match_the_mosaic_where_they_overlap() {
        let f = ChainFrame::noise_free(&Model::default(), &intrinsics(), &scene());
        let m = render_mosaic(&f, 40, 30, &DEFAULT_MOSAIC);
        let planes = render_colocated(&f, 40, 30, &Channel::ALL);
        for v in 0..30 {
            for u in 0..40 {
                let ch = Layout::dofp_channel(&DEFAULT_MOSAIC, u, v).index();
                assert_eq!(m[v * 40 + u], planes[ch][v * 40 + u]);
            }
        }
    }

    #[test]
    fn peak_intensity_bounds_the_frame() {
        let p = peak_intensity(&Model::default(), &intrinsics(), &scene(), 612, 512, 8);
        let f = ChainFrame::noise_free(&Model::default(), &intrinsics(), &scene());
        let planes = render_colocated(&f, 612, 512, &Channel::ALL);
        let true_max = planes.iter().flatten().cloned().fold(0f32, f32::max) as f64;
        assert!(p <= true_max * (1.0 + 1e-6), "{p} vs {true_max}");
        assert!((p - true_max).abs() / true_max < 0.01, "{p} vs {true_max}");
    }
}
