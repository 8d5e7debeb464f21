//! The contact-volume spring and damper (thesis eq. 5.8–5.13) against exact identities: the
//! spring is k_N·V·n through the intersection's centroid (V and centroid from an independent
//! vertex enumeration), and a uniform approach velocity is damped over the projected area.

use crate::common::{Rng, close, random_polyhedron, reference};
use glam::{DQuat, DVec3};
use hapticd_physics::clip::Clipper;
use hapticd_physics::contact::{damper, spring};
use hapticd_physics::polyhedron::{Plane, Polyhedron};

#[test]
fn the_spring_is_k_v_n_through_the_centroid_for_random_pairs() {
    let mut rng = Rng::new(7);
    let mut clipper = Clipper::default();
    let mut solid = Polyhedron::default();
    let mut checked = 0;
    for _ in 0..300 {
        let a = random_polyhedron(&mut rng, DVec3::ZERO, 1.0, 12);
        let q = DQuat::from_axis_angle(rng.unit(), rng.range(0.0, 3.0));
        let b = random_polyhedron(&mut rng, DVec3::ZERO, 0.8, 10)
            .transformed(q, rng.unit() * rng.range(0.0, 2.0));
        clipper.intersect(&a, &b, &mut solid);
        let planes: Vec<Plane> = a.planes.iter().chain(&b.planes).copied().collect();
        let (volume, centroid) = reference(&planes);
        if volume == 0.0 {
            continue;
        }
        checked += 1;
        let (normal, point, k) = (
            rng.unit(),
            rng.unit() * rng.range(0.0, 1.0),
            rng.range(1e3, 1e6),
        );
        let w = spring(&solid, point, normal, k);
        let (force, torque) = (k * volume * normal, k * volume * centroid.cross(normal));
        assert!(
            (w.force - force).length() <= 1e-9 * force.length(),
            "{} vs {force}",
            w.force
        );
        assert!(
            (w.torque - torque).length() <= 1e-9 * (force.length() * (1.0 + centroid.length())),
            "{} vs {torque}",
            w.torque
        );
    }
    assert!(checked > 150);
}

#[test]
fn a_box_sunk_into_the_floor_is_pushed_up_by_its_depth() {
    // A 2 × 2 × 2 box 1 mm into a floor: the intersection is a 2 × 2 × 0.001 slab.
    let floor = Polyhedron::cuboid(DVec3::new(5.0, 0.5, 5.0))
        .transformed(DQuat::IDENTITY, DVec3::new(0.0, -0.5, 0.0));
    let b =
        Polyhedron::cuboid(DVec3::ONE).transformed(DQuat::IDENTITY, DVec3::new(0.3, 0.999, -0.2));
    let mut slab = Polyhedron::default();
    Clipper::default().intersect(&b, &floor, &mut slab);
    let w = spring(&slab, DVec3::ZERO, DVec3::Y, 1e6);
    assert!(close(w.force.y, 1e6 * 4.0 * 0.001, 1e-9) && w.force.x.abs() < 1e-9);
    // Through the slab's centre: no torque about a point below it.
    let torque_about_centre = w.torque - DVec3::new(0.3, -0.0005, -0.2).cross(w.force);
    assert!(torque_about_centre.length() < 1e-9, "{torque_about_centre}");
}

/// Area of the convex hull of points in the plane across `normal` (gift wrapping).
fn projected_area(points: &[DVec3], normal: DVec3) -> f64 {
    let u = normal.any_orthonormal_vector();
    let w = normal.cross(u);
    let mut flat: Vec<(f64, f64)> = points.iter().map(|p| (p.dot(u), p.dot(w))).collect();
    flat.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64)> = Vec::new();
    for pass in [flat.clone(), flat.iter().rev().copied().collect()] {
        let start = hull.len();
        for p in pass {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    (0..hull.len())
        .map(|i| {
            let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
            a.0 * b.1 - a.1 * b.0
        })
        .sum::<f64>()
        .abs()
        / 2.0
}

#[test]
fn a_uniform_normal_motion_is_damped_over_the_projected_contact_area_both_ways() {
    let mut rng = Rng::new(8);
    let mut clipper = Clipper::default();
    let mut solid = Polyhedron::default();
    for _ in 0..100 {
        let a = random_polyhedron(&mut rng, DVec3::ZERO, 1.0, 12);
        let b = random_polyhedron(&mut rng, DVec3::ZERO, 0.8, 10)
            .transformed(DQuat::IDENTITY, rng.unit() * 1.2);
        clipper.intersect(&a, &b, &mut solid);
        if solid.faces.is_empty() {
            continue;
        }
        let normal = rng.unit();
        let area = projected_area(&solid.vertices, normal);
        let approach = normal * 0.3 + normal.any_orthonormal_vector() * 0.7;
        let w = damper(&solid, normal, 50.0, |_| approach);
        assert!(
            close(w.force.dot(normal), 50.0 * area * 0.3, 1e-9),
            "{} vs {}",
            w.force.dot(normal),
            50.0 * area * 0.3
        );
        assert!(w.force.reject_from(normal).length() < 1e-9);
        let separating = damper(&solid, normal, 50.0, |_| -approach);
        assert!((separating.force + w.force).length() < 1e-9);
        assert!((separating.torque + w.torque).length() < 1e-9);
    }
}
