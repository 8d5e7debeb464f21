//! Reading what a scene plugin's extensions declare: its world's solids, its bodies and
//! their control, and the bodies its contacts name.

use hapticd_plugin_api::geometry::GeometryError;
use hapticd_plugin_api::*;

use glam::DVec3;
use hapticd_config::plugin;
use hapticd_core::haptics::god_object::GodObjectParameters;
use hapticd_core::kinematics::pose_of;
use hapticd_core::scene::control::{self, Incoming, Reply, SceneControl};
use hapticd_core::scene::exact_shapes::{ExactShapes, Solid, SurfacePiece};
use hapticd_core::scene::held_part::{HeldPart, HeldSpec};
use hapticd_core::sync::spsc;
use hapticd_core::world_geometry::{MAX_SOLIDS, MAX_TRIANGLES};
use hapticd_core::world_state::MAX_BODIES;

use super::Instance;

/// What is wrong with an extension a scene plugin declares.
#[derive(Debug, Clone, PartialEq)]
pub enum ExtensionFault {
    /// The extension's struct leaves a function out.
    LacksFunction(&'static str),
    /// A function of it answered with a failing status.
    Failed {
        /// What was being read.
        what: String,
        /// The status it returned.
        status: i32,
    },
    /// The solids it gives break the geometry's rules.
    Solids(GeometryError),
    /// A body's name is no UTF-8 text ending in NUL.
    BodyName(u32),
    /// A joint's name is no UTF-8 text ending in NUL.
    JointName(u32),
    /// The held body it gives cannot be held, for this reason.
    Held(String),
}

impl std::fmt::Display for ExtensionFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ExtensionFault::LacksFunction(which) => {
                write!(f, "its {which} extension lacks a function")
            }
            ExtensionFault::Failed { what, status } => {
                write!(f, "reading its {what} failed (status {status})")
            }
            ExtensionFault::Solids(e) => e.fmt(f),
            ExtensionFault::BodyName(index) => {
                write!(f, "body {index} has no UTF-8 name ending in NUL")
            }
            ExtensionFault::JointName(index) => {
                write!(f, "joint {index} has no UTF-8 name ending in NUL")
            }
            ExtensionFault::Held(why) => f.write_str(why),
        }
    }
}

impl std::error::Error for ExtensionFault {}

/// [main] The solids of `instance`'s world as its plugin's geometry extension gives them
/// (none without one), checked: as many as the shared world shows.
pub(super) fn read_geometry(
    loaded: &plugin::LoadedPlugin,
    instance: &Instance,
) -> Result<Geometry, ExtensionFault> {
    // SAFETY: HapticdSceneGeometry is the struct of the geometry extension.
    let extension: Option<HapticdSceneGeometry> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_GEOMETRY) };
    let Some(extension) = extension else {
        return Ok(Geometry::default());
    };
    let (Some(counts_of), Some(solid_of), Some(triangles_of)) =
        (extension.counts, extension.solid, extension.triangles)
    else {
        return Err(ExtensionFault::LacksFunction("geometry"));
    };
    let failed = |what: &str, status: i32| ExtensionFault::Failed {
        what: what.to_string(),
        status,
    };
    let mut counts = HapticdGeometryCounts::default();
    // SAFETY: a live instance of this plugin on the main thread, a valid out pointer.
    let status = unsafe { counts_of(instance.pointer, &mut counts) };
    if status != HAPTICD_OK {
        return Err(failed("counts", status));
    }
    let mut geometry = Geometry {
        body_count: counts.bodies,
        solids: Vec::new(),
        triangles: vec![HapticdTriangle::default(); (counts.triangles as usize).min(MAX_TRIANGLES)],
    };
    if !geometry.triangles.is_empty() {
        let n = geometry.triangles.len() as u32;
        // SAFETY: as above; `triangles` holds `n` triangles.
        let status =
            unsafe { triangles_of(instance.pointer, 0, n, geometry.triangles.as_mut_ptr()) };
        if status != HAPTICD_OK {
            return Err(failed("triangles", status));
        }
    }
    for index in 0..counts.solids.min(MAX_SOLIDS as u32) {
        let mut solid = HapticdSolid::default();
        // SAFETY: as above.
        let status = unsafe { solid_of(instance.pointer, index, &mut solid) };
        if status != HAPTICD_OK {
            return Err(failed(&format!("solid {index}"), status));
        }
        let end = solid.first_triangle as u64 + solid.triangle_count as u64;
        // A solid whose triangles lie past what pictures hold is left out with them; one
        // past the plugin's own list stays, for the check to refuse.
        let held = geometry.triangles.len() as u64;
        let cut =
            solid.shape == HAPTICD_SHAPE_TRIANGLES && end > held && end <= counts.triangles as u64;
        if !cut {
            geometry.solids.push(solid);
        }
    }
    geometry.check().map_err(ExtensionFault::Solids)?;
    Ok(geometry)
}

/// The stepping side's end of a world's control: the requests, and where answers go.
pub(crate) type Commands = (Incoming, spsc::Producer<Reply>);

/// [main] The bodies of `instance`'s world as its plugin's control extension lists them,
/// with the channel that changes them: the control plane's end and the stepping side's (None
/// without the extension). The extension's `apply` is kept in the instance.
pub(super) fn read_control(
    loaded: &plugin::LoadedPlugin,
    instance: &mut Instance,
) -> Result<Option<(SceneControl, Commands)>, ExtensionFault> {
    // SAFETY: HapticdSceneControl is the struct of the control extension.
    let extension: Option<HapticdSceneControl> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_CONTROL) };
    let Some(extension) = extension else {
        return Ok(None);
    };
    let (Some(body_of), Some(apply)) = (extension.body, extension.apply) else {
        return Err(ExtensionFault::LacksFunction("control"));
    };
    let mut bodies = Vec::new();
    for index in 0..MAX_BODIES as u32 {
        let mut info = HapticdBodyInfo::new("", false);
        // SAFETY: a live instance of this plugin on the main thread, a valid out pointer.
        if unsafe { body_of(instance.pointer, index, &mut info) } != HAPTICD_OK {
            break;
        }
        let name = info.name_str().ok_or(ExtensionFault::BodyName(index))?;
        bodies.push(control::Body {
            name: name.to_string(),
            fixed: info.flags & HAPTICD_SOLID_FIXED != 0,
        });
    }
    instance.apply = Some(apply);
    let joints = read_joints(loaded, instance)?;
    let (control, incoming, replies) = control::channel(bodies, joints);
    Ok(Some((control, (incoming, replies))))
}

/// Most joints a world's control lists.
const MAX_JOINTS: u32 = 1024;

/// [main] The joints of `instance`'s world as its plugin's joints extension lists them
/// (none without one); the extension's `drive` is kept in the instance.
fn read_joints(
    loaded: &plugin::LoadedPlugin,
    instance: &mut Instance,
) -> Result<Vec<control::Joint>, ExtensionFault> {
    // SAFETY: HapticdSceneJoints is the struct of the joints extension.
    let extension: Option<HapticdSceneJoints> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_JOINTS) };
    let Some(extension) = extension else {
        return Ok(Vec::new());
    };
    let (Some(joint_of), Some(drive)) = (extension.joint, extension.drive) else {
        return Err(ExtensionFault::LacksFunction("joints"));
    };
    let mut joints = Vec::new();
    for index in 0..MAX_JOINTS {
        let mut info = HapticdJointInfo::new("", 0);
        // SAFETY: a live instance of this plugin on the main thread, a valid out pointer.
        if unsafe { joint_of(instance.pointer, index, &mut info) } != HAPTICD_OK {
            break;
        }
        let name = info.name_str().ok_or(ExtensionFault::JointName(index))?;
        joints.push(control::Joint {
            name: name.to_string(),
            kind: info.kind,
        });
    }
    instance.drive = Some(drive);
    Ok(joints)
}

/// Most objects a multi-rate scene's planes may name, for contact events.
const MAX_OBJECTS: u32 = 1 << 16;

/// [main] The body of each object of `instance`'s planes, as its plugin's contacts extension
/// names them (none without one); the extension's `touch` is kept in the instance.
pub(super) fn read_contacts(loaded: &plugin::LoadedPlugin, instance: &mut Instance) -> Vec<u32> {
    // SAFETY: HapticdSceneContacts is the struct of the contacts extension.
    let extension: Option<HapticdSceneContacts> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_CONTACTS) };
    let Some(extension) = extension else {
        return Vec::new();
    };
    instance.touch = extension.touch;
    let Some(object_body) = extension.object_body else {
        return Vec::new();
    };
    (0..MAX_OBJECTS)
        // SAFETY: a live instance of this plugin on the main thread.
        .map(|object| unsafe { object_body(instance.pointer, object) })
        .take_while(|&body| body != HAPTICD_NO_BODY)
        .collect()
}

/// [main] What `instance`'s plugin's held extension says of its world of `pointers`
/// pointers, whose objects belong to `object_bodies`: the body a pointer holds, with its
/// god-object built against every body's surface, and the pieces that are exactly balls or
/// boxes; nothing without the extension.
pub(super) fn read_bodies(
    loaded: &plugin::LoadedPlugin,
    instance: &Instance,
    (object_bodies, pointers): (&[u32], usize),
    bodies: u32,
) -> Result<(Option<HeldPart>, ExactShapes), ExtensionFault> {
    // SAFETY: HapticdSceneHeld is the struct of the held extension.
    let extension: Option<HapticdSceneHeld> =
        unsafe { loaded.scene_extension(HAPTICD_EXT_SCENE_HELD) };
    let Some(extension) = extension else {
        return Ok((None, ExactShapes::default()));
    };
    let (Some(held_of), Some(surface_of)) = (extension.held, extension.surface) else {
        return Err(ExtensionFault::LacksFunction("held"));
    };
    let mut held = HapticdHeld::default();
    // SAFETY: a live instance of this plugin on the main thread, a valid out pointer.
    let spec = match unsafe { held_of(instance.pointer, &mut held) } {
        HAPTICD_OK => Some(held_spec(&held, (bodies, pointers)).map_err(ExtensionFault::Held)?),
        HAPTICD_ERROR_ARGUMENT => None,
        status => {
            return Err(ExtensionFault::Failed {
                what: "held body".into(),
                status,
            });
        }
    };
    let failed = |body: u32, status: i32| ExtensionFault::Failed {
        what: format!("body {body}'s surface"),
        status,
    };
    // Piece `piece` of body `body` into `info`, and its first triangles into `out`.
    let ask = |body, piece, info: &mut HapticdSurfacePiece, out: &mut [HapticdTriangle]| {
        let at = match out.is_empty() {
            true => std::ptr::null_mut(),
            false => out.as_mut_ptr(),
        };
        // SAFETY: a live instance of this plugin on the main thread, `info` valid, `out`
        // null or holding the `out.len()` triangles asked for.
        unsafe { surface_of(instance.pointer, body, piece, info, at, out.len() as u32) }
    };
    let mut pieces = Vec::new();
    let mut triangles_read = 0usize;
    for body in 0..bodies {
        for piece in 0.. {
            let mut info = HapticdSurfacePiece::default();
            match ask(body, piece, &mut info, &mut []) {
                HAPTICD_OK => {}
                HAPTICD_ERROR_ARGUMENT => break,
                status => return Err(failed(body, status)),
            }
            // The triangles are the god-object's: without a held body, what each piece is
            // is enough.
            let count = if spec.is_some() {
                info.triangle_count
            } else {
                0
            };
            triangles_read += count as usize;
            if triangles_read > MAX_TRIANGLES {
                return Err(ExtensionFault::Held(format!(
                    "its bodies' surfaces have more than {MAX_TRIANGLES} triangles"
                )));
            }
            let mut triangles = vec![HapticdTriangle::default(); count as usize];
            if count > 0 {
                let status = ask(body, piece, &mut info, &mut triangles);
                if status != HAPTICD_OK || info.triangle_count != count {
                    return Err(failed(body, status));
                }
            }
            let pose = pose_of(&info.pose);
            if !(pose.position.is_finite() && pose.orientation.is_finite()) {
                return Err(ExtensionFault::Held(format!(
                    "body {body} stands at no finite pose"
                )));
            }
            // A piece names an object of its own body, or none.
            let own = object_bodies.get(info.object as usize) == Some(&body);
            pieces.push(SurfacePiece {
                body,
                fixed: info.fixed != 0,
                pose,
                triangles: triangles
                    .iter()
                    .map(|t| t.corners.map(DVec3::from))
                    .collect(),
                exact: exact_solid(&info).filter(|_| own).map(|s| (info.object, s)),
            });
        }
    }
    let held = spec
        .map(|spec| HeldPart::build(&spec, &pieces))
        .transpose()
        .map_err(ExtensionFault::Held)?;
    Ok((held, ExactShapes::of_pieces(&pieces)))
}

/// The ball or box `info` says its piece is exactly, if it says one.
fn exact_solid(info: &HapticdSurfacePiece) -> Option<Solid> {
    let offset = pose_of(&info.offset);
    let size = DVec3::from(info.size);
    match info.shape {
        HAPTICD_SHAPE_SPHERE => Some(Solid::Ball {
            centre: offset.position,
            radius: size.x,
        }),
        HAPTICD_SHAPE_BOX => Some(Solid::Box {
            centre: offset.position,
            rotation: offset.orientation,
            half: size,
        }),
        _ => None,
    }
}

/// How `held` says the body is held, checked against a world of `bodies` bodies and
/// `pointers` pointers: every number finite, the springs above zero.
fn held_spec(held: &HapticdHeld, (bodies, pointers): (u32, usize)) -> Result<HeldSpec, String> {
    if held.pointer as usize >= pointers || held.body >= bodies {
        return Err(format!(
            "pointer {} holds body {}, of {pointers} pointers and {bodies} bodies",
            held.pointer, held.body
        ));
    }
    let grip = DVec3::from(held.grip);
    let springs = [held.stiffness, held.rotational_stiffness];
    let dampers = [held.damping, held.rotational_damping, held.friction];
    if !grip.is_finite()
        || springs.iter().any(|k| !(k.is_finite() && *k > 0.0))
        || dampers.iter().any(|b| !(b.is_finite() && *b >= 0.0))
    {
        return Err(format!(
            "a grip at {grip} with springs {springs:?} and dampers and friction {dampers:?}: \
             finite, springs above 0, the rest not below"
        ));
    }
    Ok(HeldSpec {
        pointer: held.pointer as usize,
        body: held.body,
        grip,
        parameters: GodObjectParameters {
            stiffness: held.stiffness,
            damping: held.damping,
            rotational_stiffness: held.rotational_stiffness,
            rotational_damping: held.rotational_damping,
            friction: held.friction,
            ..GodObjectParameters::default()
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_held_body_no_world_could_hold_is_refused() {
        let good = HapticdHeld {
            pointer: 0,
            body: 2,
            grip: [0.0, 0.01, 0.0],
            stiffness: 2000.0,
            damping: 5.0,
            rotational_stiffness: 2.0,
            rotational_damping: 5e-3,
            friction: 0.4,
        };
        let spec = held_spec(&good, (3, 1)).unwrap();
        assert_eq!((spec.body, spec.grip), (2, DVec3::new(0.0, 0.01, 0.0)));
        assert_eq!(spec.parameters.friction, 0.4);
        for bad in [
            HapticdHeld { body: 3, ..good },
            HapticdHeld { pointer: 1, ..good },
            HapticdHeld {
                stiffness: 0.0,
                ..good
            },
            HapticdHeld {
                rotational_stiffness: f64::INFINITY,
                ..good
            },
            HapticdHeld {
                damping: -1.0,
                ..good
            },
            HapticdHeld {
                friction: f64::NAN,
                ..good
            },
            HapticdHeld {
                grip: [f64::NAN, 0.0, 0.0],
                ..good
            },
        ] {
            assert!(held_spec(&bad, (3, 1)).is_err(), "{bad:?}");
        }
    }
}
