//! `metadata.yaml` of a rosbag2 folder: its storage, its files and its topics.
//!
//! Read leniently (versions 1 to 9 differ in keys bpins does not need: QoS profiles,
//! type hashes, custom data); written as version 9, the keys rosbag2 and rosbags
//! read.

use serde::{Deserialize, Serialize};

/// The top of `metadata.yaml`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MetadataFile {
    pub rosbag2_bagfile_information: Metadata,
}

/// `rosbag2_bagfile_information`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Metadata {
    pub version: u32,
    /// `mcap` or `sqlite3`.
    pub storage_identifier: String,
    pub relative_file_paths: Vec<String>,
    #[serde(default)]
    pub duration: Duration,
    #[serde(default)]
    pub starting_time: StartingTime,
    #[serde(default)]
    pub message_count: u64,
    pub topics_with_message_count: Vec<TopicWithCount>,
    /// `""`, or `zstd` with `compression_mode` `file` or `message` (not read by bpins).
    #[serde(default)]
    pub compression_format: String,
    #[serde(default)]
    pub compression_mode: String,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub files: Vec<FileInfo>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ros_distro: Option<String>,
}

#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct Duration {
    pub nanoseconds: u64,
}

#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct StartingTime {
    pub nanoseconds_since_epoch: i64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TopicWithCount {
    pub topic_metadata: TopicMetadata,
    #[serde(default)]
    pub message_count: u64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TopicMetadata {
    pub name: String,
    /// `sensor_msgs/msg/Image`, …
    #[serde(rename = "type")]
    pub type_name: String,
    /// `cdr` for every ROS 2 middleware.
    pub serialization_format: String,
    /// A YAML string (version ≤ 8) or a list (version 9); not interpreted.
    #[serde(default = "no_qos")]
    pub offered_qos_profiles: serde_yaml_ng::Value,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub type_description_hash: String,
}

fn no_qos() -> serde_yaml_ng::Value {
    serde_yaml_ng::Value::Sequence(Vec::new())
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FileInfo {
    pub path: String,
    pub starting_time: StartingTime,
    pub duration: Duration,
    pub message_count: u64,
}

impl Metadata {
    /// Parses the text of `metadata.yaml`; the error is serde's, in one line.
    pub fn parse(text: &str) -> Result<Metadata, String> {
        serde_yaml_ng::from_str::<MetadataFile>(text)
            .map(|m| m.rosbag2_bagfile_information)
            .map_err(|e| e.to_string().replace('\n', " "))
    }

    /// The YAML text of this metadata.
    pub fn to_yaml(&self) -> String {
        // Plain data (strings, numbers, lists): serializing cannot fail.
        serde_yaml_ng::to_string(&MetadataFile { rosbag2_bagfile_information: self.clone() }).expect("metadata as YAML")
    }

    /// A new topic entry with no QoS profiles.
    pub fn topic(name: &str, type_name: &str, message_count: u64) -> TopicWithCount {
        TopicWithCount {
            topic_metadata: TopicMetadata {
                name: name.into(),
                type_name: type_name.into(),
                serialization_format: "cdr".into(),
                offered_qos_profiles: no_qos(),
                type_description_hash: String::new(),
            },
            message_count,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_humble_sqlite_bag_and_writes_what_it_reads() {
        let text = "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n  \
            relative_file_paths:\n    - run_0.db3\n  duration:\n    nanoseconds: 2000\n  starting_time:\n    \
            nanoseconds_since_epoch: 17\n  message_count: 3\n  topics_with_message_count:\n    - topic_metadata:\n        \
            name: /cam/image_raw\n        type: sensor_msgs/msg/Image\n        serialization_format: cdr\n        \
            offered_qos_profiles: \"- history: 3\\n  depth: 0\"\n      message_count: 3\n  compression_format: \"\"\n  \
            compression_mode: \"\"\n";
        let m = Metadata::parse(text).unwrap();
        assert_eq!((m.version, m.storage_identifier.as_str(), m.message_count), (5, "sqlite3", 3));
        assert_eq!(m.topics_with_message_count[0].topic_metadata.type_name, "sensor_msgs/msg/Image");
        let again = Metadata::parse(&m.to_yaml()).unwrap();
        assert_eq!(again.relative_file_paths, vec!["run_0.db3".to_string()]);
        assert!(Metadata::parse("rosbag2_bagfile_information:\n  version: 5\n").unwrap_err().contains("missing field"));
    }
}
