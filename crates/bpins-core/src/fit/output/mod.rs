//! What a fit gives: the result types, serialised as `fit.json` (`result`), the
//! residual maps (`residuals`) and the sky-space profiles of the residual with their
//! trends (`profiles`).

pub mod profiles;
pub mod residuals;
pub mod result;
