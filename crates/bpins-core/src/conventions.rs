//! Frames, angles and pixel conventions of `docs/spec/CONVENTIONS.md`, in one place.
//!
//! | frame  | axes                                                         |
//! |--------|--------------------------------------------------------------|
//! | world  | ENU: x East, y North, z Up (right-handed)                     |
//! | camera | x image columns (right), y image rows (down), z optical axis  |
//!
//! * Azimuth: degrees from North toward East; elevation above the horizon.
//!   A direction is `(sin A cos h, cos A cos h, sin h)` in ENU.
//! * Level camera at heading ψ: the optical axis is the zenith and the image top
//!   (camera −y) points to azimuth ψ; `world_from_camera` has columns
//!   `x_c = (−cos ψ, sin ψ, 0)`, `y_c = (−sin ψ, −cos ψ, 0)`, `z_c = (0, 0, 1)`.
//!   At ψ = 0 the image shows North up and East **left** (a sky chart seen from below).
//! * Tilt: `world_from_camera = R_level(ψ) · Rx(tilt_x) · Ry(tilt_y)`.
//! * Pixel centres at integer `(u, v)` = (column, row); image centre `((W−1)/2, (H−1)/2)`.
//! * In-image angles (analyzer θ, AoP α, radial angle β) run from image +x toward
//!   image −y: counter-clockwise as displayed. α is reported in (−90°, 90°].
//! * AoE `φ = α − β`, `β = atan2(−(v − c_y), u − c_x)`, wrapped to (−90°, 90°].
//!
//! Every other module takes its angles and frames from here; tests at the bottom pin
//! them, and `tests/samples.rs` pins them against the independent sample captures.

use glam::{DMat3, DVec3};

/// Wraps an angle in degrees to (−180°, 180°]: heading errors, azimuth differences.
pub fn wrap_deg_180(a_deg: f64) -> f64 {
    let r = a_deg.rem_euclid(360.0); // [0, 360)
    if r > 180.0 {
        r - 360.0
    } else {
        r
    }
}

/// Wraps an axial angle (period 180°) in degrees to (−90°, 90°]: AoP, AoE.
pub fn wrap_deg_90(a_deg: f64) -> f64 {
    let r = a_deg.rem_euclid(180.0); // [0, 180)
    if r > 90.0 {
        r - 180.0
    } else {
        r
    }
}

/// Wraps an axial angle (period π) in radians to (−π/2, π/2]: an AoP or AoE
/// difference, as [`wrap_deg_90`] in degrees.
pub fn wrap_rad_90(a_rad: f64) -> f64 {
    let r = a_rad.rem_euclid(std::f64::consts::PI); // [0, π)
    if r > std::f64::consts::FRAC_PI_2 {
        r - std::f64::consts::PI
    } else {
        r
    }
}

/// Wraps an azimuth in degrees to [0°, 360°), the form used in files.
pub fn wrap_deg_360(a_deg: f64) -> f64 {
    let r = a_deg.rem_euclid(360.0);
    if r >= 360.0 {
        0.0
    } else {
        r
    }
}

/// ENU unit vector of a direction at azimuth `az_deg` (from North toward East) and
/// elevation `el_deg` (above the horizon).
pub fn enu_from_az_el_deg(az_deg: f64, el_deg: f64) -> DVec3 {
    let (sa, ca) = az_deg.to_radians().sin_cos();
    let (sh, ch) = el_deg.to_radians().sin_cos();
    DVec3::new(sa * ch, ca * ch, sh)
}

/// Azimuth in [0°, 360°) and elevation in degrees of an ENU direction (any length).
pub fn az_el_deg_from_enu(v: DVec3) -> (f64, f64) {
    let v = v.normalize();
    let az = wrap_deg_360(v.x.atan2(v.y).to_degrees());
    let el = v.z.clamp(-1.0, 1.0).asin().to_degrees();
    (az, el)
}

/// Rotation taking level-camera coordinates to ENU for heading ψ (`heading_deg`).
pub fn world_from_level_camera(heading_deg: f64) -> DMat3 {
    let (s, c) = heading_deg.to_radians().sin_cos();
    DMat3::from_cols(DVec3::new(-c, s, 0.0), DVec3::new(-s, -c, 0.0), DVec3::new(0.0, 0.0, 1.0))
}

/// `Rx(tilt_x) · Ry(tilt_y)`: the camera's tilt about its own x then y axis,
/// right-handed; it takes camera coordinates to level-camera coordinates.
pub fn level_from_camera(tilt_x_deg: f64, tilt_y_deg: f64) -> DMat3 {
    DMat3::from_rotation_x(tilt_x_deg.to_radians()) * DMat3::from_rotation_y(tilt_y_deg.to_radians())
}

/// `world_from_camera = R_level(ψ) · Rx(tilt_x) · Ry(tilt_y)`.
pub fn world_from_camera(heading_deg: f64, tilt_x_deg: f64, tilt_y_deg: f64) -> DMat3 {
    world_from_level_camera(heading_deg) * level_from_camera(tilt_x_deg, tilt_y_deg)
}

/// Heading ψ (degrees, [0, 360)) of a level camera that sees the sun at
/// level-camera direction `sun_level` while the sun stands at azimuth `sun_az_deg`.
///
/// From the columns above: `s_level = (cos h·sin(ψ − A), −cos h·cos(ψ − A), sin h)`.
pub fn heading_deg_from_level_sun(sun_level: DVec3, sun_az_deg: f64) -> f64 {
    wrap_deg_360(sun_az_deg + sun_level.x.atan2(-sun_level.y).to_degrees())
}

/// Image angle (radians) of the pixel-plane direction `(du_px, dv_px)`:
/// from image +x toward image −y, counter-clockwise as displayed.
pub fn image_angle_rad(du_px: f64, dv_px: f64) -> f64 {
    (-dv_px).atan2(du_px)
}

/// The seed paper's 1-based (row, column) principal point in this convention's
/// 0-based (x, y) = (column, row): (512.5, 612.5) → (611.5, 511.5).
pub fn xy_from_paper_row_col(row_1based: f64, col_1based: f64) -> (f64, f64) {
    (col_1based - 1.0, row_1based - 1.0)
}

/// Image centre `((W−1)/2, (H−1)/2)` in pixels: the default principal point.
pub fn image_centre_px(width_px: u32, height_px: u32) -> (f64, f64) {
    ((width_px as f64 - 1.0) * 0.5, (height_px as f64 - 1.0) * 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).length() < 1e-12
    }

    #[test]
    fn wraps_to_half_open_ranges() {
        assert_eq!(wrap_deg_180(180.0), 180.0);
        assert_eq!(wrap_deg_180(-180.0), 180.0);
        assert_eq!(wrap_deg_180(190.0), -170.0);
        assert_eq!(wrap_deg_90(90.0), 90.0);
        assert_eq!(wrap_deg_90(-90.0), 90.0);
        assert_eq!(wrap_deg_90(100.0), -80.0);
        assert_eq!(wrap_deg_360(-10.0), 350.0);
        assert_eq!(wrap_deg_360(360.0), 0.0);
    }

    #[test]
    fn level_camera_at_heading_zero_shows_north_up_east_left() {
        let r = world_from_camera(0.0, 0.0, 0.0);
        // Image top is camera −y: North.
        assert!(close(r * DVec3::new(0.0, -1.0, 0.0), DVec3::new(0.0, 1.0, 0.0)));
        // Image left is camera −x: East.
        assert!(close(r * DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0)));
        // Optical axis: zenith.
        assert!(close(r * DVec3::Z, DVec3::Z));
        assert!((r.determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn image_top_points_to_heading() {
        for psi in [0.0, 37.0, 90.0, 200.0, 315.0] {
            let top = world_from_camera(psi, 0.0, 0.0) * DVec3::new(0.0, -1.0, 0.0);
            let (az, el) = az_el_deg_from_enu(top);
            assert!(wrap_deg_180(az - psi).abs() < 1e-9, "ψ={psi}: {az}");
            assert!(el.abs() < 1e-9);
        }
    }

    #[test]
    fn heading_from_sun_inverts_the_level_frame() {
        for psi in [0.0, 10.0, 135.0, 271.0] {
            for a in [10.0, 80.0, 300.0] {
                let s_w = enu_from_az_el_deg(a, 5.0);
                let s_level = world_from_level_camera(psi).transpose() * s_w;
                let got = heading_deg_from_level_sun(s_level, a);
                assert!(wrap_deg_180(got - psi).abs() < 1e-9, "{psi} {a} {got}");
            }
        }
    }

    #[test]
    fn tilt_is_about_camera_x_then_y() {
        // A pure tilt about camera x by +90° turns the optical axis (z) onto −y
        // (right-handed rotation about x takes z to −y).
        let r = level_from_camera(90.0, 0.0);
        assert!(close(r * DVec3::Z, DVec3::new(0.0, -1.0, 0.0)));
        let r = level_from_camera(0.0, 90.0);
        assert!(close(r * DVec3::Z, DVec3::new(1.0, 0.0, 0.0)));
    }

    #[test]
    fn paper_principal_point_is_the_image_centre() {
        assert_eq!(xy_from_paper_row_col(512.5, 612.5), (611.5, 511.5));
        assert_eq!(image_centre_px(1224, 1024), (611.5, 511.5));
    }

    #[test]
    fn image_angles_are_counter_clockwise_as_displayed() {
        assert_eq!(image_angle_rad(1.0, 0.0), 0.0);
        assert!((image_angle_rad(0.0, -1.0) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    }
}
