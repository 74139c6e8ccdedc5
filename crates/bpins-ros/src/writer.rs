//! A new rosbag2 folder with MCAP storage: `NAME_0.mcap` (schemas `ros2msg`,
//! messages `cdr`, profile `ros2`, uncompressed chunks, or zstd chunks as rosbag2's
//! MCAP plugin writes by default: [`BagWriter::create_with`]) and `metadata.yaml`
//! (version 9), written last. The folder must not exist yet: bpins never writes
//! into an existing bag.

use crate::error::{BagError, Failure, Where};
use crate::metadata::{Duration, FileInfo, Metadata, StartingTime, TopicWithCount};
use crate::msgs;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// An MCAP bag being written, message by message.
pub struct BagWriter {
    dir: PathBuf,
    file_name: String,
    mcap: Option<mcap::Writer<BufWriter<File>>>,
    /// Topic → (channel id, type, count), in the order first written.
    channels: Vec<(String, u16, String, u64)>,
    schemas: BTreeMap<String, u16>,
    first_ns: Option<i64>,
    last_ns: i64,
}

/// How the MCAP file's messages are grouped into chunks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Chunks {
    /// zstd-compress each chunk (else stored uncompressed).
    pub zstd: bool,
    /// A chunk is closed once it holds this many bytes (a larger message is one chunk).
    pub size_bytes: u64,
}

impl Default for Chunks {
    /// Uncompressed chunks of `mcap`'s default size (1 MiB).
    fn default() -> Self {
        Chunks { zstd: false, size_bytes: mcap::WriteOptions::DEFAULT_CHUNK_SIZE }
    }
}

impl BagWriter {
    /// Creates the folder `dir` (which must not exist) and its MCAP file, with
    /// uncompressed chunks.
    pub fn create(dir: &Path) -> Result<BagWriter, BagError> {
        Self::create_with(dir, Chunks::default())
    }

    /// Creates the folder `dir` (which must not exist) and its MCAP file, with chunks
    /// as `chunks` says.
    pub fn create_with(dir: &Path, chunks: Chunks) -> Result<BagWriter, BagError> {
        let at = Where { bag: dir.to_path_buf(), ..Default::default() };
        if dir.exists() {
            let message = "already exists: bpins writes a new bag folder, never into an existing one".into();
            return Err(BagError::Write { at, message });
        }
        std::fs::create_dir_all(dir).map_err(io_error(&at, dir, "the folder cannot be created"))?;
        let stem = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "bag".into());
        let file_name = format!("{stem}_0.mcap");
        let path = dir.join(&file_name);
        let f = File::create(&path).map_err(io_error(&at, &path, "cannot be created"))?;
        let mcap = mcap::WriteOptions::new()
            .compression(chunks.zstd.then_some(mcap::Compression::Zstd))
            .chunk_size(Some(chunks.size_bytes))
            .profile("ros2")
            .library("bpins")
            .create(BufWriter::new(f))
            .map_err(mcap_error(&at, &path, "its header cannot be written"))?;
        Ok(BagWriter {
            dir: dir.to_path_buf(),
            file_name,
            mcap: Some(mcap),
            channels: Vec::new(),
            schemas: BTreeMap::new(),
            first_ns: None,
            last_ns: 0,
        })
    }

    fn at(&self, topic: &str) -> Where {
        Where { bag: self.dir.clone(), topic: Some(topic.into()), index: None }
    }

    fn fail(&self, topic: &str, message: String) -> BagError {
        BagError::Write { at: self.at(topic), message }
    }

    /// `mcap`'s failure writing `what` of `topic`.
    fn mcap_fail(&self, topic: &str, what: &str) -> impl FnOnce(mcap::McapError) -> BagError {
        mcap_error(&self.at(topic), &self.dir.join(&self.file_name), what)
    }

    /// Writes one serialized message of `type_name` (one of [`msgs::types`]) on
    /// `topic`, received at `time_ns` (ns since the epoch).
    pub fn write(&mut self, topic: &str, type_name: &str, time_ns: i64, cdr: &[u8]) -> Result<(), BagError> {
        let Some(w) = self.mcap.as_mut() else { return Err(self.fail(topic, "the bag is already finished".into())) };
        let chan = match self.channels.iter_mut().position(|c| c.0 == topic) {
            Some(i) => {
                if self.channels[i].2 != type_name {
                    let had = self.channels[i].2.clone();
                    return Err(self.fail(topic, format!("{type_name} on a topic of type {had}")));
                }
                i
            }
            None => {
                let schema = match self.schemas.get(type_name) {
                    Some(&s) => s,
                    None => {
                        let Some(def) = msgs::definition(type_name) else {
                            return Err(self.fail(topic, format!("no definition of {type_name}")));
                        };
                        let s = w.add_schema(type_name, "ros2msg", def.as_bytes());
                        let s = s.map_err(self.mcap_fail(topic, "its schema cannot be written"))?;
                        self.schemas.insert(type_name.into(), s);
                        s
                    }
                };
                let w = self.mcap.as_mut().expect("checked above");
                let id = w.add_channel(schema, topic, "cdr", &BTreeMap::new());
                let id = id.map_err(self.mcap_fail(topic, "its channel cannot be written"))?;
                self.channels.push((topic.into(), id, type_name.into(), 0));
                self.channels.len() - 1
            }
        };
        let (_, id, _, count) = &mut self.channels[chan];
        let t = u64::try_from(time_ns).unwrap_or(0);
        let header =
            mcap::records::MessageHeader { channel_id: *id, sequence: *count as u32, log_time: t, publish_time: t };
        *count += 1;
        self.first_ns = Some(self.first_ns.map_or(time_ns, |f| f.min(time_ns)));
        self.last_ns = self.last_ns.max(time_ns);
        let w = self.mcap.as_mut().expect("checked above");
        let r = w.write_to_known_channel(&header, cdr);
        r.map_err(self.mcap_fail(topic, "a message cannot be written"))
    }

    /// Finishes the MCAP file and writes `metadata.yaml`.
    pub fn finish(mut self) -> Result<PathBuf, BagError> {
        let at = Where { bag: self.dir.clone(), ..Default::default() };
        let path = self.dir.join(&self.file_name);
        if let Some(mut w) = self.mcap.take() {
            w.finish().map_err(mcap_error(&at, &path, "its summary cannot be written"))?;
            use std::io::Write;
            w.into_inner().flush().map_err(io_error(&at, &path, "cannot be written"))?;
        }
        let start = self.first_ns.unwrap_or(0);
        let duration = Duration { nanoseconds: (self.last_ns - start).max(0) as u64 };
        let count: u64 = self.channels.iter().map(|c| c.3).sum();
        let topics: Vec<TopicWithCount> = self.channels.iter().map(|c| Metadata::topic(&c.0, &c.2, c.3)).collect();
        let m = Metadata {
            version: 9,
            storage_identifier: "mcap".into(),
            relative_file_paths: vec![self.file_name.clone()],
            duration,
            starting_time: StartingTime { nanoseconds_since_epoch: start },
            message_count: count,
            topics_with_message_count: topics,
            compression_format: String::new(),
            compression_mode: String::new(),
            files: vec![FileInfo {
                path: self.file_name.clone(),
                starting_time: StartingTime { nanoseconds_since_epoch: start },
                duration,
                message_count: count,
            }],
            ros_distro: Some("bpins".into()),
        };
        let yaml = self.dir.join("metadata.yaml");
        std::fs::write(&yaml, m.to_yaml()).map_err(io_error(&at, &yaml, "cannot be written"))?;
        Ok(self.dir.clone())
    }
}

/// The file system's failure on `path` while doing `what`, as the source.
fn io_error(at: &Where, path: &Path, what: &str) -> impl FnOnce(std::io::Error) -> BagError {
    let (at, path, message) = (at.clone(), path.to_path_buf(), what.to_string());
    move |source| BagError::Io { at, path, message, source }
}

/// `mcap`'s failure on `path` while doing `what`, as the source.
fn mcap_error(at: &Where, path: &Path, what: &str) -> impl FnOnce(mcap::McapError) -> BagError {
    let (at, path, message) = (at.clone(), path.to_path_buf(), what.to_string());
    move |source| BagError::Mcap(Box::new(Failure { at, path, message, source }))
}
