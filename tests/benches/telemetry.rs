//! The telemetry ring, measured side by side in one run: what writing a tick costs the
//! haptic thread (its goal: at most 0.3 µs), against the tick of the static scene's haptic
//! loop on the simulated SPIDAR-G that it records; and what reading a tick costs a reader.
//!
//! Run: `cargo bench -p hapticd-e2e --bench telemetry`.

use divan::Bencher;
use hapticd_core::telemetry::Sample;
use hapticd_ipc::telemetry_share::{MappedTelemetry, SharedTelemetryFile};

#[path = "../support/mod.rs"]
mod support;

fn main() {
    divan::main();
}

/// A loop pressing the static scene's floor, ticked a second first.
fn haptic_loop() -> hapticd_core::haptic_loop::HapticLoop {
    let m = support::shipped("spidar-g");
    let script = "hands:\n  grip:\n    - move: { to: [0.0, -0.05, 0.0], seconds: 0.5 }\n    - hold: { seconds: 100 }\n";
    let mut haptic = support::simulated_loop(&m, script, 1e-3);
    for _ in 0..1000 {
        haptic.tick(1e-3);
    }
    haptic
}

#[divan::bench]
fn write_a_tick(bencher: Bencher) {
    let frame = *haptic_loop().frame();
    let (_file, mut ring) = SharedTelemetryFile::create(1000.0).unwrap();
    bencher.bench_local(|| ring.write(divan::black_box(&frame)));
}

#[divan::bench]
fn haptic_tick_it_records(bencher: Bencher) {
    let mut haptic = haptic_loop();
    bencher.bench_local(|| *haptic.tick(1e-3));
}

#[divan::bench]
fn read_a_tick(bencher: Bencher) {
    let frame = *haptic_loop().frame();
    let (file, mut ring) = SharedTelemetryFile::create(1000.0).unwrap();
    let telemetry = MappedTelemetry::open(&file.share().unwrap()).unwrap();
    let mut cursor = telemetry.from_now();
    let mut sample = Sample::EMPTY;
    bencher.bench_local(|| {
        ring.write(&frame);
        telemetry.next(&mut cursor, &mut sample)
    });
}
