//! Where the pictures come from: hapticd on the bus, the world its haptic loop writes into
//! shared memory (`OpenWorld`), where everything is, read at every frame, and the scene's
//! solids (`OpenGeometry`), asked for again whenever the frames count another scene. The active scene's file
//! (`ActiveSceneFile`) only names the scene on the status line. A hapticd that restarts is
//! found again by its new bus name.

use std::path::Path;
use std::time::{Duration, Instant};

use glam::DVec3;
use hapticd_core::kinematics::{Dof, Pose};
use hapticd_core::world_state::{WorldFrame, pose_of};
use hapticd_ipc::bus::Bus;
use hapticd_ipc::geometry_share;
use hapticd_ipc::world_share::MappedWorld;
use hapticd_ipc::{BUS_NAME, DEVICE_INTERFACE, MANAGER_INTERFACE, MANAGER_PATH, device_path};
use hapticd_plugin_api::{Geometry, HAPTICD_SOLID_POINTER};
use hapticd_render::camera::Camera;
use hapticd_render::scenery::{DrawnGrip, DrawnString, Scenery};
use hapticd_render::shading::Shaded;

/// How often the bus is asked again whether hapticd and its scene are the same.
const RECHECK: Duration = Duration::from_secs(1);

/// How often a scene's solids are asked for while hapticd shares another scene's.
const ASK_AGAIN: Duration = Duration::from_millis(100);

/// The scene being drawn.
struct Scene {
    switches: u32,
    effectors: u32,
    geometry: Shaded,
    /// Framed when the scene was first drawn, then kept, so that pictures follow one
    /// another.
    camera: Camera,
}

/// One picture's worth: what to draw, from where by default, and a line saying what it is.
pub struct View {
    /// The meshes.
    pub scenery: Scenery,
    /// The scene's camera.
    pub camera: Camera,
    /// Scene, rate and state, for the status line.
    pub status: String,
}

/// Why there is nothing to draw.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NoWorld(pub String);

/// hapticd's world, as the renderer sees it.
pub struct WorldSource {
    bus: Bus,
    device: usize,
    connection: Option<zbus::Connection>,
    /// hapticd's unique bus name when its world was opened.
    owner: Option<String>,
    world: Option<MappedWorld>,
    frame: Box<WorldFrame>,
    scene: Option<Scene>,
    /// The active scene's file as last asked.
    file: String,
    checked: Option<Instant>,
    /// When the scene's solids were last asked for.
    asked: Option<Instant>,
}

impl WorldSource {
    /// The world of hapticd's device `device` on `bus` (not asked for until drawn).
    pub fn new(bus: Bus, device: usize) -> Self {
        Self {
            bus,
            device,
            connection: None,
            owner: None,
            world: None,
            frame: Box::new(WorldFrame::empty()),
            scene: None,
            file: String::new(),
            checked: None,
            asked: None,
        }
    }

    /// What to draw now.
    pub fn view(&mut self) -> Result<View, NoWorld> {
        if self.checked.is_none_or(|t| t.elapsed() >= RECHECK) || self.world.is_none() {
            self.check()?;
        }
        let world = self.world.as_ref().expect("check opened it");
        if world.read(&mut self.frame).is_none() {
            return Err(NoWorld("hapticd's world could not be read whole".into()));
        }
        let frame = &*self.frame;
        let stale = self
            .scene
            .as_ref()
            .is_none_or(|s| s.switches != frame.scene_switches || s.effectors != frame.effectors);
        if stale && self.asked.is_none_or(|t| t.elapsed() >= ASK_AGAIN) {
            self.asked = Some(Instant::now());
            // Until the new scene's solids are there, the last scene's are drawn.
            if let Some(geometry) = self.geometry(frame.scene_switches) {
                let mut scene = Scene {
                    switches: frame.scene_switches,
                    effectors: frame.effectors,
                    geometry: Shaded::new(geometry),
                    camera: Camera::orbit(DVec3::ZERO, 1.0, 0.45, 0.75),
                };
                scene.camera = scenery(&scene.geometry, frame).camera();
                self.scene = Some(scene);
            }
        }
        let (scenery, camera) = match &self.scene {
            Some(scene) => (scenery(&scene.geometry, frame), scene.camera),
            None => {
                let scenery = scenery(&Shaded::default(), frame);
                let camera = scenery.camera();
                (scenery, camera)
            }
        };
        Ok(View {
            scenery,
            camera,
            status: status(&self.file, frame),
        })
    }

    /// The solids of the scene the frames count as `switches`, if hapticd shares that
    /// scene's.
    fn geometry(&self, switches: u32) -> Option<Geometry> {
        let connection = self.connection.as_ref()?;
        let (fd, shared): (zbus::OwnedFd, u32) = zbus::block_on(call(
            connection,
            BUS_NAME,
            &device_path(self.device),
            DEVICE_INTERFACE,
            "OpenGeometry",
            &(),
        ))
        .ok()?;
        if shared != switches {
            return None;
        }
        geometry_share::read(&fd.into())
            .ok()
            .map(|(_, geometry)| geometry)
    }

    /// Ask the bus who hapticd is and what it renders; open its world again if it is new.
    fn check(&mut self) -> Result<(), NoWorld> {
        let bus_error =
            |e: zbus::Error| NoWorld(format!("hapticd is not reachable on {:?}: {e}", self.bus));
        if self.connection.is_none() {
            self.connection = Some(zbus::block_on(self.bus.connection()).map_err(bus_error)?);
        }
        let connection = self.connection.as_ref().expect("connected above");
        let owner = zbus::block_on(call::<String>(
            connection,
            "org.freedesktop.DBus",
            "/org/freedesktop/DBus",
            "org.freedesktop.DBus",
            "GetNameOwner",
            &(BUS_NAME,),
        ))
        .map_err(|_| {
            self.world = None;
            NoWorld(format!("hapticd is not running ({BUS_NAME} has no owner)"))
        })?;
        let file: zbus::OwnedVariant = zbus::block_on(call(
            connection,
            BUS_NAME,
            MANAGER_PATH,
            "org.freedesktop.DBus.Properties",
            "Get",
            &(MANAGER_INTERFACE, "ActiveSceneFile"),
        ))
        .map_err(|e| NoWorld(format!("cannot ask hapticd for its scene: {e}")))?;
        self.file = String::try_from(file).unwrap_or_default();
        if self.world.is_none() || self.owner.as_deref() != Some(owner.as_str()) {
            let fd: zbus::OwnedFd = zbus::block_on(call(
                connection,
                BUS_NAME,
                &device_path(self.device),
                DEVICE_INTERFACE,
                "OpenWorld",
                &(),
            ))
            .map_err(|e| {
                NoWorld(format!(
                    "hapticd gives no world of device {}: {e}",
                    self.device
                ))
            })?;
            let world = MappedWorld::open(&fd.into()).map_err(|e| NoWorld(e.to_string()))?;
            self.world = Some(world);
            self.owner = Some(owner);
            self.scene = None;
        }
        self.checked = Some(Instant::now());
        Ok(())
    }
}

/// Call `method` and decode its reply.
async fn call<T>(
    connection: &zbus::Connection,
    destination: &str,
    path: &str,
    interface: &str,
    method: &str,
    body: &(impl serde::Serialize + zbus::zvariant::DynamicType),
) -> zbus::Result<T>
where
    T: for<'d> zbus::zvariant::DynamicDeserialize<'d>,
{
    let reply = connection
        .call_method(Some(destination), path, Some(interface), method, body)
        .await?;
    reply.body().deserialize()
}

/// `shaded` where `frame` has its bodies, and the device.
fn scenery(shaded: &Shaded, frame: &WorldFrame) -> Scenery {
    let geometry = &shaded.geometry;
    let poses: Vec<Pose> = frame.body_poses().collect();
    let mut scenery = Scenery::of_geometry(shaded, &poses, frame.deformed_corners());
    let effectors = (frame.effectors as usize).min(frame.grips.len());
    let strings: Vec<DrawnString> = (0..(frame.strings as usize).min(frame.motors.len()))
        .map(|k| DrawnString {
            motor: DVec3::from(frame.motors[k]),
            knot: DVec3::from(frame.knots[k]),
            tension: frame.tensions[k],
            range: frame.tension_ranges[k],
        })
        .collect();
    let grips: Vec<DrawnGrip> = (0..effectors)
        .map(|k| DrawnGrip {
            pose: pose_of(&frame.grips[k]),
            dof: if frame.dofs[k] == 6 {
                Dof::Six
            } else {
                Dof::Three
            },
            force: DVec3::from(frame.wrenches[k].force),
            torque: DVec3::from(frame.wrenches[k].torque),
        })
        .collect();
    // The proxies, or the pointers' solids in the world, show where the fingers rest.
    let rests_shown = frame.has_proxies != 0
        || geometry
            .solids
            .iter()
            .any(|s| s.flags & HAPTICD_SOLID_POINTER != 0);
    scenery.add_device(&strings, &grips, !rests_shown);
    if frame.has_proxies != 0 {
        let proxies: Vec<DVec3> = frame.proxies[..effectors]
            .iter()
            .map(|p| DVec3::from(*p))
            .collect();
        scenery.add_proxies(&proxies);
    }
    scenery
}

/// `blocks | 1000 Hz | running | 12.3 s`.
fn status(file: &str, frame: &WorldFrame) -> String {
    let scene = Path::new(file).file_stem().map_or_else(
        || "no scene file".into(),
        |s| s.to_string_lossy().into_owned(),
    );
    let state = frame.device_state().name();
    format!(
        "{scene} | {:.0} Hz | {state} | {:.1} s",
        frame.rate, frame.time
    )
}
