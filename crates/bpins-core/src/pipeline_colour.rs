//! A colour-polarization capture's plain headings (`bpins heading --estimator plain`
//! on `[sensor] colour_tiles`): each band's Stokes samples from its own pixels, each
//! band's heading with the plain extractors (least squares, statistical 1σ), and the
//! bands' fused heading ([`crate::sweep::fused_estimate`]), as the colour sweep reads
//! its trials. Units: degrees, DN; frame: image pixels (CONVENTIONS.md).

use super::{heading_context, ReconMode};
use crate::capture::{Capture, FrameData};
use crate::effects::Model;
use crate::error::{Error, Result};
use crate::heading::{Extractor, HeadingContext, HeadingEstimate, HeadingSums};
use crate::recon::{PolImage, Reconstructor};
use crate::sensor::{Band, ColourTiles, Layout};

/// One extractor's plain headings of a colour-polarization frame
/// ([`colour_frame_headings_of`]): each band's, and the bands' fused one.
#[derive(Debug)]
pub struct ColourPlainHeadings {
    pub extractor: Extractor,
    /// Each band the sensor has ([`crate::sensor::ColourTiles::bands`], R, G, B order),
    /// with its heading or why it has none.
    pub bands: Vec<(Band, Result<HeadingEstimate>)>,
    /// The bands' inverse-variance heading and its statistical 1σ
    /// ([`crate::sweep::fused_estimate`]); `None` where no band has a heading.
    pub fused: Option<HeadingEstimate>,
}

/// [`frame_headings_of`](super::frame_headings_of) of a colour-polarization capture's frame `data` (its DoFP
/// mosaic, `[sensor] colour_tiles`), band by band: each band's Stokes samples from its
/// own pixels only (`colour_band_sums`, `mode` the reconstruction), each band solved
/// with every extractor, then fused ([`crate::sweep::fused_estimate`]: inverse-variance,
/// statistical 1σ). Per extractor, in `extractors`' order. A monochrome capture, or a
/// frame that is not a DoFP mosaic, is refused.
pub fn colour_frame_headings_of(
    c: &Capture,
    index: usize,
    data: &FrameData,
    known: &Model,
    mode: ReconMode,
    extractors: &[Extractor],
) -> Result<Vec<ColourPlainHeadings>> {
    let ctx = heading_context(c, &c.frames[index], known);
    let (bands, sums) = colour_band_sums(c, data, known, mode, &ctx)?;
    Ok(extractors
        .iter()
        .map(|&e| {
            // By `Band::index`; a band the tiles lack has no sums and no heading. The
            // demosaic's samples share DN: each band's 1σ widened by √F_b.
            let mut solved = sums.map(|s| s.solve(e, &ctx));
            if mode == ReconMode::Demosaic {
                let tiles = c.sensor.colour.as_ref().expect("colour_band_sums read a colour capture");
                for (r, b) in solved.iter_mut().zip(Band::ALL) {
                    if let Ok(est) = r {
                        est.sigma_deg *= design_effect(tiles, b).sqrt();
                    }
                }
            }
            let est =
                std::array::from_fn(|k| solved[k].as_ref().ok().copied().filter(|_| bands.contains(&Band::ALL[k])));
            let fused = crate::sweep::fused_estimate(&est);
            let bands = Band::ALL.into_iter().zip(solved).filter(|(b, _)| bands.contains(b)).collect();
            ColourPlainHeadings { extractor: e, bands, fused }
        })
        .collect())
}

/// The design effect F_b of band `b`'s demosaic samples (Kish, Survey Sampling, 1965: the
/// variance of a mean of correlated samples over that of as many independent ones): the plain
/// extractors' 1σ takes the samples as independent, and the tile means of the bilinear
/// colour demosaic ([`colour_band_sums`]) share raw DN with their neighbours, so the
/// band's 1σ is multiplied by √F_b.
///
/// ```text
/// F = Σ_j ρ_ij = (Σ_s w_s)² / Σ_s w_s² = 1 / Σ_s w_s²   (Σ_s w_s = 1: the stencil keeps a constant)
/// w_s  the weight of raw sample s (the band's own, of one channel) in a tile's mean
/// one tile per superpixel (R, B): w = (7/8, 1/8) ⊗ (7/8, 1/8)          Σw² = 2500/4096, F = 1.638
/// two diagonal tiles (G): w = (168, 40, 12, 12, 12, 12)/256           Σw² = 1900/4096, F = 2.156
/// ```
///
/// ρ_ij is the correlation of tile means i and j through the raw samples they share
/// (each raw sample's noise independent, all of one variance); F = Σ_j ρ_ij holds where
/// the extractor's influence varies slowly over a few tiles (its least squares over the
/// whole frame). The same F for every channel (its stencil is the others' mirrored),
/// so for Q, U and the AoP. Derivation of w: a channel's value at the tile's own pixel
/// of that channel is its sample; at the tile's other pixels the stage-2 bilinear mean
/// of that sample and the next lattice point's, itself the stage-1 Bayer mean of the
/// band's samples around it (`maps_colour.rs`). Interior tiles; the border's OpenCV
/// rule differs on its one-tile rim. `tests` checks w against `colour_maps` itself. The
/// arithmetic is [`super::kish_design_effect`]'s, as the monochrome demosaic's.
pub(crate) fn design_effect(tiles: &ColourTiles, b: Band) -> f64 {
    /// One tile per superpixel: (7/8, 1/8) ⊗ (7/8, 1/8).
    const ONE_TILE: [f64; 4] = [49.0 / 64.0, 7.0 / 64.0, 7.0 / 64.0, 1.0 / 64.0];
    /// Two diagonal tiles per superpixel.
    const TWO_TILES: [f64; 6] = [168.0 / 256.0, 40.0 / 256.0, 12.0 / 256.0, 12.0 / 256.0, 12.0 / 256.0, 12.0 / 256.0];
    match tiles.classes(b).iter().flatten().filter(|&&on| on).count() {
        2 => super::kish_design_effect(&TWO_TILES),
        _ => super::kish_design_effect(&ONE_TILE),
    }
}

/// Each band's heading sums of a colour frame (by `Band::index`), and the bands the
/// tiles have. Every 2 × 2 analyzer tile lies under one filter (CONVENTIONS.md), so no
/// band is mixed:
///
/// - [`ReconMode::Superpixel`]: each tile is one band's superpixel, its Stokes from its
///   own four pixels (samples at 0 or full scale masked), each moved to the tile centre
///   by its gradient across the band's tiles 4 px to either side
///   ([`crate::recon::band_superpixels_centred`]). As the tile reads them (the colour
///   sweep's sums, [`crate::sweep::colour_mosaic_heading_sums`]) its four rays read the
///   sky's gradient as polarization: 0.09°–0.13° in heading on `samples/colour-clear`'s
///   frames, ten or more times their 1σ, before the move.
/// - [`ReconMode::Demosaic`]: each band's Stokes at each of its own pixels, at that
///   pixel's ray, from the band's bilinear maps (`colour_maps`, [`Interpolation::Bilinear`]:
///   each analyzer plane's band samples averaged from that band's own samples, then the
///   band's mosaic demosaiced per channel, unrounded; a pixel weighing a sample at 0 or
///   full scale is NaN), (I, Q, U) = I·(1, P cos 2α, P sin 2α) from its intensity, DoLP
///   and AoP (float32: AoP to 1e-5°); the four pixels of each of the band's tiles
///   averaged into one sample at the tile centre (a NaN pixel masks the tile). Each
///   channel is then the mean of its values at four pixels symmetric about the centre,
///   so a gradient across the tile cancels to first order (on `samples/colour-clear`
///   0.002°–0.017° RMS by band, as the field estimator's), and a band gives one sample
///   per tile, as many as the superpixel route: its samples share only their
///   neighbours' part of the interpolation, which [`design_effect`] puts back into
///   each band's 1σ (a sample per pixel would put four strongly correlated samples on
///   each tile and halve the 1σ).
///
/// [`Interpolation::Bilinear`]: crate::maps::Interpolation::Bilinear
fn colour_band_sums(
    c: &Capture,
    data: &FrameData,
    known: &Model,
    mode: ReconMode,
    ctx: &HeadingContext,
) -> Result<(Vec<Band>, [HeadingSums; 3])> {
    use crate::maps::{colour_maps, Interpolation, MapsConfig};
    let refuse = |m: String| Error::Capture { path: c.toml_path(), message: m };
    let tiles = c.sensor.colour.as_ref().ok_or_else(|| refuse("colour headings of a monochrome capture".into()))?;
    let (FrameData::Mosaic { width_px, height_px, dn }, Layout::Dofp { mosaic }) = (data, &c.sensor.layout) else {
        return Err(refuse("a colour-polarization frame is a DoFP mosaic".into()));
    };
    let rec = Reconstructor::new(known, c.sensor.black_level_dn, &c.sensor.channels())?;
    let (w, h) = (*width_px as usize, *height_px as usize);
    let full = c.sensor.full_scale_dn();
    let bands = tiles.bands();
    let sums = match mode {
        ReconMode::Superpixel => {
            let mut sums = [HeadingSums::default(); 3];
            for &b in &bands {
                let img = crate::recon::band_superpixels_centred(dn, w, h, mosaic, &rec, full, &tiles.classes(b));
                sums[b.index()] = HeadingSums::from_image(&img, ctx);
            }
            sums
        }
        ReconMode::Demosaic => {
            let cfg = MapsConfig {
                interpolation: Interpolation::Bilinear,
                mosaic: *mosaic,
                full_scale_dn: full,
                aoe_centre_px: [0.0; 2],
            };
            let raw = crate::heading::field::RawImage::packed(dn.as_slice(), w, h);
            let maps = colour_maps(&raw, &rec, &cfg, tiles).map_err(|e| refuse(e.to_string()))?;
            let mut sums = [HeadingSums::default(); 3];
            for m in &maps {
                let classes = tiles.classes(m.band);
                let (tw, th) = (w / 2, h / 2);
                let px = |u: usize, v: usize| {
                    let p = v * w + u;
                    let (i, dolp, aop) =
                        (m.maps.intensity_dn[p] as f64, m.maps.dolp[p] as f64, (m.maps.aop_deg[p] as f64).to_radians());
                    let pol = i * dolp;
                    [i, pol * (2.0 * aop).cos(), pol * (2.0 * aop).sin()]
                };
                let iqu = (0..tw * th)
                    .map(|t| {
                        let (ti, tj) = (t % tw, t / tw);
                        if !classes[tj % 2][ti % 2] {
                            return [f64::NAN; 3];
                        }
                        let mut acc = [0.0; 3];
                        for (du, dv) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                            let s = px(2 * ti + du, 2 * tj + dv);
                            for k in 0..3 {
                                acc[k] += 0.25 * s[k];
                            }
                        }
                        if acc.iter().all(|x| x.is_finite()) {
                            acc
                        } else {
                            [f64::NAN; 3]
                        }
                    })
                    .collect();
                let img = PolImage { width: tw, height: th, origin_px: 0.5, step_px: 2.0, iqu };
                sums[m.band.index()] = HeadingSums::from_image(&img, ctx);
            }
            sums
        }
    };
    Ok((bands, sums))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Projection;
    use crate::capture::{FrameSpec, LensSpec, SensorSpec};
    use crate::pipeline::{simulate_capture, SimSensor};
    use crate::sensor::{ColourTiles, Geometry, DEFAULT_MOSAIC};
    use crate::sky::sun::SunPosition;

    /// A colour capture (RGGB) of the colour sample's sensor and lens (408 × 340 px of
    /// 20.7 µm, f = 8 mm), sun 200°/45°, one frame at 7°.
    fn colour_capture() -> Capture {
        Capture {
            dir: "/nowhere".into(),
            sensor: SensorSpec {
                colour: Some(ColourTiles::imx250myr()),
                layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
                geometry: Geometry { width_px: 408, height_px: 340, pixel_pitch_um: 20.7 },
                bit_depth: 12,
                black_level_dn: 64.0,
            },
            lens: LensSpec {
                projection: Projection::Pinhole,
                focal_length_mm: 8.0,
                principal_point_px: (203.5, 169.5),
            },
            frames: vec![FrameSpec {
                heading_deg: Some(7.0),
                ..FrameSpec::new("f.png", SunPosition::given(200.0, 45.0))
            }],
        }
    }

    /// [`design_effect`]'s weights are `colour_maps`' own: on a flat mosaic, one raw
    /// sample raised by 64 DN moves each of its band's tile means of the intensity
    /// (½ Σ_k x_k) by ½·64·w_T; the w_T sum to 1 and 1/Σ w_T² is F_b.
    #[test]
    fn the_design_effect_is_the_bilinear_colour_stencils() {
        use crate::maps::{colour_maps, Interpolation, MapsConfig};
        use crate::sensor::Channel;
        let tiles = ColourTiles::imx250myr();
        let (w, h) = (48, 48);
        let rec = Reconstructor::new(&Model::default(), 0.0, &Channel::ALL).unwrap();
        let cfg = MapsConfig {
            interpolation: Interpolation::Bilinear,
            mosaic: DEFAULT_MOSAIC,
            full_scale_dn: 4095.0,
            aoe_centre_px: [0.0; 2],
        };
        let intensity = |dn: &[f32], b: Band| {
            let raw = crate::heading::field::RawImage::packed(dn, w, h);
            colour_maps(&raw, &rec, &cfg, &tiles).unwrap().into_iter().find(|m| m.band == b).unwrap().maps.intensity_dn
        };
        // A sample of each band (tile row v/2, column u/2 of the superpixel), each channel.
        for (b, (u0, v0)) in [(Band::R, (16, 16)), (Band::G, (18, 16)), (Band::G, (16, 18)), (Band::B, (18, 18))] {
            for (du, dv) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let flat = vec![1000.0f32; w * h];
                let mut raised = flat.clone();
                raised[(v0 + dv) * w + u0 + du] += 64.0;
                let (a, z) = (intensity(&flat, b), intensity(&raised, b));
                let mut wt = Vec::new();
                let on = tiles.classes(b);
                for (tj, ti) in
                    (0..h / 2).flat_map(|j| (0..w / 2).map(move |i| (j, i))).filter(|&(j, i)| on[j % 2][i % 2])
                {
                    let px = [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(x, y)| (2 * tj + y) * w + 2 * ti + x);
                    wt.push(px.iter().map(|&p| f64::from(z[p] - a[p])).sum::<f64>() / 4.0 * 2.0 / 64.0);
                }
                let (sum, sq) = (wt.iter().sum::<f64>(), wt.iter().map(|x| x * x).sum::<f64>());
                let f = design_effect(&tiles, b);
                assert!(
                    (sum - 1.0).abs() < 1e-4 && (1.0 / sq - f).abs() < 1e-3 * f,
                    "{} ({du}, {dv}): Σw {sum}, 1/Σw² {}",
                    b.name(),
                    1.0 / sq
                );
            }
        }
    }

    /// Noise-free, the demosaic route's samples (tile means of each pixel at its own
    /// ray) and the superpixel route's (each channel moved to its tile's centre) read
    /// every band's heading to a few thousandths of a degree, where the colour sweep's
    /// sums of the same tiles (four rays per sample) are biased by the sky's gradient; with
    /// noise each band within 3σ, the fused 1σ the bands' inverse-variance one, below
    /// every band's, and G with twice the samples of R and B.
    #[test]
    fn each_band_reads_its_own_tiles_and_the_fused_1sigma_is_the_inverse_variance_one() {
        let c = colour_capture();
        let known = Model::default();
        let read = |s: SimSensor, mode| {
            let (_, frames) = simulate_capture(&c, &known, &s, None).unwrap();
            let mut hs = colour_frame_headings_of(&c, 0, &frames[0], &known, mode, &[Extractor::SunVector]).unwrap();
            hs.remove(0)
        };
        let quiet = SimSensor { read_noise_dn: 0.0, system_gain_dn_per_e: 1e-6, ..SimSensor::samples(1) };
        let err = |e: &HeadingEstimate| crate::conventions::wrap_deg_180(e.heading_deg - 7.0);
        let (demosaic, superpixel) = (read(quiet, ReconMode::Demosaic), read(quiet, ReconMode::Superpixel));
        let (_, frames) = simulate_capture(&c, &known, &quiet, None).unwrap();
        let FrameData::Mosaic { dn, .. } = &frames[0] else { panic!("a mosaic") };
        let Layout::Dofp { mosaic } = &c.sensor.layout else { panic!("dofp") };
        let rec = Reconstructor::new(&known, c.sensor.black_level_dn, &c.sensor.channels()).unwrap();
        let (w, h) = (c.sensor.geometry.width_px as usize, c.sensor.geometry.height_px as usize);
        let ctx = crate::pipeline::heading_context(&c, &c.frames[0], &known);
        let tiles = c.sensor.colour.as_ref().unwrap();
        let as_tiles = crate::sweep::colour_mosaic_heading_sums(
            dn,
            w,
            h,
            mosaic,
            tiles,
            &rec,
            c.sensor.full_scale_dn(),
            std::slice::from_ref(&ctx),
        )[0];
        for ((b, d), (_, s)) in demosaic.bands.iter().zip(&superpixel.bands) {
            let (d, s) = (err(d.as_ref().unwrap()), err(s.as_ref().unwrap()));
            let raw = crate::conventions::wrap_deg_180(
                as_tiles[b.index()].solve(Extractor::SunVector, &ctx).unwrap().heading_deg - 7.0,
            );
            assert!(
                d.abs() < 0.005 && s.abs() < 0.005 && raw.abs() > 0.05,
                "{}: demosaic {d}°, superpixel {s}°, as the tiles read {raw}°",
                b.name()
            );
        }
        let noisy = read(SimSensor::samples(3), ReconMode::Demosaic);
        let bands: Vec<HeadingEstimate> = noisy.bands.iter().map(|(_, r)| *r.as_ref().unwrap()).collect();
        for (b, e) in noisy.bands.iter().map(|(b, _)| b).zip(&bands) {
            assert!(err(e).abs() < 3.0 * e.sigma_deg, "{}: {e:?}", b.name());
        }
        let fused = noisy.fused.unwrap();
        let inverse = bands.iter().map(|e| e.sigma_deg.powi(-2)).sum::<f64>().sqrt().recip();
        assert!((fused.sigma_deg - inverse).abs() < 1e-15 && bands.iter().all(|e| fused.sigma_deg < e.sigma_deg));
        assert_eq!((bands[1].samples, bands[0].samples), (2 * bands[2].samples, bands[2].samples));
        assert_eq!(fused.samples, bands.iter().map(|e| e.samples).sum::<usize>());
    }
}
