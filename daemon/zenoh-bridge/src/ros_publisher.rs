//! A publisher as rmw_zenoh has one: its own id (GID, derived from its liveliness token as
//! rmw_zenoh derives a publisher's), and its own sequence numbers 1, 2, 3… in each sample's
//! attachment, so a subscriber that counts a skipped number as a lost message counts none.
//! What tick a message is of lies in the message (its stamp), not in the attachment.

use std::cell::Cell;

use hapticd_ros2::keys::{attachment, gid};
use zenoh::Wait;

/// A declared publisher with its GID and the number of its next message.
pub(crate) struct RosPublisher<'a> {
    publisher: zenoh::pubsub::Publisher<'a>,
    gid: [u8; 16],
    next: Cell<i64>,
}

impl<'a> RosPublisher<'a> {
    /// `publisher`, announced by the liveliness token `token`.
    pub(crate) fn new(publisher: zenoh::pubsub::Publisher<'a>, token: &str) -> Self {
        Self {
            publisher,
            gid: gid(token),
            next: Cell::new(1),
        }
    }

    /// Put `bytes`, made at `stamp_ns` (nanoseconds since the Unix epoch), as this
    /// publisher's next message.
    pub(crate) fn put(&self, bytes: Vec<u8>, stamp_ns: i64) -> zenoh::Result<()> {
        let sequence = self.next.replace(self.next.get() + 1);
        self.publisher
            .put(bytes)
            .attachment(attachment(sequence, stamp_ns, &self.gid).to_vec())
            .wait()
    }
}
