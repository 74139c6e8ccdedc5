//! rmw_zenoh's key expressions (design.md, "Topic and service name mapping to Zenoh
//! key expressions" and "Graph cache"): where a topic's samples go, and the
//! liveliness tokens by which every node, publisher and subscription is seen in the
//! graph (`ros2 node list`, `ros2 topic list -v`). A token's names are "mangled":
//! each `/` written `%`, an empty or root name written `%`.

/// The DDS type name of a ROS 2 type: `sensor_msgs/msg/Imu` → `sensor_msgs::msg::dds_::Imu_`.
pub fn dds_type_name(ros_type: &str) -> String {
    match ros_type.split('/').collect::<Vec<_>>().as_slice() {
        [pkg, kind, name] => format!("{pkg}::{kind}::dds_::{name}_"),
        _ => ros_type.replace('/', "::"),
    }
}

/// A name with each `/` as `%`; the root namespace (or nothing) is `%`.
pub fn mangle(name: &str) -> String {
    if name.is_empty() || name == "/" {
        "%".into()
    } else {
        name.replace('/', "%")
    }
}

/// The key of a topic's samples: `<domain>/<topic>/<DDS type>/<hash>`, the topic
/// fully qualified, without its leading `/`.
pub fn topic_key(domain_id: u32, topic: &str, ros_type: &str, type_hash: &str) -> String {
    format!("{domain_id}/{}/{}/{type_hash}", topic.trim_start_matches('/'), dds_type_name(ros_type))
}

/// What a liveliness token declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EntityKind {
    Node,
    Publisher,
    Subscription,
}

impl EntityKind {
    fn code(self) -> &'static str {
        match self {
            EntityKind::Node => "NN",
            EntityKind::Publisher => "MP",
            EntityKind::Subscription => "MS",
        }
    }
}

/// A node: its domain, its session's Zenoh id (hex, as Zenoh prints it), its id in
/// the session, its namespace (`/` for none) and name.
#[derive(Clone, Debug)]
pub struct Node {
    pub domain_id: u32,
    pub zid: String,
    pub node_id: u32,
    pub namespace: String,
    pub name: String,
}

/// QoS as the tokens encode it, rmw_zenoh's defaults (reliable, volatile, keep last
/// 10, no deadline, lifespan or liveliness lease) left empty:
/// `<reliability>:<durability>:<history>,<depth>:<deadline>:<lifespan>:<liveliness>`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Qos {
    /// Best effort (2) instead of reliable (1, the default).
    pub best_effort: bool,
    /// Keep the last `depth` samples.
    pub depth: u32,
}

impl Qos {
    /// A publisher's default: reliable, keep last 10.
    pub const DEFAULT: Qos = Qos { best_effort: false, depth: 10 };
    /// A camera's images: best effort, the newest only (REP 2003's sensor data QoS,
    /// depth 1: a node that reads the newest frame keeps no queue).
    pub const SENSOR_NEWEST: Qos = Qos { best_effort: true, depth: 1 };

    pub fn encode(&self) -> String {
        let reliability = if self.best_effort { "2" } else { "" };
        format!("{reliability}::,{}:,:,:,,", self.depth)
    }
}

/// An endpoint of a node: a publisher or subscription on a topic.
#[derive(Clone, Debug)]
pub struct Endpoint<'a> {
    pub node: &'a Node,
    pub entity_id: u32,
    pub kind: EntityKind,
    pub topic: &'a str,
    pub ros_type: &'a str,
    pub type_hash: &'a str,
    pub qos: Qos,
}

/// The admin space of the graph's tokens.
pub const ADMIN_SPACE: &str = "@ros2_lv";

fn node_part(n: &Node, entity_id: u32, kind: EntityKind) -> String {
    format!(
        "{ADMIN_SPACE}/{}/{}/{}/{entity_id}/{}/%/{}/{}",
        n.domain_id,
        n.zid,
        n.node_id,
        kind.code(),
        mangle(&n.namespace),
        mangle(&n.name)
    )
}

/// The node's liveliness token (its entity id is its node id).
pub fn node_token(n: &Node) -> String {
    node_part(n, n.node_id, EntityKind::Node)
}

/// A publisher's or subscription's liveliness token.
pub fn endpoint_token(e: &Endpoint<'_>) -> String {
    format!(
        "{}/{}/{}/{}/{}",
        node_part(e.node, e.entity_id, e.kind),
        mangle(e.topic),
        dds_type_name(e.ros_type),
        e.type_hash,
        e.qos.encode()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_and_tokens_follow_rmw_zenoh() {
        assert_eq!(dds_type_name("sensor_msgs/msg/Imu"), "sensor_msgs::msg::dds_::Imu_");
        assert_eq!(
            topic_key(0, "/bpins/heading", "sensor_msgs/msg/Imu", "RIHS01_ab"),
            "0/bpins/heading/sensor_msgs::msg::dds_::Imu_/RIHS01_ab"
        );
        let n = Node { domain_id: 3, zid: "a1b2".into(), node_id: 0, namespace: "/".into(), name: "bpins".into() };
        assert_eq!(node_token(&n), "@ros2_lv/3/a1b2/0/0/NN/%/%/bpins");
        let e = Endpoint {
            node: &n,
            entity_id: 2,
            kind: EntityKind::Subscription,
            topic: "/camera/image_raw",
            ros_type: "sensor_msgs/msg/Image",
            type_hash: "RIHS01_cd",
            qos: Qos::SENSOR_NEWEST,
        };
        assert_eq!(
            endpoint_token(&e),
            "@ros2_lv/3/a1b2/0/2/MS/%/%/bpins/%camera%image_raw/sensor_msgs::msg::dds_::Image_/RIHS01_cd/2::,1:,:,:,,"
        );
        assert_eq!(Qos::DEFAULT.encode(), "::,10:,:,:,,");
        let ns = Node { namespace: "/robot1".into(), ..n };
        assert!(node_token(&ns).ends_with("/NN/%/%robot1/bpins"));
    }
}
