//! One frame drawn offscreen with Vulkan and read back, at 1280 × 720: the shipped `blocks`
//! scene alone, flat and with its depth cues (shadows, smoothed edges), and with SPIDAR-G's
//! grip, strings and a force arrow over it (on this machine, Mesa's lavapipe on the CPU).
//!
//! Run: `make bench`.

#[path = "../support/mod.rs"]
mod support;

use divan::Bencher;
use glam::DVec3;
use hapticd_physics::scene::PenaltyScene;
use hapticd_render::scenery::Scenery;
use hapticd_render::shading::Shaded;
use hapticd_render::vulkan::Renderer;

const SIZE: (u32, u32) = (1280, 720);
const SKY: [f32; 4] = [0.93, 0.95, 0.98, 1.0];

fn main() {
    divan::main();
}

fn blocks() -> Scenery {
    let path = support::repo_dir().join("config/scenes/blocks.yaml");
    let scene = PenaltyScene::load(&path, 0).unwrap();
    Scenery::of_geometry(&Shaded::new(scene.geometry()), &scene.poses(), &[])
}

fn bench_frame(bencher: Bencher, scenery: &Scenery) {
    bench_frame_with(bencher, scenery, true);
}

fn bench_frame_with(bencher: Bencher, scenery: &Scenery, depth_cues: bool) {
    let mut renderer = Renderer::new().expect("a Vulkan device");
    renderer.set_depth_cues(depth_cues);
    let camera = scenery.camera();
    let meshes: Vec<_> = scenery.meshes.iter().collect();
    // The first frame compiles the shaders' variants.
    renderer.draw(&meshes, &camera, SIZE, SKY).unwrap();
    bencher.bench_local(|| renderer.draw(&meshes, &camera, SIZE, SKY).unwrap());
}

#[divan::bench(sample_count = 30)]
fn blocks_1280x720(bencher: Bencher) {
    bench_frame(bencher, &blocks());
}

#[divan::bench(sample_count = 30)]
fn blocks_flat_1280x720(bencher: Bencher) {
    bench_frame_with(bencher, &blocks(), false);
}

#[divan::bench(sample_count = 30)]
fn blocks_with_spidar_g_strings_1280x720(bencher: Bencher) {
    let mut scenery = blocks();
    let mechanism = support::shipped("spidar-g");
    let poses: Vec<_> = mechanism.effectors.iter().map(|e| e.calibration).collect();
    let tensions: Vec<f64> = mechanism.strings.iter().map(|s| s.tension_min).collect();
    scenery.add_mechanism(&mechanism, &poses, &tensions, &[DVec3::new(2.0, 3.0, 0.0)]);
    bench_frame(bencher, &scenery);
}
