//! Intersections and mass properties against exact results and an independent method:
//! vertex enumeration (every triple of face planes), faces rebuilt by angle, volume and
//! centroid summed over tetrahedra from an interior point.

use crate::common::{Rng, random_polyhedron, reference};
use glam::{DQuat, DVec3};
use hapticd_physics::clip::Clipper;
use hapticd_physics::mass::volume_and_centroid;
use hapticd_physics::polyhedron::{Plane, Polyhedron};

use crate::common::close;

#[test]
fn boxes_have_their_exact_volume_and_centre() {
    let q = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let b =
        Polyhedron::cuboid(DVec3::new(1.0, 2.0, 3.0)).transformed(q, DVec3::new(0.5, -1.0, 2.0));
    let (v, c) = volume_and_centroid(&b);
    assert!(close(v, 48.0, 1e-12), "{v}");
    assert!((c - DVec3::new(0.5, -1.0, 2.0)).length() < 1e-12);
    assert!(b.contains(DVec3::new(0.5, -1.0, 2.0), 0.0));
}

#[test]
fn a_corner_tetrahedron_has_the_textbook_volume_and_centroid() {
    let planes = [
        Plane {
            normal: -DVec3::X,
            offset: 0.0,
        },
        Plane {
            normal: -DVec3::Y,
            offset: 0.0,
        },
        Plane {
            normal: -DVec3::Z,
            offset: 0.0,
        },
        Plane {
            normal: DVec3::ONE.normalize(),
            offset: 1.0 / 3f64.sqrt(),
        },
    ];
    let t = Polyhedron::from_planes(&planes, 5.0);
    let (v, c) = volume_and_centroid(&t);
    assert!(close(v, 1.0 / 6.0, 1e-12), "{v}");
    assert!((c - DVec3::splat(0.25)).length() < 1e-12, "{c}");
    assert_eq!((t.vertices.len(), t.faces.len()), (4, 4));
}

#[test]
fn overlapping_boxes_intersect_in_the_box_of_their_overlap() {
    let a = Polyhedron::cuboid(DVec3::splat(1.0));
    let b = Polyhedron::cuboid(DVec3::splat(1.0))
        .transformed(DQuat::IDENTITY, DVec3::new(1.5, 0.5, -0.25));
    let mut out = Polyhedron::default();
    Clipper::default().intersect(&a, &b, &mut out);
    let (v, c) = volume_and_centroid(&out);
    // Overlap: x ∈ [0.5, 1], y ∈ [−0.5, 1], z ∈ [−1, 0.75].
    assert!(close(v, 0.5 * 1.5 * 1.75, 1e-12), "{v}");
    assert!((c - DVec3::new(0.75, 0.25, -0.125)).length() < 1e-12, "{c}");
}

#[test]
fn random_convex_pairs_match_vertex_enumeration() {
    let mut rng = Rng::new(42);
    let mut clipper = Clipper::default();
    let mut out = Polyhedron::default();
    let mut overlapping = 0;
    for _ in 0..300 {
        let a = random_polyhedron(&mut rng, DVec3::ZERO, 1.0, 12);
        let offset = rng.unit() * rng.range(0.0, 2.5);
        let q = DQuat::from_axis_angle(rng.unit(), rng.range(0.0, 3.0));
        let b = random_polyhedron(&mut rng, DVec3::ZERO, 0.8, 10).transformed(q, offset);
        clipper.intersect(&a, &b, &mut out);
        let (v, c) = volume_and_centroid(&out);
        let planes: Vec<Plane> = a.planes.iter().chain(&b.planes).copied().collect();
        let (rv, rc) = reference(&planes);
        if rv == 0.0 {
            assert!(v.abs() < 1e-12, "{v}");
            continue;
        }
        overlapping += 1;
        assert!(close(v, rv, 1e-9), "volume {v} vs {rv}");
        assert!(
            (c - rc).length() <= 1e-9 * (1.0 + rc.length()),
            "centroid {c} vs {rc}"
        );
        // The other way round gives the same solid.
        let mut other = Polyhedron::default();
        clipper.intersect(&b, &a, &mut other);
        let (v2, c2) = volume_and_centroid(&other);
        assert!(close(v, v2, 1e-9) && (c - c2).length() < 1e-9);
    }
    assert!(overlapping > 150, "{overlapping}");
}

#[test]
fn separated_solids_do_not_intersect() {
    let a = Polyhedron::cuboid(DVec3::splat(1.0));
    let b = a.transformed(DQuat::IDENTITY, DVec3::new(2.5, 0.0, 0.0));
    let mut out = Polyhedron::default();
    Clipper::default().intersect(&a, &b, &mut out);
    assert!(out.faces.is_empty());
    assert_eq!(volume_and_centroid(&out).0, 0.0);
}

#[test]
fn a_box_has_the_textbook_inertia_in_any_pose() {
    use hapticd_physics::mass::mass_properties;
    // A 2 × 4 × 6 box: m = 48, Ixx = m(4² + 6²)/12, ...
    let q = DQuat::from_axis_angle(DVec3::new(3.0, -1.0, 2.0).normalize(), 1.1);
    let b =
        Polyhedron::cuboid(DVec3::new(1.0, 2.0, 3.0)).transformed(q, DVec3::new(5.0, -3.0, 1.0));
    let (m, c, inertia) = mass_properties(&b);
    assert!(close(m, 48.0, 1e-12) && (c - DVec3::new(5.0, -3.0, 1.0)).length() < 1e-11);
    let local = glam::DMat3::from_quat(q).transpose() * inertia * glam::DMat3::from_quat(q);
    let expected = DVec3::new(
        48.0 * (16.0 + 36.0) / 12.0,
        48.0 * (4.0 + 36.0) / 12.0,
        48.0 * (4.0 + 16.0) / 12.0,
    );
    for (i, e) in expected.to_array().iter().enumerate() {
        assert!(
            close(local.col(i)[i], *e, 1e-10),
            "axis {i}: {} vs {e}",
            local.col(i)[i]
        );
        for j in 0..3 {
            if j != i {
                assert!(local.col(i)[j].abs() < 1e-9);
            }
        }
    }
}
