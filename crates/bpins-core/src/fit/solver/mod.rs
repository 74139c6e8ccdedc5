//! The solver: Levenberg–Marquardt (`lm`), the normal equations kept by blocks
//! (`block`) and solved by the Schur complement over the frames (`schur`), the dense
//! pseudo-inverse and its estimability rule (`linalg`), and a fit on a subsample
//! (`subfit`, what the diagnosis ranks its candidates with).

pub mod block;
pub mod linalg;
pub(crate) mod lm;
pub mod schur;
pub(crate) mod subfit;
