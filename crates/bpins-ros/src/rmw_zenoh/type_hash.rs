//! RIHS01 type hashes (REP 2011; rosidl_generator_type_description): the SHA-256 of
//! a message's type description (its fields, and those of every type it nests,
//! sorted by name; constants and default values left out) written as JSON with
//! `", "` and `": "` separators, in hex after `RIHS01_`. rmw_zenoh puts the hash in
//! every key and token, so a subscriber of another hash never hears a publisher:
//! the hashes must be ROS's own, byte for byte. Computed here from the definitions
//! in [`crate::msgs::definition`], pinned by tests against published values.

use crate::msgs::definition;
use sha2::{Digest, Sha256};

/// `type_description_interfaces/FieldType`'s id of a primitive type; `None` for a
/// nested message type.
fn primitive_id(t: &str) -> Option<u8> {
    Some(match t {
        "int8" => 2,
        "uint8" => 3,
        "int16" => 4,
        "uint16" => 5,
        "int32" => 6,
        "uint32" => 7,
        "int64" => 8,
        "uint64" => 9,
        "float32" => 10,
        "float64" => 11,
        "char" => 13,
        "bool" => 15,
        "byte" => 16,
        "string" => 17,
        "wstring" => 18,
        _ => return None,
    })
}

/// `pkg/Name` or `pkg/msg/Name` → `pkg/msg/Name`.
fn full_name(t: &str) -> String {
    match t.split('/').collect::<Vec<_>>().as_slice() {
        [pkg, name] => format!("{pkg}/msg/{name}"),
        _ => t.to_string(),
    }
}

/// One type's description as JSON: `{"type_name": …, "fields": [{"name": …, "type":
/// {"type_id": …, "capacity": …, "string_capacity": 0, "nested_type_name": …}}, …]}`,
/// and the nested types it names. Handles what bpins' messages use: primitives,
/// nested types, fixed arrays `T[N]` and unbounded sequences `T[]`.
fn describe(type_name: &str, body: &str) -> Result<(String, Vec<String>), String> {
    let mut fields = Vec::new();
    let mut nested = Vec::new();
    for line in body.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        let mut parts = line.split_whitespace();
        let (Some(ty), Some(name)) = (parts.next(), parts.next()) else { continue };
        if name.contains('=') || parts.next() == Some("=") {
            continue; // a constant
        }
        let (base, suffix) = match ty.find('[') {
            Some(i) => (&ty[..i], &ty[i..]),
            None => (ty, ""),
        };
        let (offset, capacity) = match suffix {
            "" => (0, 0),
            "[]" => (144, 0),
            s => match s.trim_start_matches('[').trim_end_matches(']').parse::<u64>() {
                Ok(n) => (48, n),
                Err(_) => return Err(format!("{type_name}: field {name}: {ty} is not supported")),
            },
        };
        let (id, nested_name) = match primitive_id(base) {
            Some(id) => (id, String::new()),
            None => {
                let n = full_name(base);
                nested.push(n.clone());
                (1, n)
            }
        };
        fields.push(format!(
            "{{\"name\": \"{name}\", \"type\": {{\"type_id\": {}, \"capacity\": {capacity}, \"string_capacity\": 0, \
             \"nested_type_name\": \"{nested_name}\"}}}}",
            u32::from(id) + offset
        ));
    }
    Ok((format!("{{\"type_name\": \"{type_name}\", \"fields\": [{}]}}", fields.join(", ")), nested))
}

/// The RIHS01 hash of a type given as a `ros2msg` text (the type's own fields, then
/// each nested type after a `MSG: pkg/Name` line, as MCAP schemas hold them).
pub fn hash_of_definition(type_name: &str, text: &str) -> Result<String, String> {
    let mut sections = text.split("\nMSG: ");
    let main = sections.next().unwrap_or("");
    let (own, _) = describe(type_name, main)?;
    let mut refs: Vec<(String, String)> = Vec::new();
    for s in sections {
        let (name, body) = s.split_once('\n').unwrap_or((s, ""));
        let name = full_name(name.trim());
        let body = body.trim_end_matches(|c| c == '=' || c == '\n');
        let (desc, _) = describe(&name, body)?;
        refs.push((name, desc));
    }
    refs.sort_by(|a, b| a.0.cmp(&b.0));
    refs.dedup_by(|a, b| a.0 == b.0);
    let refs: Vec<String> = refs.into_iter().map(|r| r.1).collect();
    let json = format!("{{\"type_description\": {own}, \"referenced_type_descriptions\": [{}]}}", refs.join(", "));
    let digest = Sha256::digest(json.as_bytes());
    Ok(format!("RIHS01_{}", digest.iter().map(|b| format!("{b:02x}")).collect::<String>()))
}

/// The RIHS01 hash of one of the types bpins reads and writes ([`crate::msgs::types`]).
pub fn type_hash(type_name: &str) -> Option<String> {
    hash_of_definition(type_name, &definition(type_name)?).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::types;

    #[test]
    fn hashes_are_ros_own() {
        // Published hashes: std_msgs/String in rmw_zenoh's design.md; Imu and Image
        // as rmw_zenoh nodes put them in their keys (ROS 2 Jazzy and later; these
        // messages have not changed since).
        assert_eq!(
            hash_of_definition("std_msgs/msg/String", "string data").unwrap(),
            "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
        assert_eq!(
            type_hash(types::IMU).unwrap(),
            "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b"
        );
        assert_eq!(
            type_hash(types::IMAGE).unwrap(),
            "RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47"
        );
        // The rest as zenoh-ros2-sdk (PyPI, an independent implementation) computes
        // them from common_interfaces' .msg files (tests/data/ros2_msgs; tests/ros_node.rs
        // checks the node's tokens against the SDK's hashes live).
        for (t, h) in [
            (types::CAMERA_INFO, "RIHS01_b3dfd68ff46c9d56c80fd3bd4ed22c7a4ddce8c8348f2f59c299e73118e7e275"),
            (types::NAV_SAT_FIX, "RIHS01_62223ab3fe210a15976021da7afddc9e200dc9ec75231c1b6a557fc598a65404"),
            (types::DIAGNOSTIC_ARRAY, "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e"),
        ] {
            assert_eq!(type_hash(t).unwrap(), h, "{t}");
        }
        assert!(type_hash("foo_msgs/msg/Bar").is_none());
    }
}
