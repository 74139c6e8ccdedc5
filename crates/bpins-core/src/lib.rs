//! # bpins-core
//!
//! The measurement model of a bionic polarization imaging navigation sensor (BPINS):
//! Rayleigh sky → lens Mueller matrix → micro-polarizer analyzers → CMOS response
//! with noise → Stokes reconstruction → heading. Conventions (frames, angles, mosaic,
//! Stokes) are those of `docs/spec/CONVENTIONS.md`, kept in [`conventions`].
//!
//! # Where things are
//!
//! | for | modules |
//! |---|---|
//! | a robot: raw frames in, heading ± 1σ out | [`compass`] (the front door), [`calibration`], [`backend`] |
//! | headings from Stokes images or cells | [`heading`], [`heading::field`] (the field estimator) |
//! | the measurement chain, pixel by pixel | [`sky`], [`camera`], [`effects`] (the catalog and its registry), [`sensor`], [`noise`], [`chain`], [`stokes`], [`recon`], [`conventions`] |
//! | simulation and the seed paper's error analysis | [`simulate`], [`scene`] (field conditions), [`montecarlo`] |
//! | measured captures (feature `io`) | `capture`, `pipeline`, `fit` (fit and diagnosis), `field_conditions` |
//! | north and place from the sky alone, no GNSS (feature `io`) | `locate` |
//!
//! The per-pixel kernels stay public where the GPU twin's parity tests and the
//! registry-wide tests call them as the reference; row loops, scratch sums and the
//! drivers' helpers are private.
//!
//! The per-pixel physics are pure functions (CPU reference of the GPU shaders);
//! rayon appears only in the drivers that map them over pixels and trials.
//! Libraries never print: errors are typed ([`Error`]).
//!
//! # Example: a frame from sky to heading
//!
//! Simulate a small DoFP frame with a 0.3° rotated analyzer array, reconstruct it as
//! a user would (nominal analyzers), and read the heading with both extractors:
//!
//! ```
//! use bpins_core::camera::{Intrinsics, Projection};
//! use bpins_core::chain::{ChainFrame, NoiseIndex, Scene};
//! use bpins_core::conventions::wrap_deg_180;
//! use bpins_core::effects::{EffectSet, Model};
//! use bpins_core::heading::{estimate, Extractor, HeadingContext};
//! use bpins_core::recon::{demosaic, Reconstructor};
//! use bpins_core::sensor::{Channel, Response, DEFAULT_MOSAIC};
//! use bpins_core::simulate::render_mosaic;
//!
//! let (w, h) = (306, 256);
//! let camera = Intrinsics { projection: Projection::Pinhole, f_px: 8000.0 / 27.6, cx_px: 152.5, cy_px: 127.5, distortion: [0.0; 2] };
//! let scene = Scene { sun_az_deg: 40.0, sun_el_deg: 25.0, heading_deg: 30.0, tilt_x_deg: 0.0, tilt_y_deg: 0.0, dmax: 0.6 };
//! let sensor = Response { gain_dn: 3000.0, black_level_dn: 64.0, read_noise_dn: 1.0, bit_depth: 12, quantize: true, ..Response::ideal(1.0) };
//!
//! let mut truth = EffectSet::new();
//! truth.parse_assignment("array_rotation.dtheta_deg=0.3")?;
//! let frame = ChainFrame::new(&truth.model(), &camera, &scene, &sensor, NoiseIndex { seed: 1, trial: 0, frame: 0 });
//! let dn = render_mosaic(&frame, w, h, &DEFAULT_MOSAIC); // DN, 12-bit
//!
//! let rec = Reconstructor::new(&Model::default(), 64.0, &Channel::ALL)?;
//! let stokes = demosaic(&dn, w, h, &DEFAULT_MOSAIC, &rec, 4095.0);
//! let ctx = HeadingContext::new(camera, w, h, scene.sun_az_deg, scene.sun_el_deg);
//! for e in Extractor::ALL {
//!     let est = estimate(&stokes, &ctx, e)?;
//!     let err = wrap_deg_180(est.heading_deg - scene.heading_deg);
//!     // The unknown array rotation biases the heading by about its own angle.
//!     assert!(err > 0.1 && err < 0.5, "{}: {err}°", e.name());
//! }
//! # Ok::<(), bpins_core::Error>(())
//! ```

pub mod backend;
pub mod calibration;
pub mod camera;
#[cfg(feature = "io")]
pub mod capture;
pub mod catalog;
pub mod chain;
pub mod compass;
pub mod conventions;
#[cfg(feature = "io")]
pub mod diagnose;
pub mod effects;
pub mod error;
#[cfg(feature = "io")]
pub mod field_conditions;
#[cfg(feature = "io")]
pub mod fit;
pub mod heading;
#[cfg(feature = "io")]
pub mod lab;
#[cfg(feature = "io")]
pub mod locate;
pub mod maps;
pub(crate) mod math;
pub mod montecarlo;
pub mod noise;
#[cfg(feature = "io")]
pub mod output;
#[cfg(feature = "io")]
pub mod pipeline;
pub mod pixel_analyzers;
pub mod recon;
pub mod scene;
pub mod sensor;
pub mod simulate;
pub mod sky;
pub mod stokes;
#[cfg(feature = "io")]
pub mod sweep;

pub use error::{Error, Result};
