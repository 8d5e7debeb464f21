//! A chain of 20 links on ball joints, held out level from the world and let go: it swings
//! down and whips over a floor it heaps its lower links on (contacts between the links and
//! the floor, and between links not joined), in both engines side by side, a quarter of a
//! second after letting go: the penalty engine's work per device tick (1 ms, four steps of
//! 0.25 ms) and rapier's per physics step (at 60 Hz). Issue 47's goal: 100 µs a tick.
//!
//! Run: `make bench`, or `cargo bench -p hapticd-e2e --bench joints`.

use divan::Bencher;
use hapticd_physics::scene::SceneFile;
use hapticd_rapier::world::RapierWorld;

fn main() {
    divan::main();
}

/// Links in the chain.
const LINKS: usize = 20;

/// The chain's scene for an engine (its `engine:`, step and material lines).
fn chain(engine: &str) -> SceneFile {
    let mut text = format!(
        "name: chain\n{engine}\nbodies:\n  - {{ name: floor, box: [0.3, 0.02, 0.3], position: \
         [0, -0.16, 0], fixed: true }}\n"
    );
    // 2 cm links, 6 mm thick, held out level from 20 cm up and let go: the chain swings
    // down, and hanging its lowest five would lie on the floor.
    let (x, y) = (-0.2, 0.2);
    for k in 0..LINKS {
        let centre = x + 0.02 * k as f64 + 0.01;
        text += &format!(
            "  - {{ name: link{k}, box: [0.02, 0.006, 0.006], position: [{centre:.3}, {y}, 0], \
             density: 2000 }}\n"
        );
    }
    text += "joints:\n";
    for k in 0..LINKS {
        let parent = if k == 0 {
            "world".to_string()
        } else {
            format!("link{}", k - 1)
        };
        text += &format!(
            "  - {{ kind: spherical, bodies: [{parent}, link{k}], anchor: [{:.3}, {y}, 0] }}\n",
            x + 0.02 * k as f64
        );
    }
    SceneFile::parse(&text, std::path::Path::new("chain.yaml"), 0).expect("a valid chain")
}

/// One device tick (1 ms) of the penalty engine's chain, a quarter of a second after it was
/// let go.
#[divan::bench]
fn penalty_tick(bencher: Bencher) {
    let SceneFile::Penalty(mut scene) = chain(
        "engine: penalty\ndt: 0.00025\nmaterial: { stiffness: 2.0e7, damping: 1.0e4, \
         static_friction: 0.4, friction: 0.3, friction_stiffness: 2.0e7, friction_damping: \
         1.0e4, slip_speed: 0.001 }",
    ) else {
        unreachable!("a penalty scene");
    };
    for _ in 0..1000 {
        scene.world.step(0.00025);
    }
    bencher.bench_local(|| {
        for _ in 0..4 {
            scene.world.step(0.00025);
        }
    });
}

/// One physics step (1/60 s) of rapier's chain, a quarter of a second after it was let go.
#[divan::bench]
fn rapier_step(bencher: Bencher) {
    let SceneFile::Rapier(spec) =
        chain("engine: rapier\nrate: 60\nmaterial: { static_friction: 0.4, friction: 0.3 }")
    else {
        unreachable!("a rapier scene");
    };
    let mut world = RapierWorld::new(&spec, 0);
    for _ in 0..15 {
        world.advance(1.0 / 60.0);
    }
    bencher.bench_local(|| world.advance(1.0 / 60.0));
}
