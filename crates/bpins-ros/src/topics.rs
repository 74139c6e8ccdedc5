//! The topics bpins writes, and the rule that keeps its own outputs out of its inputs.
//!
//! Everything bpins writes as a result or a truth lies under [`NAMESPACE`] (`/bpins/`):
//! `bpins heading --bag-out`'s headings ([`HEADING`]) and `bpins simulate --bag-out`'s
//! true heading ([`REFERENCE_HEADING`]). Both are `sensor_msgs/Imu`, yet neither is an
//! IMU measurement, so a reader choosing a topic by its type alone never takes one
//! ([`is_bpins_output`]); named by its flag (`--imu-topic /bpins/reference_heading`)
//! it is read like any other. `simulate --bag-out` records its inputs where a robot's
//! drivers usually publish them ([`IMAGE`], [`CAMERA_INFO`], [`IMU`], [`GNSS_FIX`]).

/// The namespace of bpins' own outputs.
pub const NAMESPACE: &str = "/bpins/";
/// The headings, `sensor_msgs/Imu` per REP 103/145 (`bpins heading --bag-out`'s
/// default `--heading-topic`).
pub const HEADING: &str = "/bpins/heading";
/// The truth of a simulated bag: the reference heading as a `sensor_msgs/Imu` per
/// REP 103, zero covariance (`bpins simulate --bag-out`).
pub const REFERENCE_HEADING: &str = "/bpins/reference_heading";

/// `simulate --bag-out`'s raw DoFP mosaics (`sensor_msgs/Image`, mono16).
pub const IMAGE: &str = "/cam/image_raw";
/// `simulate --bag-out`'s `sensor_msgs/CameraInfo`.
pub const CAMERA_INFO: &str = "/cam/camera_info";
/// `simulate --bag-out`'s IMU: the reference tilt, yaw not measured.
pub const IMU: &str = "/imu/data";
/// `simulate --bag-out`'s `sensor_msgs/NavSatFix`, where the sun came from a time and place.
pub const GNSS_FIX: &str = "/gnss/fix";

/// Whether `topic` is one of bpins' own outputs ([`NAMESPACE`]): never an input
/// unless named.
pub fn is_bpins_output(topic: &str) -> bool {
    topic.starts_with(NAMESPACE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bpins_outputs_are_its_namespace() {
        assert!(is_bpins_output(HEADING) && is_bpins_output(REFERENCE_HEADING));
        for t in [IMAGE, CAMERA_INFO, IMU, GNSS_FIX, "/bpins", "/imu/bpins/data"] {
            assert!(!is_bpins_output(t), "{t}");
        }
    }
}
