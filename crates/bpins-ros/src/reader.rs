//! Opening a rosbag2 folder and reading its topics' messages in storage order.
//!
//! [`Bag::open`] reads `metadata.yaml` and opens the storage files it lists (MCAP
//! files are memory-mapped, read-only; sqlite3 files opened immutable, read-only).
//! [`Bag::cursors`] gives a cursor per topic, all served by one walk of the storage
//! (each zstd chunk decompressed once, each sqlite3 row visited once): the cursors
//! walk forward independently, which is how images are matched with the IMU and GNSS
//! samples around their stamps without holding either stream in memory. A message
//! met before its cursor asks for it waits in that cursor's queue; the queues hold at
//! most [`READ_AHEAD_BYTES`], beyond which the cursor reading ahead leaves the shared
//! walk for one of its own (so memory stays bounded whatever the topics' timing).
//! [`Bag::cursor`] walks one topic by itself; [`Bag::messages`] is the one walk over a
//! set of topics, message by message.

use crate::error::{BagError, Fault, Where};
use crate::metadata::Metadata;
use crate::{storage_mcap, storage_sqlite};
use std::borrow::Cow;
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// The most bytes of messages that cursors sharing one walk ([`Bag::cursors`]) hold
/// for one another (a message's owned bytes and 64 bytes for its place in the queue;
/// a message borrowed from an MCAP file's map costs only the latter).
pub const READ_AHEAD_BYTES: usize = 256 << 20;

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
    /// Compressed MCAP chunks decompressed so far, by every reader of this bag.
    decompressed: AtomicU64,
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
        let text = std::fs::read_to_string(&yaml).map_err(|source| BagError::Io {
            at: at.clone(),
            path: yaml.clone(),
            message: "cannot be read (a rosbag2 bag is a folder holding metadata.yaml and its .mcap or .db3 files)"
                .into(),
            source,
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
                    // Missing or unreadable: the OS says which (SQLite, opening it
                    // read-only later, would only say it cannot open it).
                    let file = std::fs::metadata(p).and_then(|m| {
                        if m.is_file() {
                            Ok(())
                        } else {
                            Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a regular file"))
                        }
                    });
                    file.and_then(|()| std::fs::File::open(p).map(drop)).map_err(|source| BagError::Io {
                        at: at.clone(),
                        path: p.clone(),
                        message: "cannot be opened (a storage file metadata.yaml lists)".into(),
                        source,
                    })?;
                }
                Storage::Sqlite(files)
            }
            other => {
                return Err(meta_err(format!("storage_identifier `{other}`: bpins reads `mcap` and `sqlite3` bags")))
            }
        };
        Ok(Bag { dir, metadata, topics, storage, decompressed: AtomicU64::new(0) })
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

    /// A cursor over the messages of `topic` in storage order, walking the storage
    /// by itself (for several topics read together, [`Bag::cursors`]).
    pub fn cursor(&self, topic: &str) -> Result<TopicCursor<'_>, BagError> {
        let inner = Inner::Own(Own { stream: self.stream(&[topic]), start: 0, next_index: 0 });
        Ok(TopicCursor { bag: self, topic: topic.to_string(), inner, done: false })
    }

    /// A cursor over each of `topics` (in their order), all served by one walk of the
    /// storage: what a run that reads several topics in step uses. A topic named twice
    /// gets a second cursor of its own. Dropping a cursor drops what waits for it, and
    /// the walk passes over its topic from then on.
    pub fn cursors(&self, topics: &[&str]) -> Result<Vec<TopicCursor<'_>>, BagError> {
        self.cursors_with(topics, READ_AHEAD_BYTES)
    }

    /// [`Bag::cursors`] with queues of at most `read_ahead_bytes`.
    pub(crate) fn cursors_with(
        &self,
        topics: &[&str],
        read_ahead_bytes: usize,
    ) -> Result<Vec<TopicCursor<'_>>, BagError> {
        let mut unique: Vec<&str> = Vec::new();
        for t in topics {
            if !unique.contains(t) {
                unique.push(t);
            }
        }
        let n = unique.len();
        let demux = Arc::new(Mutex::new(Demux {
            bag: self,
            topics: unique.iter().map(|t| t.to_string()).collect(),
            shared: Some(self.stream(&unique)),
            failed: false,
            queues: (0..n).map(|_| VecDeque::new()).collect(),
            met: vec![0; n],
            held: 0,
            budget: read_ahead_bytes,
            own: (0..n).map(|_| None).collect(),
            closed: vec![false; n],
        }));
        let mut given = vec![false; n];
        let mut out = Vec::with_capacity(topics.len());
        for t in topics {
            let slot = unique.iter().position(|u| u == t).expect("listed above");
            if std::mem::replace(&mut given[slot], true) {
                out.push(self.cursor(t)?);
            } else {
                let inner = Inner::Shared(Arc::clone(&demux), slot);
                out.push(TopicCursor { bag: self, topic: t.to_string(), inner, done: false });
            }
        }
        Ok(out)
    }

    /// The messages of `topics` in storage order, in one walk of the storage: each
    /// with the position of its topic in `topics` (a topic named twice is read at its
    /// first position).
    pub fn messages(&self, topics: &[&str]) -> Messages<'_> {
        Messages { bag: self, stream: self.stream(topics), met: vec![0; topics.len()], done: false }
    }

    /// Compressed MCAP chunks decompressed so far by every reader of this bag: each
    /// chunk once per walk (a measure of how many walks the reads took).
    pub fn chunks_decompressed(&self) -> u64 {
        self.decompressed.load(Ordering::Relaxed)
    }

    /// A walk of the storage over `topics`.
    fn stream(&self, topics: &[&str]) -> Stream<'_> {
        match &self.storage {
            Storage::Mcap(files) => {
                Stream::Mcap(Box::new(storage_mcap::Stream::new(files, topics, &self.decompressed)))
            }
            Storage::Sqlite(files) => Stream::Sqlite(Box::new(storage_sqlite::Stream::new(files, topics))),
        }
    }

    pub(crate) fn at(&self, topic: Option<&str>, index: Option<u64>) -> Where {
        Where { bag: self.dir.clone(), topic: topic.map(str::to_string), index }
    }
}

/// One walk of a bag's storage over a set of topics.
enum Stream<'a> {
    Mcap(Box<storage_mcap::Stream<'a>>),
    Sqlite(Box<storage_sqlite::Stream>),
}

impl<'a> Stream<'a> {
    /// The next message: (its topic's slot, log time ns, bytes), `None` at the end.
    fn next(&mut self) -> Result<Option<storage_mcap::Found<'a>>, Fault> {
        match self {
            Stream::Mcap(s) => s.next(),
            Stream::Sqlite(s) => Ok(s.next()?.map(|(slot, t, data)| (slot, t, Cow::Owned(data)))),
        }
    }
}

/// The messages of a set of topics in storage order, in one walk ([`Bag::messages`]):
/// each with the position of its topic in the set.
pub struct Messages<'a> {
    bag: &'a Bag,
    stream: Stream<'a>,
    /// Messages met so far on each topic: the next one's index.
    met: Vec<u64>,
    done: bool,
}

impl<'a> Iterator for Messages<'a> {
    type Item = Result<(usize, BagMessage<'a>), BagError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        match self.stream.next() {
            Ok(Some((slot, log_time_ns, data))) => {
                let index = self.met[slot];
                self.met[slot] += 1;
                Some(Ok((slot, BagMessage { index, log_time_ns, data })))
            }
            Ok(None) => {
                self.done = true;
                None
            }
            Err(f) => {
                // A walk of several topics: the damage is not on one of them.
                self.done = true;
                Some(Err(f.at(self.bag.at(None, None))))
            }
        }
    }
}

/// One topic walked by itself: from the start of the storage, its messages before
/// `start` passed over (they were handed on by a shared walk it left).
struct Own<'a> {
    stream: Stream<'a>,
    start: u64,
    next_index: u64,
}

impl<'a> Own<'a> {
    fn next(&mut self, bag: &Bag, topic: &str) -> Option<Result<BagMessage<'a>, BagError>> {
        loop {
            match self.stream.next() {
                Ok(None) => return None,
                Err(f) => return Some(Err(f.at(bag.at(Some(topic), Some(self.next_index))))),
                Ok(Some((_, log_time_ns, data))) => {
                    let index = self.next_index;
                    self.next_index += 1;
                    if index >= self.start {
                        return Some(Ok(BagMessage { index, log_time_ns, data }));
                    }
                }
            }
        }
    }
}

/// One walk shared by the cursors of several topics: a message met while another
/// topic's cursor reads waits in its topic's queue.
struct Demux<'a> {
    bag: &'a Bag,
    topics: Vec<String>,
    /// The shared walk; `None` once it ended or failed.
    shared: Option<Stream<'a>>,
    failed: bool,
    queues: Vec<VecDeque<BagMessage<'a>>>,
    /// Messages of each topic the shared walk has met: the next one's index.
    met: Vec<u64>,
    /// Bytes held in the queues (see [`READ_AHEAD_BYTES`]), and their limit.
    held: usize,
    budget: usize,
    /// A topic's own walk, once it left the shared one.
    own: Vec<Option<Own<'a>>>,
    /// Topics whose cursor was dropped: their messages are passed over.
    closed: Vec<bool>,
}

/// What a queued message counts against [`READ_AHEAD_BYTES`].
fn held_bytes(m: &BagMessage<'_>) -> usize {
    64 + match &m.data {
        Cow::Borrowed(_) => 0,
        Cow::Owned(v) => v.len(),
    }
}

impl<'a> Demux<'a> {
    /// The next message of the topic in `slot`.
    fn next_for(&mut self, slot: usize) -> Option<Result<BagMessage<'a>, BagError>> {
        if let Some(m) = self.queues[slot].pop_front() {
            self.held -= held_bytes(&m);
            return Some(Ok(m));
        }
        loop {
            if let Some(own) = self.own[slot].as_mut() {
                return own.next(self.bag, &self.topics[slot]);
            }
            let Some(stream) = self.shared.as_mut() else {
                if !self.failed {
                    return None;
                }
                // The walk failed while another topic read: this one reads on by
                // itself, to the damage (an error of its own, of its own type) or to
                // its end, as a cursor of its own would have.
                self.leave(slot);
                continue;
            };
            match stream.next() {
                Ok(None) => {
                    self.shared = None;
                    return None;
                }
                Err(f) => {
                    self.shared = None;
                    self.failed = true;
                    return Some(Err(f.at(self.bag.at(Some(&self.topics[slot]), Some(self.met[slot])))));
                }
                Ok(Some((s, log_time_ns, data))) => {
                    let index = self.met[s];
                    self.met[s] += 1;
                    let m = BagMessage { index, log_time_ns, data };
                    if s == slot {
                        return Some(Ok(m));
                    }
                    if self.own[s].is_some() || self.closed[s] {
                        // That topic reads by itself now, or is read no more.
                        continue;
                    }
                    self.held += held_bytes(&m);
                    self.queues[s].push_back(m);
                    if self.held > self.budget {
                        // Reading ahead this far for this topic would hold too much
                        // of the others': it walks by itself from here.
                        self.leave(slot);
                    }
                }
            }
        }
    }

    /// The cursor of the topic in `slot` is dropped: its queue is emptied and the
    /// messages the walk meets on it from now on are passed over.
    fn close(&mut self, slot: usize) {
        self.closed[slot] = true;
        self.own[slot] = None;
        for m in std::mem::take(&mut self.queues[slot]) {
            self.held -= held_bytes(&m);
        }
    }

    /// The topic in `slot` leaves the shared walk for one of its own, from the
    /// message after the last one handed on.
    fn leave(&mut self, slot: usize) {
        let stream = self.bag.stream(&[&self.topics[slot]]);
        self.own[slot] = Some(Own { stream, start: self.met[slot], next_index: 0 });
    }
}

enum Inner<'a> {
    Own(Own<'a>),
    Shared(Arc<Mutex<Demux<'a>>>, usize),
}

/// The messages of one topic, one at a time, in storage order.
pub struct TopicCursor<'a> {
    bag: &'a Bag,
    topic: String,
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

impl Drop for TopicCursor<'_> {
    fn drop(&mut self) {
        if let Inner::Shared(d, slot) = &self.inner {
            d.lock().unwrap_or_else(|e| e.into_inner()).close(*slot);
        }
    }
}

impl<'a> Iterator for TopicCursor<'a> {
    type Item = Result<BagMessage<'a>, BagError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = match &mut self.inner {
            Inner::Own(own) => own.next(self.bag, &self.topic),
            // Poisoned only by a panic in another cursor's read, which nothing in the
            // walk raises (mcap's own panics are caught as damage): read on.
            Inner::Shared(d, slot) => d.lock().unwrap_or_else(|e| e.into_inner()).next_for(*slot),
        };
        if !matches!(r, Some(Ok(_))) {
            // The end, or an error: the cursor is not read again.
            self.done = true;
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::writer::{BagWriter, Chunks};

    /// A zstd bag: per step a small "IMU" message and a 20 kB "image".
    fn bag(dir: &Path) {
        let mut w = BagWriter::create_with(dir, Chunks { zstd: true, size_bytes: 8 << 10 }).unwrap();
        for i in 0..40i64 {
            w.write("/imu", "sensor_msgs/msg/Imu", i * 10, &[i as u8; 90]).unwrap();
            w.write("/cam", "sensor_msgs/msg/Image", i * 10 + 5, &vec![i as u8; 20_000]).unwrap();
        }
        w.finish().unwrap();
    }

    fn all(c: TopicCursor<'_>) -> Vec<(u64, i64, Vec<u8>)> {
        c.map(|m| m.unwrap()).map(|m| (m.index, m.log_time_ns, m.data.into_owned())).collect()
    }

    #[test]
    fn a_cursor_reading_ahead_past_the_budget_leaves_the_shared_walk_and_reads_the_same() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("b");
        bag(&dir);
        let b = Bag::open(&dir).unwrap();
        let want = [all(b.cursor("/cam").unwrap()), all(b.cursor("/imu").unwrap())];
        let one_walk = b.chunks_decompressed() / 2;
        for budget in [0, 50_000, READ_AHEAD_BYTES] {
            let mut c = b.cursors_with(&["/cam", "/imu"], budget).unwrap();
            let imu = c.pop().unwrap();
            let mut cam = c.pop().unwrap();
            // Three images, then the IMU to its end (the images read ahead wait, up to
            // the budget), then the rest of the images.
            let mut got_cam: Vec<_> = cam
                .by_ref()
                .take(3)
                .map(|m| m.unwrap())
                .map(|m| (m.index, m.log_time_ns, m.data.into_owned()))
                .collect();
            let before = b.chunks_decompressed();
            let got_imu = all(imu);
            got_cam.extend(all(cam));
            assert!(got_cam == want[0] && got_imu == want[1], "budget {budget}");
            let walks = b.chunks_decompressed() - before;
            if budget == READ_AHEAD_BYTES {
                // Everything held: no second walk.
                assert!(walks < one_walk, "budget {budget}: {walks} chunks, one walk {one_walk}");
            } else {
                // The IMU left the shared walk for one of its own.
                assert!(walks > one_walk, "budget {budget}: {walks} chunks, one walk {one_walk}");
            }
        }
    }

    #[test]
    fn a_dropped_cursor_holds_nothing_back() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("b");
        bag(&dir);
        let b = Bag::open(&dir).unwrap();
        let want = all(b.cursor("/imu").unwrap());
        let one_walk = b.chunks_decompressed();
        // With room for two images only: were the images' messages held for their
        // dropped cursor, the IMU would leave the shared walk and walk again.
        let mut c = b.cursors_with(&["/cam", "/imu"], 50_000).unwrap();
        let imu = c.pop().unwrap();
        let mut cam = c.pop().unwrap();
        assert_eq!(cam.next().unwrap().unwrap().index, 0);
        drop(cam);
        assert!(all(imu) == want);
        assert_eq!(b.chunks_decompressed(), 2 * one_walk);
    }

    #[test]
    fn cursors_can_move_to_another_thread() {
        fn send<T: Send>() {}
        send::<TopicCursor<'static>>();
    }

    #[test]
    fn a_topic_named_twice_gets_two_cursors() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("b");
        bag(&dir);
        let b = Bag::open(&dir).unwrap();
        let want = all(b.cursor("/imu").unwrap());
        let c = b.cursors(&["/imu", "/cam", "/imu"]).unwrap();
        assert_eq!(c.iter().map(|c| c.topic()).collect::<Vec<_>>(), ["/imu", "/cam", "/imu"]);
        for (k, c) in c.into_iter().enumerate() {
            if k != 1 {
                assert!(all(c) == want);
            }
        }
    }
}
