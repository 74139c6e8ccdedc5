//! `locate` end to end on simulated time series (issue 33): a site, a start time, a
//! frame every few minutes, the sun by SPA; the sky's sun per frame, then north,
//! latitude and longitude with their 1σ, checked against the truth over seeds.

mod common;

use bpins_core::conventions::wrap_deg_180;
use bpins_core::effects::{EffectSet, Model};
use bpins_core::internal::capture::{Capture, FrameData};
use bpins_core::internal::heading::field::FieldOptions;
use bpins_core::internal::locate::{locate, measure_data, LocateError, LocateOptions, Located, Series, SunObs};
use bpins_core::internal::scene::{Draws, FieldScene};

/// The series of seed `seed`: a site drawn over latitudes −50°…60° and every
/// longitude, a day of the year, a start between 08:00 and 14:00 local solar time,
/// a heading, frames every `every_min` over `span_min`; rendered on the tests' small
/// sensor. Returns the written capture, its frames and the series.
pub fn series(
    seed: u64,
    every_min: f64,
    span_min: f64,
    yaw_step_deg: f64,
    yaw_sigma_deg: Option<f64>,
) -> (Capture, Vec<FrameData>, Series) {
    let d = Draws::keyed(seed, 0x10ca_7e00, 0);
    let lat = -50.0 + 110.0 * d.uniform(0);
    let lon = -180.0 + 360.0 * d.uniform(1);
    let day = (365.0 * d.uniform(2)).floor();
    let local_h = 8.0 + 6.0 * d.uniform(3);
    // 2026-01-01T00:00:00Z = 1767225600 s.
    let t = 1_767_225_600.0 + day * 86_400.0 + (local_h - lon / 15.0) * 3600.0;
    let start =
        chrono::DateTime::from_timestamp(t as i64, 0).unwrap().to_rfc3339_opts(chrono::SecondsFormat::Secs, true);
    let s = Series {
        latitude_deg: lat,
        longitude_deg: lon,
        start_utc: start,
        every_s: every_min * 60.0,
        span_s: span_min * 60.0,
        heading_deg: 360.0 * d.uniform(4),
        yaw_step_deg,
        yaw_sigma_deg,
        seed,
    };
    let sim = common::sim_sensor(seed, 0.0);
    let (c, data) = s.simulate(&common::small_capture(), &Model::default(), None, &Default::default(), &sim).unwrap();
    (c, data, s)
}

/// An hour of frames every 5 min under Berry's quartic sky with the neutral points
/// `separation_deg` apart (`sky_neutral_points`, the sky's radiance in the scene): a
/// site at 30°–55° of either hemisphere, a start between 09:00 and 11:00 local solar
/// time (the sun well off the zenith, where the effect holds), a static camera.
fn berry_series(seed: u64, separation_deg: f64) -> (Capture, Vec<FrameData>, Series) {
    let d = Draws::keyed(seed, 0xbe77_0000, 0);
    let lat = (30.0 + 25.0 * d.uniform(0)) * if d.uniform(5) < 0.5 { -1.0 } else { 1.0 };
    let lon = -180.0 + 360.0 * d.uniform(1);
    let day = (365.0 * d.uniform(2)).floor();
    let t = 1_767_225_600.0 + day * 86_400.0 + (9.0 + 2.0 * d.uniform(3) - lon / 15.0) * 3600.0;
    let start =
        chrono::DateTime::from_timestamp(t as i64, 0).unwrap().to_rfc3339_opts(chrono::SecondsFormat::Secs, true);
    let s = Series {
        latitude_deg: lat,
        longitude_deg: lon,
        start_utc: start,
        every_s: 300.0,
        span_s: 3600.0,
        heading_deg: 360.0 * d.uniform(4),
        yaw_step_deg: 0.0,
        yaw_sigma_deg: None,
        seed,
    };
    let mut set = EffectSet::new();
    set.set("sky_neutral_points", "separation_deg", separation_deg).unwrap();
    let mut field = FieldScene::new(seed);
    field.parse("sky_radiance").unwrap();
    let sim = common::sim_sensor(seed, 0.0);
    let (c, data) =
        s.simulate(&common::small_capture(), &set.model(), Some(&field), &Default::default(), &sim).unwrap();
    (c, data, s)
}

fn located(c: &Capture, data: &[FrameData], opts: &LocateOptions) -> Result<Located, LocateError> {
    let frames = measure_data(c, data, &Model::default(), &FieldOptions::default())?;
    let obs: Vec<SunObs> = frames.iter().filter_map(|f| f.obs()).collect();
    locate(&obs, opts)
}

/// Bounds wide enough that every answer is returned (the honesty test judges them).
fn wide() -> LocateOptions {
    LocateOptions {
        max_heading_sigma_deg: 90.0,
        max_latitude_sigma_deg: 90.0,
        max_longitude_sigma_deg: 180.0,
        pole_only: false,
    }
}

/// Issue 33, "an honest answer": over seeds, at least 90 % of the north, latitude
/// and longitude errors lie within 2σ; a static camera on half the seeds, one that
/// turns 7° a frame with a gyro of 0.05° on the other half. Frames every 5 min for an
/// hour. At mid-latitudes (30°–50°) the errors must also meet the clear-sky targets
/// (north ≤ 0.2°, latitude and longitude ≤ 0.5°) on every seed.
#[test]
fn errors_lie_within_two_sigma_over_seeds() {
    let seeds = 24u64;
    let mut within = [0usize; 3];
    for seed in 0..seeds {
        let (step, sigma) = if seed % 2 == 0 { (0.0, None) } else { (7.0, Some(0.05)) };
        let (c, data, s) = series(seed, 5.0, 60.0, step, sigma);
        let r = located(&c, &data, &wide()).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let errs = [
            (wrap_deg_180(r.heading_deg - s.heading_deg), r.heading_sigma_deg, 0.2),
            (r.latitude_deg - s.latitude_deg, r.latitude_sigma_deg, 0.5),
            (wrap_deg_180(r.longitude_deg.unwrap() - s.longitude_deg), r.longitude_sigma_deg.unwrap(), 0.5),
        ];
        for (k, (e, sig, target)) in errs.into_iter().enumerate() {
            let mid_latitude = (30.0..=50.0).contains(&s.latitude_deg.abs());
            assert!(
                !mid_latitude || e.abs() < target,
                "seed {seed}: error {e}° ± {sig}° over the target {target}° ({r:?})"
            );
            within[k] += usize::from(e.abs() <= 2.0 * sig);
        }
    }
    for (k, what) in ["north", "latitude", "longitude"].iter().enumerate() {
        let frac = within[k] as f64 / seeds as f64;
        assert!(frac >= 0.9, "{what}: {:.0} % within 2σ", 100.0 * frac);
    }
}

/// Without stamps (or with them set aside), the pole alone: three hours of frames
/// every 15 minutes give north and latitude within 3σ, and no longitude.
#[test]
fn the_pole_route_gives_north_and_latitude_without_a_clock() {
    for seed in [3u64, 4] {
        let (c, data, s) = series(seed, 15.0, 180.0, 0.0, None);
        let r = located(&c, &data, &LocateOptions { pole_only: true, ..wide() }).unwrap();
        assert_eq!(r.longitude_deg, None);
        let north = wrap_deg_180(r.heading_deg - s.heading_deg);
        let lat = r.latitude_deg - s.latitude_deg;
        assert!(north.abs() < 3.0 * r.heading_sigma_deg && north.abs() < 2.0, "seed {seed}: north {north} ({r:?})");
        assert!(lat.abs() < 3.0 * r.latitude_sigma_deg && lat.abs() < 2.0, "seed {seed}: latitude {lat} ({r:?})");
    }
}

/// "A sequence too short or too cloudy says so instead of answering": two frames are
/// too few; ten minutes of frames cannot meet a 0.01° bound on the longitude.
#[test]
fn too_few_frames_or_too_short_a_span_is_a_typed_refusal() {
    let (c, data, _) = series(5, 5.0, 5.0, 0.0, None);
    assert_eq!(c.frames.len(), 2);
    let e = located(&c, &data, &LocateOptions::default()).unwrap_err();
    assert!(matches!(e, LocateError::TooFewFrames { usable: 2, needed: 3, .. }), "{e}");
    let (c, data, _) = series(5, 2.0, 10.0, 0.0, None);
    let strict = LocateOptions { max_longitude_sigma_deg: 0.001, ..LocateOptions::default() };
    let e = located(&c, &data, &strict).unwrap_err();
    assert!(matches!(e, LocateError::TooUncertain { what: "longitude", .. }), "{e}");
    assert!(e.to_string().contains("longer span"), "{e}");
}

/// The pole route over seeds: three hours of frames every 15 minutes, stamps set
/// aside; north and latitude within 2σ on at least 90 % of the seeds.
#[test]
fn the_pole_route_is_honest_over_seeds() {
    let seeds = 16u64;
    let mut within = [0usize; 2];
    let mut answered = 0;
    for seed in 0..seeds {
        let (c, data, s) = series(100 + seed, 15.0, 180.0, 0.0, None);
        let Ok(r) = located(&c, &data, &LocateOptions { pole_only: true, ..wide() }) else { continue };
        answered += 1;
        within[0] += usize::from(wrap_deg_180(r.heading_deg - s.heading_deg).abs() <= 2.0 * r.heading_sigma_deg);
        within[1] += usize::from((r.latitude_deg - s.latitude_deg).abs() <= 2.0 * r.latitude_sigma_deg);
    }
    assert!(answered >= seeds as usize - 2, "{answered} of {seeds} answered");
    for (k, what) in ["north", "latitude"].iter().enumerate() {
        let frac = within[k] as f64 / answered as f64;
        assert!(frac >= 0.9, "{what}: {:.0} % within 2σ", 100.0 * frac);
    }
}

/// The site a robot located itself at serves the Compass in place of a GNSS fix: the
/// sun at a later stamp from the site, its 1σ the place's, and the frame's heading
/// within 2σ of the truth.
#[test]
fn the_compass_navigates_with_a_located_site() {
    use bpins_core::compass::{Attitude, Compass, CompassConfig};
    use bpins_core::internal::heading::field::RawImage;
    use bpins_core::internal::locate::Site;
    let (c, data, s) = series(7, 5.0, 60.0, 0.0, None);
    let r = located(&c, &data, &LocateOptions::default()).unwrap();
    let site = Site::from_located(&r, None);
    let g = c.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let mut compass = Compass::new(CompassConfig::dofp(c.intrinsics(), w, h, 12, 64.0)).unwrap();
    let last = c.frames.len() - 1;
    let t = bpins_core::internal::sky::sun::parse_time_utc(c.frames[last].sun.source.time_utc().unwrap()).unwrap();
    let sun = site.compass_sun(t.timestamp() as f64).unwrap();
    let FrameData::Mosaic { dn, .. } = &data[last] else { panic!("dofp") };
    let fix = compass.heading(RawImage::packed(dn, w, h), sun, Attitude::default()).unwrap();
    let (hd, sigma) = (fix.heading_deg().unwrap(), fix.sigma_deg().unwrap());
    let e = wrap_deg_180(hd - s.heading_deg);
    assert!(e.abs() < 2.0 * sigma && e.abs() < 0.3, "{hd} ± {sigma} against {}", s.heading_deg);
    // A site from the pole route has no longitude: no sun at a time, an error.
    let pole = Site { longitude_deg: None, longitude_sigma_deg: None, ..site };
    assert!(pole.compass_sun(t.timestamp() as f64).is_err());
}

/// Issue 33's "honest answer" on a sky that is not Rayleigh's: Berry's quartic sky
/// with the neutral points 30° apart. Read as Rayleigh's, its sun elevation is off by
/// degrees in the ±28° view with a small residual (the answer was 10° wrong with a 1σ
/// of 3°). `sky_sun` fits the separation as a nuisance: per frame it finds the
/// separation near 30° and an elevation within 2σ of the truth on ≥ 90 % of frames,
/// and the Rayleigh reading is shown to be off (so the check bites); over seeds, ≥ 90 %
/// of the north, latitude and longitude errors lie within 2σ; with the default bounds
/// each sequence is either answered within 2σ or refused, naming the sky.
#[test]
fn a_berry_sky_is_read_honestly_or_refused() {
    let seeds = 6u64;
    let (mut within, mut frames_within, mut frames) = ([0usize; 3], 0usize, 0usize);
    let (mut rayleigh_sq, mut quartic_sq, mut separations) = (0.0, 0.0, Vec::new());
    for seed in 0..seeds {
        let (c, data, s) = berry_series(300 + seed, 30.0);
        let measured = measure_data(&c, &data, &Model::default(), &FieldOptions::default()).unwrap();
        let (truth, _) = s.frames("png").unwrap();
        for (f, t) in measured.iter().zip(&truth) {
            let sun = f.sun.as_ref().unwrap_or_else(|e| panic!("seed {seed}, frame {}: {e}", f.index));
            let e = sun.elevation_deg - t.sun.elevation_deg;
            frames += 1;
            frames_within += usize::from(e.abs() <= 2.0 * sun.elevation_sigma_deg);
            quartic_sq += e * e;
            rayleigh_sq += (sun.rayleigh_elevation_deg - t.sun.elevation_deg).powi(2);
            separations.push(sun.separation_deg);
        }
        let obs: Vec<SunObs> = measured.iter().filter_map(|f| f.obs()).collect();
        let r = locate(&obs, &wide()).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let errs = [
            (wrap_deg_180(r.heading_deg - s.heading_deg), r.heading_sigma_deg),
            (r.latitude_deg - s.latitude_deg, r.latitude_sigma_deg),
            (wrap_deg_180(r.longitude_deg.unwrap() - s.longitude_deg), r.longitude_sigma_deg.unwrap()),
        ];
        for (k, (e, sig)) in errs.into_iter().enumerate() {
            within[k] += usize::from(e.abs() <= 2.0 * sig);
        }
        match locate(&obs, &LocateOptions::default()) {
            Ok(a) => {
                let north = wrap_deg_180(a.heading_deg - s.heading_deg);
                assert!(north.abs() <= 2.0 * a.heading_sigma_deg, "seed {seed}: answered {north}° off ({a:?})");
            }
            Err(e @ LocateError::NotRayleigh { .. }) => assert!(e.to_string().contains("not Rayleigh's"), "{e}"),
            Err(e) => panic!("seed {seed}: refused for another reason: {e}"),
        }
    }
    let n = frames as f64;
    separations.sort_by(f64::total_cmp);
    let median = separations[separations.len() / 2];
    assert!((24.0..=36.0).contains(&median), "median separation {median}°");
    let (rayleigh, quartic) = ((rayleigh_sq / n).sqrt(), (quartic_sq / n).sqrt());
    assert!(rayleigh > 1.0 && quartic < 0.5 * rayleigh, "elevation RMS: Rayleigh's {rayleigh}°, quartic {quartic}°");
    assert!(frames_within as f64 >= 0.9 * n, "{frames_within} of {frames} frames' elevations within 2σ");
    for (k, what) in ["north", "latitude", "longitude"].iter().enumerate() {
        let frac = within[k] as f64 / seeds as f64;
        assert!(frac >= 0.9, "{what}: {:.0} % within 2σ", 100.0 * frac);
    }
}
