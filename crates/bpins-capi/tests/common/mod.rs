//! The clean sample's frame 0 as a camera would hand it over, and the compass the
//! Rust front door builds for it (the reference the ABI must equal).

#![allow(dead_code)]

use bpins_core::compass::{Attitude, CompassConfig, Sun};
use bpins_core::sensor::Layout;
use bpins_core::{Capture, FrameData};

/// samples/clean of the repository: found upwards from the package that includes this
/// file (crates/bpins-capi's own tests, or the root package's C example).
pub fn clean_dir() -> std::path::PathBuf {
    let here = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let found = here.ancestors().map(|a| a.join("samples/clean")).find(|p| p.join("capture.toml").is_file());
    found.unwrap_or_else(|| here.join("samples/clean"))
}

pub struct Sample {
    pub config: CompassConfig,
    pub raw: Vec<u16>,
    pub sun: Sun,
    pub attitude: Attitude,
    pub truth_deg: f64,
}

/// Frame `k` of samples/clean, its sun, its attitude and its true heading.
pub fn clean_frame(k: usize) -> Sample {
    let c = Capture::load(&clean_dir()).expect("samples/clean");
    let Layout::Dofp { mosaic } = c.sensor.layout else { panic!("samples/clean is DoFP") };
    let g = &c.sensor.geometry;
    let mut config = CompassConfig::dofp(
        c.intrinsics(),
        g.width_px as usize,
        g.height_px as usize,
        c.sensor.bit_depth,
        c.sensor.black_level_dn,
    );
    config.mosaic = mosaic;
    let FrameData::Mosaic { dn, .. } = c.read_frame(k).expect("frame") else { panic!("a mosaic frame") };
    let f = &c.frames[k];
    Sample {
        config,
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
        truth_deg: f.heading_deg.expect("the sample's truth"),
    }
}
