//! Calibrate, then navigate: a sensor whose analyzers are off their nominal angles
//! (+1.0° at 45°, −0.6° at 135°) is fitted on a turntable capture, the fit becomes a
//! calibration (as `bpins fit` writes `calibration.toml`), and a `Compass` built with
//! it reads new frames at the noise floor.
//!
//! ```sh
//! cargo run --release -p bpins-core --example calibrate_then_navigate
//! ```

use bpins_core::calibration::Calibration;
use bpins_core::compass::{Attitude, Compass, CompassConfig, Sun};
use bpins_core::conventions::{image_centre_px, wrap_deg_180};
use bpins_core::effects::{find, EffectSet};
use bpins_core::internal::capture::{Capture, FrameData, FrameSpec, LensSpec, SensorSpec};
use bpins_core::internal::fit::{fit, FitOptions};
use bpins_core::internal::heading::field::RawImage;
use bpins_core::internal::pipeline::{simulate_capture, SimSensor};
use bpins_core::internal::sky::sun::SunPosition;
use bpins_core::sensor::{Geometry, Layout, DEFAULT_MOSAIC};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut truth = EffectSet::new();
    truth.parse_assignment("analyzer_angles.d45_deg=1.0")?;
    truth.parse_assignment("analyzer_angles.d135_deg=-0.6")?;
    let capture = |headings: &[f64]| Capture {
        dir: Default::default(),
        sensor: SensorSpec {
            colour: None,
            layout: Layout::Dofp { mosaic: DEFAULT_MOSAIC },
            geometry: Geometry { width_px: 306, height_px: 256, pixel_pitch_um: 27.6 },
            bit_depth: 12,
            black_level_dn: 64.0,
        },
        lens: LensSpec {
            projection: bpins_core::camera::Projection::Pinhole,
            focal_length_mm: 8.0,
            principal_point_px: image_centre_px(306, 256),
        },
        frames: headings
            .iter()
            .enumerate()
            .map(|(i, &h)| FrameSpec {
                file: format!("frames/f{i:03}.png").into(),
                sun: SunPosition::given(40.0, 25.0),
                heading_deg: Some(h),
                tilt_x_deg: None,
                tilt_y_deg: None,
                tilt_sigma_deg: None,
                sun_sigma_deg: None,
                yaw_deg: None,
                yaw_sigma_deg: None,
            })
            .collect(),
    };

    // 1. The turntable: eight headings, fitted with the analyzer angles free.
    let table = capture(&[0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0]);
    let (_, frames) = simulate_capture(&table, &truth.model(), &SimSensor::samples(1), None)?;
    let opts = FitOptions { effects: vec![find("analyzer_angles")?], ..Default::default() };
    let r = fit(&table, &frames, &opts, &|_, _| {})?;
    let cal = Calibration::from_params(
        r.params.iter().map(|p| (p.name.as_str(), p.value, p.sigma)),
        "calibrate_then_navigate example",
        Some(r.chi2_per_dof),
    )?;
    println!("fitted (χ²/dof {:.4}):", r.chi2_per_dof);
    for p in &r.params {
        println!("  {} = {:+.4} ± {:.4} {}", p.name, p.value, p.sigma, p.unit);
    }
    println!("\ncalibration.toml:\n{}", cal.to_toml());

    // 2. Navigation: new frames at other headings, read without and with the calibration.
    let drive = capture(&[13.0, 101.0, 222.0, 333.0]);
    let (_, frames) = simulate_capture(&drive, &truth.model(), &SimSensor::samples(2), None)?;
    let base = CompassConfig::dofp(drive.intrinsics(), 306, 256, 12, 64.0);
    let mut plain = Compass::new(base.clone())?;
    let mut calibrated = Compass::new(CompassConfig { calibration: cal, ..base })?;
    println!("{:>12} {:>22} {:>22}", "truth (°)", "uncalibrated error (°)", "calibrated error (°)");
    for (f, data) in drive.frames.iter().zip(&frames) {
        let FrameData::Mosaic { dn, .. } = data else { return Err("a DoFP frame that is not a mosaic".into()) };
        let raw: Vec<u16> = dn.iter().map(|&x| x as u16).collect();
        let sun = Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 };
        let err = |c: &mut Compass| -> Result<String, Box<dyn std::error::Error>> {
            let fix = c.heading(RawImage::packed(&raw, 306, 256), sun, Attitude::default())?;
            let truth = f.heading_deg.unwrap_or(0.0);
            Ok(match fix.result {
                Ok((h, s)) => format!("{:+.4} ± {:.4}", wrap_deg_180(h - truth), s.total_deg()),
                Err(why) => format!("none: {why}"),
            })
        };
        println!("{:>12.1} {:>22} {:>22}", f.heading_deg.unwrap_or(0.0), err(&mut plain)?, err(&mut calibrated)?);
    }
    Ok(())
}
