//! `bpins calibrate`'s work on a full IMX250MZR-size lab capture (issue 17: ≤ 10 s on
//! dev-2c for 2448 × 2048, 12 polarizer angles, 3 exposures and a dark frame):
//!
//! * `lab/calibrate_2448x2048_12angles_3exp_1dark`: read the 16 PNG frames, fit every
//!   pixel, photon transfer, flat field, summaries (`lab::calibrate`).
//! * `lab/write_outputs_2448x2048`: the maps as EXR and PNG, pixels.exr, the report.
//!
//! The capture is simulated once (`lab::simulate`) into a temporary folder.

use std::hint::black_box;

use bpins_core::calibration::Calibration;
use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::effects::Model;
use bpins_core::internal::capture::{LabCapture, LensSpec, SensorSpec};
use bpins_core::internal::lab::simulate::{lab_frames, truth_maps, LabPlan, LabSensor, PixelFlaws};
use bpins_core::internal::lab::{calibrate, output, report};
use bpins_core::sensor::{Geometry, Layout, DEFAULT_MOSAIC};
use criterion::{criterion_group, criterion_main, Criterion};

fn lab(c: &mut Criterion) {
    let (w, h) = (2448u32, 2048u32);
    let intr = Intrinsics::new(Projection::Pinhole, 8000.0 / 3.45, 1223.5, 1023.5);
    let flaws = PixelFlaws {
        angle_sigma_deg: 0.3,
        angle_gradient_deg: [0.6, -0.4],
        eps_sigma: 0.004,
        prnu: 0.01,
        dsnu_dn: 1.5,
        seed: 1,
    };
    let truth = truth_maps(&Model::default(), &intr, w as usize, h as usize, DEFAULT_MOSAIC, 64.0, &flaws);
    let plan = LabPlan::default();
    let sensor = LabSensor { signal_dn: 2400.0, k_dn_per_e: 0.1, read_noise_dn: 1.0, full_scale_dn: 4095.0, seed: 2 };
    let frames = lab_frames(&truth, &plan, &sensor);
    let tmp = tempfile::tempdir().expect("a temporary folder");
    let capture = LabCapture {
        dir: tmp.path().join("lab"),
        sensor: SensorSpec {
            colour: None,
            layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
            geometry: Geometry { width_px: w, height_px: h, pixel_pitch_um: 3.45 },
            bit_depth: 12,
            black_level_dn: 64.0,
        },
        lens: LensSpec { projection: Projection::Pinhole, focal_length_mm: 8.0, principal_point_px: (1223.5, 1023.5) },
        frames: plan.frames(),
    };
    capture.write(&capture.dir, &frames).expect("a new folder");
    drop(frames);
    let mut g = c.benchmark_group("lab");
    g.sample_size(10);
    g.bench_function("calibrate_2448x2048_12angles_3exp_1dark", |b| {
        b.iter(|| {
            let lab = LabCapture::load(&capture.dir).expect("the capture just written");
            black_box(calibrate(&lab, &|_, _| {}).expect("a full capture"))
        })
    });
    let cal = calibrate(&LabCapture::load(&capture.dir).unwrap(), &|_, _| {}).unwrap();
    let out = tmp.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    g.bench_function("write_outputs_2448x2048", |b| {
        b.iter(|| {
            let maps = output::write_maps(&cal, &out).expect("writable");
            let file = Calibration { pixels: Some(std::sync::Arc::new(cal.maps.clone())), ..Default::default() };
            file.write_pixels(&out).expect("writable");
            std::fs::write(out.join("report.html"), report::report_html(&cal, "bench", &maps).unwrap()).unwrap();
        })
    });
    g.finish();
}

criterion_group!(benches, lab);
criterion_main!(benches);
