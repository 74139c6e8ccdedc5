//! The compass's tests (`frame` is shared with `capture.rs`'s).

use super::*;
use crate::calibration::Calibration;
use crate::camera::Projection;
use crate::chain::{ChainFrame, NoiseIndex, Scene};
use crate::sensor::{Response, DEFAULT_MOSAIC};
use crate::simulate::render_mosaic;

pub(super) fn frame(truth: &Model, tilt: [f64; 2]) -> (Vec<u16>, Intrinsics) {
    frame_under(truth, tilt, 40.0, 25.0)
}

fn frame_under(truth: &Model, tilt: [f64; 2], sun_az_deg: f64, sun_el_deg: f64) -> (Vec<u16>, Intrinsics) {
    let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
    let scene =
        Scene { sun_az_deg, sun_el_deg, heading_deg: 30.0, tilt_x_deg: tilt[0], tilt_y_deg: tilt[1], dmax: 0.6 };
    let f =
        ChainFrame::new(truth, &lens, &scene, &Response::samples(2400.0), NoiseIndex { seed: 2, trial: 0, frame: 0 });
    (render_mosaic(&f, 306, 256, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect(), lens)
}

#[test]
fn u8_u16_f32_and_strided_buffers_give_the_same_heading() {
    let (raw, lens) = frame(&Model::default(), [1.0, 2.0]);
    let mut c = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
    let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
    let att = Attitude { tilt_x_deg: 1.0, tilt_y_deg: 2.0, sigma_deg: 0.0 };
    let a = c.heading(RawImage::packed(&raw, 306, 256), sun, att).unwrap();
    let f: Vec<f32> = raw.iter().map(|&x| x as f32).collect();
    let b = c.heading(RawImage::packed(&f, 306, 256), sun, att).unwrap();
    let mut padded = vec![0u16; 320 * 256];
    for v in 0..256 {
        padded[v * 320..][..306].copy_from_slice(&raw[v * 306..][..306]);
    }
    let s = c.heading(RawImage { data: &padded, width_px: 306, height_px: 256, stride: 320 }, sun, att).unwrap();
    assert_eq!(a, b);
    assert_eq!(a, s);
    let (h, sigma) = (a.heading_deg().unwrap(), a.sigma_deg().unwrap());
    assert!((h - 30.0).abs() < 0.02 && (h - 30.0).abs() < 3.0 * sigma, "{h} ± {sigma}");
    // An 8-bit camera: the DN scaled to 8 bits, black level too.
    let mut c8 = Compass::new(CompassConfig::dofp(lens, 306, 256, 8, 4.0)).unwrap();
    let raw8: Vec<u8> = raw.iter().map(|&x| ((x as f64 / 16.0).round() as u8).max(1)).collect();
    let r8 = c8.heading(RawImage::packed(&raw8, 306, 256), sun, att).unwrap();
    assert!((r8.heading_deg().unwrap() - 30.0).abs() < 0.1, "{r8:?}");
}

#[test]
#[cfg(feature = "spa")]
fn the_calibration_and_the_sun_from_a_clock_are_used() {
    use crate::effects::EffectSet;
    let mut truth = EffectSet::new();
    truth.set("array_rotation", "dtheta_deg", 0.5).unwrap();
    let (raw, lens) = frame(&truth.model(), [0.0, 0.0]);
    let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
    let read = |cal: Calibration| {
        let mut c =
            Compass::new(CompassConfig { calibration: cal, ..CompassConfig::dofp(lens, 306, 256, 12, 64.0) }).unwrap();
        c.heading(RawImage::packed(&raw, 306, 256), sun, Attitude::default()).unwrap().heading_deg().unwrap()
    };
    let raw_err = read(Calibration::default()) - 30.0;
    let cal_err = read(Calibration { effects: truth.clone(), ..Default::default() }) - 30.0;
    assert!(raw_err.abs() > 0.3 && cal_err.abs() < 0.02, "uncalibrated {raw_err}, calibrated {cal_err}");
    // A clock and a place: 2026-06-21T02:30:00Z (10:30 local) at Qingdao, the sun
    // from SPA; the frame rendered under that sun reads back at its heading.
    let (time_s, lat, lon) = (1_782_009_000.0, 36.07, 120.38);
    let s = crate::sky::sun::sun_from_unix_time(time_s, lat, lon).unwrap();
    assert!(s.elevation_deg > 30.0 && s.elevation_deg < 80.0, "{s:?}");
    let (raw, lens) = frame_under(&Model::default(), [0.0, 0.0], s.azimuth_deg, s.elevation_deg);
    let mut c = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
    let t = Sun::UnixTime { time_s, latitude_deg: lat, longitude_deg: lon, sigma_deg: 0.0 };
    let r = c.heading(RawImage::packed(&raw, 306, 256), t, Attitude::default()).unwrap();
    assert!((r.heading_deg().unwrap() - 30.0).abs() < 0.03, "{r:?}");
    let bad = Sun::UnixTime { time_s: f64::NAN, latitude_deg: 0.0, longitude_deg: 0.0, sigma_deg: 0.0 };
    assert!(matches!(c.heading(RawImage::packed(&raw, 306, 256), bad, Attitude::default()), Err(CompassError::Sun(_))));
}

/// A clock-given frame's sun resolved on numbers (`sky::SunAndMoon`, no timestamp text)
/// is, bit for bit, what the capture reader's text route gives: the source and shares
/// of `sky::source_and_shares_from_unix_time`, `sky::refusal` on them, the other body of
/// a mixed twilight from its own ephemeris (`sun_from_unix_time`, `moon_from_unix_time`),
/// the moon's 1σ ⊕ 0.005°. A day, a moonlit night (the full moon > 99 %), a mixed
/// twilight of each source, a dark night, and a fraction of a second.
#[test]
#[cfg(feature = "spa")]
fn a_clock_resolves_bit_for_bit_as_the_text_route() {
    use crate::sky::sun::SunSource;
    let (qd, south) = ((36.07, 120.38), (20.0, 120.38));
    let cases = [
        (1_782_009_000.0, qd),     // 2026-06-21T02:30Z: day
        (1_782_748_800.0, south),  // 2026-06-29T16:00Z: the full moon at 41.6°
        (1_782_304_200.0, qd),     // 2026-06-24T12:30Z: mixed, the sun the source
        (1_782_305_100.0, qd),     // 2026-06-24T12:45Z: mixed, the moon the source
        (1_784_044_800.0, qd),     // 2026-07-14T16:00Z: a dark night
        (1_782_304_200.123_4, qd), // a fraction of a second
    ];
    let mut seen = (0, 0, 0, 0);
    for (time_s, (lat, lon)) in cases {
        let sigma_deg = 0.02;
        let r = resolve_sun(Sun::UnixTime { time_s, latitude_deg: lat, longitude_deg: lon, sigma_deg }).unwrap();
        // The text route, as the compass took it before.
        let (s, shares) = crate::sky::source_and_shares_from_unix_time(time_s, lat, lon).unwrap();
        let moonlit = matches!(s.source, SunSource::Moon { .. });
        let sd = if moonlit { sigma_deg.hypot(crate::sky::moon::MOON_POSITION_SIGMA_DEG) } else { sigma_deg };
        assert_eq!(r.angles, (s.azimuth_deg, s.elevation_deg, sd), "{time_s}");
        assert_eq!(r.source, if moonlit { SkySource::Moon(shares) } else { SkySource::Sun(shares) }, "{time_s}");
        let dark = matches!(crate::sky::refusal(&s, &shares), Some(Refusal::Dark(_)));
        assert_eq!(r.refusal, dark.then_some(NoHeading::DarkNight { shares }), "{time_s}");
        let second = (!dark && shares.reads_both()).then(|| {
            let w_sun = shares.sun_unit_share();
            if moonlit {
                let o = crate::sky::sun::sun_from_unix_time(time_s, lat, lon).unwrap();
                SecondSource { azimuth_deg: o.azimuth_deg, elevation_deg: o.elevation_deg, share: 1.0 - w_sun, shares }
            } else {
                let o = crate::sky::moon::moon_from_unix_time(time_s, lat, lon).unwrap();
                SecondSource { azimuth_deg: o.azimuth_deg, elevation_deg: o.elevation_deg, share: w_sun, shares }
            }
        });
        assert_eq!(r.second, second, "{time_s}");
        seen.0 += usize::from(moonlit && second.is_none());
        seen.1 += usize::from(!moonlit && second.is_some());
        seen.2 += usize::from(moonlit && second.is_some());
        seen.3 += usize::from(dark);
    }
    // Every road was taken: moonlit, mixed under each source, dark.
    assert_eq!(seen, (1, 2, 1, 1), "moonlit, mixed (sun), mixed (moon), dark");
}

#[test]
fn compasses_on_several_threads_read_what_one_reads() {
    // Frames under three attitudes; one compass reads them in turn, then three
    // compasses, each on its own thread (and the first moved there), read them
    // at once: the same headings, bit for bit.
    let frames: Vec<(Vec<u16>, [f64; 2])> =
        [[0.0, 0.0], [3.0, -2.0], [-4.0, 1.0]].into_iter().map(|t| (frame(&Model::default(), t).0, t)).collect();
    let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
    let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
    let read_all = |c: &mut Compass| -> Vec<FieldHeading> {
        frames
            .iter()
            .map(|(raw, t)| {
                let att = Attitude { tilt_x_deg: t[0], tilt_y_deg: t[1], sigma_deg: 0.05 };
                c.heading(RawImage::packed(raw, 306, 256), sun, att).unwrap()
            })
            .collect()
    };
    let mut one = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
    let alone = read_all(&mut one);
    let together: Vec<Vec<FieldHeading>> = std::thread::scope(|s| {
        let mut handles = vec![s.spawn(|| read_all(&mut one))];
        for _ in 0..2 {
            handles
                .push(s.spawn(|| read_all(&mut Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap())));
        }
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for r in &together {
        assert_eq!(r, &alone);
    }
    assert!(alone.iter().all(|h| (h.heading_deg().unwrap() - 30.0).abs() < 0.05), "{alone:?}");
}

#[test]
fn wrong_buffers_and_configurations_are_refused_not_panicked_on() {
    let (raw, lens) = frame(&Model::default(), [0.0, 0.0]);
    let mut c = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
    let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
    let short = c.heading(
        RawImage { data: &raw[..1000], width_px: 306, height_px: 256, stride: 306 },
        sun,
        Attitude::default(),
    );
    assert!(matches!(short, Err(CompassError::FrameSize { len: 1000, .. })), "{short:?}");
    let small = c.heading(RawImage::packed(&raw[..300 * 200], 300, 200), sun, Attitude::default());
    assert!(small.unwrap_err().to_string().contains("300 × 200"));
    let att = Attitude { tilt_x_deg: 95.0, ..Default::default() };
    assert!(matches!(c.heading(RawImage::packed(&raw, 306, 256), sun, att), Err(CompassError::Attitude(_))));
    for cfg in [
        CompassConfig::dofp(lens, 2, 2, 12, 64.0),
        CompassConfig::dofp(lens, 306, 256, 17, 64.0),
        CompassConfig::dofp(lens, 306, 256, 12, 5000.0),
        CompassConfig::dofp(Intrinsics { f_px: -1.0, ..lens }, 306, 256, 12, 64.0),
    ] {
        assert!(matches!(Compass::new(cfg), Err(CompassError::Config(_))));
    }
}

/// Each refusal names the value that is wrong and the range it must lie in, not
/// only the values given (issue 35: "sun: azimuth 40°, elevation 95°, 1σ 0°").
#[test]
fn refusals_name_the_wrong_value_and_its_range() {
    let (raw, lens) = frame(&Model::default(), [0.0, 0.0]);
    let mut c = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
    let sun = |az, el, s| Sun::Angles { azimuth_deg: az, elevation_deg: el, sigma_deg: s };
    let msg = |c: &mut Compass, s: Sun, a: Attitude| {
        c.heading(RawImage::packed(&raw, 306, 256), s, a).unwrap_err().to_string()
    };
    let ok = sun(40.0, 25.0, 0.0);
    let level = Attitude::default();
    for (s, want) in [
        (sun(40.0, 95.0, 0.0), "elevation 95° is outside [−90, 90]°"),
        (sun(f64::NAN, 25.0, 0.0), "azimuth NaN° is not a number"),
        (sun(40.0, 25.0, -1.0), "1σ -1° must be a finite number ≥ 0"),
    ] {
        let m = msg(&mut c, s, level);
        assert!(m.starts_with("sun: ") && m.contains(want), "{m}");
    }
    for (a, want) in [
        (Attitude { tilt_x_deg: 95.0, ..level }, "tilt about x 95° is outside (−90, 90)°"),
        (Attitude { tilt_y_deg: -90.0, ..level }, "tilt about y -90° is outside (−90, 90)°"),
        (Attitude { sigma_deg: f64::INFINITY, ..level }, "1σ inf° must be a finite number ≥ 0"),
    ] {
        let m = msg(&mut c, ok, a);
        assert!(m.starts_with("attitude: ") && m.contains(want), "{m}");
    }
    let refusal = |cfg| Compass::new(cfg).err().expect("refused").to_string();
    let m = refusal(CompassConfig::dofp(Intrinsics { f_px: -5.0, ..lens }, 306, 256, 12, 64.0));
    assert!(m.contains("focal length -5 px must be a finite number > 0") && !m.contains("principal"), "{m}");
    let m = refusal(CompassConfig::dofp(Intrinsics { cx_px: f64::NAN, ..lens }, 306, 256, 12, 64.0));
    assert!(m.contains("principal point (NaN, 127.5) px must be finite"), "{m}");
    let m = c.heading(RawImage::packed(&raw[..300 * 200], 300, 200), ok, level).unwrap_err().to_string();
    assert!(m.contains("give the sensor's width and height"), "{m}");
}

/// A frame of the moonlit sky at `time_s` and a place, as `bpins simulate --exposure-s`
/// makes one: the pattern about the moon (`sky::source_from_unix_time`), its signal the
/// moon's sky in cd/m² (K&S, `sky_light`) through an IMX250MZR-like sensor at f/1.4 for
/// `exposure_s` (`sensor_exposure.rs`: photon and read noise), with this file's binned
/// 27.6 µm pixels; the moon's (azimuth, elevation) with it.
#[cfg(feature = "spa")]
fn moonlit_frame(time_s: f64, lat: f64, lon: f64, exposure_s: f64, heading_deg: f64) -> (Vec<u16>, (f64, f64)) {
    let src = crate::sky::source_from_unix_time(time_s, lat, lon).unwrap();
    assert!(matches!(src.source, crate::sky::sun::SunSource::Moon { .. }), "{src:?}");
    let sky = crate::sky::radiometry::sky_light(&src).unwrap();
    let e = crate::sensor_exposure::Exposure::imx250mzr(exposure_s, 1.4);
    let k = e.system_gain_dn_per_e(4095.0 - 64.0);
    let response = Response {
        gain_dn: k * e.electrons_per_cd_m2(27.6) * sky.unit_cd_m2,
        read_noise_dn: e.read_noise_e * k,
        system_gain_dn_per_e: k,
        ..Response::samples(0.0)
    };
    let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
    let (az, el) = (src.azimuth_deg, src.elevation_deg);
    let scene = Scene { sun_az_deg: az, sun_el_deg: el, heading_deg, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
    let f = ChainFrame::new(&Model::default(), &lens, &scene, &response, NoiseIndex { seed: 5, trial: 0, frame: 0 });
    (render_mosaic(&f, 306, 256, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect(), (az, el))
}

/// Issue 48 item 3: a clock and a place at night read the moon like the sun by day.
/// The full moon at 41.6° (2026-06-29T16:00:00Z at 20° N 120.38° E, docs/night.md),
/// 0.1 s at f/1.4: each heading within 2σ, the reading saying the moon lit the sky
/// with its share, the moon's ephemeris 1σ in the sun's part.
#[test]
#[cfg(feature = "spa")]
fn a_moonlit_frame_from_its_clock_reads_the_moon_within_two_sigma() {
    let (time_s, lat, lon) = (1_782_748_800.0, 20.0, 120.38);
    let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 27.6, 152.5, 127.5);
    let mut c = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
    let clock = Sun::UnixTime { time_s, latitude_deg: lat, longitude_deg: lon, sigma_deg: 0.0 };
    for heading_deg in [30.0, 200.0] {
        let (raw, (_, moon_el)) = moonlit_frame(time_s, lat, lon, 0.1, heading_deg);
        assert!((moon_el - 41.6).abs() < 0.1, "{moon_el}");
        let r = c.heading(RawImage::packed(&raw, 306, 256), clock, Attitude::default()).unwrap();
        let (h, sigma) = r.result.as_ref().map(|(h, s)| (*h, *s)).unwrap_or_else(|e| panic!("{e}"));
        let err = crate::conventions::wrap_deg_180(h - heading_deg);
        assert!(err.abs() < 2.0 * sigma.total_deg(), "{heading_deg}: {h} ± {}", sigma.total_deg());
        let SkySource::Moon(shares) = r.source else { panic!("{:?}", r.source) };
        assert!(shares.moon_share() > 0.99 && shares.sun_elevation_deg < -18.0, "{}", shares.describe());
        assert!((shares.moon_illuminated_fraction - 1.0).abs() < 0.02, "{}", shares.describe());
        // The caller gave an exact clock: the moon's 1σ is the ephemeris's, entering 1:1.
        let ephemeris = crate::sky::moon::MOON_POSITION_SIGMA_DEG;
        assert!((sigma.sun_deg - ephemeris).abs() < 1e-12, "{sigma:?}");
    }
    // The same frame with the moon's angles given reads the same heading, its source
    // the caller's ("given"), its sun part 0: the clock went through the moon.
    let (raw, (az, el)) = moonlit_frame(time_s, lat, lon, 0.1, 30.0);
    let given = Sun::Angles { azimuth_deg: az, elevation_deg: el, sigma_deg: 0.0 };
    let g = c.heading(RawImage::packed(&raw, 306, 256), given, Attitude::default()).unwrap();
    let t = c.heading(RawImage::packed(&raw, 306, 256), clock, Attitude::default()).unwrap();
    assert_eq!(g.source, SkySource::Given);
    assert!((g.heading_deg().unwrap() - t.heading_deg().unwrap()).abs() < 1e-9, "{g:?} {t:?}");
    assert!(g.result.as_ref().unwrap().1.sun_deg < t.result.as_ref().unwrap().1.sun_deg);
}

/// A dark night (no moon up, the sun far below) is refused with a typed reason naming
/// the shares, as `bpins heading` refuses it; a mixed twilight (the sun at −12.4° and
/// a 75 % moon, about half each) is read with both sources by a monochrome compass
/// (`two_sources.rs`; its accuracy is `tests/cli.rs`'s, on frames rendered with both
/// skies) and by a colour one band by band (its accuracy below); by day the reading
/// says the sun.
#[test]
#[cfg(feature = "spa")]
fn a_dark_night_is_refused_and_a_mixed_twilight_read_with_both_sources() {
    let (raw, lens) = frame(&Model::default(), [0.0, 0.0]);
    let mut c = Compass::new(CompassConfig::dofp(lens, 306, 256, 12, 64.0)).unwrap();
    let at = |time_s| Sun::UnixTime { time_s, latitude_deg: 36.07, longitude_deg: 120.38, sigma_deg: 0.01 };
    let read = |c: &mut Compass, t| c.heading(RawImage::packed(&raw, 306, 256), at(t), Attitude::default()).unwrap();
    // 2026-07-14T16:00:00Z, midnight at Qingdao a day after the new moon.
    let dark = read(&mut c, 1_784_044_800.0);
    let Err(NoHeading::DarkNight { shares }) = &dark.result else { panic!("{dark:?}") };
    assert!(shares.moon_elevation_deg < 0.0 && shares.sun_elevation_deg < -10.0, "{}", shares.describe());
    assert!(matches!(dark.source, SkySource::Sun(_)), "{:?}", dark.source);
    let words = dark.result.as_ref().unwrap_err().to_string();
    let src = crate::sky::source_from_unix_time(1_784_044_800.0, 36.07, 120.38).unwrap();
    assert_eq!(Some(words.clone()), crate::sky::dark_night(&src), "the capture reader's words");
    assert!(words.starts_with("not yet: the moon is at"), "{words}");
    // 2026-06-24T12:30:00Z: the sun at −12.4°, a 75 % moon at 35.5°.
    // (This frame was rendered under a day's sun: only the road is asked of it.)
    let mixed = read(&mut c, 1_782_304_200.0);
    assert!(!matches!(mixed.result, Err(NoHeading::MixedSky { .. })), "{mixed:?}");
    let SkySource::Sun(shares) = mixed.source else { panic!("{:?}", mixed.source) };
    assert!(shares.sun_share() > 0.1 && shares.moon_share() > 0.1, "{}", shares.describe());
    assert!(shares.reads_both() && shares.dominant() == crate::sky::twilight::Dominant::Mixed);
    let words = crate::sky::twilight::Shares::mixed_reason(&shares);
    assert!(words.contains("no single source") && words.contains("35.5°"), "{words}");
    // Every extractor's reading says the same.
    let all = c
        .headings(RawImage::packed(&raw, 306, 256), at(1_784_044_800.0), Attitude::default(), &Extractor::ALL)
        .unwrap();
    assert!(all.len() == 2 && all.iter().all(|h| matches!(h.result, Err(NoHeading::DarkNight { .. }))));
    // A colour compass: each band and the fused reading read with both sources, not
    // refused (this frame's sky is a day's: only the road is asked of it).
    let colour = CompassConfig {
        colour: Some(crate::sensor::ColourTiles::imx250myr()),
        ..CompassConfig::dofp(lens, 306, 256, 12, 64.0)
    };
    let fix = Compass::new(colour)
        .unwrap()
        .colour_headings(RawImage::packed(&raw, 306, 256), at(1_782_304_200.0), Attitude::default(), &Extractor::ALL)
        .unwrap();
    assert_eq!(fix.bands.len(), 3);
    for h in fix.bands.iter().flat_map(|(_, hs)| hs).chain(&fix.fused) {
        assert!(!matches!(h.result, Err(NoHeading::MixedSky { .. })) && matches!(h.source, SkySource::Sun(_)), "{h:?}");
    }
    // By day (10:30 local): the sun, with all of the light (this frame was rendered
    // under another sun, so only the source is asked of it).
    let day = read(&mut c, 1_782_009_000.0);
    let SkySource::Sun(shares) = day.source else { panic!("{:?}", day.source) };
    assert!(shares.sun_share() > 0.999_999 && shares.sun_elevation_deg > 30.0, "{}", shares.describe());
    // A one-source sky's reading has no fitted share (a mixed one's: tests/cli.rs).
    assert_eq!((day.fitted_sun_share(), day.fitted_sun_share_sigma()), (None, None), "{day:?}");
}

/// Issue 48: a colour frame's mixed twilight (2026-06-24T12:30Z at Qingdao, the sun at
/// −12.4° and a 75 % moon at 35.5°, about half the light each; the colour compass
/// refused it before) rendered with both skies by `bpins simulate`'s code path
/// (`twilight` element, IMX250MYR tiles), 128 × 128 px of 27.6 µm behind an 8 mm lens,
/// read band by band with both sources and fused (`colour.rs`): the fused heading
/// within 3σ, each band with its own fitted share near the one rendered, the fused
/// reading carrying the green band's.
#[test]
#[cfg(all(feature = "spa", feature = "io"))]
fn a_colour_mixed_twilight_is_read_band_by_band_with_both_sources() {
    use crate::capture::{Capture, FrameData, FrameSpec, LensSpec, SensorSpec};
    use crate::pipeline::{simulate_capture, SimSensor};
    use crate::scene::FieldScene;
    use crate::sensor::{Band, ColourTiles, Geometry, Layout};
    const TIME: &str = "2026-06-24T12:30:00Z";
    let (lat, lon, w) = (36.07, 120.38, 128usize);
    let src = crate::sky::source_from_time_place(TIME, lat, lon).unwrap();
    let headings = [20.0, 200.0];
    let capture = Capture {
        dir: "/nowhere".into(),
        sensor: SensorSpec {
            colour: Some(ColourTiles::imx250myr()),
            layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
            geometry: Geometry { width_px: w as u32, height_px: w as u32, pixel_pitch_um: 27.6 },
            bit_depth: 12,
            black_level_dn: 64.0,
        },
        lens: LensSpec {
            projection: Projection::Pinhole,
            focal_length_mm: 8.0,
            principal_point_px: crate::conventions::image_centre_px(w as u32, w as u32),
        },
        frames: headings
            .iter()
            .enumerate()
            .map(|(i, &h)| FrameSpec { heading_deg: Some(h), ..FrameSpec::new(format!("f{i}.png"), src.clone()) })
            .collect(),
    };
    let mut scene = FieldScene::new(1);
    scene.enable("twilight").unwrap();
    let (_, data) = simulate_capture(&capture, &Model::default(), &SimSensor::samples(1), Some(&scene)).unwrap();
    let opts = FieldOptions::default();
    let mut c = Compass::for_capture(&capture, Calibration::default(), opts, Extractor::SunVector).unwrap();
    let clock = Sun::UnixTime { time_s: 1_782_304_200.0, latitude_deg: lat, longitude_deg: lon, sigma_deg: 0.0 };
    let rendered = crate::sky::twilight::shares_at(TIME, lat, lon).unwrap().sun_unit_share();
    for (d, &truth) in data.iter().zip(&headings) {
        let FrameData::Mosaic { dn, .. } = d else { panic!("a colour frame is a mosaic") };
        let raw: Vec<u16> = dn.iter().map(|&x| x.round() as u16).collect();
        let fix = c.colour_headings(RawImage::packed(&raw, w, w), clock, Attitude::default(), &[Extractor::SunVector]);
        let fix = fix.unwrap();
        let fused = &fix.fused[0];
        let (h, sigma) = (fused.heading_deg().expect("read"), fused.sigma_deg().unwrap());
        let err = crate::conventions::wrap_deg_180(h - truth);
        assert!(err.abs() < 3.0 * sigma && sigma < 0.5, "{truth}: {h} ± {sigma}");
        assert!(matches!(fused.source, SkySource::Sun(_)), "{:?}", fused.source);
        // Each band fits its own share; the frames hold the rendered one in every band.
        for (b, hs) in &fix.bands {
            let (share, sd) = (hs[0].fitted_sun_share().expect("a share"), hs[0].fitted_sun_share_sigma().unwrap());
            assert!((share - rendered).abs() < 0.05 && sd > 0.0, "{b:?}: {share} ± {sd}, rendered {rendered}");
        }
        let green = &fix.bands.iter().find(|(b, _)| *b == Band::G).unwrap().1[0];
        assert_eq!(fused.fitted_share, green.fitted_share);
        // `heading` reads the same fused heading, every field of it bit for bit (its
        // bands on the stack, `Compass::band_heading`).
        let one = c.heading(RawImage::packed(&raw, w, w), clock, Attitude::default()).unwrap();
        assert_eq!(one.heading_deg(), Some(h));
        assert_eq!(format!("{one:?}"), format!("{fused:?}"));
        // So does a frame given by its sun's angles alone (one source, no twilight).
        let sun = Sun::Angles { azimuth_deg: 250.0, elevation_deg: 30.0, sigma_deg: 0.1 };
        let fix = c.colour_headings(RawImage::packed(&raw, w, w), sun, Attitude::default(), &[Extractor::SunVector]);
        let one = c.heading(RawImage::packed(&raw, w, w), sun, Attitude::default()).unwrap();
        assert_eq!(format!("{one:?}"), format!("{:?}", fix.unwrap().fused[0]));
    }
}
