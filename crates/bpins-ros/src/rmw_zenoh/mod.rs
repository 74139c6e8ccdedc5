//! ROS 2 over Zenoh as rmw_zenoh (ROS 2's Tier-1 middleware since Kilted) speaks it,
//! without ROS installed: what a process must put on a Zenoh session to be a node of
//! a ROS 2 graph, seen by `ros2 topic list` and by rmw_zenoh's subscribers. Only the
//! formats live here (no Zenoh session: the `bpins node` command opens one):
//!
//! ```text
//! data          <domain>/<topic without its leading />/<DDS type>/<RIHS01 hash>   keyexpr.rs
//!               payload: the CDR message (cdr.rs); attachment: sequence number,
//!               source timestamp, publisher GID                                   attachment.rs
//! liveliness    @ros2_lv/<domain>/<zid>/<node id>/<entity id>/<NN|MP|MS>/<enclave>/
//!               <namespace>/<node>[/<topic>/<DDS type>/<hash>/<QoS>]              keyexpr.rs
//! type hashes   RIHS01_<sha256 of the type description> (REP 2011)                type_hash.rs
//! ```
//!
//! Source of the formats: rmw_zenoh's docs/design.md (ros2/rmw_zenoh); checked
//! against an independent implementation (zenoh-ros2-sdk, PyPI) by tests/ros_node.rs.

pub mod attachment;
pub mod keyexpr;
pub mod type_hash;

pub use attachment::Attachment;
pub use keyexpr::{dds_type_name, endpoint_token, node_token, topic_key, Endpoint, EntityKind, Node, Qos};
pub use type_hash::type_hash;
