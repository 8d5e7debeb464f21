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

/// The key expression of topic `topic` (a fully qualified name, `/hapticd/sim/pose`) carrying
/// messages `M` in ROS domain `domain`: `<domain>/<name>/<type>/<hash>`, the name without its
/// leading slash.
pub fn topic_key<M: Message>(domain: u32, topic: &str) -> String {
    format!(
        "{domain}/{}/{}/{}",
        topic.trim_start_matches('/'),
        dds_type_name(M::TYPE),
        M::HASH
    )
}

/// A name as liveliness tokens spell it: every `/` as `%` (`%` alone for none).
pub fn mangled(name: &str) -> String {
    match name {
        "" => "%".into(),
        name => name.replace('/', "%"),
    }
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
    use crate::messages::{PoseStamped, WrenchStamped};

    #[test]
    fn a_topic_key_is_domain_name_type_and_hash() {
        assert_eq!(
            topic_key::<PoseStamped>(0, "/hapticd/sim/pose"),
            "0/hapticd/sim/pose/geometry_msgs::msg::dds_::PoseStamped_/\
             RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8"
        );
        assert!(topic_key::<WrenchStamped>(7, "wrench").starts_with("7/wrench/geometry_msgs"));
    }

    #[test]
    fn names_are_mangled_for_liveliness_tokens() {
        assert_eq!(mangled("/hapticd/sim/pose"), "%hapticd%sim%pose");
        assert_eq!(mangled(""), "%");
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
