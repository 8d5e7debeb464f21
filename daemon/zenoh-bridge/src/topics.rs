//! The topics of one device: ROS 2 names built from the device's identity and its effectors'
//! names, and the key expressions rmw_zenoh puts them under.

use hapticd_ros2::keys::topic_key;
use hapticd_ros2::messages::{PoseStamped, WrenchStamped};

/// A word of a ROS 2 name: letters, digits and underscores, not starting with a digit.
pub fn name_word(word: &str) -> String {
    let mut out: String = word
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, '_');
    }
    out
}

/// Where one effector of a device is published.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EffectorTopics {
    /// The frame its messages are in (`hapticd_<device>`).
    pub frame: String,
    /// The key of its pose (`geometry_msgs/msg/PoseStamped`).
    pub pose: String,
    /// The key of the wrench it displays (`geometry_msgs/msg/WrenchStamped`).
    pub wrench: String,
}

impl EffectorTopics {
    /// The topics of effector `effector` of device `device` in ROS domain `domain`:
    /// `/hapticd/<device>/<effector>/pose` and `…/wrench`.
    pub fn new(domain: u32, device: &str, effector: &str) -> Self {
        let base = format!("/hapticd/{}/{}", name_word(device), name_word(effector));
        Self {
            frame: format!("hapticd_{}", name_word(device)),
            pose: topic_key::<PoseStamped>(domain, &format!("{base}/pose")),
            wrench: topic_key::<WrenchStamped>(domain, &format!("{base}/wrench")),
        }
    }
}

/// The key a device's status is asked at: `hapticd/<device>/status`.
pub fn status_key(device: &str) -> String {
    format!("hapticd/{}/status", name_word(device))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identities_become_ros_names_and_keys() {
        assert_eq!(name_word("usb-1-2.3"), "usb_1_2_3");
        assert_eq!(name_word("3d"), "_3d");
        let topics = EffectorTopics::new(0, "sim", "grip");
        assert!(
            topics.pose.starts_with(
                "0/hapticd/sim/grip/pose/geometry_msgs::msg::dds_::PoseStamped_/RIHS01_"
            )
        );
        assert!(
            topics
                .wrench
                .starts_with("0/hapticd/sim/grip/wrench/geometry_msgs::msg::dds_::WrenchStamped_/")
        );
        assert_eq!(status_key("usb-1"), "hapticd/usb_1/status");
    }
}
