//! The ROS 2 messages bpins reads and writes, field for field in their `.msg` order
//! (CDR has no field names: the order and the types are the format), and their
//! `ros2msg` definitions for the schemas of the MCAP files bpins writes.
//!
//! Definitions: `sensor_msgs`, `std_msgs`, `geometry_msgs`, `builtin_interfaces` and
//! `diagnostic_msgs` of ROS 2 (Humble to Jazzy: these messages have not changed).

use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// `builtin_interfaces/Time`: seconds and nanoseconds since the Unix epoch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

impl Time {
    /// Nanoseconds since the epoch.
    pub fn ns(&self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)
    }

    /// From nanoseconds since the epoch (floor division: a negative stamp keeps
    /// `nanosec` in [0, 1e9)).
    pub fn from_ns(ns: i64) -> Time {
        Time { sec: ns.div_euclid(1_000_000_000) as i32, nanosec: ns.rem_euclid(1_000_000_000) as u32 }
    }

    /// Seconds since the epoch.
    pub fn seconds(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

/// `sensor_msgs/Image`: `data` borrowed from the message bytes when read.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Image<'a> {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub encoding: String,
    pub is_bigendian: u8,
    /// Row length in bytes (≥ width × bytes per pixel).
    pub step: u32,
    #[serde(borrow, with = "serde_bytes")]
    pub data: Cow<'a, [u8]>,
}

/// `sensor_msgs/RegionOfInterest`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionOfInterest {
    pub x_offset: u32,
    pub y_offset: u32,
    pub height: u32,
    pub width: u32,
    pub do_rectify: bool,
}

/// `sensor_msgs/CameraInfo`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraInfo {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub distortion_model: String,
    pub d: Vec<f64>,
    pub k: [f64; 9],
    pub r: [f64; 9],
    pub p: [f64; 12],
    pub binning_x: u32,
    pub binning_y: u32,
    pub roi: RegionOfInterest,
}

/// `geometry_msgs/Quaternion`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

/// `geometry_msgs/Vector3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// `sensor_msgs/Imu`. Covariances row-major about x, y, z; element 0 = −1 means
/// "not provided" (REP 145), all zeros "unknown".
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Imu {
    pub header: Header,
    pub orientation: Quaternion,
    pub orientation_covariance: [f64; 9],
    pub angular_velocity: Vector3,
    pub angular_velocity_covariance: [f64; 9],
    pub linear_acceleration: Vector3,
    pub linear_acceleration_covariance: [f64; 9],
}

/// `sensor_msgs/NavSatStatus`: `status` −1 no fix, 0 fix, 1 SBAS, 2 GBAS.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavSatStatus {
    pub status: i8,
    pub service: u16,
}

/// `sensor_msgs/NavSatFix`: WGS 84 degrees, metres.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavSatFix {
    pub header: Header,
    pub status: NavSatStatus,
    pub latitude: f64,
    pub longitude: f64,
    pub altitude: f64,
    pub position_covariance: [f64; 9],
    pub position_covariance_type: u8,
}

/// `diagnostic_msgs/KeyValue`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct KeyValue {
    pub key: String,
    pub value: String,
}

/// `diagnostic_msgs/DiagnosticStatus`: `level` 0 OK, 1 WARN, 2 ERROR, 3 STALE.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    pub level: u8,
    pub name: String,
    pub message: String,
    pub hardware_id: String,
    pub values: Vec<KeyValue>,
}

/// `diagnostic_msgs/DiagnosticArray`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    pub header: Header,
    pub status: Vec<DiagnosticStatus>,
}

/// The type names bpins reads and writes, as rosbag2 spells them.
pub mod types {
    pub const IMAGE: &str = "sensor_msgs/msg/Image";
    pub const CAMERA_INFO: &str = "sensor_msgs/msg/CameraInfo";
    pub const IMU: &str = "sensor_msgs/msg/Imu";
    pub const NAV_SAT_FIX: &str = "sensor_msgs/msg/NavSatFix";
    pub const DIAGNOSTIC_ARRAY: &str = "diagnostic_msgs/msg/DiagnosticArray";
}

const SEP: &str = "\n================================================================================\nMSG: ";
const TIME: &str = "builtin_interfaces/Time\nint32 sec\nuint32 nanosec";
const HEADER: &str = "std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id";

/// The `ros2msg` schema text of `type_name` (one of [`types`]), its dependencies
/// appended as ROS 2's MCAP writer does; `None` for another type.
pub fn definition(type_name: &str) -> Option<String> {
    let (main, deps): (&str, &[&str]) = match type_name {
        types::IMU => (
            "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n\
             geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n\
             geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance",
            &[
                HEADER,
                TIME,
                "geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
                "geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z",
            ],
        ),
        types::DIAGNOSTIC_ARRAY => (
            "std_msgs/Header header\ndiagnostic_msgs/DiagnosticStatus[] status",
            &[
                HEADER,
                TIME,
                "diagnostic_msgs/DiagnosticStatus\nbyte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\n\
                 string name\nstring message\nstring hardware_id\ndiagnostic_msgs/KeyValue[] values",
                "diagnostic_msgs/KeyValue\nstring key\nstring value",
            ],
        ),
        types::IMAGE => (
            "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data",
            &[HEADER, TIME],
        ),
        types::CAMERA_INFO => (
            "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\n\
             float64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nsensor_msgs/RegionOfInterest roi",
            &[
                HEADER,
                TIME,
                "sensor_msgs/RegionOfInterest\nuint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify",
            ],
        ),
        types::NAV_SAT_FIX => (
            "uint8 COVARIANCE_TYPE_UNKNOWN=0\nuint8 COVARIANCE_TYPE_APPROXIMATED=1\nuint8 COVARIANCE_TYPE_DIAGONAL_KNOWN=2\n\
             uint8 COVARIANCE_TYPE_KNOWN=3\nstd_msgs/Header header\nsensor_msgs/NavSatStatus status\nfloat64 latitude\n\
             float64 longitude\nfloat64 altitude\nfloat64[9] position_covariance\nuint8 position_covariance_type",
            &[
                HEADER,
                TIME,
                "sensor_msgs/NavSatStatus\nint8 STATUS_NO_FIX=-1\nint8 STATUS_FIX=0\nint8 STATUS_SBAS_FIX=1\n\
                 int8 STATUS_GBAS_FIX=2\nuint16 SERVICE_GPS=1\nuint16 SERVICE_GLONASS=2\nuint16 SERVICE_COMPASS=4\n\
                 uint16 SERVICE_GALILEO=8\nint8 status\nuint16 service",
            ],
        ),
        _ => return None,
    };
    let mut s = main.to_string();
    for d in deps {
        s.push_str(SEP);
        s.push_str(d);
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cdr::{decode, encode};

    #[test]
    fn messages_round_trip_through_cdr_and_both_byte_orders_decode() {
        let imu = Imu {
            header: Header { stamp: Time { sec: 1_782_009_000, nanosec: 5 }, frame_id: "cam".into() },
            orientation: Quaternion { x: 0.1, y: 0.2, z: 0.3, w: 0.9 },
            orientation_covariance: [1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0],
            angular_velocity_covariance: [-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            ..Default::default()
        };
        let bytes = encode(&imu);
        // Encapsulation (4) + stamp (8) + frame_id (4 + "cam\0", ending 8-aligned) + 4 + 9 + 3 + 9 + 3 + 9 doubles.
        assert_eq!(bytes.len(), 4 + 8 + 4 + 4 + 8 * 37);
        assert_eq!(decode::<Imu>(&bytes).unwrap(), imu);
        // The same Image, little- and big-endian by hand: sizes, string, byte sequence.
        let mut le = vec![0u8, 1, 0, 0];
        let mut be = vec![0u8, 0, 0, 0];
        for (out, big) in [(&mut le, false), (&mut be, true)] {
            let u32b = |x: u32| if big { x.to_be_bytes() } else { x.to_le_bytes() };
            out.extend(u32b(7)); // sec
            out.extend(u32b(9)); // nanosec
            out.extend(u32b(2));
            out.extend(b"c\0\0\0"); // frame_id "c" + pad
            out.extend(u32b(2)); // height
            out.extend(u32b(3)); // width
            out.extend(u32b(6));
            out.extend(b"mono8\0");
            out.push(0); // is_bigendian
            out.push(0); // pad to 4
            out.extend(u32b(3)); // step
            out.extend(u32b(6));
            out.extend([1, 2, 3, 4, 5, 6]);
        }
        for bytes in [&le, &be] {
            let im: Image = decode(bytes).unwrap();
            assert_eq!((im.header.stamp, im.height, im.width, im.step), (Time { sec: 7, nanosec: 9 }, 2, 3, 3));
            assert_eq!((im.encoding.as_str(), &im.data[..]), ("mono8", &[1u8, 2, 3, 4, 5, 6][..]));
        }
        assert_eq!(encode(&decode::<Image>(&le).unwrap()), le);
        // Cut short, a bad header: errors, not panics.
        assert!(decode::<Image>(&le[..le.len() - 1]).is_err());
        assert!(decode::<Image>(&le[..3]).unwrap_err().contains("shorter than"));
        assert!(decode::<Image>(&[0, 7, 0, 0, 1]).unwrap_err().contains("not plain CDR"));
    }

    #[test]
    fn stamps_convert_both_ways() {
        for ns in [0i64, 1, 1_782_009_000_123_456_789, -1] {
            assert_eq!(Time::from_ns(ns).ns(), ns);
        }
        assert_eq!(Time::from_ns(-1), Time { sec: -1, nanosec: 999_999_999 });
    }

    #[test]
    fn definitions_name_their_dependencies() {
        let d = definition(types::IMU).unwrap();
        assert!(d.starts_with("std_msgs/Header header\n") && d.contains("MSG: geometry_msgs/Quaternion\n"), "{d}");
        assert!(definition("foo_msgs/msg/Bar").is_none());
    }
}
