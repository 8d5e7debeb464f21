//! A world stepped on another machine (thesis Fig. 6.13's hierarchy over a network): a
//! world host runs the physics for the pointers of several haptic hosts; each haptic host
//! renders it locally from the intermediate representation, exactly as it renders a world
//! stepped in its own physics thread ([`multirate`](super::multirate)).
//!
//! Two messages cross, little-endian ([`wire`](crate::wire)):
//! - [`WorldUpdate`], world host → haptic host after every step: the planes near each of
//!   the host's pointers (each with how it gives under a press: a soft body's), the bodies it moves itself (local dynamics, with the last of the
//!   host's own changes the step took in, and how a jointed one moves through its joints),
//!   and where every body is, for pictures;
//! - host → world host, as often as the haptic side hands something back and at least
//!   twice a world period ([`encode_host`]): where the grips and proxies are, and the
//!   impulses and local changes since the last message.
//!
//! Neither side trusts the other: every count is bounded before it sizes anything, and the
//! haptic host checks what it renders as it checks a plugin's planes.
//!
//! A haptic host's scene file says only that its world is elsewhere and how fast it steps:
//!
//! ```yaml
//! engine: remote
//! rate: 60
//! ```

use std::path::Path;

use hapticd_plugin_api::{
    HAPTICD_MAX_BODY_CONTACTS, HAPTICD_MAX_LOCAL_BODIES, HAPTICD_MAX_PLANES, HapticdBodyContact,
    HapticdBodyPose, HapticdImpulse, HapticdLocalBody, HapticdLocalState, HapticdMobility,
    HapticdPlane, HapticdPlaneCompliance, HapticdPlanes, HapticdPointer,
};
use serde::Deserialize;

use crate::diagnostics::{self, Diagnostics, Findings};
use crate::kinematics::MAX_EFFECTORS;
use crate::scene::multirate::PlaneSet;
use crate::wire::{Decoder, Encoder};

/// The `engine:` of a scene whose world is on another machine.
pub const ENGINE: &str = "remote";

/// First bytes of a [`WorldUpdate`].
pub const WORLD_MAGIC: u32 = u32::from_le_bytes(*b"hdW4");

/// First bytes of a host's message.
pub const HOST_MAGIC: u32 = u32::from_le_bytes(*b"hdH2");

/// Most bodies whose poses one update carries (pictures of larger worlds show these).
pub const MAX_POSES: usize = 512;

/// Most impulses or local changes one host message carries (a period gives at most one per
/// plane, 32, and one per local body, 8).
pub const MAX_HAND_BACKS: usize = 64;

/// Largest encoded [`WorldUpdate`], bytes.
pub const MAX_WORLD_BYTES: usize = 4
    + 8
    + 4
    + 4
    + MAX_EFFECTORS * (4 + HAPTICD_MAX_PLANES * PLANE_BYTES)
    + 4
    + HAPTICD_MAX_LOCAL_BODIES * (BODY_BYTES + MOBILITY_BYTES)
    + 4
    + MAX_POSES * 7 * 8;

/// Largest encoded host message, bytes.
pub const MAX_HOST_BYTES: usize = 4
    + 8
    + 4
    + 2 * MAX_EFFECTORS * POINTER_BYTES
    + 2 * 4
    + MAX_HAND_BACKS * (IMPULSE_BYTES + LOCAL_BYTES);

const PLANE_BYTES: usize = 4 + 11 * 8;
const CONTACT_BYTES: usize = 8 * 8;
const MOBILITY_BYTES: usize = 4 + 42 * 8;
const BODY_BYTES: usize = 4 * 4 + 8 + 30 * 8 + 4 + HAPTICD_MAX_BODY_CONTACTS * CONTACT_BYTES;
const POINTER_BYTES: usize = 10 * 8;
const IMPULSE_BYTES: usize = 4 + 6 * 8;
const LOCAL_BYTES: usize = 4 + 8 + 12 * 8 + 4;

/// A remote scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRemote {
    engine: String,
    rate: f64,
    /// Haptic effects: the daemon checks them against each device and renders them.
    #[serde(default)]
    #[allow(dead_code)]
    effects: Vec<crate::haptics::effects::spec::EffectSpec>,
}

/// What a haptic host knows of a world stepped elsewhere before it hears from it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RemoteSceneSpec {
    /// The world's physics steps per second (10–1000): how old a set may grow before the
    /// world counts as gone.
    pub rate: f64,
}

impl RemoteSceneSpec {
    /// The spec of scene file `text`, named `path` in findings.
    pub fn parse(text: &str, path: &Path) -> Result<Self, Diagnostics> {
        let parsed = diagnostics::parse_yaml::<RawRemote>(text, path)?;
        let (raw, map) = (parsed.value, parsed.map);
        let locate = |field: &str| map.find(field);
        let mut f = Findings::after_schema(path, &locate, parsed.schema);
        if raw.engine != ENGINE {
            f.error("engine", format!("must be {ENGINE}"));
        }
        if !(10.0..=1000.0).contains(&raw.rate) {
            f.error("rate", "must be 10 to 1000 steps a second");
        }
        f.finish()?;
        Ok(Self { rate: raw.rate })
    }
}

/// The head of a [`WorldUpdate`] as read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WorldUpdate {
    /// The world's step, increasing.
    pub step: u64,
    /// Pointers whose planes it carries.
    pub pointers: usize,
    /// Bodies whose poses it carries.
    pub poses: usize,
}

fn put_pointer(out: &mut Encoder, p: &HapticdPointer) {
    out.f64s(&p.position);
    out.f64s(&p.orientation);
    out.f64s(&p.velocity);
}

fn get_pointer(from: &mut Decoder) -> Option<HapticdPointer> {
    Some(HapticdPointer {
        position: from.array()?,
        orientation: from.array()?,
        velocity: from.array()?,
    })
}

fn put_body(out: &mut Encoder, b: &HapticdLocalBody) {
    out.u32(b.body);
    out.u32(b.first_object);
    out.u32(b.object_count);
    out.u32(b.left_out);
    out.u64(b.applied);
    out.f64s(&b.position);
    out.f64s(&b.orientation);
    out.f64s(&b.velocity);
    out.f64s(&b.spin);
    out.f64s(&[b.inverse_mass]);
    out.f64s(&b.inverse_inertia);
    out.f64s(&b.acceleration);
    let count = (b.contact_count as usize).min(HAPTICD_MAX_BODY_CONTACTS);
    out.u32(count as u32);
    for c in &b.contacts[..count] {
        out.f64s(&c.point);
        out.f64s(&c.normal);
        out.f64s(&[c.gap, c.friction]);
    }
}

fn get_body(from: &mut Decoder) -> Option<HapticdLocalBody> {
    let mut b = HapticdLocalBody {
        body: from.u32()?,
        first_object: from.u32()?,
        object_count: from.u32()?,
        left_out: from.u32()?,
        applied: from.u64()?,
        position: from.array()?,
        orientation: from.array()?,
        velocity: from.array()?,
        spin: from.array()?,
        ..HapticdLocalBody::default()
    };
    [b.inverse_mass] = from.array()?;
    b.inverse_inertia = from.array()?;
    b.acceleration = from.array()?;
    let count = from.count(HAPTICD_MAX_BODY_CONTACTS, CONTACT_BYTES)?;
    b.contact_count = count as u32;
    for c in &mut b.contacts[..count] {
        *c = HapticdBodyContact {
            point: from.array()?,
            normal: from.array()?,
            gap: 0.0,
            friction: 0.0,
        };
        [c.gap, c.friction] = from.array()?;
    }
    Some(b)
}

/// A jointed body's mobility after its body (a flag, then its numbers), or a free body's
/// flag alone.
fn put_mobility(out: &mut Encoder, m: Option<&HapticdMobility>) {
    out.u32(u32::from(m.is_some()));
    if let Some(m) = m {
        for row in &m.mobility {
            out.f64s(row);
        }
        out.f64s(&m.acceleration);
    }
}

fn get_mobility(from: &mut Decoder) -> Option<Option<HapticdMobility>> {
    match from.u32()? {
        0 => Some(None),
        1 => {
            let mut m = HapticdMobility::default();
            for row in &mut m.mobility {
                *row = from.array()?;
            }
            m.acceleration = from.array()?;
            Some(Some(m))
        }
        _ => None,
    }
}

/// Write the update of world step `step` for a host: the planes of its `pointers` first
/// pointers in `set`, `set`'s local bodies, and `poses` (at most [`MAX_POSES`] of them).
pub fn encode_world(
    out: &mut Encoder,
    step: u64,
    set: &PlaneSet,
    pointers: usize,
    poses: &[HapticdBodyPose],
) {
    out.u32(WORLD_MAGIC);
    out.u64(step);
    out.u32(u32::from(set.shared));
    let pointers = pointers.min(MAX_EFFECTORS);
    out.u32(pointers as u32);
    for (planes, gives) in set.planes[..pointers].iter().zip(&set.compliances) {
        let count = (planes.count as usize).min(HAPTICD_MAX_PLANES);
        out.u32(count as u32);
        for (p, g) in planes.planes[..count].iter().zip(gives) {
            out.u32(p.object);
            out.f64s(&p.point);
            out.f64s(&p.normal);
            out.f64s(&p.velocity);
            out.f64s(&[g.compliance, g.load]);
        }
    }
    let bodies = (set.body_count as usize).min(HAPTICD_MAX_LOCAL_BODIES);
    out.u32(bodies as u32);
    for (b, m) in set.bodies[..bodies].iter().zip(&set.mobilities) {
        put_body(out, b);
        put_mobility(out, m.as_ref());
    }
    let poses = &poses[..poses.len().min(MAX_POSES)];
    out.u32(poses.len() as u32);
    for p in poses {
        out.f64s(&p.position);
        out.f64s(&p.orientation);
    }
}

/// Read a [`WorldUpdate`] into `set` (its planes and bodies; sequence and timing left alone)
/// and `poses`; None for bytes that are no whole update (counts past the limits included),
/// `set` and `poses` then in no particular state.
pub fn decode_world(
    bytes: &[u8],
    set: &mut PlaneSet,
    poses: &mut [HapticdBodyPose],
) -> Option<WorldUpdate> {
    let mut from = Decoder::new(bytes);
    if from.u32()? != WORLD_MAGIC {
        return None;
    }
    let step = from.u64()?;
    set.shared = from.u32()? != 0;
    let pointers = from.count(MAX_EFFECTORS, 4)?;
    set.planes = [HapticdPlanes::default(); MAX_EFFECTORS];
    set.compliances = [[HapticdPlaneCompliance::default(); HAPTICD_MAX_PLANES]; MAX_EFFECTORS];
    for (planes, gives) in set.planes[..pointers].iter_mut().zip(&mut set.compliances) {
        let count = from.count(HAPTICD_MAX_PLANES, PLANE_BYTES)?;
        planes.count = count as u32;
        for (p, g) in planes.planes[..count].iter_mut().zip(gives.iter_mut()) {
            *p = HapticdPlane {
                object: from.u32()?,
                point: from.array()?,
                normal: from.array()?,
                velocity: from.array()?,
            };
            let [compliance, load] = from.array()?;
            *g = HapticdPlaneCompliance { compliance, load };
        }
    }
    let bodies = from.count(
        HAPTICD_MAX_LOCAL_BODIES,
        BODY_BYTES - HAPTICD_MAX_BODY_CONTACTS * CONTACT_BYTES + 4,
    )?;
    set.body_count = bodies as u32;
    for (b, m) in set.bodies[..bodies].iter_mut().zip(&mut set.mobilities) {
        *b = get_body(&mut from)?;
        *m = get_mobility(&mut from)?;
    }
    let count = from.count(MAX_POSES.min(poses.len()), 7 * 8)?;
    for p in &mut poses[..count] {
        *p = HapticdBodyPose {
            position: from.array()?,
            orientation: from.array()?,
        };
    }
    from.finished().then_some(WorldUpdate {
        step,
        pointers,
        poses: count,
    })
}

/// What a haptic host tells the world host.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct HostUpdate {
    /// The world step of the last update the host rendered from (0: none yet): what it has
    /// seen of the other hosts' changes.
    pub seen: u64,
    /// The grips, one per pointer.
    pub pointers: Vec<HapticdPointer>,
    /// Where each pointer's proxy rests.
    pub proxies: Vec<HapticdPointer>,
    /// Impulses on objects the host did not move itself.
    pub impulses: Vec<HapticdImpulse>,
    /// The hand's changes on bodies the host moved.
    pub locals: Vec<HapticdLocalState>,
    /// For each of `locals`, whether the host's hand moved the body that period (else it only
    /// brings the world's body to where the host's own integration has it).
    pub touched: Vec<bool>,
}

/// Write a host's message: the world step it last rendered from, its grips and proxies (as
/// many), and what it hands back (at most [`MAX_HAND_BACKS`] of each; the caller sends the
/// rest in the next).
pub fn encode_host(
    out: &mut Encoder,
    seen: u64,
    pointers: &[HapticdPointer],
    proxies: &[HapticdPointer],
    impulses: &[HapticdImpulse],
    (locals, touched): (&[HapticdLocalState], &[bool]),
) {
    out.u32(HOST_MAGIC);
    out.u64(seen);
    let n = pointers.len().min(proxies.len()).min(MAX_EFFECTORS);
    out.u32(n as u32);
    for p in pointers[..n].iter().chain(&proxies[..n]) {
        put_pointer(out, p);
    }
    let impulses = &impulses[..impulses.len().min(MAX_HAND_BACKS)];
    out.u32(impulses.len() as u32);
    for i in impulses {
        out.u32(i.object);
        out.f64s(&i.point);
        out.f64s(&i.impulse);
    }
    let locals = &locals[..locals.len().min(MAX_HAND_BACKS)];
    out.u32(locals.len() as u32);
    for (k, l) in locals.iter().enumerate() {
        out.u32(l.body);
        out.u64(l.sequence);
        out.f64s(&l.displacement);
        out.f64s(&l.rotation);
        out.f64s(&l.velocity);
        out.f64s(&l.spin);
        out.u32(u32::from(touched.get(k).copied().unwrap_or(true)));
    }
}

/// Read a host's message; None for bytes that are no whole message.
pub fn decode_host(bytes: &[u8]) -> Option<HostUpdate> {
    let mut from = Decoder::new(bytes);
    if from.u32()? != HOST_MAGIC {
        return None;
    }
    let seen = from.u64()?;
    let n = from.count(MAX_EFFECTORS, 2 * POINTER_BYTES)?;
    let mut update = HostUpdate {
        seen,
        ..HostUpdate::default()
    };
    for _ in 0..n {
        update.pointers.push(get_pointer(&mut from)?);
    }
    for _ in 0..n {
        update.proxies.push(get_pointer(&mut from)?);
    }
    for _ in 0..from.count(MAX_HAND_BACKS, IMPULSE_BYTES)? {
        update.impulses.push(HapticdImpulse {
            object: from.u32()?,
            point: from.array()?,
            impulse: from.array()?,
        });
    }
    for _ in 0..from.count(MAX_HAND_BACKS, LOCAL_BYTES)? {
        update.locals.push(HapticdLocalState {
            body: from.u32()?,
            sequence: from.u64()?,
            displacement: from.array()?,
            rotation: from.array()?,
            velocity: from.array()?,
            spin: from.array()?,
        });
        update.touched.push(from.u32()? != 0);
    }
    from.finished().then_some(update)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set() -> PlaneSet {
        let mut set = PlaneSet::default();
        set.planes[0].count = 2;
        set.planes[0].planes[1] = HapticdPlane {
            object: 7,
            point: [0.1, 0.2, 0.3],
            normal: [0.0, 1.0, 0.0],
            velocity: [-1.0, 0.5, 0.25],
        };
        // A soft body's plane gives; the other plane is rigid.
        set.compliances[0][1] = HapticdPlaneCompliance {
            compliance: 4e-4,
            load: 1.25,
        };
        set.planes[1].count = 1;
        set.shared = true;
        set.body_count = 2;
        // The second body a door through its hinge: its mobility crosses whole.
        let mut door = HapticdMobility::default();
        door.mobility[4][4] = 7.5;
        door.mobility[2][4] = 0.25;
        door.mobility[4][2] = 0.25;
        door.acceleration = [0.0, 0.0, 0.1, 0.0, -0.5, 0.0];
        set.mobilities[1] = Some(door);
        set.bodies[1] = HapticdLocalBody {
            body: 5,
            orientation: [1.0, 0.0, 0.0, 0.0],
            inverse_mass: 2.0,
            ..HapticdLocalBody::default()
        };
        set.bodies[0] = HapticdLocalBody {
            body: 3,
            first_object: 4,
            object_count: 2,
            left_out: 1,
            applied: 99,
            position: [1.0, 2.0, 3.0],
            orientation: [1.0, 0.0, 0.0, 0.0],
            inverse_mass: 10.0,
            inverse_inertia: [1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0],
            acceleration: [0.0, -9.81, 0.0],
            contact_count: 1,
            ..HapticdLocalBody::default()
        };
        set.bodies[0].contacts[0] = HapticdBodyContact {
            point: [0.0, -0.01, 0.0],
            normal: [0.0, 1.0, 0.0],
            gap: -1e-4,
            friction: 0.5,
        };
        set
    }

    #[test]
    fn a_world_update_reads_back_as_written() {
        let sent = set();
        let poses = [HapticdBodyPose {
            position: [0.5, 0.0, -0.5],
            orientation: [0.0, 1.0, 0.0, 0.0],
        }; 3];
        let mut out = Encoder::default();
        encode_world(&mut out, 42, &sent, 2, &poses);
        assert!(out.bytes().len() <= MAX_WORLD_BYTES);
        let mut got = PlaneSet::default();
        let mut read = [HapticdBodyPose::default(); 8];
        let head = decode_world(out.bytes(), &mut got, &mut read).unwrap();
        assert_eq!(
            head,
            WorldUpdate {
                step: 42,
                pointers: 2,
                poses: 3
            }
        );
        assert_eq!(got.planes[..2], sent.planes[..2]);
        assert_eq!(got.compliances[..2], sent.compliances[..2]);
        assert_eq!(got.body_count, 2);
        assert_eq!(got.bodies[..2], sent.bodies[..2]);
        assert_eq!(got.mobilities[..2], sent.mobilities[..2]);
        assert_eq!(read[..3], poses);
    }

    #[test]
    fn a_host_message_reads_back_as_written() {
        let grip = HapticdPointer {
            position: [0.0, 0.1, 0.0],
            orientation: [1.0, 0.0, 0.0, 0.0],
            velocity: [0.2, 0.0, 0.0],
        };
        let sent = HostUpdate {
            seen: 12,
            pointers: vec![grip; 2],
            proxies: vec![grip; 2],
            impulses: vec![HapticdImpulse {
                object: 5,
                point: [0.0; 3],
                impulse: [0.0, -0.01, 0.0],
            }],
            locals: vec![HapticdLocalState {
                body: 2,
                sequence: 17,
                displacement: [1e-3, 0.0, 0.0],
                ..HapticdLocalState::default()
            }],
            touched: vec![false],
        };
        let mut out = Encoder::default();
        encode_host(
            &mut out,
            sent.seen,
            &sent.pointers,
            &sent.proxies,
            &sent.impulses,
            (&sent.locals, &sent.touched),
        );
        assert!(out.bytes().len() <= MAX_HOST_BYTES);
        assert_eq!(decode_host(out.bytes()), Some(sent));
    }

    #[test]
    fn truncated_padded_or_foreign_bytes_are_no_message() {
        let mut out = Encoder::default();
        encode_world(&mut out, 1, &set(), 2, &[]);
        let bytes = out.into_bytes();
        let (mut got, mut poses) = (PlaneSet::default(), [HapticdBodyPose::default(); 1]);
        for cut in [0, 3, 4, 20, bytes.len() - 1] {
            assert_eq!(decode_world(&bytes[..cut], &mut got, &mut poses), None);
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert_eq!(decode_world(&longer, &mut got, &mut poses), None);
        let mut other = bytes.clone();
        other[0] ^= 1;
        assert_eq!(decode_world(&other, &mut got, &mut poses), None);
        // A count of planes past the limit is refused, not trusted.
        let mut many = bytes.clone();
        many[16..20].copy_from_slice(&(HAPTICD_MAX_PLANES as u32 + 1).to_le_bytes());
        assert_eq!(decode_world(&many, &mut got, &mut poses), None);
        assert_eq!(
            decode_host(&bytes),
            None,
            "a world update is no host message"
        );
    }

    #[test]
    fn a_remote_scene_file_names_its_engine_and_a_rate_in_range() {
        let parse = |text: &str| RemoteSceneSpec::parse(text, Path::new("far.yaml"));
        assert_eq!(
            parse("engine: remote\nrate: 60\n").unwrap(),
            RemoteSceneSpec { rate: 60.0 }
        );
        for bad in [
            "engine: remote\nrate: 5\n",
            "engine: remote\nrate: .nan\n",
            "engine: remote\n",
            "engine: remote\nrate: 60\nhost: x\n",
        ] {
            let error = parse(bad).unwrap_err().to_string();
            assert!(error.contains("far.yaml"), "{bad}: {error}");
        }
    }
}
