//! `hapticctl body …`: the running world's bodies, read and changed from outside through the
//! daemon's Scene interface (by name, or by id as a number); shown by
//! [`hapticctl::body_report`].

use clap::{Args, Subcommand};
use hapticctl::body_report;
use hapticd_ipc::client::{BodyState, Scene};

use crate::Failure;
use crate::client::Client;
use crate::mechanism::{Output, print};

#[derive(Subcommand)]
pub enum Command {
    /// The bodies of the running world: id, name, fixed or free.
    List(Output),
    /// Where a body is and how it moves, now.
    Show(Target),
    /// Put a body's centre of mass at X Y Z metres (the forces ramp to zero and back).
    Pose {
        #[command(flatten)]
        target: Target,
        /// X Y Z, metres.
        #[arg(num_args = 3, allow_negative_numbers = true, required = true)]
        position: Vec<f64>,
        /// Its orientation, a unit quaternion W X Y Z (default: none turned).
        #[arg(long, num_args = 4, allow_negative_numbers = true, value_names = ["W", "X", "Y", "Z"])]
        orientation: Option<Vec<f64>>,
    },
    /// Set a body moving at VX VY VZ m/s.
    Velocity {
        #[command(flatten)]
        target: Target,
        /// VX VY VZ, m/s.
        #[arg(num_args = 3, allow_negative_numbers = true, required = true)]
        velocity: Vec<f64>,
        /// Turning at WX WY WZ rad/s (default: not turning).
        #[arg(long, num_args = 3, allow_negative_numbers = true, value_names = ["WX", "WY", "WZ"])]
        spin: Option<Vec<f64>>,
    },
    /// Give a body the momentum JX JY JZ N·s.
    Push {
        #[command(flatten)]
        target: Target,
        /// JX JY JZ, N·s.
        #[arg(num_args = 3, allow_negative_numbers = true, required = true)]
        impulse: Vec<f64>,
        /// Where it acts, X Y Z metres (default: the centre of mass, so the body does not turn).
        #[arg(long, num_args = 3, allow_negative_numbers = true, value_names = ["X", "Y", "Z"])]
        at: Option<Vec<f64>>,
    },
    /// Hold the force FX FY FZ N on a body from now on, besides gravity (0 0 0 ends it).
    Force {
        #[command(flatten)]
        target: Target,
        /// FX FY FZ, newtons.
        #[arg(num_args = 3, allow_negative_numbers = true, required = true)]
        force: Vec<f64>,
    },
    /// Make a body's mass KG kilograms, its inertia scaled with it.
    Mass {
        #[command(flatten)]
        target: Target,
        /// Kilograms.
        kg: f64,
    },
    /// Add a body to the running world: one entry of a scene file's `bodies:` in YAML, such as
    /// '{ name: cube, box: [0.02, 0.02, 0.02], position: [0, 0.05, 0] }' (the world is built
    /// again, the other bodies kept where they are; the forces ramp down and up).
    Add {
        /// The body, in the scene format, with a name no body of the world has.
        body: String,
    },
    /// Remove a body from the running world (the ids after it move down by one).
    Remove {
        /// The body: its name, or its id.
        body: String,
    },
    /// Make the friction coefficient of a body's contacts MU.
    Friction {
        #[command(flatten)]
        target: Target,
        /// The coefficient (a contact takes the lower of its two bodies').
        mu: f64,
    },
    /// Make a soft body of Young's modulus YOUNG Pa and Poisson's ratio POISSON.
    Material {
        #[command(flatten)]
        target: Target,
        /// Young's modulus, Pa.
        young: f64,
        /// Poisson's ratio, 0 to 0.49.
        poisson: f64,
        /// Its damping, seconds (stiffness-proportional).
        #[arg(long, default_value_t = 0.0)]
        damping: f64,
    },
    /// Hold still the nodes of a soft body that stand where NX NY NZ · x ≤ OFFSET now.
    Pin(Plane),
    /// Let go the held nodes of a soft body that stand where NX NY NZ · x ≤ OFFSET now.
    Release(Plane),
}

/// A soft body and the plane bounding its nodes a command is about.
#[derive(Args)]
pub struct Plane {
    #[command(flatten)]
    target: Target,
    /// NX NY NZ: the plane's unit normal, pointing away from the nodes meant.
    #[arg(num_args = 3, allow_negative_numbers = true, required = true)]
    normal: Vec<f64>,
    /// The plane's offset along its normal, metres.
    #[arg(allow_negative_numbers = true)]
    offset: f64,
}

/// The body a command is about, and how to print its state after it.
#[derive(Args)]
pub struct Target {
    /// The body: its name in the scene file, or its id (`hapticctl body list`).
    body: String,
    #[command(flatten)]
    output: Output,
}

/// `values` as `N` numbers (clap has counted them).
fn three(values: &[f64]) -> [f64; 3] {
    [values[0], values[1], values[2]]
}

/// Print `target`'s `state`.
fn show(target: &Target, state: &BodyState) {
    let report = body_report::state(&target.body, state);
    print(&target.output, report.json, report.text);
}

/// Run one `body` subcommand against the daemon on `client`.
pub fn run(command: Command, client: &Client) -> Result<(), Failure> {
    let scene = client.hapticd()?.scene().map_err(|e| client.refused(e))?;
    let act = |target: &Target, change: &dyn Fn(&Scene, &str) -> Result<BodyState, _>| {
        let state = change(&scene, &target.body).map_err(|e| client.refused(e))?;
        show(target, &state);
        Ok(())
    };
    match command {
        Command::List(output) => {
            let bodies = scene.bodies().map_err(|e| client.refused(e))?;
            let report = body_report::list(&bodies);
            print(&output, report.json, report.text);
            Ok(())
        }
        Command::Show(target) => act(&target, &|s, b| s.body(b)),
        Command::Pose {
            target,
            position,
            orientation,
        } => {
            let q = orientation.map_or([1.0, 0.0, 0.0, 0.0], |q| [q[0], q[1], q[2], q[3]]);
            act(&target, &|s, b| s.set_pose(b, three(&position), q))
        }
        Command::Velocity {
            target,
            velocity,
            spin,
        } => {
            let w = spin.map_or([0.0; 3], |w| three(&w));
            act(&target, &|s, b| s.set_velocity(b, three(&velocity), w))
        }
        Command::Push {
            target,
            impulse,
            at,
        } => act(&target, &|s, b| {
            s.apply_impulse(b, three(&impulse), at.as_deref().map(three))
        }),
        Command::Force { target, force } => act(&target, &|s, b| s.set_force(b, three(&force))),
        Command::Mass { target, kg } => act(&target, &|s, b| s.set_mass(b, kg)),
        Command::Friction { target, mu } => act(&target, &|s, b| s.set_friction(b, mu)),
        Command::Material {
            target,
            young,
            poisson,
            damping,
        } => act(&target, &|s, b| {
            s.set_material(b, (young, poisson, damping))
        }),
        Command::Pin(plane) => act(&plane.target, &|s, b| {
            s.pin(b, (three(&plane.normal), plane.offset), true)
        }),
        Command::Release(plane) => act(&plane.target, &|s, b| {
            s.pin(b, (three(&plane.normal), plane.offset), false)
        }),
        Command::Add { body } => {
            let id = scene.add_body(&body).map_err(|e| client.refused(e))?;
            println!("added as body {id}");
            Ok(())
        }
        Command::Remove { body } => Ok(scene.remove_body(&body).map_err(|e| client.refused(e))?),
    }
}
