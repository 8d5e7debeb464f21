//! `hapticctl joint …`: the running world's joints, read and driven by their motors through
//! the daemon's Scene interface.

use clap::{Args, Subcommand};
use hapticd_ipc::client::{Joint, JointMotor, JointState};
use serde_json::json;

use crate::Failure;
use crate::client::Client;
use crate::mechanism::{Output, print};

#[derive(Subcommand)]
pub enum Command {
    /// The joints of the running world: name and kind.
    List(Output),
    /// Where a joint stands: its coordinate (rad, a hinge's counted in whole turns; or m)
    /// and its rate.
    Show(Target),
    /// Drive a joint's coordinate with its motor: `--velocity V` (rad/s or m/s) or
    /// `--position P` (rad or m) with at most `--max-force F` (N·m or N), or `--off`.
    Drive {
        #[command(flatten)]
        target: Target,
        /// Drive it at this rate, rad/s or m/s.
        #[arg(long, allow_negative_numbers = true, conflicts_with_all = ["position", "off"])]
        velocity: Option<f64>,
        /// Drive it to this coordinate, rad or m.
        #[arg(long, allow_negative_numbers = true, conflicts_with = "off")]
        position: Option<f64>,
        /// Stop driving it.
        #[arg(long)]
        off: bool,
        /// The most torque or force the motor gives, N·m or N (up to 100).
        #[arg(long, default_value_t = 1.0)]
        max_force: f64,
    },
}

/// The joint a command is about, and how to print its state after it.
#[derive(Args)]
pub struct Target {
    /// The joint's name (`hapticctl joint list`).
    joint: String,
    #[command(flatten)]
    output: Output,
}

/// Print `target`'s `state`.
fn show(target: &Target, state: &JointState) {
    let text = format!(
        "{}: at {} (rad or m), moving at {} (rad/s or m/s)\n",
        target.joint, state.position, state.velocity
    );
    let json = json!({
        "joint": target.joint,
        "position": state.position,
        "velocity": state.velocity,
    });
    print(&target.output, json, text);
}

/// Print the `joints`.
fn list(output: &Output, joints: &[Joint]) {
    let mut text: String = joints
        .iter()
        .map(|j| format!("{:<20} {}\n", j.name, j.kind))
        .collect();
    if joints.is_empty() {
        text = "the running scene has no joints to read or drive from outside\n".into();
    }
    let rows: Vec<_> = joints
        .iter()
        .map(|j| json!({"name": j.name, "kind": j.kind}))
        .collect();
    print(output, json!(rows), text);
}

/// Run one `joint` subcommand against the daemon on `client`.
pub fn run(command: Command, client: &Client) -> Result<(), Failure> {
    let scene = client.hapticd()?.scene().map_err(|e| client.refused(e))?;
    match command {
        Command::List(output) => {
            list(&output, &scene.joints().map_err(|e| client.refused(e))?);
        }
        Command::Show(target) => {
            let state = scene.joint(&target.joint).map_err(|e| client.refused(e))?;
            show(&target, &state);
        }
        Command::Drive {
            target,
            velocity,
            position,
            off,
            max_force,
        } => {
            let motor = match (velocity, position, off) {
                (Some(target), None, false) => JointMotor::Velocity { target, max_force },
                (None, Some(target), false) => JointMotor::Position { target, max_force },
                (None, None, true) => JointMotor::Off,
                _ => {
                    return Err(Failure::usage(
                        "give one of --velocity V, --position P or --off",
                    ));
                }
            };
            let state = scene
                .drive_joint(&target.joint, motor)
                .map_err(|e| client.refused(e))?;
            show(&target, &state);
        }
    }
    Ok(())
}
