//! Haptic shading: a mesh felt as the smooth surface it samples rather than as its flat faces.
//! Each corner gets the normal of the faces that meet there, weighted by their angles at it,
//! and a point on a face is pushed along the blend of its corners' normals by the point's
//! barycentric weights, so that the push turns continuously across the mesh's edges.

use std::collections::HashMap;

use glam::DVec3;
use serde::Deserialize;

use super::obstacle::Shape;
use super::scenery::Scenery;
use super::touch::Touch;
use crate::kinematics::Pose;

/// How a mesh's surface turns from face to face under the hand.
#[derive(Deserialize, Default, Clone, Copy, PartialEq, Eq, Debug)]
#[serde(rename_all = "lowercase")]
pub enum Shading {
    /// Each face pushes along its own normal: the facets are felt.
    #[default]
    Flat,
    /// The push turns smoothly across faces, along normals blended from the corners'
    /// (Phong's normals, felt: force shading).
    Smooth,
}

/// The blended normals at the corners of a mesh's `triangles` (other shapes are skipped): at
/// each corner, the faces that meet there weighted by their angles at it. Corners within a
/// nanometre are one (a file's rounding does not open a seam).
pub fn corner_normals(triangles: &[Shape]) -> Vec<[DVec3; 3]> {
    let key = |p: DVec3| (p * 1e9).round().to_array().map(|c| c as i64);
    let mut summed: HashMap<[i64; 3], DVec3> = HashMap::new();
    let faces: Vec<([DVec3; 3], DVec3)> = triangles
        .iter()
        .filter_map(|t| match *t {
            Shape::Triangle {
                corners, normal, ..
            } => Some((corners, normal)),
            _ => None,
        })
        .collect();
    for (corners, normal) in &faces {
        for k in 0..3 {
            let (a, b, c) = (corners[k], corners[(k + 1) % 3], corners[(k + 2) % 3]);
            let angle = (b - a).angle_between(c - a);
            let angle = if angle.is_finite() { angle } else { 0.0 };
            *summed.entry(key(a)).or_default() += *normal * angle;
        }
    }
    faces
        .iter()
        .map(|(corners, normal)| {
            corners.map(|c| summed[&key(c)].try_normalize().unwrap_or(*normal))
        })
        .collect()
}

/// How far from a body's mesh a touch may be and still be shaded, m: a contact's point lies
/// in the overlap of the pointer and the body, a few millimetres deep at most.
const REACH: f64 = 0.01;

/// A body's mesh, smoothly shaded: its faces in the body's frame, found near a point through
/// a tree, and their corners' blended normals.
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothMesh {
    faces: Vec<Shape>,
    corners: Vec<[DVec3; 3]>,
    scenery: Scenery,
}

impl SmoothMesh {
    /// The shading of the closed mesh `triangles` (in the body's frame, wound
    /// counter-clockwise from outside); None when none of them has an area.
    pub fn new(triangles: &[[DVec3; 3]]) -> Option<Self> {
        let faces: Vec<Shape> = triangles
            .iter()
            .filter_map(|&[a, b, c]| Shape::triangle(a, b, c))
            .collect();
        (!faces.is_empty()).then(|| Self {
            corners: corner_normals(&faces),
            scenery: Scenery::new(&faces),
            faces,
        })
    }

    /// [rt] The shaded normal at `p` (the body's frame) of the face nearest it, on the side
    /// of `side` (the normal the contact pushes along); None when no face is within reach.
    pub fn normal(&self, p: DVec3, side: DVec3) -> Option<DVec3> {
        let (k, face) = self.scenery.nearest_within(p, REACH)?;
        let face = if face.dot(side) < 0.0 { -face } else { face };
        self.faces[k].blend(p, &self.corners[k], face)
    }

    /// [rt] The scene's `force` on a pointer that `touch`es this mesh's body, posed at `body`:
    /// its push along the contact's normal turned to the shaded normal there (force shading,
    /// as a static scene's meshes are felt); unchanged where no face is near.
    pub fn shade(&self, force: DVec3, touch: &Touch, body: &Pose) -> DVec3 {
        if !touch.touching || touch.normal == DVec3::ZERO {
            return force;
        }
        let p = body.inverse_transform_point(touch.point);
        let side = body.orientation.inverse() * touch.normal;
        match self.normal(p, side) {
            Some(shaded) => {
                force + (body.orientation * shaded - touch.normal) * force.dot(touch.normal)
            }
            None => force,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube's twelve faces, wound outward.
    fn cube() -> Vec<[DVec3; 3]> {
        super::super::fixtures::box_faces(DVec3::ZERO, DVec3::splat(0.5))
    }

    #[test]
    fn a_cube_corner_points_along_its_diagonal_and_a_face_centre_along_the_face() {
        let mesh = SmoothMesh::new(&cube()).unwrap();
        // At a corner every face meeting there weighs its angle: the three faces' right
        // angles (two triangles share one face's) sum to the diagonal.
        let corner = DVec3::splat(0.5);
        let n = mesh.normal(corner, DVec3::ONE).unwrap();
        assert!((n - DVec3::ONE.normalize()).length() < 1e-9, "{n}");
        // On the top face, the blend of its triangle's corners by barycentric weights.
        let p = DVec3::new(0.1, 0.2, 0.5);
        let n = mesh.normal(p, DVec3::Z).unwrap();
        let faces: Vec<Shape> = cube()
            .iter()
            .filter_map(|&[a, b, c]| Shape::triangle(a, b, c))
            .collect();
        let corners = corner_normals(&faces);
        let (k, face) = faces
            .iter()
            .enumerate()
            .filter(|(_, f)| f.signed_distance(p).abs() < 1e-12)
            .find_map(|(k, f)| f.blend(p, &corners[k], DVec3::Z).map(|b| (k, b)))
            .unwrap();
        let Shape::Triangle {
            corners: [a, b, c], ..
        } = faces[k]
        else {
            unreachable!()
        };
        // Barycentric weights by areas, independently of the blend's own.
        let area = |x: DVec3, y: DVec3, z: DVec3| (y - x).cross(z - x).length() / 2.0;
        let w = [area(p, b, c), area(p, c, a), area(p, a, b)];
        let expected =
            (corners[k][0] * w[0] + corners[k][1] * w[1] + corners[k][2] * w[2]).normalize();
        assert!((face - expected).length() < 1e-9);
        assert!((n - expected).length() < 1e-9, "{n} {expected}");
        assert!(n.z > 0.5 && n.x > 0.0, "{n}");
    }

    #[test]
    fn a_point_out_of_reach_is_not_shaded() {
        let mesh = SmoothMesh::new(&cube()).unwrap();
        assert_eq!(
            mesh.normal(DVec3::new(0.0, 0.0, 0.5 + 2.0 * REACH), DVec3::Z),
            None
        );
        assert_eq!(SmoothMesh::new(&[[DVec3::ZERO; 3]]), None);
    }
}
