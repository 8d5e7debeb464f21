//! The topics of one device: ROS 2 names built from the device's identity and its effectors'
//! names, the key expressions rmw_zenoh puts them under, and the keys of its queries and
//! commands.
//!
//! | topic | type | what |
//! |---|---|---|
//! | `/hapticd/<device>/<effector>/pose` | `geometry_msgs/msg/PoseStamped` | the grip's pose |
//! | `/hapticd/<device>/<effector>/twist` | `geometry_msgs/msg/TwistStamped` | its velocity and angular velocity, in the device's frame |
//! | `/hapticd/<device>/<effector>/wrench` | `geometry_msgs/msg/WrenchStamped` | the wrench displayed |
//! | `/hapticd/<device>/strings` | `sensor_msgs/msg/JointState` | each string's tension (effort) |
//! | `/hapticd/<device>/bodies` | `geometry_msgs/msg/PoseArray` | the world's bodies, by id, at the world's rate |
//! | `/hapticd/<device>/joint_states` | `sensor_msgs/msg/JointState` | the world's joints with a coordinate: position (rad or m) and velocity, at 50 Hz |
//! | `/hapticd/<device>/state` | `std_msgs/msg/String` | running, fault, …; transient-local |
//! | `/hapticd/<device>/touches` | `std_msgs/msg/String` | each touch begun, ended, slipping (JSON) |
//! | `/hapticd/<device>/<effector>/wrench_command` | `geometry_msgs/msg/WrenchStamped` | taken: added to the displayed wrench (commands on) |

use hapticd_ros2::keys::{Graph, topic_key};
use hapticd_ros2::messages::{
    JointState, Message, PoseArray, PoseStamped, StringMessage, TwistStamped, WrenchStamped,
};

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

/// One topic: its ROS 2 name and the key its samples travel under.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topic {
    /// The fully qualified ROS 2 name.
    pub name: String,
    /// The Zenoh key expression.
    pub key: String,
}

impl Topic {
    /// Topic `name` of messages `M` in `graph`.
    fn new<M: Message>(graph: Graph, name: String) -> Self {
        Self {
            key: topic_key::<M>(graph, &name),
            name,
        }
    }
}

/// Where one effector of a device is published.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EffectorTopics {
    /// Its pose.
    pub pose: Topic,
    /// Its velocity.
    pub twist: Topic,
    /// The wrench it displays.
    pub wrench: Topic,
    /// The wrench commanded to it, taken.
    pub command: Topic,
}

/// Where one device is published and asked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceTopics {
    /// The device's word in names and keys.
    pub device: String,
    /// The frame its messages are in (`hapticd_<device>`), and the name of its ROS node.
    pub frame: String,
    /// Each effector's topics.
    pub effectors: Vec<EffectorTopics>,
    /// Its strings' tensions.
    pub strings: Topic,
    /// The poses of its world's bodies.
    pub bodies: Topic,
    /// Its world's joints.
    pub joints: Topic,
    /// Its state.
    pub state: Topic,
    /// Its touches.
    pub touches: Topic,
}

impl DeviceTopics {
    /// The topics of device `device` with effectors `effectors` in `graph`.
    pub fn new(graph: Graph, device: &str, effectors: &[String]) -> Self {
        let word = name_word(device);
        let base = format!("/hapticd/{word}");
        Self {
            frame: format!("hapticd_{word}"),
            effectors: effectors
                .iter()
                .map(|e| {
                    let at = format!("{base}/{}", name_word(e));
                    EffectorTopics {
                        pose: Topic::new::<PoseStamped>(graph, format!("{at}/pose")),
                        twist: Topic::new::<TwistStamped>(graph, format!("{at}/twist")),
                        wrench: Topic::new::<WrenchStamped>(graph, format!("{at}/wrench")),
                        command: Topic::new::<WrenchStamped>(graph, format!("{at}/wrench_command")),
                    }
                })
                .collect(),
            strings: Topic::new::<JointState>(graph, format!("{base}/strings")),
            bodies: Topic::new::<PoseArray>(graph, format!("{base}/bodies")),
            joints: Topic::new::<JointState>(graph, format!("{base}/joint_states")),
            state: Topic::new::<StringMessage>(graph, format!("{base}/state")),
            touches: Topic::new::<StringMessage>(graph, format!("{base}/touches")),
            device: word,
        }
    }

    /// The key its ticks are published under whole, for hapticd's own clients
    /// (`hapticctl --remote record`): `hapticd/<device>/telemetry/v<layout>`, each sample as
    /// `hapticd_core::telemetry::Sample::encode` writes it.
    pub fn telemetry(&self) -> String {
        format!(
            "hapticd/{}/telemetry/v{}",
            self.device,
            hapticd_core::telemetry::VERSION
        )
    }

    /// The key its status is asked at: `hapticd/<device>/status`.
    pub fn status(&self) -> String {
        format!("hapticd/{}/status", self.device)
    }
}

/// The keys devices' parameters are set at: `hapticd/<device>/set/<Parameter>`.
pub const SET_COMMANDS: &str = "hapticd/*/set/*";

/// The keys devices' effects are commanded at: `hapticd/<device>/effect/add`,
/// `…/effect/change/<id>`, `…/effect/remove/<id>` and `…/effect/clear`.
pub const EFFECT_COMMANDS: &str = "hapticd/*/effect/**";

/// The keys of the scene's commands: `hapticd/scene/switch` and
/// `hapticd/scene/body/<body>/<pose|velocity|impulse|force|mass|friction>`.
pub const SCENE_COMMANDS: &str = "hapticd/scene/**";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identities_become_ros_names_and_keys() {
        assert_eq!(name_word("usb-1-2.3"), "usb_1_2_3");
        assert_eq!(name_word("3d"), "_3d");
        let topics = DeviceTopics::new(Graph::default(), "sim", &["grip".into()]);
        let grip = &topics.effectors[0];
        assert_eq!(grip.pose.name, "/hapticd/sim/grip/pose");
        assert!(
            grip.pose.key.starts_with(
                "0/hapticd/sim/grip/pose/geometry_msgs::msg::dds_::PoseStamped_/RIHS01_"
            )
        );
        assert!(
            grip.twist
                .key
                .starts_with("0/hapticd/sim/grip/twist/geometry_msgs::msg::dds_::TwistStamped_/")
        );
        assert!(
            topics
                .strings
                .key
                .starts_with("0/hapticd/sim/strings/sensor_msgs::msg::dds_::JointState_/")
        );
        assert!(
            topics
                .state
                .key
                .starts_with("0/hapticd/sim/state/std_msgs::msg::dds_::String_/")
        );
        assert_eq!(topics.frame, "hapticd_sim");
        assert_eq!(
            DeviceTopics::new(Graph::default(), "usb-1", &[]).status(),
            "hapticd/usb_1/status"
        );
    }
}
