//! `--record`: every tick's frame (time, state, poses, wrenches, tensions) as a CSV row,
//! written by a thread of its own from the ring the real-time thread fills.

use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use hapticd_core::haptic_loop::{DeviceState, Frame};
use hapticd_core::kinematics::quat_to_wxyz;
use hapticd_core::mechanism::Mechanism;
use hapticd_core::sync::spsc;

/// The CSV header for `mechanism`'s effectors and strings.
pub fn csv_header(mechanism: &Mechanism) -> String {
    let mut header = String::from("time,state");
    for e in &mechanism.effectors {
        for field in [
            "x", "y", "z", "qw", "qx", "qy", "qz", "fx", "fy", "fz", "tx", "ty", "tz",
        ] {
            header += &format!(",{}_{field}", e.name);
        }
    }
    for i in 0..mechanism.strings.len() {
        header += &format!(",tension_{i}");
    }
    header
}

/// One frame as a CSV row under [`csv_header`].
fn csv_row(frame: &Frame) -> String {
    let state = match frame.state {
        DeviceState::Running => "running",
        DeviceState::Fault => "fault",
        DeviceState::Disconnected => "disconnected",
        DeviceState::Uncalibrated => "uncalibrated",
    };
    let mut row = format!("{:.6},{state}", frame.time);
    for e in 0..frame.effectors {
        let p = frame.poses[e].position;
        for v in p
            .to_array()
            .into_iter()
            .chain(quat_to_wxyz(frame.poses[e].orientation))
        {
            row += &format!(",{v:.7}");
        }
        for v in frame.wrenches[e].to_array() {
            row += &format!(",{v:.5}");
        }
    }
    for t in &frame.tensions[..frame.strings] {
        row += &format!(",{t:.5}");
    }
    row
}

/// Drain `frames` into a CSV file until `done` is set and the ring is empty.
pub fn spawn_recorder(
    path: PathBuf,
    header: String,
    mut frames: spsc::Consumer<Frame>,
    done: &'static AtomicBool,
) -> Result<std::thread::JoinHandle<std::io::Result<()>>, String> {
    let file = std::fs::File::create(&path)
        .map_err(|e| format!("{}: cannot create: {e}", path.display()))?;
    Ok(std::thread::spawn(move || {
        let mut out = std::io::BufWriter::new(file);
        writeln!(out, "{header}")?;
        loop {
            let finished = done.load(Ordering::Acquire);
            while let Some(frame) = frames.pop() {
                writeln!(out, "{}", csv_row(&frame))?;
            }
            if finished {
                return out.flush();
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }))
}
