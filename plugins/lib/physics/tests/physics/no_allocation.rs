//! Once its contacts are established, a world step allocates nothing: a counting allocator
//! watches this thread while blocks rest, slide and press on each other.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use glam::{DQuat, DVec3};
use hapticd_physics::body::Body;
use hapticd_physics::friction::FrictionParameters;
use hapticd_physics::polyhedron::Polyhedron;
use hapticd_physics::world::{ContactModel, Material, World};

struct Counting;

thread_local! {
    static WATCHING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator unchanged; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if WATCHING.with(Cell::get) {
            ALLOCATIONS.with(|a| a.set(a.get() + 1));
        }
        // SAFETY: same contract as ours.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as ours.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn steps_with_established_contacts_do_not_allocate() {
    let floor = Polyhedron::cuboid(DVec3::new(2.0, 0.5, 2.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.5, 0.0));
    let mut bodies = vec![Body::new(&floor, 1000.0, true)];
    // Two stacked blocks and one sliding beside them.
    for (k, position) in [
        DVec3::new(0.0, 0.1, 0.0),
        DVec3::new(0.02, 0.3, 0.0),
        DVec3::new(0.5, 0.1, 0.0),
    ]
    .iter()
    .enumerate()
    {
        let cube = Polyhedron::cuboid(DVec3::splat(0.1))
            .transformed(DQuat::from_rotation_y(0.1 * k as f64), *position);
        bodies.push(Body::new(&cube, 125.0, false));
    }
    let critical = 2.0 * (1e6f64 * 0.04).sqrt() / 0.04;
    let mut world = World::new(
        bodies,
        DVec3::new(0.0, -9.81, 0.0),
        Material {
            stiffness: 1e6,
            damping: critical,
            friction: FrictionParameters {
                static_coefficient: 0.5,
                dynamic_coefficient: 0.4,
                stiffness: 1e6,
                damping: critical,
                slip_speed: 1e-3,
            },
            model: ContactModel::Volume,
            scaling: None,
        },
    );
    world.bodies[3].velocity.x = 0.5;
    for _ in 0..500 {
        world.step(1e-4);
    }
    WATCHING.with(|w| w.set(true));
    for _ in 0..2000 {
        world.step(1e-4);
    }
    WATCHING.with(|w| w.set(false));
    assert_eq!(ALLOCATIONS.with(Cell::get), 0);
}

/// Allocations in 1000 ticks of the blocks scene with two pointers pressing onto the table
/// among the blocks and sliding, after 300 ticks to establish the contacts.
fn allocations_in_blocks_ticks(coupled: bool) -> usize {
    use hapticd_core::kinematics::Wrench;
    use hapticd_physics::coupling::Grip;
    use hapticd_physics::scene::PenaltyScene;
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/scenes/blocks.yaml");
    let mut text = std::fs::read_to_string(path).unwrap();
    if coupled {
        text = text.replace(
            "pointer:\n",
            "pointer:\n  coupling: { stiffness: 300, damping: 3, rotational_stiffness: 0.3 }\n",
        );
        assert!(text.contains("coupling"));
    }
    let mut scene = PenaltyScene::parse(&text, std::path::Path::new("test.yaml"), 2).unwrap();
    let grip = |t: f64, x: f64| Grip {
        position: DVec3::new(x + 0.02 * t, -0.03, 0.0),
        orientation: DQuat::IDENTITY,
        velocity: DVec3::new(0.02, 0.0, 0.0),
        spin: DVec3::ZERO,
    };
    let mut felt = [Wrench::default(); 2];
    let mut tick = |k: usize| {
        let t = k as f64 * 1e-3;
        scene.step_pointers(1e-3, &[grip(t, -0.1), grip(t, 0.1)], &mut felt);
    };
    for k in 0..300 {
        tick(k);
    }
    let before = ALLOCATIONS.with(Cell::get);
    WATCHING.with(|w| w.set(true));
    for k in 300..1300 {
        tick(k);
    }
    WATCHING.with(|w| w.set(false));
    ALLOCATIONS.with(Cell::get) - before
}

#[test]
fn scene_ticks_with_placed_or_coupled_pointers_do_not_allocate() {
    assert_eq!(allocations_in_blocks_ticks(false), 0, "placed pointers");
    assert_eq!(allocations_in_blocks_ticks(true), 0, "coupled pointers");
}
