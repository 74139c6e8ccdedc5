//! The front door allocates nothing per frame once warm (issue: a 30 Hz loop on a
//! robot must not touch the heap). A counting global allocator around the system's;
//! this file holds one test so that nothing else in the process allocates meanwhile.
//!
//! The loop runs inside a rayon pool of its own ([`in_pool`]), as a robot's loop that
//! wants no allocation at all runs the compass: each parallel step of a frame then
//! stays on the pool's own deques. Called from a thread outside rayon's pools, each
//! parallel step hands a job to rayon's global queue, a crossbeam `Injector`, which
//! allocates one 1520-byte block per 63 jobs and frees the one it leaves (the heap
//! stays flat): a few allocations per hundred frames, none of them the compass's
//! (`outside_a_pool_only_rayons_queue_allocates`).

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

/// Runs `f` on a worker of a rayon pool of its own (two threads): the loop's parallel
/// steps stay on the pool's deques (module doc). Building the pool allocates; `f`
/// warms and counts inside it.
fn in_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new().num_threads(2).build().expect("a rayon pool").install(f)
}

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
    // A colour-polarization sensor (IMX250MYR tiles) reads each band from its own
    // pixels and fuses them on the stack: these frames' sky is neutral, every band alike.
    let colour = Some(bpins_core::sensor::ColourTiles::imx250myr());
    let cases = [
        (Extractor::SunVector, Default::default(), None),
        (Extractor::MeridianLine, Default::default(), None),
        (Extractor::SunVector, calibrated, None),
        (Extractor::SunVector, Default::default(), colour),
    ];
    in_pool(|| {
        for (extractor, calibration, colour) in cases {
            let mut compass = Compass::new(CompassConfig {
                extractor,
                calibration,
                colour,
                ..CompassConfig::dofp(lens, w, h, 12, 64.0)
            })
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
            let what = if compass.is_colour() { "colour" } else { "mono" };
            assert_eq!(n, 0, "{extractor:?}, {what}: {n} allocations in {} warm frames", frames.len());
        }
    });
    #[cfg(feature = "spa")]
    in_pool(clock::allocates_nothing_warm);
    #[cfg(feature = "io")]
    in_pool(mixed_twilight::allocates_nothing_warm);
    outside_a_pool_only_rayons_queue_allocates(&frames, lens, w, h);
}

/// The same compass called from this test's own thread, outside rayon's pools, over
/// 120 warm frames: each parallel step goes through rayon's global queue, whose
/// crossbeam `Injector` allocates a 1520-byte block per 63 jobs (module doc). Measured
/// (2026-11-28, mono 612 × 512, sun vector): 4 allocations of 1520 bytes in 120 frames.
/// Bounded here at one per 10 frames: a buffer the compass made per frame would be
/// 120 or more.
fn outside_a_pool_only_rayons_queue_allocates(frames: &[(Vec<u16>, Scene)], lens: Intrinsics, w: usize, h: usize) {
    let mut compass = Compass::new(CompassConfig::dofp(lens, w, h, 12, 64.0)).unwrap();
    let mut read = |raw: &[u16], s: &Scene| {
        let sun = Sun::Angles { azimuth_deg: s.sun_az_deg, elevation_deg: s.sun_el_deg, sigma_deg: 0.1 };
        let attitude = Attitude { tilt_x_deg: s.tilt_x_deg, tilt_y_deg: s.tilt_y_deg, sigma_deg: 0.05 };
        compass.heading(RawImage::packed(raw, w, h), sun, attitude).unwrap()
    };
    for (raw, s) in frames {
        read(raw, s);
    }
    ALLOCATIONS.store(0, Ordering::SeqCst);
    ARMED.store(true, Ordering::SeqCst);
    let mut read_frames = 0;
    for _ in 0..20 {
        for (raw, s) in frames {
            read(raw, s);
            read_frames += 1;
        }
    }
    ARMED.store(false, Ordering::SeqCst);
    let n = ALLOCATIONS.load(Ordering::SeqCst);
    assert!(10 * n <= read_frames, "outside a pool: {n} allocations in {read_frames} warm frames");
}

/// Frames given by clock and place (`Sun::UnixTime`, as a robot with GNSS time gives
/// them) through the front door, `Compass::heading`: the ephemeris it runs per frame
/// (SPA, the moon's series, the two sources' shares) allocates nothing either. A day
/// sun, a moonlit night and a mixed twilight whose source is the moon here; one whose
/// source is the sun in `mixed_twilight` (its frames rendered with both skies).
#[cfg(feature = "spa")]
mod clock {
    use super::*;
    use bpins_core::compass::SkySource;
    use bpins_core::internal::sky::source_from_unix_time;

    const W: usize = 128;

    pub fn allocates_nothing_warm() {
        // 128 × 128 px of 27.6 µm behind a 2.2 mm equidistant lens (±46° across).
        let c = (W as f64 - 1.0) / 2.0;
        let lens = Intrinsics::new(Projection::Equidistant, 2200.0 / 27.6, c, c);
        // 2026-06-21T02:30:00Z at Qingdao (10:30 local, the sun high); 2026-06-29T16:00:00Z
        // at 20° N 120.38° E, the full moon at 41.6° giving > 99 % of the light
        // (docs/night.md); 2026-06-24T12:45:00Z at Qingdao, a mixed twilight whose source
        // is the moon (the sun at −14.7°, read with both: the sun the second source). The
        // frames are rendered under the source's pattern alone, as bright as the day's:
        // what is counted is the clock's road, not the night's photon noise.
        let cases = [
            ("day", 1_782_009_000.0, 36.07, 120.38),
            ("moonlit", 1_782_748_800.0, 20.0, 120.38),
            ("mixed, the moon the source", 1_782_305_100.0, 36.07, 120.38),
        ];
        for (case, time_s, lat, lon) in cases {
            let src = source_from_unix_time(time_s, lat, lon).unwrap();
            let headings = [20.0, 140.0, 260.0];
            let raws: Vec<Vec<u16>> = headings
                .iter()
                .enumerate()
                .map(|(k, &heading_deg)| {
                    let scene = Scene {
                        sun_az_deg: src.azimuth_deg,
                        sun_el_deg: src.elevation_deg,
                        heading_deg,
                        tilt_x_deg: 0.0,
                        tilt_y_deg: 0.0,
                        dmax: 0.6,
                    };
                    let noise = NoiseIndex { seed: 11, trial: 0, frame: k as u32 };
                    let f = ChainFrame::new(&Default::default(), &lens, &scene, &Response::samples(2400.0), noise);
                    render_mosaic(&f, W, W, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect()
                })
                .collect();
            // Mono, then the same frames through a colour compass (neutral sky: every band
            // alike), each band read with both sources in the mixed case.
            for colour in [None, Some(bpins_core::sensor::ColourTiles::imx250myr())] {
                let what = if colour.is_some() { "colour" } else { "mono" };
                let mut compass =
                    Compass::new(CompassConfig { colour, ..CompassConfig::dofp(lens, W, W, 12, 64.0) }).unwrap();
                let sun = Sun::UnixTime { time_s, latitude_deg: lat, longitude_deg: lon, sigma_deg: 0.01 };
                let mut read =
                    |raw: &[u16]| compass.heading(RawImage::packed(raw, W, W), sun, Attitude::default()).unwrap();
                for raw in &raws {
                    read(raw);
                }
                ALLOCATIONS.store(0, Ordering::SeqCst);
                ARMED.store(true, Ordering::SeqCst);
                let mut got = [(f64::NAN, f64::NAN, SkySource::Given, None); 3];
                for (k, raw) in raws.iter().enumerate() {
                    let h = read(raw);
                    got[k] = (
                        h.heading_deg().unwrap_or(f64::NAN),
                        h.sigma_deg().unwrap_or(f64::NAN),
                        h.source,
                        h.fitted_share,
                    );
                }
                ARMED.store(false, Ordering::SeqCst);
                let n = ALLOCATIONS.load(Ordering::SeqCst);
                for (k, &(h, sd, source, share)) in got.iter().enumerate() {
                    let err = (h - headings[k] + 540.0).rem_euclid(360.0) - 180.0;
                    assert!(
                        err.abs() < 3.0 * sd.max(0.05),
                        "{case}, {what}, frame {k}: heading {h} ± {sd} for {}",
                        headings[k]
                    );
                    match (case, source) {
                        ("day", SkySource::Sun(s)) => assert!(s.sun_share() > 0.99, "{}", s.describe()),
                        ("moonlit", SkySource::Moon(s)) => assert!(s.moon_share() >= 0.99, "{}", s.describe()),
                        (_, SkySource::Moon(s)) if s.reads_both() => {
                            assert!(share.is_some(), "{case}: {}", s.describe())
                        }
                        _ => panic!("{case} frame {k}: source {source:?}"),
                    }
                }
                assert_eq!(n, 0, "{case} frames by clock, {what}: {n} allocations in {} warm frames", raws.len());
            }
        }
    }
}

/// A mixed twilight read with both sources (`two_sources.rs`) allocates nothing once
/// the scratch is warm: the compass's mixed branch (`Compass::heading` under a
/// `Sun::UnixTime` whose sky reads both), its cells and the two-source fit on the
/// compass's [`FieldScratch`]; then the same frames through the front door given by
/// clock and place (the ephemeris on numbers, `sky::SunAndMoon`: no timestamp text).
#[cfg(feature = "io")]
mod mixed_twilight {
    use super::*;
    use bpins_core::internal::capture::{Capture, FrameData, FrameSpec, LensSpec, SensorSpec};
    use bpins_core::internal::heading::field::{
        estimate_two_with, Cells, FieldContext, FieldOptions, FieldScratch, SecondSource,
    };
    use bpins_core::internal::pipeline::{simulate_capture, SimSensor};
    use bpins_core::internal::recon::Reconstructor;
    use bpins_core::internal::sky::sun::SunSource;
    use bpins_core::internal::sky::{moon, source_from_time_place, sun, twilight};
    use bpins_core::scene::FieldScene;
    use bpins_core::sensor::{Channel, Geometry};
    use std::path::PathBuf;

    /// 2026-06-24T12:30Z at Qingdao: the sun at −12.4° and a 75 % moon at 35.5°, each
    /// about half the sky's light (tests/cli.rs's mixed twilight).
    const TIME: &str = "2026-06-24T12:30:00Z";
    const PLACE: (f64, f64) = (36.07, 120.38);
    const W: usize = 128;

    pub fn allocates_nothing_warm() {
        let src = source_from_time_place(TIME, PLACE.0, PLACE.1).unwrap();
        let frame = |i: usize, heading: f64| FrameSpec {
            file: PathBuf::from(format!("frames/f{i:03}.png")),
            sun: src.clone(),
            heading_deg: Some(heading),
            tilt_x_deg: None,
            tilt_y_deg: None,
            tilt_sigma_deg: None,
            sun_sigma_deg: None,
            yaw_deg: None,
            yaw_sigma_deg: None,
        };
        let headings = [20.0, 140.0, 260.0];
        let capture = Capture {
            dir: PathBuf::new(),
            sensor: SensorSpec {
                colour: None,
                layout: bpins_core::sensor::Layout::Dofp { mosaic: DEFAULT_MOSAIC },
                geometry: Geometry { width_px: W as u32, height_px: W as u32, pixel_pitch_um: 27.6 },
                bit_depth: 12,
                black_level_dn: 64.0,
            },
            lens: LensSpec {
                projection: Projection::Equidistant,
                focal_length_mm: 2.2,
                principal_point_px: bpins_core::conventions::image_centre_px(W as u32, W as u32),
            },
            frames: headings.iter().enumerate().map(|(i, &h)| frame(i, h)).collect(),
        };
        let mut scene = FieldScene::new(1);
        scene.enable("twilight").unwrap();
        let (_, data) = simulate_capture(&capture, &Default::default(), &SimSensor::samples(3), Some(&scene)).unwrap();
        let raws: Vec<Vec<u16>> = data
            .iter()
            .map(|d| match d {
                FrameData::Mosaic { dn, .. } => dn.iter().map(|&x| x.round() as u16).collect(),
                _ => panic!("a DoFP capture gives mosaics"),
            })
            .collect();
        // The frame's source and the other body, as the compass resolves the clock.
        let (s, m) = (
            sun::sun_from_time_place(TIME, PLACE.0, PLACE.1).unwrap(),
            moon::moon_from_time_place(TIME, PLACE.0, PLACE.1).unwrap(),
        );
        let shares = twilight::shares_of(s.elevation_deg, &m);
        assert!(shares.reads_both(), "{}", shares.describe());
        let w_sun = shares.sun_unit_share();
        let ((az, el), other) = match src.source {
            SunSource::Moon { .. } => (
                (m.azimuth_deg, m.elevation_deg),
                SecondSource { azimuth_deg: s.azimuth_deg, elevation_deg: s.elevation_deg, share: 1.0 - w_sun, shares },
            ),
            _ => (
                (s.azimuth_deg, s.elevation_deg),
                SecondSource { azimuth_deg: m.azimuth_deg, elevation_deg: m.elevation_deg, share: w_sun, shares },
            ),
        };
        let f_px = 2200.0 / 27.6;
        let c = (W as f64 - 1.0) / 2.0;
        let ctx = FieldContext::new(Intrinsics::new(Projection::Equidistant, f_px, c, c), az, el);
        let rec = Reconstructor::new(&Default::default(), 64.0, &Channel::ALL).unwrap();
        let (opts, mut cells, mut scratch) = (FieldOptions::default(), Cells::default(), FieldScratch::default());
        let mut read = |raw: &[u16]| {
            cells.fill_from_mosaic(
                &RawImage::packed(raw, W, W),
                &DEFAULT_MOSAIC,
                &rec,
                4095.0,
                Cells::default_cell_px(W, W),
                &mut scratch.cells,
            );
            estimate_two_with(&cells, &ctx, &other, &opts, Extractor::SunVector, &mut scratch)
        };
        for raw in &raws {
            read(raw);
        }
        ALLOCATIONS.store(0, Ordering::SeqCst);
        ARMED.store(true, Ordering::SeqCst);
        let mut got = [(f64::NAN, f64::NAN, None); 3];
        for (k, raw) in raws.iter().enumerate() {
            let h = read(raw);
            got[k] = (h.heading_deg().unwrap_or(f64::NAN), h.sigma_deg().unwrap_or(f64::NAN), h.fitted_share);
        }
        ARMED.store(false, Ordering::SeqCst);
        let n = ALLOCATIONS.load(Ordering::SeqCst);
        for (k, &(h, sd, share)) in got.iter().enumerate() {
            let err = (h - headings[k] + 540.0).rem_euclid(360.0) - 180.0;
            assert!(err.abs() < 3.0 * sd.max(0.05), "mixed frame {k}: heading {h} ± {sd} for {}", headings[k]);
            assert!(share.is_some(), "mixed frame {k}: a fitted share");
        }
        assert_eq!(n, 0, "a mixed twilight: {n} allocations in {} warm frames", raws.len());

        // The same frames through the front door, given by clock and place: the compass
        // runs both ephemerides and the shares per frame, then the same reader.
        let t = sun::parse_time_utc(TIME).unwrap();
        let time_s = t.timestamp() as f64;
        let lens = Intrinsics::new(Projection::Equidistant, f_px, c, c);
        let mut compass = Compass::new(CompassConfig::dofp(lens, W, W, 12, 64.0)).unwrap();
        let clock = Sun::UnixTime { time_s, latitude_deg: PLACE.0, longitude_deg: PLACE.1, sigma_deg: 0.0 };
        let mut read = |raw: &[u16]| compass.heading(RawImage::packed(raw, W, W), clock, Attitude::default()).unwrap();
        for raw in &raws {
            read(raw);
        }
        ALLOCATIONS.store(0, Ordering::SeqCst);
        ARMED.store(true, Ordering::SeqCst);
        let mut front = [(f64::NAN, None); 3];
        for (k, raw) in raws.iter().enumerate() {
            let h = read(raw);
            front[k] = (h.heading_deg().unwrap_or(f64::NAN), h.fitted_share);
        }
        ARMED.store(false, Ordering::SeqCst);
        let n = ALLOCATIONS.load(Ordering::SeqCst);
        for (k, &(h, share)) in front.iter().enumerate() {
            // The compass's context is the estimator's above (level, 1σ 0): the same reading.
            assert!((h - got[k].0).abs() < 1e-9, "mixed frame {k} by clock: {h} against {}", got[k].0);
            assert_eq!(share, got[k].2, "mixed frame {k} by clock: the fitted share");
        }
        assert_eq!(n, 0, "a mixed twilight by clock: {n} allocations in {} warm frames", raws.len());
    }
}
