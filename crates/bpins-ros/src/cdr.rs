//! ROS 2's serialized messages: a 4-byte encapsulation header (representation id
//! `CDR_BE` 0x0000 or `CDR_LE` 0x0001, then 2 option bytes) and the message in
//! CDR (XCDR1, alignment counted from after the header), through `cdr-encoding`.
//! Both byte orders are read; messages are written little-endian (what every ROS 2
//! middleware on x86 and ARM writes).

use byteorder::{BigEndian, LittleEndian};
use serde::{Deserialize, Serialize};

/// Decodes one serialized ROS 2 message; the error says what is wrong in words.
pub fn decode<'de, T: Deserialize<'de>>(bytes: &'de [u8]) -> Result<T, String> {
    if bytes.len() < 4 {
        return Err(format!("{} bytes: shorter than the 4-byte CDR encapsulation header", bytes.len()));
    }
    let body = &bytes[4..];
    let r = match (bytes[0], bytes[1]) {
        (0, 0) => cdr_encoding::from_bytes::<T, BigEndian>(body),
        (0, 1) => cdr_encoding::from_bytes::<T, LittleEndian>(body),
        (a, b) => {
            return Err(format!(
                "encapsulation {a:#04x}{b:02x} is not plain CDR (0x0000 big-endian, 0x0001 little-endian)"
            ))
        }
    };
    r.map(|(v, _)| v).map_err(|e| format!("does not decode as CDR: {e}"))
}

/// Serializes one ROS 2 message, little-endian CDR with its encapsulation header.
pub fn encode<T: Serialize>(msg: &T) -> Vec<u8> {
    let mut out = vec![0u8, 1, 0, 0];
    // Writing into a Vec cannot fail, and our message types hold only what CDR has
    // (numbers, strings, sequences and fixed arrays).
    cdr_encoding::to_writer::<T, LittleEndian, _>(&mut out, msg).expect("CDR into a Vec");
    out
}
