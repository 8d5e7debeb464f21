//! Where rmw_zenoh puts a topic, and what it attaches to each sample: a ROS 2 node subscribed
//! to one of these keys through `rmw_zenoh_cpp` receives hapticd's samples as its own.

use crate::messages::Message;

/// A message type's name as DDS (and so rmw_zenoh) spells it:
/// `geometry_msgs/msg/PoseStamped` → `geometry_msgs::msg::dds_::PoseStamped_`.
pub fn dds_type_name(ros: &str) -> String {
    let mut parts: Vec<&str> = ros.split('/').collect();
    let name = parts.pop().unwrap_or_default();
    format!("{}::dds_::{name}_", parts.join("::"))
}

/// A ROS 2 distribution, as far as what rmw_zenoh puts on the wire differs between them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Distro {
    /// Humble Hawksbill (2022 LTS): no type hashes.
    Humble,
    /// Jazzy Jalisco (2024 LTS).
    #[default]
    Jazzy,
    /// Kilted Kaiju (2025).
    Kilted,
    /// Rolling Ridley.
    Rolling,
}

impl Distro {
    /// Every distribution, by the name `ros_distro:` takes.
    pub const ALL: [(&str, Distro); 4] = [
        ("humble", Distro::Humble),
        ("jazzy", Distro::Jazzy),
        ("kilted", Distro::Kilted),
        ("rolling", Distro::Rolling),
    ];

    /// What stands for the type hash of `M` in keys and tokens: Humble's rmw_zenoh writes a
    /// constant where later ones write `RIHS01_` and the hash.
    pub fn type_hash<M: Message>(self) -> &'static str {
        match self {
            Distro::Humble => "TypeHashNotSupported",
            _ => M::HASH,
        }
    }
}

/// The ROS 2 graph a node joins: its domain, and the distribution of the nodes it meets.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Graph {
    /// The ROS domain.
    pub domain: u32,
    /// The distribution.
    pub distro: Distro,
}

/// The key expression of topic `topic` (a fully qualified name, `/hapticd/sim/pose`) carrying
/// messages `M` in `graph`: `<domain>/<name>/<type>/<hash>`, the name without its leading
/// slash.
pub fn topic_key<M: Message>(graph: Graph, topic: &str) -> String {
    format!(
        "{}/{}/{}/{}",
        graph.domain,
        topic.trim_start_matches('/'),
        dds_type_name(M::TYPE),
        graph.distro.type_hash::<M>()
    )
}

/// A name as liveliness tokens spell it: every `/` as `%` (`%` alone for none).
pub fn mangled(name: &str) -> String {
    match name {
        "" => "%".into(),
        name => name.replace('/', "%"),
    }
}

/// The QoS of a liveliness token with every policy at rmw_zenoh's default (reliable,
/// volatile, keep last, its own depth, no deadline, lifespan or lease): fields
/// `reliability:durability:history,depth:deadline s,ns:lifespan s,ns:liveliness,lease s,ns`,
/// each left empty at its default. hapticd's publishers are Zenoh's defaults over TCP, which
/// is what these say.
pub const DEFAULT_QOS: &str = "::,:,:,:,,";

/// The QoS of a publisher that keeps its last message for subscriptions that come later, as
/// ROS 2 latches a state: transient-local durability (`1`), keep last 1, the rest at the
/// defaults.
pub const TRANSIENT_LOCAL_QOS: &str = ":1:,1:,:,:,,";

/// A ROS 2 node as rmw_zenoh announces it: the liveliness tokens through which `ros2 node
/// list` and `ros2 topic list` find the node and its publishers and subscriptions.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Node {
    /// Its ROS graph.
    pub graph: Graph,
    /// Its Zenoh session's id, as Zenoh writes it.
    pub zid: String,
    /// Its number within the session.
    pub id: u32,
    /// Its namespace (`/` for none).
    pub namespace: String,
    /// Its name.
    pub name: String,
}

impl Node {
    /// The part every token of the node starts with, up to the entity's kind.
    fn prefix(&self, entity: u32, kind: &str) -> String {
        format!(
            "@ros2_lv/{}/{}/{}/{entity}/{kind}/%/{}/{}",
            self.graph.domain,
            self.zid,
            self.id,
            mangled(&self.namespace),
            mangled(&self.name)
        )
    }

    /// The node's own token.
    pub fn token(&self) -> String {
        self.prefix(self.id, "NN")
    }

    /// The token of its publisher number `entity` of `topic`, messages `M`, of QoS `qos`
    /// ([`DEFAULT_QOS`], [`TRANSIENT_LOCAL_QOS`]).
    pub fn publisher<M: Message>(&self, entity: u32, topic: &str, qos: &str) -> String {
        self.endpoint::<M>(entity, "MP", topic, qos)
    }

    /// The token of its subscription number `entity` to `topic`, messages `M`.
    pub fn subscription<M: Message>(&self, entity: u32, topic: &str) -> String {
        self.endpoint::<M>(entity, "MS", topic, DEFAULT_QOS)
    }

    fn endpoint<M: Message>(&self, entity: u32, kind: &str, topic: &str, qos: &str) -> String {
        format!(
            "{}/{}/{}/{}/{qos}",
            self.prefix(entity, kind),
            mangled(topic),
            dds_type_name(M::TYPE),
            self.graph.distro.type_hash::<M>()
        )
    }
}

/// The id (GID) of the entity whose liveliness token is `token`: the XXH3 128-bit hash of
/// the token's key expression, low 64 bits first, each little-endian, as rmw_zenoh makes its
/// entities' GIDs, so that the GID in a sample's attachment is the one the graph shows.
pub fn gid(token: &str) -> [u8; 16] {
    let hash = twox_hash::XxHash3_128::oneshot(token.as_bytes());
    hash.to_le_bytes()
}

/// The attachment of a published sample: its sequence number, its source time (nanoseconds
/// since the Unix epoch) and the publisher's 16-byte id, as rmw_zenoh reads them (each
/// number little-endian, the id after its length).
pub fn attachment(sequence: i64, time_ns: i64, publisher: &[u8; 16]) -> [u8; 33] {
    let mut out = [0; 33];
    out[..8].copy_from_slice(&sequence.to_le_bytes());
    out[8..16].copy_from_slice(&time_ns.to_le_bytes());
    out[16] = 16;
    out[17..].copy_from_slice(publisher);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::messages::{PoseStamped, StringMessage, WrenchStamped};

    #[test]
    fn a_topic_key_is_domain_name_type_and_hash() {
        assert_eq!(
            topic_key::<PoseStamped>(Graph::default(), "/hapticd/sim/pose"),
            "0/hapticd/sim/pose/geometry_msgs::msg::dds_::PoseStamped_/\
             RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8"
        );
        let seven = Graph {
            domain: 7,
            ..Graph::default()
        };
        assert!(topic_key::<WrenchStamped>(seven, "wrench").starts_with("7/wrench/geometry_msgs"));
    }

    #[test]
    fn humble_writes_no_type_hash_and_the_others_their_rihs01() {
        for (name, distro) in Distro::ALL {
            let graph = Graph { domain: 0, distro };
            let node = Node {
                graph,
                zid: "a1b2".into(),
                id: 3,
                namespace: "/".into(),
                name: "hapticd_sim".into(),
            };
            let (key, token) = (
                topic_key::<PoseStamped>(graph, "/p"),
                node.publisher::<PoseStamped>(4, "/p", DEFAULT_QOS),
            );
            let hash = match name {
                "humble" => "TypeHashNotSupported",
                _ => "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
            };
            assert_eq!(
                key,
                format!("0/p/geometry_msgs::msg::dds_::PoseStamped_/{hash}"),
                "{name}"
            );
            assert!(
                token.ends_with(&format!("PoseStamped_/{hash}/{DEFAULT_QOS}")),
                "{token}"
            );
        }
    }

    #[test]
    fn a_gid_is_the_xxh3_128_of_the_token_low_half_first() {
        // XXH3-128 of no bytes, from xxHash's own test vectors: 99aa06d3014798d8 (high)
        // 6001c324468d497f (low).
        let mut empty = [0u8; 16];
        empty[..8].copy_from_slice(&0x6001_c324_468d_497f_u64.to_le_bytes());
        empty[8..].copy_from_slice(&0x99aa_06d3_0147_98d8_u64.to_le_bytes());
        assert_eq!(gid(""), empty);
        assert_ne!(gid("@ros2_lv/0/a"), gid("@ros2_lv/0/b"));
    }

    #[test]
    fn names_are_mangled_for_liveliness_tokens() {
        assert_eq!(mangled("/hapticd/sim/pose"), "%hapticd%sim%pose");
        assert_eq!(mangled(""), "%");
    }

    #[test]
    fn a_node_and_its_endpoints_are_announced_as_rmw_zenoh_announces_them() {
        let node = Node {
            graph: Graph::default(),
            zid: "a1b2".into(),
            id: 3,
            namespace: "/".into(),
            name: "hapticd_sim".into(),
        };
        assert_eq!(node.token(), "@ros2_lv/0/a1b2/3/3/NN/%/%/hapticd_sim");
        assert_eq!(
            node.publisher::<PoseStamped>(4, "/hapticd/sim/grip/pose", DEFAULT_QOS),
            "@ros2_lv/0/a1b2/3/4/MP/%/%/hapticd_sim/%hapticd%sim%grip%pose/\
             geometry_msgs::msg::dds_::PoseStamped_/\
             RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8/::,:,:,:,,"
        );
        assert!(
            node.publisher::<StringMessage>(5, "/hapticd/sim/state", TRANSIENT_LOCAL_QOS)
                .ends_with("/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/:1:,1:,:,:,,")
        );
        let spaced = Node {
            namespace: "/lab".into(),
            ..node
        };
        assert!(
            spaced
                .subscription::<WrenchStamped>(5, "/x")
                .starts_with("@ros2_lv/0/a1b2/3/5/MS/%/%lab/hapticd_sim/%x/")
        );
    }

    #[test]
    fn an_attachment_holds_sequence_time_and_publisher() {
        let id: [u8; 16] = std::array::from_fn(|k| k as u8);
        let a = attachment(3, 1_700_000_000_000_000_001, &id);
        assert_eq!(a[..8], 3i64.to_le_bytes());
        assert_eq!(a[8..16], 1_700_000_000_000_000_001i64.to_le_bytes());
        assert_eq!(a[16], 16);
        assert_eq!(a[17..], id);
    }
}
