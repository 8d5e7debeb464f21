//! Intersections and mass properties against exact results and an independent method:
//! vertex enumeration (every triple of face planes), faces rebuilt by angle, volume and
//! centroid summed over tetrahedra from an interior point.

use glam::{DQuat, DVec3};
use hapticd_physics::clip::Clipper;
use hapticd_physics::mass::volume_and_centroid;
use hapticd_physics::polyhedron::{Plane, Polyhedron};

/// SplitMix64, to draw reproducible cases.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }

    fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            if (0.1..1.0).contains(&v.length()) {
                return v.normalize();
            }
        }
    }
}

/// Volume and centroid of {x : every plane}, by vertex enumeration.
fn reference(planes: &[Plane]) -> (f64, DVec3) {
    let mut vertices: Vec<DVec3> = Vec::new();
    let n = planes.len();
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let (a, b, c) = (planes[i], planes[j], planes[k]);
                let det = a.normal.dot(b.normal.cross(c.normal));
                if det.abs() < 1e-12 {
                    continue;
                }
                let x = (a.offset * b.normal.cross(c.normal)
                    + b.offset * c.normal.cross(a.normal)
                    + c.offset * a.normal.cross(b.normal))
                    / det;
                if planes.iter().all(|p| p.distance(x) <= 1e-9)
                    && vertices.iter().all(|v| (*v - x).length() > 1e-9)
                {
                    vertices.push(x);
                }
            }
        }
    }
    if vertices.len() < 4 {
        return (0.0, DVec3::ZERO);
    }
    let inside = vertices.iter().sum::<DVec3>() / vertices.len() as f64;
    let (mut volume, mut moment) = (0.0, DVec3::ZERO);
    for plane in planes {
        let on: Vec<DVec3> = vertices
            .iter()
            .copied()
            .filter(|v| plane.distance(*v).abs() < 1e-9)
            .collect();
        if on.len() < 3 {
            continue;
        }
        let centre = on.iter().sum::<DVec3>() / on.len() as f64;
        let u = plane.normal.any_orthonormal_vector();
        let w = plane.normal.cross(u);
        let mut ordered = on.clone();
        ordered.sort_by(|p, q| {
            let angle = |v: &DVec3| (*v - centre).dot(w).atan2((*v - centre).dot(u));
            angle(p).total_cmp(&angle(q))
        });
        for t in 0..ordered.len() {
            let (b, c) = (ordered[t], ordered[(t + 1) % ordered.len()]);
            let v = ((centre - inside).dot((b - inside).cross(c - inside)) / 6.0).abs();
            volume += v;
            moment += v * (inside + centre + b + c) / 4.0;
        }
    }
    (volume, moment / volume)
}

/// A convex polyhedron around `centre`: `count` random tangent planes of a ball of radius
/// `radius`, trimmed by a box.
fn random_polyhedron(rng: &mut Rng, centre: DVec3, radius: f64, count: usize) -> Polyhedron {
    let planes: Vec<Plane> = (0..count)
        .map(|_| {
            let normal = rng.unit();
            Plane {
                normal,
                offset: normal.dot(centre) + radius,
            }
        })
        .collect();
    Polyhedron::from_planes(&planes, 10.0)
}

fn close(a: f64, b: f64, relative: f64) -> bool {
    (a - b).abs() <= relative * a.abs().max(b.abs()).max(1e-300)
}

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
    let mut rng = Rng(42);
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
