//! MCAP storage: each file memory-mapped (read-only) and streamed record by record
//! with `mcap`'s [`mcap::read::RawMessageStream`]: at most one decompressed chunk and
//! one message in memory, whatever the file's length. Chunks may be uncompressed or
//! zstd; lz4 chunks are refused by name (the feature is not built).

use crate::error::{BagError, Where};
use mcap::read::RawMessageStream;
use std::collections::HashMap;
use std::path::PathBuf;

/// Maps `path` read-only.
pub(crate) fn map(at: &Where, path: PathBuf) -> Result<(PathBuf, memmap2::Mmap), BagError> {
    let io = |e: std::io::Error| BagError::Io { at: at.clone(), message: format!("{}: {e}", path.display()) };
    let f = std::fs::File::open(&path).map_err(io)?;
    // SAFETY: the map is read-only and private to this process; a file changed by
    // another process while it is read would give wrong bytes (checked by the MCAP
    // records' lengths and CRCs, and by CDR decoding), not undefined behaviour in
    // the safe code that reads it, which never trusts a length without bounds checks.
    let m = unsafe { memmap2::Mmap::map(&f) }.map_err(io)?;
    Ok((path, m))
}

/// One topic's messages across the bag's MCAP files.
pub(crate) struct Cursor<'a> {
    files: &'a [(PathBuf, memmap2::Mmap)],
    file: usize,
    stream: Option<RawMessageStream<'a>>,
    /// Channel id → whether it is the topic, its encoding checked.
    wanted: HashMap<u16, bool>,
}

impl<'a> Cursor<'a> {
    pub(crate) fn new(files: &'a [(PathBuf, memmap2::Mmap)], _topic: &str) -> Self {
        Cursor { files, file: 0, stream: None, wanted: HashMap::new() }
    }

    /// The next message of `topic`: (log time ns, bytes), `None` at the end.
    pub(crate) fn next(&mut self, topic: &str) -> Result<Option<(i64, Vec<u8>)>, String> {
        loop {
            if self.stream.is_none() {
                let Some((path, map)) = self.files.get(self.file) else { return Ok(None) };
                let s = RawMessageStream::new(&map[..]).map_err(|e| format!("{}: {}", path.display(), words(&e)))?;
                self.stream = Some(s);
                self.wanted.clear();
            }
            let path = &self.files[self.file].0;
            let stream = self.stream.as_mut().expect("opened above");
            // mcap 0.26 can panic on a damaged file (an integer underflow when a
            // record claims more bytes than its uncompressed chunk holds; found by
            // tests/fuzz_bags.rs): that is a damaged bag, reported as an error, and the
            // stream is not used again.
            let next = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| stream.next())) {
                Ok(n) => n,
                Err(_) => {
                    self.stream = None;
                    self.file = self.files.len();
                    return Err(format!("{}: a record overruns its chunk (the file is damaged)", path.display()));
                }
            };
            match next {
                None => {
                    self.stream = None;
                    self.file += 1;
                }
                Some(Err(e)) => return Err(format!("{}: {}", path.display(), words(&e))),
                Some(Ok(m)) => {
                    let id = m.header.channel_id;
                    let want = match self.wanted.get(&id) {
                        Some(&w) => w,
                        None => {
                            let Some(ch) = stream.get_channel(id) else {
                                return Err(format!(
                                    "{}: a message on channel {id}, which no channel record declares",
                                    path.display()
                                ));
                            };
                            let w = ch.topic == topic;
                            if w && ch.message_encoding != "cdr" {
                                return Err(format!(
                                    "{}: message encoding `{}`: only `cdr` (ROS 2's) is read",
                                    path.display(),
                                    ch.message_encoding
                                ));
                            }
                            self.wanted.insert(id, w);
                            w
                        }
                    };
                    if want {
                        let t = i64::try_from(m.header.log_time).unwrap_or(i64::MAX);
                        return Ok(Some((t, m.data.into_owned())));
                    }
                }
            }
        }
    }
}

/// An MCAP error in words a user can act on.
fn words(e: &mcap::McapError) -> String {
    let s = e.to_string();
    if s.contains("lz4") || s.contains("Lz4") || s.contains("compression") {
        format!("{s} (bpins reads uncompressed and zstd MCAP chunks; `mcap convert` or `ros2 bag convert` an lz4 bag)")
    } else if s.contains("EOF") || s.contains("eof") || s.contains("end of") || s.contains("Unexpected") {
        format!("{s} (the file is truncated or damaged)")
    } else {
        s
    }
}
