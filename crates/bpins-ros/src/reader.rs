//! Opening a rosbag2 folder and reading one topic's messages in storage order.
//!
//! [`Bag::open`] reads `metadata.yaml` and opens the storage files it lists (MCAP
//! files are memory-mapped, read-only; sqlite3 files opened immutable, read-only).
//! [`Bag::cursor`] walks one topic: several cursors over one bag walk forward
//! independently, which is how images are matched with the IMU and GNSS samples
//! around their stamps without holding either stream in memory.

use crate::error::{BagError, Where};
use crate::metadata::Metadata;
use crate::{storage_mcap, storage_sqlite};
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// One topic of a bag, as `metadata.yaml` lists it.
#[derive(Clone, Debug, PartialEq)]
pub struct TopicInfo {
    pub name: String,
    /// `sensor_msgs/msg/Image`, …
    pub type_name: String,
    pub message_count: u64,
}

/// One serialized message of a topic: its bytes borrowed from the bag's memory map
/// where they lie there whole (MCAP, outside compressed chunks), else its own.
#[derive(Clone, Debug, PartialEq)]
pub struct BagMessage<'a> {
    /// 0-based index on its topic, in storage order.
    pub index: u64,
    /// When the recorder received it, ns since the Unix epoch.
    pub log_time_ns: i64,
    /// The CDR bytes (with their encapsulation header).
    pub data: Cow<'a, [u8]>,
}

pub(crate) enum Storage {
    Mcap(Vec<(PathBuf, memmap2::Mmap)>),
    Sqlite(Vec<PathBuf>),
}

/// An open rosbag2 folder.
pub struct Bag {
    pub dir: PathBuf,
    pub metadata: Metadata,
    pub topics: Vec<TopicInfo>,
    pub(crate) storage: Storage,
}

impl Bag {
    /// Opens the rosbag2 folder `dir` (or the folder of its `metadata.yaml`).
    pub fn open(dir: &Path) -> Result<Bag, BagError> {
        let dir = if dir.file_name().is_some_and(|n| n == "metadata.yaml") && dir.is_file() {
            dir.parent().unwrap_or(Path::new(".")).to_path_buf()
        } else {
            dir.to_path_buf()
        };
        let at = Where { bag: dir.clone(), ..Default::default() };
        let yaml = dir.join("metadata.yaml");
        let text = std::fs::read_to_string(&yaml).map_err(|e| BagError::Io {
            at: at.clone(),
            message: format!(
                "{}: {e} (a rosbag2 bag is a folder holding metadata.yaml and its .mcap or .db3 files)",
                yaml.display()
            ),
        })?;
        let metadata = Metadata::parse(&text).map_err(|message| BagError::Metadata { at: at.clone(), message })?;
        let meta_err = |message: String| BagError::Metadata { at: at.clone(), message };
        if !metadata.compression_mode.is_empty() && !metadata.compression_mode.eq_ignore_ascii_case("none") {
            return Err(meta_err(format!(
                "compression_mode `{}` ({}): bag-level compression is not read; `ros2 bag convert` it to an \
                 uncompressed bag (MCAP chunk compression is read)",
                metadata.compression_mode, metadata.compression_format
            )));
        }
        let topics: Vec<TopicInfo> = metadata
            .topics_with_message_count
            .iter()
            .map(|t| TopicInfo {
                name: t.topic_metadata.name.clone(),
                type_name: t.topic_metadata.type_name.clone(),
                message_count: t.message_count,
            })
            .collect();
        for t in &metadata.topics_with_message_count {
            if t.topic_metadata.serialization_format != "cdr" {
                return Err(BagError::Topic {
                    at: Where { topic: Some(t.topic_metadata.name.clone()), ..at.clone() },
                    message: format!(
                        "serialization format `{}`: only `cdr` (every ROS 2 middleware's) is read",
                        t.topic_metadata.serialization_format
                    ),
                });
            }
        }
        if metadata.relative_file_paths.is_empty() {
            return Err(meta_err("relative_file_paths is empty: the bag has no storage file".into()));
        }
        let files: Vec<PathBuf> = metadata
            .relative_file_paths
            .iter()
            .map(|f| dir.join(Path::new(f).file_name().unwrap_or_default()))
            .collect();
        let storage = match metadata.storage_identifier.as_str() {
            "mcap" => Storage::Mcap(files.into_iter().map(|p| storage_mcap::map(&at, p)).collect::<Result<_, _>>()?),
            "sqlite3" => {
                for p in &files {
                    if !p.is_file() {
                        return Err(BagError::Io { at: at.clone(), message: format!("{}: no such file", p.display()) });
                    }
                }
                Storage::Sqlite(files)
            }
            other => {
                return Err(meta_err(format!("storage_identifier `{other}`: bpins reads `mcap` and `sqlite3` bags")))
            }
        };
        Ok(Bag { dir, metadata, topics, storage })
    }

    /// The topic named `name`, checked to be of type `type_name`.
    pub fn topic(&self, name: &str, type_name: &str) -> Result<&TopicInfo, BagError> {
        let at = self.at(Some(name), None);
        match self.topics.iter().find(|t| t.name == name) {
            None => Err(BagError::Topic { at, message: format!("no such topic; the bag has: {}", self.topic_list()) }),
            Some(t) if t.type_name != type_name => {
                Err(BagError::Topic { at, message: format!("is of type {}, not {type_name}", t.type_name) })
            }
            Some(t) => Ok(t),
        }
    }

    /// The one topic of type `type_name`: `None` if there is none, an error naming
    /// them if there are several (choose one by its flag).
    pub fn only_topic_of_type(&self, type_name: &str) -> Result<Option<&TopicInfo>, BagError> {
        let all: Vec<&TopicInfo> = self.topics.iter().filter(|t| t.type_name == type_name).collect();
        match all.as_slice() {
            [] => Ok(None),
            [one] => Ok(Some(one)),
            many => Err(BagError::Topic {
                at: self.at(None, None),
                message: format!(
                    "{} topics of type {type_name} ({}): name the one to read",
                    many.len(),
                    many.iter().map(|t| t.name.as_str()).collect::<Vec<_>>().join(", ")
                ),
            }),
        }
    }

    /// Every topic, `name (type)`, comma-separated.
    pub fn topic_list(&self) -> String {
        self.topics.iter().map(|t| format!("{} ({})", t.name, t.type_name)).collect::<Vec<_>>().join(", ")
    }

    /// A cursor over the messages of `topic` in storage order.
    pub fn cursor(&self, topic: &str) -> Result<TopicCursor<'_>, BagError> {
        let inner = match &self.storage {
            Storage::Mcap(files) => Inner::Mcap(Box::new(storage_mcap::Cursor::new(files, topic))),
            Storage::Sqlite(files) => Inner::Sqlite(storage_sqlite::Cursor::new(files, topic)),
        };
        Ok(TopicCursor { bag: self, topic: topic.to_string(), next_index: 0, inner, done: false })
    }

    pub(crate) fn at(&self, topic: Option<&str>, index: Option<u64>) -> Where {
        Where { bag: self.dir.clone(), topic: topic.map(str::to_string), index }
    }
}

enum Inner<'a> {
    Mcap(Box<storage_mcap::Cursor<'a>>),
    Sqlite(storage_sqlite::Cursor),
}

/// The messages of one topic, one at a time, in storage order.
pub struct TopicCursor<'a> {
    bag: &'a Bag,
    topic: String,
    next_index: u64,
    inner: Inner<'a>,
    done: bool,
}

impl TopicCursor<'_> {
    /// The topic this cursor walks.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Where the message `index` of this topic lies, for errors.
    pub fn at(&self, index: u64) -> Where {
        self.bag.at(Some(&self.topic), Some(index))
    }
}

impl<'a> Iterator for TopicCursor<'a> {
    type Item = Result<BagMessage<'a>, BagError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = match &mut self.inner {
            Inner::Mcap(c) => c.next(&self.topic),
            Inner::Sqlite(c) => c.next(&self.topic).map(|m| m.map(|(t, data)| (t, Cow::Owned(data)))),
        };
        let index = self.next_index;
        match r {
            Ok(Some((log_time_ns, data))) => {
                self.next_index += 1;
                Some(Ok(BagMessage { index, log_time_ns, data }))
            }
            Ok(None) => {
                self.done = true;
                None
            }
            Err(message) => {
                self.done = true;
                Some(Err(BagError::Storage { at: self.at(index), message }))
            }
        }
    }
}
