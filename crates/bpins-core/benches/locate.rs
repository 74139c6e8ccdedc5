//! Criterion benchmarks of `locate` (`cargo bench -p bpins-core --bench locate`): an
//! hour of frames every 5 min (13 frames) at 45° N, rendered once on the samples' 8 mm
//! pinhole view and a 306 × 256 DoFP sensor (as `examples/locate_targets.rs`), then
//! read as `bpins locate` reads them. Figures and the machine go to BENCHMARKS.md
//! (issue 33's item 5: targets are met in benchmarks, not timed tests).
//!
//! * `locate/hour_sky_sun`: every frame's cells and its sky's sun
//!   (`locate::measure_data`, which runs `heading::field::sky_sun` per frame);
//!   criterion's throughput is per frame.
//! * `locate/hour_solve`: the stamped route's solve from the 13 suns
//!   (`locate::locate`: the 5° × 10° grid over the globe, then Levenberg–Marquardt).
//! * `locate/hour_end_to_end`: both, what one `locate` of the hour costs.

use bpins_core::camera::Projection;
use bpins_core::conventions::image_centre_px;
use bpins_core::effects::Model;
use bpins_core::internal::capture::{Capture, FrameData, FrameSpec, LensSpec, SensorSpec};
use bpins_core::internal::heading::field::FieldOptions;
use bpins_core::internal::locate::{locate, measure_data, LocateOptions, Series, SunObs};
use bpins_core::internal::pipeline::SimSensor;
use bpins_core::internal::sky::sun::SunPosition;
use bpins_core::sensor::{Geometry, Layout, DEFAULT_MOSAIC};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use std::path::PathBuf;

/// The hour's capture (stamps only, as a user holds it) and its rendered frames.
fn hour() -> (Capture, Vec<FrameData>) {
    let (w, h) = (306u32, 256u32);
    let base = Capture {
        dir: PathBuf::new(),
        sensor: SensorSpec {
            colour: None,
            layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
            geometry: Geometry { width_px: w, height_px: h, pixel_pitch_um: 27.6 },
            bit_depth: 12,
            black_level_dn: 64.0,
        },
        lens: LensSpec {
            projection: Projection::Pinhole,
            focal_length_mm: 8.0,
            principal_point_px: image_centre_px(w, h),
        },
        frames: vec![FrameSpec::new("frames/f000.png", SunPosition::given(0.0, 45.0))],
    };
    let s = Series {
        latitude_deg: 45.0,
        longitude_deg: 10.0,
        start_utc: "2026-05-10T08:20:00Z".into(),
        every_s: 300.0,
        span_s: 3600.0,
        heading_deg: 30.0,
        yaw_step_deg: 0.0,
        yaw_sigma_deg: None,
        seed: 1,
    };
    s.simulate(&base, &Model::default(), None, &Default::default(), &SimSensor::samples(1)).expect("a valid series")
}

fn suns(c: &Capture, data: &[FrameData]) -> Vec<SunObs> {
    let frames = measure_data(c, data, &Model::default(), &FieldOptions::default()).expect("frames");
    frames.iter().filter_map(|f| f.obs()).collect()
}

fn bench(cr: &mut Criterion) {
    let (c, data) = hour();
    let obs = suns(&c, &data);
    assert_eq!(obs.len(), data.len(), "every frame of a clear hour has a sun");
    let opts = LocateOptions::default();
    locate(&obs, &opts).expect("a clear hour is located");
    let mut g = cr.benchmark_group("locate");
    g.sample_size(10);
    g.throughput(Throughput::Elements(data.len() as u64));
    g.bench_function("hour_sky_sun", |b| b.iter(|| black_box(suns(&c, black_box(&data)))));
    g.throughput(Throughput::Elements(1));
    g.bench_function("hour_solve", |b| b.iter(|| black_box(locate(black_box(&obs), &opts).unwrap())));
    g.bench_function("hour_end_to_end", |b| b.iter(|| black_box(locate(&suns(&c, black_box(&data)), &opts).unwrap())));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
