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
    /// threads: it must be quick), borrowed where Zenoh holds it in one piece, else
    /// the one contiguous copy (which a callback keeping it takes without another).
    pub fn subscribe(
        &mut self,
        topic: &str,
        ros_type: &str,
        qos: Qos,
        on_sample: impl Fn(std::borrow::Cow<'_, [u8]>) + Send + Sync + 'static,
    ) -> anyhow::Result<()> {
        let (key, _) = self.endpoint(EntityKind::Subscription, topic, ros_type, qos)?;
        let sub = self
            .session
            .declare_subscriber(key)
            .callback(move |sample| on_sample(sample.payload().to_bytes()))
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
