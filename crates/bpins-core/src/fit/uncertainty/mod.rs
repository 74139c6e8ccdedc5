//! The uncertainty: each 1σ widened by the residual's effective sample count
//! (`correlation`), the cluster-robust sandwich 1σ (`robust`), and the score test of a
//! parameter the model does not have yet (`score`: the Δχ² one step would gain, which
//! the diagnosis ranks candidates by, and the heading's 1σ with it freed, held to its
//! physical range by `prior`).

pub mod correlation;
pub(crate) mod prior;
pub(crate) mod robust;
pub mod score;
pub(crate) mod spatial;
