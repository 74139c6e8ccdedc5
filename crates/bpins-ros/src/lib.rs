//! ROS 2 bags (rosbag2) in and out of bpins, without ROS installed.
//!
//! ```text
//! bag folder ─ metadata.yaml (metadata.rs) ─┬─ *.mcap   (storage_mcap.rs, mapped, read in place)
//!                                           └─ *.db3    (storage_sqlite.rs, one row at a time)
//!     messages: CDR (cdr.rs) → sensor_msgs/Image, CameraInfo, Imu, NavSatFix (msgs.rs)
//!     → a DoFP mosaic buffer, intrinsics, tilt + 1σ, the sun's place (convert.rs)
//! headings → sensor_msgs/Imu per REP 103/145, diagnostic_msgs/DiagnosticArray
//!     (rep103.rs) → a new MCAP bag folder (writer.rs)
//! ```
//!
//! Memory is bounded by one frame (and what cursors read ahead for one another, at
//! most [`reader::READ_AHEAD_BYTES`]): an MCAP file is memory-mapped and walked
//! record by record, a message of an uncompressed chunk handed on as a slice of the
//! map (no copy; [`BagMessage::data`] borrows) and a zstd chunk decompressed as it is
//! walked; a sqlite3 file is read one row at a time, each message's bytes by SQLite's
//! blob API into one buffer. The image, IMU and GNSS topics are read by cursors that
//! walk forward in step ([`reader::TopicCursor`]), all served by one walk of the
//! storage ([`Bag::cursors`]: each zstd chunk decompressed once, each row visited
//! once), a message met early held for its cursor. Nothing is ever written into a bag
//! being read. Every error names the bag, the topic and the message index
//! ([`BagError`]), and keeps the file system's, SQLite's or `mcap`'s error as its
//! source.
//!
//! Storage support: MCAP with uncompressed or zstd chunks (rosbag2's MCAP plugin
//! writes zstd by default; lz4 chunks are refused by name), ROS 2 `cdr` message
//! encoding; sqlite3 (`.db3`) as rosbag2 writes it (ROS 2 Foxy to Humble's default).
//! Not read: bag-level compression (`compression_mode: file|message`), ROS 1 bags.

pub mod cdr;
pub mod convert;
mod error;
pub mod matching;
pub mod metadata;
pub mod msgs;
pub mod reader;
pub mod rep103;
pub mod rmw_zenoh;
mod storage_mcap;
mod storage_sqlite;
pub mod topics;
pub mod writer;

pub use error::{BagError, Failure, Where};
pub use reader::{Bag, BagMessage, Messages, TopicCursor, TopicInfo};
