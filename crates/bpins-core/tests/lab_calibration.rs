//! Lab calibration end to end: the sample `lab-flawed-sensor` (an independent
//! implementation's flawed sensor, with truth in samples/README.md) calibrated from
//! its lab capture and its sky headings read through the calibration.

use std::path::Path;
use std::sync::Arc;

use bpins_core::calibration::Calibration;
use bpins_core::capture::{Capture, FrameData, LabCapture};
use bpins_core::compass::{Attitude, Compass, CompassConfig, Sun};
use bpins_core::conventions::wrap_deg_180;
use bpins_core::heading::field::RawImage;
use bpins_core::lab::{calibrate, LabCalibration};
use bpins_core::sensor::DEFAULT_MOSAIC;

const LAB: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/lab-flawed-sensor/lab");
const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../samples/lab-flawed-sensor/sky");

fn sample_calibration() -> LabCalibration {
    let lab = LabCapture::load(Path::new(LAB)).unwrap();
    calibrate(&lab, &|_, _| {}).unwrap()
}

/// RMS heading error of the sky frames through the front door with `cal`.
fn compass_rms(sky: &Capture, cal: Calibration) -> f64 {
    let g = &sky.sensor.geometry;
    let (w, h) = (g.width_px as usize, g.height_px as usize);
    let cfg = CompassConfig {
        calibration: cal,
        ..CompassConfig::dofp(sky.intrinsics(), w, h, sky.sensor.bit_depth, sky.sensor.black_level_dn)
    };
    let mut compass = Compass::new(cfg).unwrap();
    let mut s2 = 0.0;
    for (i, f) in sky.frames.iter().enumerate() {
        let FrameData::Mosaic { dn, .. } = sky.read_frame(i).unwrap() else { panic!() };
        let sun = Sun::Angles { azimuth_deg: f.sun.azimuth_deg, elevation_deg: f.sun.elevation_deg, sigma_deg: 0.0 };
        let fix = compass.heading(RawImage::packed(&dn, w, h), sun, Attitude::default()).unwrap();
        let e = wrap_deg_180(fix.heading_deg().unwrap() - f.heading_deg.unwrap());
        s2 += e * e;
    }
    (s2 / sky.frames.len() as f64).sqrt()
}

#[test]
fn the_flawed_sample_sensor_is_calibrated_and_its_sky_headings_fall_to_the_noise() {
    let cal = sample_calibration();
    for s in &cal.summary {
        eprintln!("{s:?}");
    }
    eprintln!("{:?}\n{:?}\n{:?}", cal.photon_transfer, cal.flat, cal.left_out);
    let sky = Capture::load(Path::new(SKY)).unwrap();
    let raw = compass_rms(&sky, Calibration::default());
    let pixels = Calibration { pixels: Some(Arc::new(cal.maps.clone())), ..Default::default() };
    let calibrated = compass_rms(&sky, pixels);
    eprintln!("heading RMS: nominal {raw:.4}°, calibrated {calibrated:.4}°");
    assert!(raw > 0.3, "{raw}");
    assert!(calibrated < 0.02, "{calibrated}");
    let _ = DEFAULT_MOSAIC;
}
