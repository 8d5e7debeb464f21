//! hapticd's ROS 2 messages against an independent encoder: the bytes `hapticd_ros2` writes
//! for PoseStamped, WrenchStamped, TwistStamped, PoseArray, JointState and String are those rosbags (a pure-Python ROS 2
//! serialiser from PyPI, with the message definitions of ROS 2 Jazzy) writes for the same
//! values, and the type hashes in the topic keys are those rosbags computes
//! from the definitions.

use std::process::Command;

use hapticd_ros2::messages::{
    Header, JointState, Message, PoseArray, PoseStamped, StringMessage, Time, TwistStamped,
    WrenchStamped,
};

use crate::support;

/// Run `script` under Python with rosbags; its standard output.
fn rosbags(script: &str) -> String {
    let out = Command::new("/usr/bin/python3")
        .args(["-c", script])
        .env("PYTHONPATH", support::python_package("rosbags"))
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    String::from_utf8(out.stdout).unwrap()
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

const PRELUDE: &str = "
import numpy
from rosbags.typesys import Stores, get_typestore
ts = get_typestore(Stores.ROS2_JAZZY)
T = ts.types
def header(sec, nanosec, frame):
    return T['std_msgs/msg/Header'](stamp=T['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec), frame_id=frame)
def vector(x, y, z):
    return T['geometry_msgs/msg/Vector3'](x=x, y=y, z=z)
def show(message, name):
    print(ts.serialize_cdr(message, name).hex())
";

#[test]
fn every_message_s_bytes_are_those_of_an_independent_encoder() {
    let frames = ["", "spidar", "hapticd/sim/grip-with-a-longer-name"];
    let mut script = PRELUDE.to_string();
    let mut ours = Vec::new();
    for (k, frame) in frames.iter().enumerate() {
        let (sec, nanosec) = (1_700_000_000 + k as i32, 123_456_789 * k as u32);
        let header = Header {
            stamp: Time { sec, nanosec },
            frame_id: frame.to_string(),
        };
        let s = k as f64 + 0.5;
        let pose = PoseStamped {
            header: header.clone(),
            position: [0.1 * s, -0.2, 1e-9 * s],
            orientation: [0.5, -0.5, 0.5, 0.5],
        };
        let wrench = WrenchStamped {
            header: header.clone(),
            force: [1.5 * s, -2.0, 0.0],
            torque: [-0.0, 1e-3, -7.0 * s],
        };
        let twist = TwistStamped {
            header: header.clone(),
            linear: [0.1, s, -0.3],
            angular: [3.0, 2.0, -s],
        };
        let p = &pose.position;
        let [qx, qy, qz, qw] = pose.orientation;
        script += &format!(
            "h = header({sec}, {nanosec}, {frame:?})\n\
             show(T['geometry_msgs/msg/PoseStamped'](header=h, pose=T['geometry_msgs/msg/Pose'](\
             position=T['geometry_msgs/msg/Point'](x={:?}, y={:?}, z={:?}), \
             orientation=T['geometry_msgs/msg/Quaternion'](x={qx:?}, y={qy:?}, z={qz:?}, w={qw:?}))), \
             'geometry_msgs/msg/PoseStamped')\n\
             show(T['geometry_msgs/msg/WrenchStamped'](header=h, wrench=T['geometry_msgs/msg/Wrench'](\
             force=vector({:?}, {:?}, {:?}), torque=vector({:?}, {:?}, {:?}))), 'geometry_msgs/msg/WrenchStamped')\n\
             show(T['geometry_msgs/msg/TwistStamped'](header=h, twist=T['geometry_msgs/msg/Twist'](\
             linear=vector({:?}, {:?}, {:?}), angular=vector({:?}, {:?}, {:?}))), 'geometry_msgs/msg/TwistStamped')\n",
            p[0],
            p[1],
            p[2],
            wrench.force[0],
            wrench.force[1],
            wrench.force[2],
            wrench.torque[0],
            wrench.torque[1],
            wrench.torque[2],
            twist.linear[0],
            twist.linear[1],
            twist.linear[2],
            twist.angular[0],
            twist.angular[1],
            twist.angular[2],
        );
        // From no string to eight (SPIDAR-G), names of every length modulo the alignment.
        let strings = JointState {
            header,
            name: (0..k * 4).map(|i| "s".repeat(i + 1)).collect(),
            position: vec![],
            velocity: vec![],
            effort: (0..k * 4).map(|i| 0.25 * i as f64 + s).collect(),
        };
        let text = StringMessage {
            data: frame.repeat(k),
        };
        // No body to four, in frames of every string length.
        let bodies = PoseArray {
            header: strings.header.clone(),
            poses: (0..k * 2)
                .map(|i| ([i as f64, -s, 1e-9], [0.5, -0.5, 0.5, 0.5 * i as f64]))
                .collect(),
        };
        let poses: Vec<String> = bodies
            .poses
            .iter()
            .map(|(p, q)| {
                format!(
                    "T['geometry_msgs/msg/Pose'](position=T['geometry_msgs/msg/Point'](x={:?}, y={:?}, z={:?}), \
                     orientation=T['geometry_msgs/msg/Quaternion'](x={:?}, y={:?}, z={:?}, w={:?}))",
                    p[0], p[1], p[2], q[0], q[1], q[2], q[3]
                )
            })
            .collect();
        script += &format!(
            "show(T['geometry_msgs/msg/PoseArray'](header=h, poses=[{}]), 'geometry_msgs/msg/PoseArray')\n",
            poses.join(", ")
        );
        script += &format!(
            "show(T['sensor_msgs/msg/JointState'](header=h, name={:?}, \
             position=numpy.zeros(0), velocity=numpy.zeros(0), \
             effort=numpy.array({:?}, dtype=numpy.float64)), 'sensor_msgs/msg/JointState')\n\
             show(T['std_msgs/msg/String'](data={:?}), 'std_msgs/msg/String')\n",
            strings.name, strings.effort, text.data
        );
        ours.push(pose.encode());
        ours.push(wrench.encode());
        ours.push(twist.encode());
        // In the order the script shows them.
        ours.push(bodies.encode());
        ours.push(strings.encode());
        ours.push(text.encode());
    }
    let theirs: Vec<String> = rosbags(&script).lines().map(String::from).collect();
    assert_eq!(theirs.len(), ours.len());
    for (k, (theirs, ours)) in theirs.iter().zip(&ours).enumerate() {
        assert_eq!(*theirs, hex(ours), "message {k}");
    }
}

#[test]
fn the_type_hashes_in_the_topic_keys_are_those_of_the_definitions() {
    let said = rosbags(&format!(
        "{PRELUDE}\nfor name in ['geometry_msgs/msg/PoseStamped', 'geometry_msgs/msg/WrenchStamped', \
         'geometry_msgs/msg/TwistStamped', 'sensor_msgs/msg/JointState', 'std_msgs/msg/String', \
         'geometry_msgs/msg/PoseArray']:\n    \
         print(ts.hash_rihs01(name))\n"
    ));
    let theirs: Vec<&str> = said.lines().collect();
    assert_eq!(
        theirs,
        [
            PoseStamped::HASH,
            WrenchStamped::HASH,
            TwistStamped::HASH,
            JointState::HASH,
            StringMessage::HASH,
            PoseArray::HASH
        ]
    );
}
