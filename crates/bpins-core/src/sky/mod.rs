//! The sky: sun position and the polarization pattern.

pub mod rayleigh;
#[cfg(feature = "spa")]
pub mod sun;

pub use rayleigh::sky_stokes;
