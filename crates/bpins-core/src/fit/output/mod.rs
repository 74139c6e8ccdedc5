//! What a fit gives: the result types, serialised as `fit.json` (`result`), the
//! residual maps (`residuals`), the sky-space profiles of the residual with their
//! trends (`profiles`) and what one effect changes in the fitted model (`contrast`).

pub mod contrast;
pub mod profiles;
pub mod residuals;
pub mod result;
