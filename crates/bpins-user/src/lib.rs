//! Nothing here: this package exists for its tests (`tests/front_door.rs`), which use
//! bpins-core as a crate outside the workspace would, through its public paths only.
