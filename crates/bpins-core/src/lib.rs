//! # bpins-core
//!
//! The measurement model of a bionic polarization imaging navigation sensor (BPINS):
//! Rayleigh sky → lens Mueller matrix → micro-polarizer analyzers → CMOS response
//! with noise → Stokes reconstruction → heading. Conventions (frames, angles, mosaic,
//! Stokes) are those of `shared/spec/CONVENTIONS.md`, kept in [`conventions`].
//!
//! The per-pixel physics are pure functions (CPU reference of the GPU shaders);
//! rayon appears only in the drivers that map them over pixels and trials.
//! Libraries never print: errors are typed ([`Error`]).

pub mod camera;
pub mod capture;
pub mod chain;
pub mod conventions;
pub mod effects;
pub mod error;
pub mod heading;
pub mod montecarlo;
pub mod noise;
pub mod pipeline;
pub mod recon;
pub mod sensor;
pub mod simulate;
pub mod sky;
pub mod stokes;

pub use error::{Error, Result};
