//! End to end on simulated frames: sky → DN → Stokes → heading, for every layout,
//! projection and extractor, against the heading the frame was simulated at.

use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::conventions::wrap_deg_180;
use bpins_core::effects::{EffectSet, Model};
use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
use bpins_core::internal::heading::{estimate, Extractor, HeadingContext};
use bpins_core::internal::recon::{self, PolImage, Reconstructor};
use bpins_core::internal::simulate::{peak_intensity, render_colocated, render_mosaic};
use bpins_core::sensor::{Channel, Response, DEFAULT_MOSAIC};

const W: usize = 612;
const H: usize = 512;

fn camera(p: Projection) -> Intrinsics {
    let f_px = match p {
        Projection::Pinhole => 8000.0 / 13.8,
        _ => 300.0,
    };
    Intrinsics { projection: p, f_px, cx_px: 305.5, cy_px: 255.5, distortion: [0.0; 2] }
}

fn sensor(model: &Model, intr: &Intrinsics, scene: &Scene) -> Response {
    let peak = peak_intensity(model, intr, scene, W, H, 8);
    Response {
        gain_dn: 0.7 * 4095.0 / peak,
        black_level_dn: 64.0,
        read_noise_dn: 1.0,
        system_gain_dn_per_e: 0.1,
        bit_depth: 12,
        quantize: true,
        ..Response::ideal(1.0)
    }
}

/// How a mosaic becomes Stokes samples: `recon::demosaic`, `recon::superpixels` or
/// `recon::superpixels_centred` (one signature).
type Recon = fn(&[f32], usize, usize, &[[Channel; 2]; 2], &Reconstructor, f64) -> PolImage;

fn heading_errors(model: &Model, p: Projection, heading_deg: f64, recon: Recon) -> Vec<(Extractor, f64, f64)> {
    let intr = camera(p);
    let scene = Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
    let resp = sensor(model, &intr, &scene);
    let f = ChainFrame::new(model, &intr, &scene, &resp, NoiseIndex { seed: 1, trial: 0, frame: 0 });
    let dn = render_mosaic(&f, W, H, &DEFAULT_MOSAIC);
    let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).unwrap();
    let img = recon(&dn, W, H, &DEFAULT_MOSAIC, &rec, 4095.0);
    let ctx = HeadingContext::new(intr, W, H, scene.sun_az_deg, scene.sun_el_deg);
    Extractor::ALL
        .iter()
        .map(|&e| {
            let est = estimate(&img, &ctx, e).unwrap();
            (e, wrap_deg_180(est.heading_deg - heading_deg), est.sigma_deg)
        })
        .collect()
}

#[test]
fn ideal_dofp_headings_are_recovered_for_every_heading_and_extractor() {
    for heading in [0.0, 45.0, 135.0, 200.0, 315.0] {
        for (e, err, sigma) in heading_errors(&Model::default(), Projection::Pinhole, heading, recon::demosaic) {
            assert!(err.abs() < 0.05, "demosaiced, {e:?} at {heading}°: error {err}°");
            assert!(sigma > 0.0 && sigma < 0.05, "{e:?}: σ {sigma}°");
        }
        // A superpixel's four rays differ: a bias of a few hundredths of a degree, gone
        // with each channel moved to the tile's centre (the plain route's superpixels).
        let raw = heading_errors(&Model::default(), Projection::Pinhole, heading, recon::superpixels);
        let centred = heading_errors(&Model::default(), Projection::Pinhole, heading, recon::superpixels_centred);
        for ((e, raw, _), (_, err, sigma)) in raw.into_iter().zip(centred) {
            assert!(raw.abs() < 0.1, "superpixels, {e:?} at {heading}°: error {raw}°");
            assert!(err.abs() < 0.05 && err.abs() < 4.0 * sigma, "centred, {e:?} at {heading}°: {err}° ± {sigma}°");
        }
    }
}

#[test]
fn fisheye_projections_and_demosaicing_recover_the_heading() {
    for p in [Projection::Equidistant, Projection::Equisolid, Projection::Stereographic] {
        for (e, err, _) in heading_errors(&Model::default(), p, 100.0, recon::superpixels) {
            assert!(err.abs() < 0.1, "{p:?} {e:?}: {err}°");
        }
    }
}

#[test]
fn array_rotation_biases_the_heading_by_its_angle() {
    // Every α reads dθ smaller: the sun vector turns with it, by ≈ dθ at the zenith.
    let mut set = EffectSet::new();
    set.set("array_rotation", "dtheta_deg", 0.5).unwrap();
    for (e, err, _) in heading_errors(&set.model(), Projection::Pinhole, 0.0, recon::superpixels) {
        assert!(err.abs() > 0.3 && err.abs() < 0.7, "{e:?}: {err}°");
    }
}

#[test]
fn principal_point_offset_moves_both_extractors_a_little() {
    // Near the zenith the E-vectors are almost parallel, so the AoE line through the
    // assumed principal point moves with it: a 3 px offset costs only hundredths of
    // a degree with either extractor (README, "Why the figures differ").
    let mut set = EffectSet::new();
    set.set("principal_point", "dx_px", 3.0).unwrap();
    set.set("principal_point", "dy_px", 3.0).unwrap();
    let shift = |p| {
        let errs = heading_errors(&set.model(), p, 20.0, recon::demosaic);
        let ideal = heading_errors(&Model::default(), p, 20.0, recon::demosaic);
        errs.iter().zip(&ideal).map(|((_, e, _), (_, e0, _))| e - e0).collect::<Vec<f64>>()
    };
    // Narrow field (±20°): both move, by less than 0.15°.
    for d in shift(Projection::Pinhole) {
        assert!(d.abs() > 1e-3 && d.abs() < 0.15, "pinhole: {d}°");
    }
    // Wide field (±49°): away from the zenith the E-vectors fan out (k ≠ 1), and the
    // half-line through the assumed principal point feels the offset more.
    let fish = shift(Projection::Equidistant);
    assert!(fish[1].abs() > fish[0].abs(), "sun vector {}°, meridian line {}°", fish[0], fish[1]);
}

#[test]
fn colocated_three_channel_sensor_recovers_the_heading() {
    let intr = camera(Projection::Pinhole);
    let scene =
        Scene { sun_az_deg: 30.0, sun_el_deg: 5.0, heading_deg: 0.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
    let ch = [Channel::C0, Channel::C45, Channel::C90];
    let f = ChainFrame::noise_free(&Model::default(), &intr, &scene);
    let planes = render_colocated(&f, W, H, &ch);
    let rec = Reconstructor::new(&Model::default(), 0.0, &ch).unwrap();
    let refs: Vec<(Channel, &[f32])> = ch.iter().copied().zip(planes.iter().map(|p| p.as_slice())).collect();
    let img = recon::colocated(&refs, W, H, &rec, f64::INFINITY);
    let ctx = HeadingContext::new(intr, W, H, scene.sun_az_deg, scene.sun_el_deg);
    for e in Extractor::ALL {
        let est = estimate(&img, &ctx, e).unwrap();
        assert!(wrap_deg_180(est.heading_deg).abs() < 1e-3, "{e:?}: {}", est.heading_deg);
    }
}
