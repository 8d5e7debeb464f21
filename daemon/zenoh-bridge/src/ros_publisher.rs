//! A publisher as rmw_zenoh has one: its own id (GID, derived from its liveliness token as
//! rmw_zenoh derives a publisher's), and its own sequence numbers 1, 2, 3… in each sample's
//! attachment, so a subscriber that counts a skipped number as a lost message counts none.
//! What tick a message is of lies in the message (its stamp), not in the attachment.
//!
//! A transient-local publisher ([`RosPublisher::latched`]) also keeps its last message for
//! subscriptions that come later, as Zenoh's advanced publisher with a cache does (which
//! rmw_zenoh uses for such publishers): a queryable and a liveliness token on
//! `<key>/@adv/pub/<zid>/uhlc/_` (the cache's key for samples ordered by timestamp), which
//! an advanced subscriber with history finds and asks; it answers with the message on the
//! topic's own key, with its attachment and the same timestamp as the sample published, so
//! a subscriber that also heard it live keeps one of the two.

use std::cell::Cell;
use std::sync::{Arc, Mutex};

use hapticd_ros2::keys::{attachment, gid};
use zenoh::Wait;
use zenoh::time::Timestamp;

/// A declared publisher with its GID and the number of its next message.
pub(crate) struct RosPublisher<'a> {
    publisher: zenoh::pubsub::Publisher<'a>,
    gid: [u8; 16],
    next: Cell<i64>,
    latched: Option<Latched>,
}

/// The last message of a transient-local publisher, and what hands it to late subscribers.
struct Latched {
    session: zenoh::Session,
    last: Arc<Mutex<Option<Kept>>>,
    _cache: zenoh::query::Queryable<()>,
    _token: zenoh::liveliness::LivelinessToken,
}

/// A message as it was published.
#[derive(Clone)]
struct Kept {
    payload: Vec<u8>,
    attachment: Vec<u8>,
    timestamp: Timestamp,
}

impl<'a> RosPublisher<'a> {
    /// `publisher`, announced by the liveliness token `token`.
    pub(crate) fn new(publisher: zenoh::pubsub::Publisher<'a>, token: &str) -> Self {
        Self {
            publisher,
            gid: gid(token),
            next: Cell::new(1),
            latched: None,
        }
    }

    /// `publisher` of `session`, announced by `token` as transient-local: its last message
    /// is kept for subscriptions that come later.
    pub(crate) fn latched(
        session: &zenoh::Session,
        publisher: zenoh::pubsub::Publisher<'a>,
        token: &str,
    ) -> zenoh::Result<Self> {
        let topic = publisher.key_expr().clone().into_owned();
        let cache = format!("{topic}/@adv/pub/{}/uhlc/_", session.zid());
        let last: Arc<Mutex<Option<Kept>>> = Arc::default();
        let kept = last.clone();
        let queryable = session
            .declare_queryable(cache.clone())
            .callback(move |query| {
                // A subscriber asks for its history's depth (`_max`); the cache holds one.
                let wanted = query.parameters().get("_max").map(str::parse::<usize>);
                if matches!(wanted, Some(Ok(0))) {
                    return;
                }
                let message = kept.lock().unwrap_or_else(|p| p.into_inner()).clone();
                if let Some(m) = message
                    && let Err(e) = query
                        .reply(topic.clone(), m.payload)
                        .attachment(m.attachment)
                        .timestamp(m.timestamp)
                        .wait()
                {
                    tracing::warn!("answering a late subscriber of {topic}: {e}");
                }
            })
            .wait()?;
        let token_of_cache = session.liveliness().declare_token(cache).wait()?;
        let mut this = Self::new(publisher, token);
        this.latched = Some(Latched {
            session: session.clone(),
            last,
            _cache: queryable,
            _token: token_of_cache,
        });
        Ok(this)
    }

    /// Put `bytes`, made at `stamp_ns` (nanoseconds since the Unix epoch), as this
    /// publisher's next message.
    pub(crate) fn put(&self, bytes: Vec<u8>, stamp_ns: i64) -> zenoh::Result<()> {
        let sequence = self.next.replace(self.next.get() + 1);
        let attachment = attachment(sequence, stamp_ns, &self.gid).to_vec();
        let Some(latched) = &self.latched else {
            return self.publisher.put(bytes).attachment(attachment).wait();
        };
        let timestamp = latched.session.new_timestamp();
        *latched.last.lock().unwrap_or_else(|p| p.into_inner()) = Some(Kept {
            payload: bytes.clone(),
            attachment: attachment.clone(),
            timestamp,
        });
        self.publisher
            .put(bytes)
            .attachment(attachment)
            .timestamp(timestamp)
            .wait()
    }
}
