//! `org.hapticd.Hapticd1.Scene` at `/org/hapticd/Hapticd1/scene`: the running world's
//! bodies and joints, read by anyone and changed by those who may change the daemon.
//!
//! A body is named by its scene file's name, or by its id (its place in the world's list)
//! written as a number. Every change is carried out between two steps of the world in every
//! device's copy of it, and answers with the body's state after it; one that would jump a
//! force (a body put elsewhere) waits for the forces to ramp to zero, as a scene switch
//! does. Bodies are added and removed by building the world again from its file, the
//! others' states carried over.

use std::collections::HashMap;
use std::sync::Arc;

use hapticd_plugin_api::*;
use hapticd_service::Workers;
use zbus::interface;
use zbus::message::Header;
use zbus::{OwnedVariant, Variant};

use super::BusError;
use super::{audit, caller, report};
use crate::control::{self, Daemon};

/// The running world's bodies.
pub struct SceneInterface {
    daemon: Arc<Daemon>,
    workers: Arc<Workers>,
}

/// A body's state as the bus returns it.
type State = HashMap<String, OwnedVariant>;

/// `values` as `N` numbers, or an error naming `what`.
fn numbers<const N: usize>(what: &str, values: &[f64]) -> Result<[f64; N], control::Error> {
    values.try_into().map_err(|_| {
        control::Error::OutOfRange(format!("{what} takes {N} numbers, not {}", values.len()))
    })
}

/// The bus form of `state`, for body `body`.
fn state_of(body: &str, state: &HapticdBodyState) -> State {
    let owned =
        |v: Variant<'_>| OwnedVariant::try_from(v).expect("numbers and text hold no descriptor");
    let array = |v: &[f64]| owned(Variant::from(v.to_vec()));
    HashMap::from([
        ("body".into(), owned(Variant::from(body))),
        ("position".into(), array(&state.position)),
        ("orientation".into(), array(&state.orientation)),
        ("velocity".into(), array(&state.velocity)),
        ("spin".into(), array(&state.spin)),
        ("mass".into(), owned(Variant::from(state.mass))),
        ("friction".into(), owned(Variant::from(state.friction))),
        ("force".into(), array(&state.force)),
    ])
}

impl SceneInterface {
    /// The scene interface of `daemon`, running blocking requests on `workers`.
    pub fn new(daemon: Arc<Daemon>, workers: Arc<Workers>) -> Self {
        Self { daemon, workers }
    }

    /// Carry out `command` on `body` for the sender of `header` (a change, unless it is a
    /// query, is logged as `what`).
    async fn drive(
        &self,
        body: String,
        command: Result<HapticdSceneCommand, control::Error>,
        what: Option<String>,
        connection: &zbus::Connection,
        header: &Header<'_>,
    ) -> Result<State, BusError> {
        let daemon = self.daemon.clone();
        let named = body.clone();
        let result = match command {
            Ok(command) => {
                self.workers
                    .run(move || daemon.drive(&named, command))
                    .await
            }
            Err(e) => Err(e),
        };
        if let Some(what) = what {
            let outcome = result.as_ref().map(|_| ()).map_err(|e| e.to_string());
            audit(
                &format!("{what} of body {body:?}"),
                &caller(connection, Some(header)).await,
                &outcome,
            );
        }
        Ok(state_of(&body, &result?))
    }

    /// Pin or release (`kind`) the nodes of soft `body` on the side of the plane
    /// `(normal, offset)` toward which its normal does not point.
    async fn hold(
        &self,
        body: String,
        kind: u32,
        (normal, offset): (Vec<f64>, f64),
        connection: &zbus::Connection,
        header: &Header<'_>,
    ) -> Result<State, BusError> {
        let set = numbers("normal", &normal).map(|n| {
            command(kind, |c| {
                (c.vector, c.value) = (n, offset);
            })
        });
        let verb = if kind == HAPTICD_COMMAND_PIN {
            "pin"
        } else {
            "release"
        };
        let what = format!("{verb} the nodes where {normal:?}·x ≤ {offset} m");
        self.drive(body, set, Some(what), connection, header).await
    }
}

/// Announce that the manager's ActiveSceneFile changed: a world built again comes from a new
/// file (its name stays).
async fn announce_rebuilt(connection: &zbus::Connection) {
    let manager = connection
        .object_server()
        .interface::<_, super::ManagerInterface>(hapticd_ipc::MANAGER_PATH)
        .await;
    if let Ok(manager) = manager {
        report(
            manager
                .get()
                .await
                .active_scene_file_changed(manager.signal_emitter())
                .await,
        );
    }
}

/// A command of `kind` with `fill` applied.
fn command(kind: u32, fill: impl FnOnce(&mut HapticdSceneCommand)) -> HapticdSceneCommand {
    let mut command = HapticdSceneCommand::new(kind, 0);
    fill(&mut command);
    command
}

/// The running world's bodies, by name or id: where each is, how it moves, and changes to
/// them (pose, velocity, impulse, a held force, mass, friction; a soft body's material and
/// held nodes). Every change answers with
/// the body's state after it: `position`, `orientation` (w, x, y, z), `velocity`, `spin`,
/// `force` (arrays of doubles), `mass` and `friction`, under those keys with `body`.
#[interface(name = "org.hapticd.Hapticd1.Scene")]
impl SceneInterface {
    /// The bodies of the running world, in the order of their ids: each one's name and
    /// whether it is fixed. Empty when the scene cannot be changed from outside. Read again
    /// once the manager's ActiveScene changes.
    #[zbus(property(emits_changed_signal = "false"))]
    fn bodies(&self) -> Vec<(String, bool)> {
        self.daemon
            .bodies()
            .into_iter()
            .map(|b| (b.name, b.fixed))
            .collect()
    }

    /// The joints of the running world, in order: each one's name and kind (`fixed`,
    /// `revolute`, `prismatic`, `spherical`). Read again once the manager's ActiveScene
    /// changes.
    #[zbus(property(emits_changed_signal = "false"))]
    fn joints(&self) -> Vec<(String, String)> {
        self.daemon
            .joints()
            .into_iter()
            .map(|j| (j.name.clone(), j.kind_name().to_string()))
            .collect()
    }

    /// Where joint `joint` stands now: its coordinate (rad, a hinge's counted in whole
    /// turns from load; or m) and its rate.
    async fn joint(&self, joint: String) -> Result<(f64, f64), BusError> {
        let query = HapticdJointCommand::default();
        let daemon = self.daemon.clone();
        let state = self
            .workers
            .run(move || daemon.drive_joint(&joint, query))
            .await?;
        Ok((state.position, state.velocity))
    }

    /// Where every joint stands, read between the same two steps of the world: each one's
    /// name, coordinate and rate, in the order of `Joints`.
    async fn joint_states(&self) -> Result<Vec<(String, f64, f64)>, BusError> {
        let daemon = self.daemon.clone();
        let states = self.workers.run(move || daemon.joint_states()).await?;
        Ok(states
            .into_iter()
            .map(|(name, s)| (name, s.position, s.velocity))
            .collect())
    }

    /// Drive joint `joint`'s coordinate with its motor: `motor` `velocity` (to the rate
    /// `target`, rad/s or m/s) or `position` (to `target`, rad or m), with at most
    /// `max_force` (N·m or N, up to 100), or `off`. Answers where the joint stands.
    async fn drive_joint(
        &self,
        joint: String,
        motor: String,
        target: f64,
        max_force: f64,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(f64, f64), BusError> {
        let kind = match motor.as_str() {
            "velocity" => Ok(HAPTICD_JOINT_MOTOR_VELOCITY),
            "position" => Ok(HAPTICD_JOINT_MOTOR_POSITION),
            "off" => Ok(HAPTICD_JOINT_MOTOR_OFF),
            other => Err(control::Error::OutOfRange(format!(
                "a motor drives by `velocity` or `position`, or is `off`, not {other:?}"
            ))),
        };
        let daemon = self.daemon.clone();
        let named = joint.clone();
        let result = match kind {
            Ok(kind) => {
                let command = HapticdJointCommand {
                    kind,
                    joint: 0,
                    target,
                    max_force,
                };
                self.workers
                    .run(move || daemon.drive_joint(&named, command))
                    .await
            }
            Err(e) => Err(e),
        };
        let outcome = result.as_ref().map(|_| ()).map_err(|e| e.to_string());
        audit(
            &format!("drive the joint {joint:?} by {motor} to {target} with {max_force}"),
            &caller(connection, Some(&header)).await,
            &outcome,
        );
        let state = result?;
        Ok((state.position, state.velocity))
    }

    /// Where `body` is and how it moves, now.
    async fn body(
        &self,
        body: String,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<State, BusError> {
        let query = command(HAPTICD_COMMAND_QUERY, |_| {});
        self.drive(body, Ok(query), None, connection, &header).await
    }

    /// Put `body`'s centre of mass at `position` (metres) with `orientation` (a unit
    /// quaternion w, x, y, z), keeping its velocities; fixed bodies too. The forces ramp to
    /// zero first and back after, as for a scene switch.
    async fn set_pose(
        &self,
        body: String,
        position: Vec<f64>,
        orientation: Vec<f64>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<State, BusError> {
        let set = numbers("position", &position).and_then(|p| {
            let q = numbers("orientation", &orientation)?;
            Ok(command(HAPTICD_COMMAND_SET_POSE, |c| {
                (c.position, c.orientation) = (p, q)
            }))
        });
        let what = format!("set the pose {position:?} {orientation:?}");
        self.drive(body, set, Some(what), connection, &header).await
    }

    /// Set `body` moving at `velocity` (m/s) and turning at `spin` (rad/s).
    async fn set_velocity(
        &self,
        body: String,
        velocity: Vec<f64>,
        spin: Vec<f64>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<State, BusError> {
        let set = numbers("velocity", &velocity).and_then(|v| {
            let w = numbers("spin", &spin)?;
            Ok(command(HAPTICD_COMMAND_SET_VELOCITY, |c| {
                (c.vector, c.spin) = (v, w)
            }))
        });
        let what = format!("set the velocity {velocity:?} {spin:?}");
        self.drive(body, set, Some(what), connection, &header).await
    }

    /// Give `body` the momentum `impulse` (N·s) at `point` (metres; empty: its centre of
    /// mass, so that it does not turn).
    async fn apply_impulse(
        &self,
        body: String,
        impulse: Vec<f64>,
        point: Vec<f64>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<State, BusError> {
        // Through the centre: where the stepping thread finds it, not where a query a
        // step earlier did (the body moves meanwhile, and the arm would turn it).
        let push = numbers("impulse", &impulse).and_then(|j| match point.is_empty() {
            true => Ok(command(HAPTICD_COMMAND_IMPULSE_AT_CENTRE, |c| c.vector = j)),
            false => {
                let p = numbers("point", &point)?;
                Ok(command(HAPTICD_COMMAND_IMPULSE, |c| {
                    (c.vector, c.position) = (j, p)
                }))
            }
        });
        let what = format!("give the impulse {impulse:?} at {point:?}");
        self.drive(body, push, Some(what), connection, &header)
            .await
    }

    /// Push `body` with `force` (newtons) at its centre of mass at every step from now on,
    /// besides gravity; a zero force ends it.
    async fn set_force(
        &self,
        body: String,
        force: Vec<f64>,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<State, BusError> {
        let set =
            numbers("force", &force).map(|f| command(HAPTICD_COMMAND_SET_FORCE, |c| c.vector = f));
        let what = format!("hold the force {force:?}");
        self.drive(body, set, Some(what), connection, &header).await
    }

    /// Make `body`'s mass `mass` kg, its inertia scaled with it.
    async fn set_mass(
        &self,
        body: String,
        mass: f64,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<State, BusError> {
        let set = Ok(command(HAPTICD_COMMAND_SET_MASS, |c| c.value = mass));
        let what = format!("set the mass {mass} kg");
        self.drive(body, set, Some(what), connection, &header).await
    }

    /// Add `body`, one entry of a scene file's `bodies:` in YAML (with a `name:` no body of
    /// the world has), to the running world; its id. The world is built again from its
    /// scene file with the body added, every other body kept where it is and as it moves,
    /// and swapped in with the forces ramped down and up as for a scene switch. A scene of
    /// no file, or with a body of a mesh, is not built again (Unavailable).
    async fn add_body(
        &self,
        body: String,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<u32, BusError> {
        let daemon = self.daemon.clone();
        let text = body.clone();
        let result = self.workers.run(move || daemon.add_body(&text)).await;
        let outcome = result.as_ref().map(|_| ()).map_err(|e| e.to_string());
        let what = format!("add the body {:?}", body.lines().next().unwrap_or(""));
        audit(&what, &caller(connection, Some(&header)).await, &outcome);
        let id = result?;
        announce_rebuilt(connection).await;
        Ok(id)
    }

    /// Remove `body` from the running world, built again as for AddBody; the ids after it
    /// move down by one.
    async fn remove_body(
        &self,
        body: String,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<(), BusError> {
        let daemon = self.daemon.clone();
        let named = body.clone();
        let result = self.workers.run(move || daemon.remove_body(&named)).await;
        let outcome = result.as_ref().map(|_| ()).map_err(|e| e.to_string());
        audit(
            &format!("remove the body {body:?}"),
            &caller(connection, Some(&header)).await,
            &outcome,
        );
        result?;
        announce_rebuilt(connection).await;
        Ok(())
    }

    /// Make the friction coefficient of `body`'s contacts `friction` (a contact takes the
    /// lower of its two bodies').
    async fn set_friction(
        &self,
        body: String,
        friction: f64,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<State, BusError> {
        let set = Ok(command(HAPTICD_COMMAND_SET_FRICTION, |c| {
            c.value = friction
        }));
        let what = format!("set the friction {friction}");
        self.drive(body, set, Some(what), connection, &header).await
    }

    /// Make soft `body` of Young's modulus `young` (Pa), Poisson's ratio `poisson` and
    /// damping `damping` (s), its shape and motion kept.
    async fn set_material(
        &self,
        body: String,
        young: f64,
        poisson: f64,
        damping: f64,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<State, BusError> {
        let set = Ok(command(HAPTICD_COMMAND_SET_MATERIAL, |c| {
            c.vector = [young, poisson, damping]
        }));
        let what = format!("set the material E {young} Pa, ν {poisson}, damping {damping} s");
        self.drive(body, set, Some(what), connection, &header).await
    }

    /// Hold still the nodes of soft `body` that stand where normal·x ≤ `offset` (metres)
    /// now, `normal` a unit vector.
    async fn pin(
        &self,
        body: String,
        normal: Vec<f64>,
        offset: f64,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<State, BusError> {
        self.hold(
            body,
            HAPTICD_COMMAND_PIN,
            (normal, offset),
            connection,
            &header,
        )
        .await
    }

    /// Let go the held nodes of soft `body` that stand where normal·x ≤ `offset` (metres)
    /// now, `normal` a unit vector.
    async fn release(
        &self,
        body: String,
        normal: Vec<f64>,
        offset: f64,
        #[zbus(connection)] connection: &zbus::Connection,
        #[zbus(header)] header: Header<'_>,
    ) -> Result<State, BusError> {
        self.hold(
            body,
            HAPTICD_COMMAND_RELEASE,
            (normal, offset),
            connection,
            &header,
        )
        .await
    }
}
