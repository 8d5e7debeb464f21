//! What a ROS 2 system reads of hapticd over Zenoh, without Zenoh itself: the messages of a
//! device (`geometry_msgs/msg/PoseStamped`, `WrenchStamped`, `TwistStamped`) encoded as ROS 2
//! encodes them (CDR, little-endian, with its 4-byte encapsulation header), and the key
//! expressions `rmw_zenoh` puts a topic under, so that `ros2 topic echo` sees hapticd's
//! topics as ordinary ones.
//!
//! - [`cdr`]: the CDR writer and reader (alignment of each primitive to its size, counted
//!   from after the encapsulation header);
//! - [`messages`]: the messages, each encoded and decoded;
//! - [`keys`]: topic names as rmw_zenoh's key expressions, with each message's type name and
//!   type hash.

pub mod cdr;
pub mod keys;
pub mod messages;
