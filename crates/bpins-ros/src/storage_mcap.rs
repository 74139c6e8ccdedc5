//! MCAP storage: each file memory-mapped (read-only) and walked record by record in
//! place. A message of an uncompressed chunk (or outside any chunk) is handed on as a
//! slice of the map: no copy, whatever its size. A zstd chunk is decompressed as it is
//! walked, by `mcap`'s sans-I/O [`mcap::sans_io::LinearReader`] fed the chunk's bytes
//! from the map (its CRC checked; no record longer than the chunk says it holds is
//! allocated for), one message at a time; lz4 chunks are refused by name (the feature
//! is not built). At most one message (and, for a zstd chunk, the decoder's window of
//! it) is held in memory, whatever the file's length.
//!
//! A [`Stream`] walks the files once for a set of topics, handing on each message with
//! the slot of its topic in that set: one walk (each zstd chunk decompressed once)
//! serves every topic a run reads.
//!
//! The walk: the file's magic, then records `opcode u8, length u64 LE, body`
//! (MCAP specification, "Records"); each body parsed by [`mcap::parse_record`], which
//! borrows. Chunk records hold records of the same framing. The data section ends at
//! the footer, which the file's closing magic follows: a file that ends before them is
//! reported truncated (after the messages before the cut).

use crate::error::{BagError, Fault, Where};
use mcap::records::Record;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::McapError;
use std::borrow::Cow;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Maps `path` read-only.
pub(crate) fn map(at: &Where, path: PathBuf) -> Result<(PathBuf, memmap2::Mmap), BagError> {
    let io = |what: &str| {
        let path = path.clone();
        let message = what.to_string();
        move |source: std::io::Error| BagError::Io { at: at.clone(), path, message, source }
    };
    let f = std::fs::File::open(&path).map_err(io("cannot be opened"))?;
    // SAFETY: the map is read-only and private to this process; a file changed by
    // another process while it is read would give wrong bytes (checked by the MCAP
    // records' lengths and CRCs, and by CDR decoding), not undefined behaviour in
    // the safe code that reads it, which never trusts a length without bounds checks.
    let m = unsafe { memmap2::Mmap::map(&f) }.map_err(io("cannot be memory-mapped"))?;
    // A hint (the walk is forward): read ahead more. Failing to advise changes nothing.
    #[cfg(unix)]
    let _ = m.advise(memmap2::Advice::Sequential);
    Ok((path, m))
}

/// The chunk being walked.
enum Chunk<'a> {
    /// Uncompressed: its records, read in place, and the offset of the next.
    Plain { records: &'a [u8], pos: usize },
    /// zstd: decompressed by `mcap` as it is walked; `input` is what is left of the
    /// chunk record's bytes (opcode, length and body) to feed it.
    Compressed { reader: Box<LinearReader>, input: &'a [u8] },
}

/// The messages of a set of topics across the bag's MCAP files, in storage order, in
/// one walk.
pub(crate) struct Stream<'a> {
    files: &'a [(PathBuf, memmap2::Mmap)],
    /// The topics read; a message is handed on with its topic's slot here.
    topics: Vec<String>,
    file: usize,
    /// Offset of the next top-level record in the current file; `None` before its magic.
    pos: Option<usize>,
    chunk: Option<Chunk<'a>>,
    /// Channel id → the slot of its topic, `None` for a topic not read; its encoding
    /// checked when it is read.
    wanted: HashMap<u16, Option<usize>>,
    /// Compressed chunks entered, counted for the bag ([`crate::Bag::chunks_decompressed`]).
    decompressed: &'a AtomicU64,
}

/// The record at `*pos` of `buf`: (opcode, body), `pos` moved past it; `None` at the
/// end of `buf`; an error if its header or body runs past the end.
fn record<'a>(buf: &'a [u8], pos: &mut usize) -> Result<Option<(u8, &'a [u8])>, String> {
    let rest = &buf[*pos..];
    if rest.is_empty() {
        return Ok(None);
    }
    if rest.len() < 9 {
        return Err(format!("a record header at byte {} is cut short ({} bytes left)", *pos, rest.len()));
    }
    let len = u64::from_le_bytes(rest[1..9].try_into().expect("8 bytes"));
    if len > (rest.len() - 9) as u64 {
        return Err(format!(
            "a record (opcode {:#04x}) of {len} bytes at byte {} runs past the end ({} bytes left)",
            rest[0],
            *pos,
            rest.len() - 9
        ));
    }
    let body = &rest[9..9 + len as usize];
    *pos += 9 + len as usize;
    Ok(Some((rest[0], body)))
}

/// A message of a topic read: (its topic's slot, log time ns, its bytes).
pub(crate) type Found<'a> = (usize, i64, Cow<'a, [u8]>);

/// What one record means for the stream.
enum Step<'a> {
    Message(usize, i64, Cow<'a, [u8]>),
    Chunk(Chunk<'a>),
    Footer,
    Other,
}

/// A failure of `mcap` on the file `path` while reading `what`, its meaning said by
/// the error's kind (the error itself is kept as the source).
fn mcap_fault(path: &Path, what: String, e: McapError) -> Fault {
    let meaning = match &e {
        McapError::UnsupportedCompression(name) => format!(
            "a chunk compressed with `{name}` (bpins reads uncompressed and zstd MCAP chunks; `mcap convert` or \
             `ros2 bag convert` the bag to one of them)"
        ),
        _ => "the file is truncated or damaged".to_string(),
    };
    Fault::Mcap { path: path.to_path_buf(), message: format!("{what}: {meaning}"), source: e }
}

impl<'a> Stream<'a> {
    pub(crate) fn new(files: &'a [(PathBuf, memmap2::Mmap)], topics: &[&str], decompressed: &'a AtomicU64) -> Self {
        Stream {
            files,
            topics: topics.iter().map(|t| t.to_string()).collect(),
            file: 0,
            pos: None,
            chunk: None,
            wanted: HashMap::new(),
            decompressed,
        }
    }

    /// Reads one parsed record: channels are noted, messages of the topics returned.
    /// `whole` is the record's bytes with its opcode and length (top-level records).
    fn step(&mut self, record: Record<'a>, whole: Option<&'a [u8]>) -> Result<Step<'a>, String> {
        let in_chunk = whole.is_none();
        match record {
            Record::Channel(ch) => {
                let slot = self.topics.iter().position(|t| *t == ch.topic);
                if slot.is_some() && ch.message_encoding != "cdr" {
                    return Err(format!("message encoding `{}`: only `cdr` (ROS 2's) is read", ch.message_encoding));
                }
                self.wanted.insert(ch.id, slot);
                Ok(Step::Other)
            }
            Record::Message { header, data } => match self.wanted.get(&header.channel_id) {
                None => Err(format!("a message on channel {}, which no channel record declares", header.channel_id)),
                Some(None) => Ok(Step::Other),
                Some(&Some(slot)) => Ok(Step::Message(slot, i64::try_from(header.log_time).unwrap_or(i64::MAX), data)),
            },
            Record::Chunk { header, data } if !in_chunk => match (header.compression.as_str(), data) {
                ("", Cow::Borrowed(records)) => {
                    if header.uncompressed_size != records.len() as u64 {
                        return Err(format!(
                            "an uncompressed chunk of {} bytes that says it holds {} (the file is damaged)",
                            records.len(),
                            header.uncompressed_size
                        ));
                    }
                    Ok(Step::Chunk(Chunk::Plain { records, pos: 0 }))
                }
                (_, Cow::Borrowed(_)) => {
                    let whole = whole.unwrap_or_default();
                    // A record inside the chunk is at most the chunk's uncompressed
                    // size: a longer one (a damaged length) is refused before anything is
                    // allocated for it. A chunk of more than 4 GiB is damaged (CDR
                    // sequences have u32 lengths; rosbag2 chunks are far smaller).
                    if header.uncompressed_size > 1 << 32 {
                        return Err(format!(
                            "a {} chunk that says it holds {} bytes uncompressed (the file is damaged)",
                            header.compression, header.uncompressed_size
                        ));
                    }
                    let limit = whole.len().max(header.uncompressed_size as usize);
                    let options = LinearReaderOptions::default()
                        .with_skip_start_magic(true)
                        .with_skip_end_magic(true)
                        .with_validate_chunk_crcs(true)
                        .with_record_length_limit(limit);
                    let reader = Box::new(LinearReader::new_with_options(options));
                    self.decompressed.fetch_add(1, Ordering::Relaxed);
                    Ok(Step::Chunk(Chunk::Compressed { reader, input: whole }))
                }
                // parse_record borrows its body: never owned here.
                (_, Cow::Owned(_)) => Err("a chunk copied out of the map".into()),
            },
            Record::Chunk { .. } => Err("a chunk inside a chunk (the file is damaged)".into()),
            Record::Footer(_) if !in_chunk => Ok(Step::Footer),
            _ => Ok(Step::Other),
        }
    }

    /// The next message of the topics: (slot, log time ns, bytes), `None` at the end.
    /// The bytes are borrowed from the map unless they come out of a compressed
    /// chunk. After an error the stream is not used again.
    pub(crate) fn next(&mut self) -> Result<Option<Found<'a>>, Fault> {
        loop {
            let Some((path, map)) = self.files.get(self.file) else { return Ok(None) };
            let here = |e: String| Fault::Damaged(format!("{}: {e}", path.display()));
            let buf: &'a [u8] = &map[..];
            // Inside a chunk: its next record.
            if let Some(chunk) = self.chunk.as_mut() {
                let rec = match chunk {
                    Chunk::Plain { records, pos } => {
                        let (records, at): (&'a [u8], usize) = (records, *pos);
                        match record(records, pos)
                            .map_err(|e| here(format!("{e} of its chunk (the file is damaged)")))?
                        {
                            None => None,
                            Some((opcode, body)) => Some(
                                mcap::parse_record(opcode, body)
                                    .map_err(|e| mcap_fault(path, format!("record at byte {at} of a chunk"), e))?,
                            ),
                        }
                    }
                    Chunk::Compressed { reader, input } => {
                        // mcap 0.26 can panic on a damaged chunk (an integer underflow
                        // when a record claims more bytes than its chunk holds; found by
                        // tests/fuzz_bags.rs): a damaged bag, reported as an error.
                        let next =
                            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| next_in_chunk(reader, input)));
                        match next {
                            Err(_) => return Err(here("a record overruns its chunk (the file is damaged)".into())),
                            Ok(r) => r.map_err(|e| mcap_fault(path, "in a compressed chunk".into(), e))?,
                        }
                    }
                };
                match rec {
                    None => self.chunk = None,
                    Some(r) => {
                        if let Step::Message(slot, t, data) = self.step(r, None).map_err(here)? {
                            return Ok(Some((slot, t, data)));
                        }
                    }
                }
                continue;
            }
            // The file's next top-level record.
            let pos = match self.pos {
                Some(p) => p,
                None => {
                    if !buf.starts_with(mcap::MAGIC) {
                        return Err(here("does not start with MCAP's magic bytes (not an MCAP file)".into()));
                    }
                    mcap::MAGIC.len()
                }
            };
            let mut next_pos = pos;
            let Some((opcode, body)) =
                record(buf, &mut next_pos).map_err(|e| here(format!("{e} (the file is truncated or damaged)")))?
            else {
                return Err(here("the file ends before its footer (it is truncated)".into()));
            };
            self.pos = Some(next_pos);
            let parsed =
                mcap::parse_record(opcode, body).map_err(|e| mcap_fault(path, format!("record at byte {pos}"), e))?;
            match self.step(parsed, Some(&buf[pos..next_pos])).map_err(here)? {
                Step::Message(slot, t, data) => return Ok(Some((slot, t, data))),
                Step::Chunk(c) => self.chunk = Some(c),
                Step::Footer => {
                    if !buf[next_pos..].starts_with(mcap::MAGIC) {
                        return Err(here(
                            "the footer is not followed by MCAP's magic bytes (the file is damaged)".into(),
                        ));
                    }
                    self.file += 1;
                    self.pos = None;
                    self.wanted.clear();
                }
                Step::Other => {}
            }
        }
    }
}

/// The next record of a compressed chunk, decompressed: `reader` is fed the chunk
/// record's bytes from `input` as it asks for them, and told the input ended when they
/// are spent (the end of the chunk, or an error if the chunk is not complete there).
fn next_in_chunk(reader: &mut LinearReader, input: &mut &[u8]) -> mcap::McapResult<Option<Record<'static>>> {
    loop {
        match reader.next_event() {
            None => return Ok(None),
            Some(Err(e)) => return Err(e),
            Some(Ok(LinearReadEvent::Record { data, opcode })) => {
                return mcap::parse_record(opcode, data).map(|r| Some(r.into_owned()))
            }
            Some(Ok(LinearReadEvent::ReadRequest(n))) => {
                let k = n.min(input.len());
                reader.insert(k).copy_from_slice(&input[..k]);
                reader.notify_read(k);
                *input = &input[k..];
            }
        }
    }
}
