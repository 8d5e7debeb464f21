//! `--record`: every tick's frame as a CSV row in the columns of every recording
//! ([`telemetry_csv`]),
//! written by a thread of its own from the ring the real-time thread fills.

use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use hapticd_core::haptic_loop::Frame;
use hapticd_core::mechanism::Mechanism;
use hapticd_core::sync::spsc;
use hapticd_core::telemetry::Sample;
use hapticd_ipc::telemetry_csv;

/// The CSV header for `mechanism`'s effectors and strings ([`telemetry_csv`]).
pub fn csv_header(mechanism: &Mechanism) -> String {
    let names: Vec<String> = mechanism.effectors.iter().map(|e| e.name.clone()).collect();
    telemetry_csv::header(&names, mechanism.strings.len())
}

/// One frame, ticking at `rate` hertz, as a CSV row under [`csv_header`]: as the telemetry
/// ring would hold it.
fn csv_row(frame: &Frame, rate: f64) -> String {
    // The loop's time counts its ticks (the first ends at one period): a frame the ring
    // dropped leaves a gap in the numbers, not a shift.
    let tick = ((frame.time * rate).round() as u64).saturating_sub(1);
    telemetry_csv::row(&Sample::of(tick, frame), frame.effectors, frame.strings)
}

/// Drain `frames` of a loop at `rate` hertz into a CSV file until `done` is set and the
/// ring is empty.
pub fn spawn_recorder(
    path: PathBuf,
    header: String,
    rate: f64,
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
                writeln!(out, "{}", csv_row(&frame, rate))?;
            }
            if finished {
                return out.flush();
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }))
}
