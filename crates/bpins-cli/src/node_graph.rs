//! `bpins node`'s place in a ROS 2 graph: one Zenoh session that speaks rmw_zenoh's
//! wire format (bpins_ros::rmw_zenoh): the node's and each endpoint's liveliness
//! token (so `ros2 node list` and `ros2 topic info` see it), subscriptions on the
//! topics' keys, publishers whose samples carry rmw_zenoh's attachment.
//!
//! The session is a Zenoh peer that connects to the router (rmw_zenoh's `rmw_zenohd`,
//! `tcp/localhost:7447` by default) and listens on a free localhost port, so that the
//! router's gossip connects the node's peers on this host to it directly, as
//! rmw_zenoh's own sessions do; multicast scouting is off, as in rmw_zenoh. It starts
//! whether or not the router is up and keeps trying to reach it (every 1 s to 4 s),
//! also after losing it: Zenoh re-declares the tokens and subscriptions on the new
//! connection.

use anyhow::{anyhow, Context};
use bpins_ros::rmw_zenoh::{self, Attachment, Endpoint, EntityKind, Node, Qos};
use std::sync::atomic::{AtomicI64, Ordering};
use zenoh::Wait;

/// The open session, the node's token and every endpoint declared on it (each
/// undeclared when dropped).
pub struct Graph {
    session: zenoh::Session,
    node: Node,
    next_entity: u32,
    tokens: Vec<zenoh::liveliness::LivelinessToken>,
    subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
}

/// One topic's publisher with its GID and sequence numbers.
pub struct Publisher {
    publisher: zenoh::pubsub::Publisher<'static>,
    gid: [u8; 16],
    sequence: AtomicI64,
}

/// Zenoh's receive buffers per link, bytes (see [`config`]).
const RX_BUFFER_BYTES: &str = "16777216";

/// The Zenoh configuration of a node peer connecting to `endpoint`.
fn config(endpoint: &str) -> anyhow::Result<zenoh::Config> {
    let mut c = zenoh::Config::default();
    let endpoint_json = serde_json::to_string(&[endpoint])?;
    for (key, value) in [
        ("mode", "\"peer\""),
        ("connect/endpoints", endpoint_json.as_str()),
        // Start without the router, and keep trying to reach it.
        ("connect/timeout_ms", "0"),
        ("connect/exit_on_failure", "false"),
        ("connect/retry", "{period_init_ms: 1000, period_max_ms: 4000, period_increase_factor: 2}"),
        ("listen/endpoints", "[\"tcp/localhost:0\"]"),
        ("scouting/multicast/enabled", "false"),
        // Zenoh keeps a fragmented message's batches (one per 64 KiB) until its last
        // one arrives, each in a receive buffer from a per-link pool of `buffer_size /
        // batch` buffers, allocating (and zeroing) the rest afresh for every message
        // past the pool: with the default 65535 bytes (a pool of one), every batch of a
        // 10 MB frame but one. 16 MiB (the size DEFAULT_CONFIG.json5 suggests for large
        // messages) recycles all of a 2448 × 2048 mono16 frame's. The pool is made
        // with the link (measured with shared memory built in too: the node starts
        // ~7 MB larger, 22 MB, and peaks lower at full frames, 46 MB instead of 60).
        ("transport/link/rx/buffer_size", RX_BUFFER_BYTES),
    ] {
        c.insert_json5(key, value).map_err(|e| anyhow!("zenoh configuration {key} = {value}: {e}"))?;
    }
    Ok(c)
}

impl Graph {
    /// Opens the session and declares the node.
    pub fn open(endpoint: &str, domain_id: u32, namespace: &str, name: &str) -> anyhow::Result<Graph> {
        let session = zenoh::open(config(endpoint)?)
            .wait()
            .map_err(|e| anyhow!("{e}"))
            .with_context(|| format!("opening a Zenoh session toward {endpoint}"))?;
        let node = Node {
            domain_id,
            zid: session.zid().to_string(),
            node_id: 0,
            namespace: namespace.into(),
            name: name.into(),
        };
        let token =
            session.liveliness().declare_token(rmw_zenoh::node_token(&node)).wait().map_err(|e| anyhow!("{e}"))?;
        Ok(Graph { session, node, next_entity: 1, tokens: vec![token], subscribers: Vec::new() })
    }

    /// The session's Zenoh id.
    pub fn zid(&self) -> &str {
        &self.node.zid
    }

    fn endpoint(&mut self, kind: EntityKind, topic: &str, ros_type: &str, qos: Qos) -> anyhow::Result<(String, u32)> {
        let hash = rmw_zenoh::type_hash(ros_type).ok_or_else(|| anyhow!("no type hash for {ros_type}"))?;
        let entity_id = self.next_entity;
        self.next_entity += 1;
        let e = Endpoint { node: &self.node, entity_id, kind, topic, ros_type, type_hash: &hash, qos };
        let token = self
            .session
            .liveliness()
            .declare_token(rmw_zenoh::endpoint_token(&e))
            .wait()
            .map_err(|e| anyhow!("{e}"))?;
        self.tokens.push(token);
        Ok((rmw_zenoh::topic_key(self.node.domain_id, topic, ros_type, &hash), entity_id))
    }

    /// Subscribes to `topic`: `on_sample` gets each sample's payload (on Zenoh's
    /// threads: it must be quick).
    pub fn subscribe(
        &mut self,
        topic: &str,
        ros_type: &str,
        qos: Qos,
        on_sample: impl Fn(Payload<'_>) + Send + Sync + 'static,
    ) -> anyhow::Result<()> {
        let (key, _) = self.endpoint(EntityKind::Subscription, topic, ros_type, qos)?;
        let sub = self
            .session
            .declare_subscriber(key)
            .callback(move |sample| on_sample(Payload(sample.payload())))
            .wait()
            .map_err(|e| anyhow!("{e}"))
            .with_context(|| format!("subscribing to {topic}"))?;
        self.subscribers.push(sub);
        Ok(())
    }

    /// A publisher on `topic`.
    pub fn publisher(&mut self, topic: &str, ros_type: &str) -> anyhow::Result<Publisher> {
        let (key, entity_id) = self.endpoint(EntityKind::Publisher, topic, ros_type, Qos::DEFAULT)?;
        let publisher = self
            .session
            .declare_publisher(key)
            .wait()
            .map_err(|e| anyhow!("{e}"))
            .with_context(|| format!("publishing on {topic}"))?;
        // A GID unique in the graph: the session's id (unique) with the entity's.
        let mut gid = [0u8; 16];
        let zid = self.node.zid.as_bytes();
        for (i, b) in zid.iter().enumerate() {
            gid[i % 12] ^= b.wrapping_add(i as u8);
        }
        gid[12..].copy_from_slice(&entity_id.to_le_bytes());
        Ok(Publisher { publisher, gid, sequence: AtomicI64::new(0) })
    }

    /// Closes the session: its tokens, subscriptions and publishers go with it.
    pub fn close(self) {
        drop(self.subscribers);
        drop(self.tokens);
        let _ = self.session.close().wait();
    }
}

/// A received sample's payload: one piece (a shared-memory buffer, or a message
/// that fit in one batch), or the batches Zenoh received a larger one in over TCP.
pub struct Payload<'a>(&'a zenoh::bytes::ZBytes);

/// A payload kept past its callback.
pub enum Kept {
    /// Zenoh's own buffer, read in place: a publisher's shared memory (mapped, no
    /// copy anywhere on this host), or the one receive batch it came in.
    InPlace(zenoh::bytes::ZBytes),
    /// Joined from its batches into a buffer of ours.
    Joined(Vec<u8>),
}

impl Kept {
    /// The payload's bytes.
    pub fn bytes(&self) -> &[u8] {
        match self {
            Kept::InPlace(z) => z.slices().next().unwrap_or(&[]),
            Kept::Joined(b) => b,
        }
    }
}

impl Payload<'_> {
    /// The bytes, borrowed where Zenoh holds them in one piece, else joined in a new
    /// buffer.
    pub fn to_bytes(&self) -> std::borrow::Cow<'_, [u8]> {
        self.0.to_bytes()
    }

    /// The payload kept: in place where it is one piece, else joined into `buffer()`
    /// (its contents replaced: a buffer used again keeps its pages, where a new one of
    /// a frame's size is mapped and faulted in afresh).
    pub fn keep(&self, buffer: impl FnOnce() -> Vec<u8>) -> Kept {
        let mut pieces = self.0.slices();
        if let (Some(_), None) = (pieces.next(), pieces.next()) {
            return Kept::InPlace(self.0.clone());
        }
        let mut b = buffer();
        b.clear();
        b.reserve(self.0.len());
        for s in self.0.slices() {
            b.extend_from_slice(s);
        }
        Kept::Joined(b)
    }
}

impl Publisher {
    /// Publishes one serialized message with its attachment.
    pub fn put(&self, cdr: Vec<u8>) -> anyhow::Result<()> {
        let a = Attachment {
            sequence_number: self.sequence.fetch_add(1, Ordering::Relaxed) + 1,
            source_timestamp_ns: now_ns(),
            gid: self.gid,
        };
        self.publisher.put(cdr).attachment(a.to_bytes()).wait().map_err(|e| anyhow!("{e}"))
    }
}

/// Nanoseconds since the Unix epoch.
pub fn now_ns() -> i64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos() as i64).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use zenoh::bytes::ZBytes;

    #[test]
    fn a_payload_in_one_piece_is_kept_in_place_and_batches_are_joined_into_the_buffer_given() {
        let one = ZBytes::from(vec![1u8, 2, 3]);
        let k = Payload(&one).keep(|| panic!("no buffer for a payload in one piece"));
        assert!(matches!(k, Kept::InPlace(_)));
        assert_eq!(k.bytes(), [1, 2, 3]);

        // Two batches, as Zenoh hands a fragmented message: joined into the buffer
        // given, its old contents replaced and its allocation kept.
        let mut w = ZBytes::writer();
        w.append(ZBytes::from(vec![4u8, 5]));
        w.append(ZBytes::from(vec![6u8, 7, 8]));
        let two = w.finish();
        assert_eq!(two.slices().count(), 2);
        let mut spare = Vec::with_capacity(64);
        spare.extend_from_slice(&[9, 9, 9, 9, 9, 9, 9, 9]);
        let at = spare.as_ptr();
        let k = Payload(&two).keep(|| spare);
        assert_eq!(k.bytes(), [4, 5, 6, 7, 8]);
        let Kept::Joined(b) = k else { panic!("two batches are joined") };
        assert_eq!(b.as_ptr(), at, "the buffer given is reused");

        let empty = ZBytes::new();
        assert_eq!(Payload(&empty).keep(Vec::new).bytes(), [] as [u8; 0]);
    }
}
