//! The attachment rmw_zenoh puts on every published sample (design.md, "Publishers"):
//! the publisher's sequence number (i64, from 1), the source timestamp (i64, ns since
//! the Unix epoch) and the publisher's GID (16 bytes), serialized as zenoh-ext does:
//! little-endian integers, the GID as a sequence (its length as a LEB128 varint: one
//! byte, 16, then the bytes). Subscribers use it to tell publishers apart and to
//! count lost samples.

/// The GID's length, bytes (rmw_zenoh's `RMW_GID_STORAGE_SIZE`).
pub const GID_LEN: usize = 16;

/// One sample's attachment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Attachment {
    pub sequence_number: i64,
    pub source_timestamp_ns: i64,
    pub gid: [u8; GID_LEN],
}

impl Attachment {
    /// 8 + 8 + 1 + 16 = 33 bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(17 + GID_LEN);
        out.extend(self.sequence_number.to_le_bytes());
        out.extend(self.source_timestamp_ns.to_le_bytes());
        out.push(GID_LEN as u8);
        out.extend(self.gid);
        out
    }

    /// Reads an attachment; the error says what is wrong (too short, a GID that is
    /// not 16 bytes).
    pub fn from_bytes(b: &[u8]) -> Result<Attachment, String> {
        if b.len() < 17 {
            return Err(format!("attachment of {} bytes: shorter than 17", b.len()));
        }
        let n = b[16] as usize;
        if n != GID_LEN || b.len() != 17 + n {
            return Err(format!("attachment of {} bytes with a {n}-byte GID: not a 16-byte GID", b.len()));
        }
        let i64_at = |i: usize| i64::from_le_bytes(b[i..i + 8].try_into().expect("8 bytes"));
        let mut gid = [0u8; GID_LEN];
        gid.copy_from_slice(&b[17..]);
        Ok(Attachment { sequence_number: i64_at(0), source_timestamp_ns: i64_at(8), gid })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attachment_is_33_bytes_little_endian_and_round_trips() {
        let a = Attachment { sequence_number: 3, source_timestamp_ns: 0x0102_0304_0506_0708, gid: [7; 16] };
        let b = a.to_bytes();
        assert_eq!(b.len(), 33);
        assert_eq!(&b[..9], &[3, 0, 0, 0, 0, 0, 0, 0, 8]);
        assert_eq!((b[16], b[17], b[32]), (16, 7, 7));
        assert_eq!(Attachment::from_bytes(&b).unwrap(), a);
        assert!(Attachment::from_bytes(&b[..20]).unwrap_err().contains("16-byte GID"));
        assert!(Attachment::from_bytes(&b[..10]).unwrap_err().contains("shorter than 17"));
    }
}
