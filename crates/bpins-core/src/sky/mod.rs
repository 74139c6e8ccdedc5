//! The sky: sun position and the polarization pattern.

pub mod radiance_shape;
pub mod rayleigh;
#[cfg(feature = "spa")]
pub mod sun;

pub use radiance_shape::radiance_shape;
pub use rayleigh::sky_stokes;
