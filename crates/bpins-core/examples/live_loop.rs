//! A robot's loop: frames in at the camera's rate, headings out with their 1σ, the
//! latency of each printed.
//!
//! ```sh
//! cargo run --release -p bpins-core --example live_loop                 # a generated drive, 30 Hz
//! cargo run --release -p bpins-core --example live_loop -- samples/clean  # a capture's frames (any bpins-capture/1 folder)
//! ```
//!
//! Generated: a 612 × 512 DoFP camera (the samples' sensor) on a robot turning 3° a
//! frame over rough ground (tilt wobbling ±5°, read by an IMU with 0.1° noise), the
//! sun at 40°/25°; each frame is rendered before the clock starts, so the latency is
//! the compass's alone: borrowed u16 buffer → heading ± 1σ.

use bpins_core::camera::{Intrinsics, Projection};
use bpins_core::compass::{Attitude, Compass, CompassConfig, Sun};
use bpins_core::conventions::wrap_deg_180;
use bpins_core::internal::capture::{Capture, FrameData};
use bpins_core::internal::chain::{ChainFrame, NoiseIndex, Scene};
use bpins_core::internal::heading::field::RawImage;
use bpins_core::internal::simulate::render_mosaic;
use bpins_core::sensor::{Layout, Response, DEFAULT_MOSAIC};
use std::time::{Duration, Instant};

/// One frame as the camera and the IMU deliver it, with the truth where known.
struct Input {
    raw: Vec<u16>,
    sun: Sun,
    attitude: Attitude,
    truth_deg: Option<f64>,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (config, inputs) = match std::env::args().nth(1) {
        Some(dir) => from_capture(&dir)?,
        None => generated(90),
    };
    let (w, h) = (config.width_px, config.height_px);
    let mut compass = Compass::new(config)?;
    let period = Duration::from_secs_f64(1.0 / 30.0);
    let mut latencies = Vec::new();
    println!(
        "{:>5} {:>12} {:>9} {:>10} {:>9} {:>12}",
        "frame", "heading (°)", "1σ (°)", "error (°)", "used (%)", "latency (ms)"
    );
    let start = Instant::now();
    for (k, input) in inputs.iter().enumerate() {
        let t0 = Instant::now();
        let fix = compass.heading(RawImage::packed(&input.raw, w, h), input.sun, input.attitude)?;
        let dt = t0.elapsed();
        latencies.push(dt.as_secs_f64() * 1e3);
        let err = fix.heading_deg().zip(input.truth_deg).map(|(a, b)| format!("{:+.4}", wrap_deg_180(a - b)));
        match &fix.result {
            Ok((hd, s)) => println!(
                "{k:>5} {hd:>12.4} {:>9.4} {:>10} {:>9.1} {:>12.3}",
                s.total_deg(),
                err.unwrap_or_else(|| "—".into()),
                100.0 * fix.quality.used_fraction,
                latencies[k]
            ),
            Err(why) => println!("{k:>5} no heading: {why} ({:.3} ms)", latencies[k]),
        }
        // Hold the camera's rate: the next frame arrives one period after this one.
        if let Some(rest) = (start + period * (k as u32 + 1)).checked_duration_since(Instant::now()) {
            std::thread::sleep(rest);
        }
    }
    latencies.sort_by(|a, b| a.total_cmp(b));
    let q = |p: f64| latencies[((latencies.len() - 1) as f64 * p) as usize];
    println!(
        "latency over {} frames: median {:.3} ms, 95 % {:.3} ms, max {:.3} ms (budget at 30 Hz: {:.1} ms)",
        latencies.len(),
        q(0.5),
        q(0.95),
        q(1.0),
        period.as_secs_f64() * 1e3
    );
    Ok(())
}

/// A drive: the robot turns 3° a frame, its tilt wobbles, the IMU reads it to 0.1°.
fn generated(frames: usize) -> (CompassConfig, Vec<Input>) {
    let lens = Intrinsics::new(Projection::Pinhole, 8000.0 / 13.8, 305.5, 255.5);
    let inputs = (0..frames)
        .map(|k| {
            let t = k as f64;
            let (tx, ty) = (5.0 * (0.31 * t).sin(), 4.0 * (0.17 * t + 1.0).cos());
            let heading = (3.0 * t).rem_euclid(360.0);
            let scene = Scene {
                sun_az_deg: 40.0,
                sun_el_deg: 25.0,
                heading_deg: heading,
                tilt_x_deg: tx,
                tilt_y_deg: ty,
                dmax: 0.6,
            };
            let f = ChainFrame::new(
                &Default::default(),
                &lens,
                &scene,
                &Response::samples(3000.0),
                NoiseIndex { seed: 7, trial: 0, frame: k as u32 },
            );
            // The IMU's reading: off by a deterministic ±0.1°-scale error.
            let imu = (0.1 * (1.7 * t).sin(), 0.1 * (2.3 * t).cos());
            Input {
                raw: render_mosaic(&f, 612, 512, &DEFAULT_MOSAIC).into_iter().map(|x| x as u16).collect(),
                sun: Sun::Angles { azimuth_deg: 40.0, elevation_deg: 25.0, sigma_deg: 0.0 },
                attitude: Attitude { tilt_x_deg: tx + imu.0, tilt_y_deg: ty + imu.1, sigma_deg: 0.1 },
                truth_deg: Some(heading),
            }
        })
        .collect();
    (CompassConfig::dofp(lens, 612, 512, 12, 64.0), inputs)
}

/// The frames of a DoFP capture folder, read before the loop starts.
fn from_capture(dir: &str) -> Result<(CompassConfig, Vec<Input>), Box<dyn std::error::Error>> {
    let c = Capture::load(std::path::Path::new(dir))?;
    let Layout::Dofp { mosaic } = c.sensor.layout else { return Err("the live loop reads DoFP captures".into()) };
    let g = &c.sensor.geometry;
    let mut config = CompassConfig::dofp(
        c.intrinsics(),
        g.width_px as usize,
        g.height_px as usize,
        c.sensor.bit_depth,
        c.sensor.black_level_dn,
    );
    config.mosaic = mosaic;
    let mut inputs = Vec::new();
    for (i, f) in c.frames.iter().enumerate() {
        let FrameData::Mosaic { dn, .. } = c.read_frame(i)? else {
            return Err("a DoFP frame that is not a mosaic".into());
        };
        inputs.push(Input {
            raw: dn.iter().map(|&x| x as u16).collect(),
            sun: Sun::Angles {
                azimuth_deg: f.sun.azimuth_deg,
                elevation_deg: f.sun.elevation_deg,
                sigma_deg: f.sun_sigma_deg.unwrap_or(0.0),
            },
            attitude: Attitude {
                tilt_x_deg: f.tilt_x_deg.unwrap_or(0.0),
                tilt_y_deg: f.tilt_y_deg.unwrap_or(0.0),
                sigma_deg: f.tilt_sigma_deg.unwrap_or(0.0),
            },
            truth_deg: f.heading_deg,
        });
    }
    Ok((config, inputs))
}
