//! The field estimator on frames the chain renders: tilt, mount tilt, twilight,
//! propagated input errors, obstructions, and frames it must refuse.

use super::*;
use crate::camera::{Intrinsics, Projection};
use crate::chain::{ChainFrame, NoiseIndex, Scene};
use crate::conventions::wrap_deg_180;
use crate::effects::{EffectSet, Model};
use crate::recon::Reconstructor;
use crate::sensor::{Channel, Response, DEFAULT_MOSAIC};
use crate::simulate::render_mosaic;

/// 306 × 256 DoFP behind the 8 mm pinhole at 27.6 µm (±19° across), or a 256 × 256
/// equidistant fisheye reaching 46° from the axis at the image's edge.
fn camera(p: Projection) -> (Intrinsics, usize, usize) {
    match p {
        Projection::Pinhole => (Intrinsics::new(p, 8000.0 / 27.6, 152.5, 127.5), 306, 256),
        _ => (Intrinsics::new(p, 127.5 / 46f64.to_radians(), 127.5, 127.5), 256, 256),
    }
}

fn scene(heading_deg: f64, sun_el_deg: f64, tilt: [f64; 2]) -> Scene {
    Scene { sun_az_deg: 40.0, sun_el_deg, heading_deg, tilt_x_deg: tilt[0], tilt_y_deg: tilt[1], dmax: 0.6 }
}

/// A 12-bit DoFP frame with read and shot noise, black level 64 DN.
fn render(p: Projection, truth: &Model, sc: &Scene, seed: u64) -> (Vec<f32>, Intrinsics, usize, usize) {
    let (intr, w, h) = camera(p);
    let resp = Response::samples(2400.0);
    let f = ChainFrame::new(truth, &intr, sc, &resp, NoiseIndex { seed, trial: 0, frame: 0 });
    (render_mosaic(&f, w, h, &DEFAULT_MOSAIC), intr, w, h)
}

fn cells_of(dn: &[f32], w: usize, h: usize) -> Cells {
    let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).unwrap();
    Cells::from_mosaic(&RawImage::packed(dn, w, h), &DEFAULT_MOSAIC, &rec, 4095.0, Cells::default_cell_px(w, h))
}

/// The frame's context as a user would give it: the scene's sun and reference tilt.
fn context(intr: Intrinsics, sc: &Scene) -> FieldContext {
    FieldContext {
        tilt_x_deg: sc.tilt_x_deg,
        tilt_y_deg: sc.tilt_y_deg,
        ..FieldContext::new(intr, sc.sun_az_deg, sc.sun_el_deg)
    }
}

fn run(dn: &[f32], w: usize, h: usize, ctx: &FieldContext) -> Vec<FieldHeading> {
    estimate(&cells_of(dn, w, h), ctx, &FieldOptions::default(), &Extractor::ALL)
}

/// (error, 1σ) of an extractor's heading against `truth_deg`, failing on no heading.
fn err_sigma(r: &FieldHeading, truth_deg: f64) -> (f64, f64) {
    let (h, s) =
        r.result.as_ref().map(|(h, s)| (*h, s.total_deg())).unwrap_or_else(|e| panic!("{:?}: {e}", r.extractor));
    (wrap_deg_180(h - truth_deg), s)
}

#[test]
fn a_clear_level_sky_is_read_at_the_noise_floor_with_a_covering_sigma() {
    let sc = scene(30.0, 25.0, [0.0; 2]);
    let (dn, intr, w, h) = render(Projection::Pinhole, &Model::default(), &sc, 1);
    for r in run(&dn, w, h, &context(intr, &sc)) {
        let (err, sigma) = err_sigma(&r, 30.0);
        let limit = if r.extractor == Extractor::SunVector { 0.01 } else { 0.1 };
        assert!(err.abs() < limit && err.abs() < 3.0 * sigma, "{:?}: error {err:+.4}°, 1σ {sigma:.4}°", r.extractor);
        assert!(r.quality.used_fraction > 0.9, "{:?}", r.quality);
        assert!(r.quality.residual_rms_deg < 0.5, "{:?}", r.quality);
    }
}

#[test]
fn tilted_frames_are_read_with_their_reference_tilt_pinhole_and_fisheye() {
    for p in [Projection::Pinhole, Projection::Equidistant] {
        for (k, tilt) in [[3.0, 3.0], [10.0, 0.0], [-4.0, 9.0]].into_iter().enumerate() {
            let sc = scene(100.0 + 70.0 * k as f64, 35.0, tilt);
            let (dn, intr, w, h) = render(p, &Model::default(), &sc, 2 + k as u64);
            for r in run(&dn, w, h, &context(intr, &sc)) {
                let (err, sigma) = err_sigma(&r, sc.heading_deg);
                let limit = if r.extractor == Extractor::SunVector { 0.03 } else { 0.3 };
                assert!(
                    err.abs() < limit && err.abs() < 4.0 * sigma,
                    "{p:?} tilt {tilt:?} {:?}: error {err:+.4}°, 1σ {sigma:.4}°",
                    r.extractor
                );
            }
            // The same frame taken as level is degrees off: the tilt is used, not ignored.
            let level = FieldContext::new(intr, sc.sun_az_deg, sc.sun_el_deg);
            let r = &run(&dn, w, h, &level)[0];
            if let Ok((hd, _)) = r.result {
                assert!(wrap_deg_180(hd - sc.heading_deg).abs() > 0.3, "{p:?} tilt {tilt:?}: tilt ignored yet {hd}");
            }
        }
    }
}

#[test]
fn a_mount_tilt_composes_after_the_frame_tilt_as_rotations() {
    let mut truth = EffectSet::new();
    truth.set("mount_tilt", "tilt_x_deg", 12.0).unwrap();
    truth.set("mount_tilt", "tilt_y_deg", -9.0).unwrap();
    let truth = truth.model();
    let sc = scene(250.0, 30.0, [-10.0, 14.0]);
    let (dn, intr, w, h) = render(Projection::Equidistant, &truth, &sc, 7);
    let composed = FieldContext { mount_tilt_deg: truth.geometry.mount_tilt_deg, ..context(intr, &sc) };
    let (err, sigma) = err_sigma(&run(&dn, w, h, &composed)[0], sc.heading_deg);
    assert!(err.abs() < 0.03 && err.abs() < 4.0 * sigma, "composed: error {err:+.4}°, 1σ {sigma:.4}°");
    // Adding the angles as if they were Euler angles of one rotation is wrong beyond
    // small angles (CONVENTIONS.md, Tilt).
    let added = FieldContext { tilt_x_deg: -10.0 + 12.0, tilt_y_deg: 14.0 - 9.0, ..context(intr, &sc) };
    if let Ok((hd, _)) = run(&dn, w, h, &added)[0].result {
        let e = wrap_deg_180(hd - sc.heading_deg);
        assert!(e.abs() > 0.5, "angles added: error {e:+.4}°, as good as composed");
    }
}

#[test]
fn twilight_gives_the_right_heading_with_the_sun_below_the_horizon() {
    for p in [Projection::Pinhole, Projection::Equidistant] {
        for (k, el) in [-1.0, -5.0].into_iter().enumerate() {
            for tilt in [[0.0, 0.0], [3.0, -2.0]] {
                let sc = scene(200.0 + 45.0 * k as f64, el, tilt);
                let (dn, intr, w, h) = render(p, &Model::default(), &sc, 11 + k as u64);
                for r in run(&dn, w, h, &context(intr, &sc)) {
                    let (err, sigma) = err_sigma(&r, sc.heading_deg);
                    assert!(
                        err.abs() < 0.3 && err.abs() < 4.0 * sigma,
                        "{p:?} sun at {el}° tilt {tilt:?} {:?}: error {err:+.4}°, 1σ {sigma:.4}°",
                        r.extractor
                    );
                }
            }
        }
    }
}

#[test]
fn the_reference_tilt_and_sun_errors_enter_the_sigma() {
    let el = 25.0;
    let sc = scene(30.0, el, [0.0; 2]);
    let (dn, intr, w, h) = render(Projection::Pinhole, &Model::default(), &sc, 3);
    let ctx = FieldContext { tilt_sigma_deg: 0.1, sun_sigma_deg: 0.05, ..context(intr, &sc) };
    for r in run(&dn, w, h, &ctx) {
        let (_, parts) = r.result.clone().unwrap();
        // An unknown tilt τ moves the heading by τ·tan h (the two axes in quadrature).
        let want = 0.1 * f64::tan(el.to_radians());
        assert!(
            (parts.tilt_deg / want - 1.0).abs() < 0.05,
            "{:?}: tilt part {} vs {want}",
            r.extractor,
            parts.tilt_deg
        );
        assert_eq!(parts.sun_deg, 0.05);
        assert!(parts.total_deg() > parts.tilt_deg && parts.total_deg() > parts.sun_deg);
    }
}

#[test]
fn an_obstructed_or_foreign_part_of_the_image_is_left_out() {
    // A third of the image shows a foreign polarization pattern (the sky seen at
    // another heading: a reflection, a window); another sixth is black (a wall).
    let sc = scene(60.0, 30.0, [0.0; 2]);
    let (mut dn, intr, w, h) = render(Projection::Pinhole, &Model::default(), &sc, 5);
    let (foreign, ..) = render(Projection::Pinhole, &Model::default(), &scene(95.0, 30.0, [0.0; 2]), 6);
    for v in 0..h {
        for u in 0..w / 3 {
            dn[v * w + u] = foreign[v * w + u];
        }
        if v < h / 2 {
            for u in 2 * w / 3..w {
                dn[v * w + u] = 0.0;
            }
        }
    }
    for r in run(&dn, w, h, &context(intr, &sc)) {
        let (err, sigma) = err_sigma(&r, sc.heading_deg);
        assert!(err.abs() < 0.1 && err.abs() < 4.0 * sigma, "{:?}: error {err:+.4}°, 1σ {sigma:.4}°", r.extractor);
        assert!(r.quality.used_fraction < 0.6 && r.quality.used_fraction > 0.3, "{:?}", r.quality);
    }
}

#[test]
fn a_sky_without_pattern_gets_no_heading_and_a_reason() {
    // d_max = 0: an overcast-like unpolarized sky; only noise polarizes it.
    let sc = Scene { dmax: 0.0, ..scene(30.0, 25.0, [0.0; 2]) };
    let (dn, intr, w, h) = render(Projection::Pinhole, &Model::default(), &sc, 8);
    for r in run(&dn, w, h, &context(intr, &sc)) {
        assert!(r.result.is_err(), "{:?}: a heading from an unpolarized sky: {:?}", r.extractor, r.result);
    }
    // A black frame: nothing usable.
    let (intr, w, h) = camera(Projection::Pinhole);
    let r = &run(&vec![0.0; w * h], w, h, &FieldContext::new(intr, 40.0, 25.0))[0];
    assert!(matches!(r.result, Err(NoHeading::TooLittleSky { used: 0, .. })), "{:?}", r.result);
    assert!(r.result.as_ref().unwrap_err().to_string().contains("too little usable sky"));
}

#[test]
fn the_sun_out_of_the_patterns_range_is_refused() {
    let (intr, w, h) = camera(Projection::Pinhole);
    let dn = vec![1000.0; w * h];
    let r = &run(&dn, w, h, &FieldContext::new(intr, 40.0, -12.0))[0];
    assert!(matches!(r.result, Err(NoHeading::SunTooLow { .. })), "{:?}", r.result);
    let r = &run(&dn, w, h, &FieldContext::new(intr, 40.0, 89.5))[0];
    assert!(matches!(r.result, Err(NoHeading::SunAtZenith { .. })), "{:?}", r.result);
}

#[test]
fn cells_from_a_demosaiced_stokes_image_give_the_heading_too() {
    let sc = scene(150.0, 40.0, [2.0, -3.0]);
    let (dn, intr, w, h) = render(Projection::Equidistant, &Model::default(), &sc, 9);
    let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL).unwrap();
    // Demosaiced: every sample at its own ray (superpixels would carry their bias).
    let img = crate::recon::demosaic(&dn, w, h, &DEFAULT_MOSAIC, &rec, 4095.0);
    let ctx = context(intr, &sc);
    let a = estimate(&Cells::from_pol_image(&img, 4), &ctx, &FieldOptions::default(), &[Extractor::SunVector]);
    let (err, sigma) = err_sigma(&a[0], sc.heading_deg);
    assert!(err.abs() < 0.05 && err.abs() < 4.0 * sigma, "from the demosaiced image: error {err:+.4}°, 1σ {sigma:.4}°");
}
