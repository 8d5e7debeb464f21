//! Solids the haptics tests share.

use glam::DVec3;

/// The box `centre` ± `half` as the twelve triangles of its faces, wound outward, as a mesh
/// file would give it.
pub(crate) fn box_faces(centre: DVec3, half: DVec3) -> Vec<[DVec3; 3]> {
    let corner = |k: usize| {
        centre
            + half
                * DVec3::new(
                    if k & 1 == 0 { -1.0 } else { 1.0 },
                    if k & 2 == 0 { -1.0 } else { 1.0 },
                    if k & 4 == 0 { -1.0 } else { 1.0 },
                )
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .map(|t| t.map(corner))
        .collect()
}
