//! The messages hapticd publishes and takes, as ROS 2 defines them, each encoded in CDR and
//! decoded from it: `builtin_interfaces/msg/Time`, `std_msgs/msg/Header`, and from
//! `geometry_msgs/msg` `PoseStamped`, `WrenchStamped`, `TwistStamped` and
//! `PoseArray` (the world's bodies), `sensor_msgs/msg/JointState` (a device's strings) and
//! `std_msgs/msg/String`.

use crate::cdr::{DecodeError, Reader, Writer};

/// A message type as ROS 2 names it, and its type hash (REP 2016's RIHS01, as ROS 2 Jazzy and
/// later compute it from the type's description; rmw_zenoh puts it in each topic's key).
pub trait Message: Sized {
    /// The type's name, such as `geometry_msgs/msg/PoseStamped`.
    const TYPE: &'static str;
    /// Its RIHS01 type hash.
    const HASH: &'static str;

    /// Write the message's fields.
    fn write(&self, out: &mut Writer);

    /// Read the message's fields.
    fn read(from: &mut Reader<'_>) -> Result<Self, DecodeError>;

    /// The message in CDR, with its encapsulation header.
    fn encode(&self) -> Vec<u8> {
        let mut out = Writer::new();
        self.write(&mut out);
        out.finish()
    }

    /// The message from CDR bytes (anything after its last field is padding, ignored).
    fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        Self::read(&mut Reader::new(bytes)?)
    }
}

/// `builtin_interfaces/msg/Time`: seconds and nanoseconds since the epoch of its clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Time {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds past them, below 10⁹.
    pub nanosec: u32,
}

impl Time {
    /// The time `nanoseconds` after its epoch.
    pub fn from_nanos(nanoseconds: u64) -> Self {
        Self {
            sec: (nanoseconds / 1_000_000_000).min(i32::MAX as u64) as i32,
            nanosec: (nanoseconds % 1_000_000_000) as u32,
        }
    }
}

/// `std_msgs/msg/Header`: when and in which frame.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Header {
    /// When the data was taken.
    pub stamp: Time,
    /// The frame the data is in.
    pub frame_id: String,
}

impl Header {
    fn write(&self, out: &mut Writer) {
        out.i32(self.stamp.sec);
        out.u32(self.stamp.nanosec);
        out.string(&self.frame_id);
    }

    fn read(from: &mut Reader<'_>) -> Result<Self, DecodeError> {
        Ok(Self {
            stamp: Time {
                sec: from.i32()?,
                nanosec: from.u32()?,
            },
            frame_id: from.string()?,
        })
    }
}

/// Three doubles (a `Point` or a `Vector3`), in order.
fn write_vector(out: &mut Writer, v: &[f64; 3]) {
    for x in v {
        out.f64(*x);
    }
}

fn read_vector(from: &mut Reader<'_>) -> Result<[f64; 3], DecodeError> {
    Ok([from.f64()?, from.f64()?, from.f64()?])
}

/// `geometry_msgs/msg/PoseStamped`: a grip's pose. ROS 2 orders a quaternion x, y, z, w.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PoseStamped {
    /// When and in which frame.
    pub header: Header,
    /// Position, metres.
    pub position: [f64; 3],
    /// Orientation, unit quaternion (x, y, z, w).
    pub orientation: [f64; 4],
}

impl Message for PoseStamped {
    const TYPE: &'static str = "geometry_msgs/msg/PoseStamped";
    const HASH: &'static str =
        "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8";

    fn write(&self, out: &mut Writer) {
        self.header.write(out);
        write_vector(out, &self.position);
        for q in &self.orientation {
            out.f64(*q);
        }
    }

    fn read(from: &mut Reader<'_>) -> Result<Self, DecodeError> {
        Ok(Self {
            header: Header::read(from)?,
            position: read_vector(from)?,
            orientation: [from.f64()?, from.f64()?, from.f64()?, from.f64()?],
        })
    }
}

/// `geometry_msgs/msg/PoseArray`: the poses of several things in one frame (the world's
/// bodies, in the order of their ids).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PoseArray {
    /// When and in which frame.
    pub header: Header,
    /// Each pose: position, metres, and orientation (x, y, z, w).
    pub poses: Vec<([f64; 3], [f64; 4])>,
}

impl Message for PoseArray {
    const TYPE: &'static str = "geometry_msgs/msg/PoseArray";
    const HASH: &'static str =
        "RIHS01_af0cc36d190e104d546d168d6b39df04fa4b4ccecf59cb4c9ed328d3d5004aa0";

    fn write(&self, out: &mut Writer) {
        self.header.write(out);
        out.sequence(self.poses.len());
        for (position, orientation) in &self.poses {
            write_vector(out, position);
            for q in orientation {
                out.f64(*q);
            }
        }
    }

    fn read(from: &mut Reader<'_>) -> Result<Self, DecodeError> {
        let header = Header::read(from)?;
        let n = from.sequence(7 * 8)?;
        let poses = (0..n)
            .map(|_| {
                Ok((
                    read_vector(from)?,
                    [from.f64()?, from.f64()?, from.f64()?, from.f64()?],
                ))
            })
            .collect::<Result<_, DecodeError>>()?;
        Ok(Self { header, poses })
    }
}

/// `geometry_msgs/msg/WrenchStamped`: a force and a torque.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WrenchStamped {
    /// When and in which frame.
    pub header: Header,
    /// Force, newtons.
    pub force: [f64; 3],
    /// Torque, newton-metres.
    pub torque: [f64; 3],
}

impl Message for WrenchStamped {
    const TYPE: &'static str = "geometry_msgs/msg/WrenchStamped";
    const HASH: &'static str =
        "RIHS01_8dc3deaf06b2ab281f9f9a742a8961c328ca7cec16e3fd6586d3a5c83fa78f77";

    fn write(&self, out: &mut Writer) {
        self.header.write(out);
        write_vector(out, &self.force);
        write_vector(out, &self.torque);
    }

    fn read(from: &mut Reader<'_>) -> Result<Self, DecodeError> {
        Ok(Self {
            header: Header::read(from)?,
            force: read_vector(from)?,
            torque: read_vector(from)?,
        })
    }
}

/// `geometry_msgs/msg/TwistStamped`: a velocity and an angular velocity.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TwistStamped {
    /// When and in which frame.
    pub header: Header,
    /// Velocity, m/s.
    pub linear: [f64; 3],
    /// Angular velocity, rad/s.
    pub angular: [f64; 3],
}

impl Message for TwistStamped {
    const TYPE: &'static str = "geometry_msgs/msg/TwistStamped";
    const HASH: &'static str =
        "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64";

    fn write(&self, out: &mut Writer) {
        self.header.write(out);
        write_vector(out, &self.linear);
        write_vector(out, &self.angular);
    }

    fn read(from: &mut Reader<'_>) -> Result<Self, DecodeError> {
        Ok(Self {
            header: Header::read(from)?,
            linear: read_vector(from)?,
            angular: read_vector(from)?,
        })
    }
}

/// `sensor_msgs/msg/JointState`: named joints' positions, velocities and efforts (each list
/// empty or one entry a name). hapticd's strings are its joints, their tensions the efforts.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct JointState {
    /// When and in which frame.
    pub header: Header,
    /// The joints' names.
    pub name: Vec<String>,
    /// Their positions.
    pub position: Vec<f64>,
    /// Their velocities.
    pub velocity: Vec<f64>,
    /// Their efforts (newtons, for a string).
    pub effort: Vec<f64>,
}

fn write_doubles(out: &mut Writer, values: &[f64]) {
    out.sequence(values.len());
    for v in values {
        out.f64(*v);
    }
}

fn read_doubles(from: &mut Reader<'_>) -> Result<Vec<f64>, DecodeError> {
    let n = from.sequence(8)?;
    (0..n).map(|_| from.f64()).collect()
}

impl Message for JointState {
    const TYPE: &'static str = "sensor_msgs/msg/JointState";
    const HASH: &'static str =
        "RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e";

    fn write(&self, out: &mut Writer) {
        self.header.write(out);
        out.sequence(self.name.len());
        for n in &self.name {
            out.string(n);
        }
        write_doubles(out, &self.position);
        write_doubles(out, &self.velocity);
        write_doubles(out, &self.effort);
    }

    fn read(from: &mut Reader<'_>) -> Result<Self, DecodeError> {
        let header = Header::read(from)?;
        // A string is at least its length and its NUL.
        let names = from.sequence(5)?;
        Ok(Self {
            header,
            name: (0..names)
                .map(|_| from.string())
                .collect::<Result<_, _>>()?,
            position: read_doubles(from)?,
            velocity: read_doubles(from)?,
            effort: read_doubles(from)?,
        })
    }
}

/// `std_msgs/msg/String`: a device's state, or a contact event as JSON.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct StringMessage {
    /// The text.
    pub data: String,
}

impl Message for StringMessage {
    const TYPE: &'static str = "std_msgs/msg/String";
    const HASH: &'static str =
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18";

    fn write(&self, out: &mut Writer) {
        out.string(&self.data);
    }

    fn read(from: &mut Reader<'_>) -> Result<Self, DecodeError> {
        Ok(Self {
            data: from.string()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(frame: &str) -> Header {
        Header {
            stamp: Time {
                sec: 12,
                nanosec: 345,
            },
            frame_id: frame.into(),
        }
    }

    #[test]
    fn a_pose_is_laid_out_as_cdr_aligns_it() {
        let pose = PoseStamped {
            header: header("spidar"),
            position: [0.1, -0.2, 0.3],
            orientation: [0.0, 0.0, 0.0, 1.0],
        };
        let bytes = pose.encode();
        // Header, stamp (8), the string's length (4) and 7 bytes with its NUL, padded to
        // 24 from the header's end, then seven doubles.
        assert_eq!(bytes.len(), 4 + 24 + 7 * 8);
        assert_eq!(bytes[..8], [0, 1, 0, 0, 12, 0, 0, 0]);
        assert_eq!(bytes[12..16], [7, 0, 0, 0]);
        assert_eq!(&bytes[16..23], b"spidar\0");
        assert_eq!(bytes[23..28], [0; 5]);
        assert_eq!(bytes[28..36], 0.1f64.to_le_bytes());
        assert_eq!(PoseStamped::decode(&bytes), Ok(pose));
    }

    #[test]
    fn wrenches_and_twists_come_back_as_they_went() {
        let wrench = WrenchStamped {
            header: header(""),
            force: [1.5, -2.0, 0.25],
            torque: [0.0, 1e-3, -7.0],
        };
        assert_eq!(WrenchStamped::decode(&wrench.encode()), Ok(wrench));
        let twist = TwistStamped {
            header: header("grip"),
            linear: [0.1, 0.0, -0.1],
            angular: [3.0, 2.0, 1.0],
        };
        assert_eq!(TwistStamped::decode(&twist.encode()), Ok(twist));
        let strings = JointState {
            header: header("spidar"),
            name: vec!["string0".into(), "s1".into()],
            position: vec![],
            velocity: vec![],
            effort: vec![0.5, 2.0],
        };
        assert_eq!(JointState::decode(&strings.encode()), Ok(strings));
        let text = StringMessage {
            data: "running".into(),
        };
        assert_eq!(StringMessage::decode(&text.encode()), Ok(text));
        let bodies = PoseArray {
            header: header("world"),
            poses: vec![([0.0, 0.1, 0.2], [0.0, 0.0, 0.0, 1.0]); 3],
        };
        assert_eq!(PoseArray::decode(&bodies.encode()), Ok(bodies));
    }

    #[test]
    fn a_sequence_longer_than_its_message_is_refused() {
        let mut bytes = JointState::default().encode();
        // The names' count follows the stamp and the empty frame id (4 + 8 + 5, padded).
        bytes[20..24].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(JointState::decode(&bytes), Err(DecodeError::Truncated));
    }

    #[test]
    fn bad_messages_are_refused_not_misread() {
        let bytes = WrenchStamped::default().encode();
        for n in 0..bytes.len() {
            assert!(WrenchStamped::decode(&bytes[..n]).is_err(), "{n} bytes");
        }
        let mut big_endian = bytes.clone();
        big_endian[1] = 0;
        assert_eq!(
            WrenchStamped::decode(&big_endian),
            Err(DecodeError::Encapsulation)
        );
        let mut unterminated = bytes.clone();
        unterminated[16] = b'x';
        assert_eq!(
            WrenchStamped::decode(&unterminated),
            Err(DecodeError::BadString)
        );
        let mut huge = bytes;
        huge[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(WrenchStamped::decode(&huge), Err(DecodeError::BadString));
    }

    #[test]
    fn a_time_splits_nanoseconds_into_seconds_and_the_rest() {
        assert_eq!(
            Time::from_nanos(12_000_000_345),
            Time {
                sec: 12,
                nanosec: 345
            }
        );
    }
}
