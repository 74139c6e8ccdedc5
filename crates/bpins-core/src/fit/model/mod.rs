//! The model and its parameters: the typed parameter slots and the per-frame nuisances
//! (`slots`), the problem a fit solves (`problem`: the chain's model DN at each pixel),
//! the smooth radiance nuisance (`radiance`), the chain stages each derivative column
//! reuses (`stages`), the starting guesses (`start`) and the pixel-by-pixel
//! accumulation of JᵀWJ and JᵀWr (`accumulate`).

pub(crate) mod accumulate;
pub(crate) mod problem;
pub mod radiance;
pub mod slots;
pub(crate) mod stages;
pub(crate) mod start;
