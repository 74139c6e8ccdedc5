//! The sky: sun position and the polarization pattern.

pub mod sun;
