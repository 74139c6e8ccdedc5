//! A heading as ROS consumes it: `sensor_msgs/Imu` orientation in ENU (REP 103),
//! its covariance (REP 145), and a `diagnostic_msgs/DiagnosticArray` for a frame
//! without a heading.
//!
//! **Body frame** (REP 103's x forward, y left, z up), fixed to the camera
//! (CONVENTIONS.md's camera frame: x image right, y image down, z optical axis):
//! `x_b` = the image top (camera −y), `y_b` = camera +x, `z_b` = the optical axis
//! (camera +z, up for a level sky camera). The orientation is `world_from_body`
//! with world = ENU:
//!
//! ```text
//! world_from_body = R_level(ψ) · Rx(tilt_x) · Ry(tilt_y) · camera_from_body
//!                 = Rz(yaw) · Ry(pitch) · Rx(roll)
//!   yaw   = 90° − ψ      (ψ the heading, clockwise from North; yaw CCW from East)
//!   pitch = tilt_x       (the camera's x axis is the body's y axis)
//!   roll  = −tilt_y      (the camera's y axis is the body's −x axis)
//! ```
//!
//! An IMU read for the reference tilt is taken to report this same body frame (its
//! x along the image top, z along the optical axis); bpins applies no mounting
//! rotation between the IMU and the camera.

use crate::msgs::{DiagnosticArray, DiagnosticStatus, Header, Imu, KeyValue, Quaternion};
use glam::{DMat3, DQuat, EulerRot};

/// `world_from_body` (ENU) of a camera at heading `heading_deg` (CONVENTIONS.md)
/// and tilt, as a unit quaternion (x, y, z, w).
pub fn enu_quaternion(heading_deg: f64, tilt_x_deg: f64, tilt_y_deg: f64) -> [f64; 4] {
    let q = DQuat::from_euler(
        EulerRot::ZYX,
        (90.0 - heading_deg).to_radians(),
        tilt_x_deg.to_radians(),
        (-tilt_y_deg).to_radians(),
    );
    [q.x, q.y, q.z, q.w]
}

/// The camera's `world_from_camera` (CONVENTIONS.md, Tilt), built from the
/// convention's columns, for tests of the mapping above.
pub fn world_from_camera(heading_deg: f64, tilt_x_deg: f64, tilt_y_deg: f64) -> DMat3 {
    let (s, c) = heading_deg.to_radians().sin_cos();
    let level = DMat3::from_cols((-c, s, 0.0).into(), (-s, -c, 0.0).into(), (0.0, 0.0, 1.0).into());
    level * DMat3::from_rotation_x(tilt_x_deg.to_radians()) * DMat3::from_rotation_y(tilt_y_deg.to_radians())
}

/// `camera_from_body`: the body's x, y, z in camera coordinates.
pub fn camera_from_body() -> DMat3 {
    DMat3::from_cols((0.0, -1.0, 0.0).into(), (1.0, 0.0, 0.0).into(), (0.0, 0.0, 1.0).into())
}

/// The tilt (tilt_x, tilt_y), degrees, of a `world_from_body` unit quaternion.
pub fn tilt_from_enu(q: [f64; 4]) -> (f64, f64) {
    let (_, pitch, roll) = DQuat::from_xyzw(q[0], q[1], q[2], q[3]).to_euler(EulerRot::ZYX);
    (pitch.to_degrees(), -roll.to_degrees())
}

/// The ENU yaw (counter-clockwise from East), degrees in (−180°, 180°], of a
/// `world_from_body` unit quaternion.
pub fn yaw_deg(q: [f64; 4]) -> f64 {
    let (yaw, _, _) = DQuat::from_xyzw(q[0], q[1], q[2], q[3]).to_euler(EulerRot::ZYX);
    yaw.to_degrees()
}

/// One heading as an Imu message: orientation per REP 103 (above); the covariance
/// (rad², about the body's x, y, z) holds the roll and pitch variances given and
/// the yaw variance `sigma_deg²`; angular velocity and linear acceleration are not
/// provided (REP 145: covariance element 0 = −1).
pub fn heading_imu(
    header: Header,
    heading_deg: f64,
    sigma_deg: f64,
    tilt_x_deg: f64,
    tilt_y_deg: f64,
    roll_var_rad2: f64,
    pitch_var_rad2: f64,
) -> Imu {
    let [x, y, z, w] = enu_quaternion(heading_deg, tilt_x_deg, tilt_y_deg);
    let mut cov = [0.0; 9];
    cov[0] = roll_var_rad2;
    cov[4] = pitch_var_rad2;
    cov[8] = sigma_deg.to_radians().powi(2);
    let mut not_provided = [0.0; 9];
    not_provided[0] = -1.0;
    Imu {
        header,
        orientation: Quaternion { x, y, z, w },
        orientation_covariance: cov,
        angular_velocity_covariance: not_provided,
        linear_acceleration_covariance: not_provided,
        ..Default::default()
    }
}

/// A frame without a heading: one status, level WARN (1), named `bpins heading`,
/// with the reason and the key–values given.
pub fn no_heading(header: Header, hardware_id: &str, reason: &str, values: &[(&str, String)]) -> DiagnosticArray {
    DiagnosticArray {
        header,
        status: vec![DiagnosticStatus {
            level: 1,
            name: "bpins heading".into(),
            message: reason.into(),
            hardware_id: hardware_id.into(),
            values: values.iter().map(|(k, v)| KeyValue { key: (*k).into(), value: v.clone() }).collect(),
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quat_mat(q: [f64; 4]) -> DMat3 {
        DMat3::from_quat(DQuat::from_xyzw(q[0], q[1], q[2], q[3]))
    }

    #[test]
    fn the_quaternion_is_the_conventions_camera_in_rep103_axes() {
        for (h, tx, ty) in [(0.0, 0.0, 0.0), (30.0, 0.0, 0.0), (200.0, 5.0, -3.0), (-45.0, -10.0, 20.0)] {
            let want = world_from_camera(h, tx, ty) * camera_from_body();
            let got = quat_mat(enu_quaternion(h, tx, ty));
            assert!(got.abs_diff_eq(want, 1e-12), "heading {h}, tilt ({tx}, {ty}): {got} vs {want}");
            let (bx, by) = tilt_from_enu(enu_quaternion(h, tx, ty));
            assert!((bx - tx).abs() < 1e-9 && (by - ty).abs() < 1e-9);
        }
    }

    /// REP 103's sign: a camera whose image top points East (heading 90°) has yaw 0;
    /// heading 30° (North-North-East) has yaw +60° (counter-clockwise from East),
    /// not −60° (which `heading − 90°` would give).
    #[test]
    fn yaw_is_ninety_minus_heading_counter_clockwise_from_east() {
        assert!(yaw_deg(enu_quaternion(90.0, 0.0, 0.0)).abs() < 1e-12);
        assert!((yaw_deg(enu_quaternion(30.0, 0.0, 0.0)) - 60.0).abs() < 1e-12);
        assert!((yaw_deg(enu_quaternion(180.0, 0.0, 0.0)) + 90.0).abs() < 1e-12);
        // The body's x axis (the image top) in ENU points along the heading's azimuth.
        let x = quat_mat(enu_quaternion(30.0, 0.0, 0.0)).x_axis;
        assert!((x.x - 30f64.to_radians().sin()).abs() < 1e-12 && (x.y - 30f64.to_radians().cos()).abs() < 1e-12);
        // Pitch up about the body's y (left) axis is a positive camera tilt about x.
        let (_, pitch, roll) = DQuat::from_slice(&enu_quaternion(0.0, 4.0, 0.0)).to_euler(EulerRot::ZYX);
        assert!((pitch.to_degrees() - 4.0).abs() < 1e-12 && roll.abs() < 1e-12);
        let (_, pitch, roll) = DQuat::from_slice(&enu_quaternion(0.0, 0.0, 4.0)).to_euler(EulerRot::ZYX);
        assert!((roll.to_degrees() + 4.0).abs() < 1e-12 && pitch.abs() < 1e-12);
    }

    #[test]
    fn covariances_follow_rep145() {
        let m = heading_imu(Header::default(), 10.0, 0.5, 0.0, 0.0, 1e-4, 2e-4);
        let c = m.orientation_covariance;
        assert_eq!((c[0], c[4], c[1], c[3]), (1e-4, 2e-4, 0.0, 0.0));
        assert!((c[8] - 0.5f64.to_radians().powi(2)).abs() < 1e-18);
        assert_eq!((m.angular_velocity_covariance[0], m.linear_acceleration_covariance[0]), (-1.0, -1.0));
    }
}
