//! Capture bundles (`bpins-capture/1`, shared/spec/CAPTURE.md): reading, validating
//! and writing. (Being written.)
