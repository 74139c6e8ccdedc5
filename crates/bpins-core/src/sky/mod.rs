//! The sky: sun position and the polarization pattern.

#[cfg(feature = "spa")]
pub mod moon;
pub mod rayleigh;
#[cfg(feature = "spa")]
pub mod sun;

pub use rayleigh::sky_stokes;
