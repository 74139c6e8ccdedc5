//! # bpins-core
//!
//! The measurement model of a bionic polarization imaging navigation sensor (BPINS):
//! Rayleigh sky → lens Mueller matrix → micro-polarizer analyzers → CMOS response
//! with noise → Stokes reconstruction → heading. Conventions (frames, angles, mosaic,
//! Stokes) are those of `docs/spec/CONVENTIONS.md`, kept in [`conventions`].
//!
//! # Where to start
//!
//! | you want | start at |
//! |---|---|
//! | a heading ± 1σ from a camera's raw frames (a robot) | [`compass::Compass`], with a [`calibration::Calibration`] |
//! | the same from a capture on disk (`docs/spec/CAPTURE.md`) | [`Capture`], then [`compass::Compass::for_capture`] |
//! | to fit the model to measured frames, and what it misses | [`fit()`], [`diagnose()`] |
//! | a sensor's effects from lab frames | [`calibrate`] |
//! | the seed paper's error analysis over any sensor | [`SweepSpec`], [`run_to_dir`] |
//! | north and place from the sky over time, no GNSS | [`locate()`] |
//! | AoP and DoLP maps of a raw frame | [`stokes_maps`] |
//! | a sky's Stokes, AoP and DoLP maps, a sensor's raw DN frames (seeded noise), a trial of the seed paper's Monte Carlo | [`render::Renderer`], [`render::paper_trial`] |
//! | what can be simulated and fitted: lens and sensor effects, scene elements | [`catalog`], [`effects`], [`scene`] |
//!
//! The camera and sensor descriptions these take are [`camera`] and [`sensor`];
//! errors are typed ([`Error`], [`compass::CompassError`], [`LocateError`], [`render::RenderError`]).
//! Adding an effect or a scene element is one module and one registry line
//! (`docs/adding-an-effect.md`); everything else in the crate is the house behind the
//! front door, private. Two narrower doors are named for the workspace's own clients:
//! [`twin`], what a GPU twin of the chain is built on (`bpins-gpu`: the per-pixel
//! kernels, their parameter blocks, the reference drivers), and [`tool`], what the
//! command line and the Python binding are built on (requests, JSON files, writers).
//! The crate's own tests reach the rest through a hidden `internal` module, which no
//! other crate uses and nothing promises.
//!
//! The per-pixel physics are pure functions (the CPU reference of the GPU shaders);
//! rayon appears only in the drivers that map them over pixels and trials. Libraries
//! never print.
//!
//! # Example: headings from a capture on disk
//!
//! Read the `samples/clean` capture, made by an independent implementation of the
//! spec, and read each frame's heading with its 1σ as a robot would:
//!
//! ```
//! use bpins_core::calibration::Calibration;
//! use bpins_core::compass::{Compass, Extractor, FieldOptions};
//! use bpins_core::conventions::wrap_deg_180;
//! use bpins_core::Capture;
//!
//! let capture = Capture::load(std::path::Path::new("../../samples/clean"))?;
//! let mut compass = Compass::for_capture(&capture, Calibration::default(), FieldOptions::default(), Extractor::SunVector)?;
//! for (i, frame) in capture.frames.iter().enumerate() {
//!     let data = capture.read_frame(i)?;
//!     let fix = &compass.capture_frame(&data, frame, &[Extractor::SunVector])?[0];
//!     let (heading_deg, sigma_deg) = (fix.heading_deg().unwrap(), fix.sigma_deg().unwrap());
//!     // Within a few 1σ of the capture's reference heading.
//!     let err_deg = wrap_deg_180(heading_deg - frame.heading_deg.unwrap());
//!     assert!(err_deg.abs() < 5.0 * sigma_deg + 0.01, "frame {i}: {err_deg}° off, 1σ {sigma_deg}°");
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

// The front door: the modules a user of the library reads (see the table above).
pub mod calibration;
pub mod camera;
pub mod catalog;
pub mod compass;
pub mod conventions;
pub mod effects;
pub mod error;
pub mod render;
pub mod scene;
pub mod sensor;
#[cfg(feature = "io")]
pub mod tool;
pub mod twin;

// The house: every implementation module, private. The C binding, the ROS 2 reader and
// the Python binding use only the front door and `tool`; the CLI `tool` and `twin`; the
// GPU twin `twin`. Only tests, benches and examples reach the house through
// [`internal`] (`tests/public_api.rs` keeps it so).
mod backend;
#[cfg(feature = "io")]
mod capture;
mod chain;
#[cfg(feature = "io")]
mod diagnose;
#[cfg(feature = "io")]
mod field_conditions;
#[cfg(feature = "io")]
mod fit;
mod heading;
#[cfg(feature = "io")]
mod lab;
#[cfg(feature = "io")]
mod locate;
mod lsq;
mod maps;
mod math;
mod montecarlo;
mod noise;
#[cfg(feature = "io")]
mod output;
#[cfg(feature = "io")]
mod pipeline;
mod pixel_analyzers;
mod recon;
#[cfg(feature = "io")]
mod sensor_exposure;
mod simulate;
mod sky;
mod stats;
mod stokes;
#[cfg(feature = "io")]
mod sweep;

pub use error::{Error, Result};

// What each kind of user calls, beside the compass (feature `io`: measured captures).
#[cfg(feature = "io")]
pub use capture::{Capture, FrameData, FrameSpec, LabCapture};
#[cfg(feature = "io")]
pub use diagnose::{diagnose, DiagnoseOptions, Diagnosis};
#[cfg(feature = "io")]
pub use fit::{fit, FitOptions, FitResult};
#[cfg(feature = "io")]
pub use lab::{calibrate, LabCalibration};
#[cfg(feature = "io")]
pub use locate::{locate, LocateError, LocateOptions, Located, SunObs};
/// The maps of a colour-polarization mosaic, per band (`docs/colour.md`).
pub use maps::{colour_maps, colour_maps_into, colour_maps_size, BandMaps, ColourScratch};
pub use maps::{stokes_maps, Maps, MapsConfig};
/// [`stokes_maps`] into the caller's buffers (no allocation per frame), as the C ABI
/// and the Python binding call it.
pub use maps::{stokes_maps_into, MapsOut};
#[cfg(feature = "io")]
pub use sweep::{run_to_dir, SweepSpec};

// The types the entry points above (and the public modules) take, return or expose,
// each reachable by a public path: a user can name, build and match on what the
// front door hands them (issue 44). Re-exports only; the modules stay private.

/// The per-pixel chain's inputs, as the compass and the scene elements see them.
pub use chain::{ActiveEffects, ChainFrame, NoiseIndex, Scene};
/// The sky mask of a frame: which pixels the heading reads.
pub use heading::field::SkyMask;
/// Headings read from the per-pixel sums, and the context each is read in.
pub use heading::{HeadingContext, HeadingEstimate, HeadingSums};
/// What [`stokes_maps`] needs and may fail with: build the reconstructor with
/// [`Reconstructor::new`]; match on [`MapsError`].
pub use maps::{Interpolation, MapsError};
/// A frame's noise key: the seed of its reproducible per-pixel noise.
pub use noise::FrameKey;
/// Per-pixel analyzer descriptions (measured or nominal), as calibrations carry them.
pub use pixel_analyzers::{CellAnalyzer, CellAnalyzers, PixelMaps};
/// The Stokes reconstruction of a raw mosaic: the reconstructor [`stokes_maps`] takes,
/// and the per-pixel polarization image it produces.
pub use recon::{PolImage, Reconstructor};
/// What a scene element implements and is given: see [`scene`] and `docs/adding-an-effect.md`.
pub use scene::frame::{ElementContext, FieldElement, FieldFrame, FieldRay, SameAs};
/// The sun's place in the sky, and where it came from (a time and place, or given).
#[cfg(feature = "spa")]
pub use sky::sun::{SunPosition, SunSource};
/// Stokes vectors and the micro-polarizer analyzers that measure them.
pub use stokes::{Analyzer, Stokes};

/// A capture's sensor and lens descriptions, lab frames and writer (`docs/spec/CAPTURE.md`).
#[cfg(feature = "io")]
pub use capture::{CaptureWriter, LabFrame, LensSpec, SensorSpec};
/// The parts of a [`Diagnosis`]: candidates, steps, what remains, and the sizes it tests.
#[cfg(feature = "io")]
pub use diagnose::{
    pairs::Confusable,
    remains::{CapCandidate, LeftByCap, Remains, Unexplained},
    sizes::{EffectSize, MinSize, OutsidePhysical, Thresholds},
    Candidate, Evidence, Step, Timings,
};
/// The parts of a [`FitResult`] and of [`FitOptions`]: parameters, per-frame fits, profiles, trends.
#[cfg(feature = "io")]
pub use fit::{
    input::{noise::NoiseModel, resolution::Raised},
    model::{radiance::Basis, slots::EffectParam},
    output::profiles::{Axis, Profile, ProfileBin, Quantity, Trend, TrendPoint},
    FitState, FrameFit, Param, Sample,
};
/// The parts of a [`LabCalibration`]: darks, photon transfer, flat field, per-channel summaries.
#[cfg(feature = "io")]
pub use lab::{
    bands::BandCalibration,
    flat::FlatField,
    photon_transfer::{Dark, PhotonTransfer, PtcPoint},
    summary::ChannelSummary,
    LeftOut, SigmaMaps,
};
/// How [`locate()`] found north and place.
#[cfg(feature = "io")]
pub use locate::Route;
/// What [`locate()`] is given from a capture on disk and what its answer is kept as:
/// each frame's sky sun and turn ([`measure`], [`FrameSun::obs`] the [`SunObs`]), and
/// the site file (`bpins-site/1`) that the compass takes in place of GNSS ([`Site`]).
#[cfg(feature = "io")]
pub use locate::{measure, FrameSun, Site};
/// The sums engine to pass [`run_to_dir`] on the CPU (rayon); `bpins-gpu` has the GPU's.
#[cfg(feature = "io")]
pub use sweep::CpuSums;
/// A [`SweepSpec`]'s parts, what [`run_to_dir`] takes (its sums engine) and returns
/// (its outcome, shards), and the summary's rows.
#[cfg(feature = "io")]
pub use sweep::{
    Budget, Distribution, ErrorSpec, Known, Outcome, Per, PixelNoise, Row, Shard, Share, Summary, SumsEngine, SumsJob,
    SweepExtractor, Target,
};

/// The house behind the front door, for bpins' own tests, benches and examples: the
/// per-pixel chain and its kernels (the CPU reference the GPU twin's parity tests call),
/// the fit's and the diagnosis's rooms, the capture format's readers and writers, the
/// sweep's shards. Hidden from the documentation and free to change in any release:
/// nothing here is part of bpins-core's public interface.
#[doc(hidden)]
pub mod internal {
    pub mod backend {
        pub use crate::backend::*;
    }
    #[cfg(feature = "io")]
    pub mod capture {
        pub use crate::capture::*;
    }
    pub mod chain {
        pub use crate::chain::*;
    }
    #[cfg(feature = "io")]
    pub mod diagnose {
        pub use crate::diagnose::*;
    }
    pub mod effects {
        pub use crate::effects::*;
        pub mod lens_diattenuation {
            pub use crate::effects::lens_diattenuation::*;
        }
    }
    #[cfg(feature = "io")]
    pub mod field_conditions {
        pub use crate::field_conditions::*;
    }
    #[cfg(feature = "io")]
    pub mod fit {
        pub use crate::fit::*;
    }
    pub mod heading {
        pub use crate::heading::*;
    }
    #[cfg(feature = "io")]
    pub mod lab {
        pub use crate::lab::*;
    }
    #[cfg(feature = "io")]
    pub mod locate {
        pub use crate::locate::*;
    }
    pub mod maps {
        pub use crate::maps::*;
    }
    pub mod montecarlo {
        pub use crate::montecarlo::*;
    }
    pub mod noise {
        pub use crate::noise::*;
    }
    #[cfg(feature = "io")]
    pub mod output {
        pub use crate::output::*;
    }
    #[cfg(feature = "io")]
    pub mod pipeline {
        pub use crate::pipeline::*;
    }
    pub mod pixel_analyzers {
        pub use crate::pixel_analyzers::*;
    }
    pub mod recon {
        pub use crate::recon::*;
    }
    pub mod scene {
        pub use crate::scene::frame::*;
        pub use crate::scene::*;
        pub mod clouds {
            pub use crate::scene::clouds::*;
        }
    }
    #[cfg(feature = "io")]
    pub mod sensor_exposure {
        pub use crate::sensor_exposure::*;
    }
    pub mod simulate {
        pub use crate::simulate::*;
    }
    pub mod sky {
        pub use crate::sky::*;
    }
    pub mod stokes {
        pub use crate::stokes::*;
    }
    #[cfg(feature = "io")]
    pub mod sweep {
        pub use crate::sweep::*;
    }
}
