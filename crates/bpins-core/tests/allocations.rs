//! The front door allocates nothing per frame once warm (issue: a 30 Hz loop on a
//! robot must not touch the heap). A counting global allocator around the system's;
//! this file holds one test so that nothing else in the process allocates meanwhile.

use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::compass::{Attitude, Compass, CompassConfig, Sun};
use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
use bpins_core::internal::heading::field::RawImage;
use bpins_core::internal::heading::Extractor;
use bpins_core::internal::simulate::render_mosaic;
use bpins_core::sensor::{Response, DEFAULT_MOSAIC};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

struct Counting;
static ARMED: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if ARMED.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if ARMED.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn a_warm_compass_allocates_nothing_per_frame() {
    let (w, h) = (612, 512);
    let lens = Intrinsics::new(Projection::Pinhole, 2.0 * 8000.0 / 27.6, 305.5, 255.5);
    // Frames under different suns, headings and tilts: every branch of the loop that
    // a clear sky takes (search, reweighting, both extractors' solves, the jackknife).
    let frames: Vec<(Vec<u16>, Scene)> = (0..6)
        .map(|k| {
            let scene = Scene {
                sun_az_deg: 40.0 + 50.0 * k as f64,
                sun_el_deg: 10.0 + 12.0 * k as f64,
                heading_deg: 30.0 + 47.0 * k as f64,
                tilt_x_deg: 2.0 - k as f64,
                tilt_y_deg: -1.0 + 0.5 * k as f64,
                dmax: 0.6,
            };
            let f = ChainFrame::new(
                &Default::default(),
                &lens,
                &scene,
                &Response::samples(2400.0),
                NoiseIndex { seed: 7, trial: 0, frame: k },
            );
            let raw = render_mosaic(&f, w, h, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect();
            (raw, scene)
        })
        .collect();
    // A lab calibration's per-pixel maps (gain and angle patterns) cost no allocation
    // per frame either: each cell's reconstruction is made once, in `Compass::new`.
    let mut maps = bpins_core::internal::pixel_analyzers::PixelMaps::nominal(w, h, DEFAULT_MOSAIC);
    maps.gain = Some((0..w * h).map(|i| 1.0 + 0.01 * ((i * 7919 % 13) as f32 - 6.0) / 6.0).collect());
    maps.analyzer_deg = Some(
        (0..w * h)
            .map(|i| bpins_core::sensor::Layout::dofp_channel(&DEFAULT_MOSAIC, i % w, i / w).angle_deg() as f32 + 0.01)
            .collect(),
    );
    let calibrated =
        bpins_core::calibration::Calibration { pixels: Some(std::sync::Arc::new(maps)), ..Default::default() };
    for (extractor, calibration) in [
        (Extractor::SunVector, Default::default()),
        (Extractor::MeridianLine, Default::default()),
        (Extractor::SunVector, calibrated),
    ] {
        let mut compass =
            Compass::new(CompassConfig { extractor, calibration, ..CompassConfig::dofp(lens, w, h, 12, 64.0) })
                .unwrap();
        let mut read = |raw: &[u16], s: &Scene| {
            compass
                .heading(
                    RawImage::packed(raw, w, h),
                    Sun::Angles { azimuth_deg: s.sun_az_deg, elevation_deg: s.sun_el_deg, sigma_deg: 0.1 },
                    Attitude { tilt_x_deg: s.tilt_x_deg, tilt_y_deg: s.tilt_y_deg, sigma_deg: 0.05 },
                )
                .unwrap()
        };
        // Warm: the first frames size the buffers (and start rayon's pool).
        for (raw, s) in &frames {
            read(raw, s);
        }
        ALLOCATIONS.store(0, Ordering::SeqCst);
        ARMED.store(true, Ordering::SeqCst);
        let mut headings = [0.0; 6];
        for (k, (raw, s)) in frames.iter().enumerate() {
            headings[k] = read(raw, s).heading_deg().unwrap_or(f64::NAN);
        }
        ARMED.store(false, Ordering::SeqCst);
        let n = ALLOCATIONS.load(Ordering::SeqCst);
        for (k, (_, s)) in frames.iter().enumerate() {
            let err = (headings[k] - s.heading_deg + 540.0).rem_euclid(360.0) - 180.0;
            assert!(err.abs() < 0.5, "{extractor:?}, frame {k}: heading {} for {}", headings[k], s.heading_deg);
        }
        assert_eq!(n, 0, "{extractor:?}: {n} allocations in {} warm frames", frames.len());
    }
}
