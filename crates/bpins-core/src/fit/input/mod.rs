//! The request and its inputs: what to fit (`FitRequest`, loaded into options, a
//! capture and its frames), the frames as the fit reads them (whole or through a seeded
//! sample of 2 × 2 tiles, `frames`), each frame's sky mask (`masks`), the EMVA noise
//! read off the frames themselves (`noise`; a colour frame's on its sky, `sky_noise`),
//! and raising the sample where it cannot decide a parameter every pixel could
//! (`resolution`); which source lit each frame's sky, a mixed twilight or a dark night
//! refused (`sky`).

pub mod frames;
pub mod masks;
pub mod noise;
pub mod request;
pub mod resolution;
pub mod sky;
pub mod sky_noise;
