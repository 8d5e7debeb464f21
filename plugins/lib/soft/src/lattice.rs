//! Cutting a box or a solid into tetrahedra: a grid of cubes at the resolution asked, each
//! cube cut into six tetrahedra around its main diagonal (Kuhn's cut, which matches itself
//! across every face, so the pieces join without cracks); a solid keeps the tetrahedra
//! whose middles are inside it, and its surface nodes are moved onto its surface. A
//! quadratic mesh adds a node at the middle of each edge, shared by the elements around it.

use std::collections::{BTreeSet, HashMap};

use glam::DVec3;

use crate::element::{EDGES, Order, signed_volume};

/// A tetrahedral mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct TetMesh {
    /// The degree of its elements.
    pub order: Order,
    /// Its nodes, m.
    pub nodes: Vec<DVec3>,
    /// Each element's nodes, [`Order::nodes`] of them each, corners positively turned.
    pub elements: Vec<u32>,
    /// Its outer surface, triangles turned outward (a quadratic face in four).
    pub surface: Vec<[u32; 3]>,
}

impl TetMesh {
    /// How many elements it has.
    pub fn element_count(&self) -> usize {
        self.elements.len() / self.order.nodes()
    }

    /// Element `e`'s nodes.
    pub fn element(&self, e: usize) -> &[u32] {
        let n = self.order.nodes();
        &self.elements[e * n..(e + 1) * n]
    }
}

/// The faces of a positively turned tetrahedron, by corner, each turned outward.
const FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// The box of half-extents `half` about `centre`, cut into cubes no larger than
/// `resolution` along each side (at least one across), and those into tetrahedra of `order`.
pub fn cut_box(centre: DVec3, half: DVec3, resolution: f64, order: Order) -> TetMesh {
    let (nodes, corners, _) = lattice(centre, half, resolution);
    with_order(nodes, &corners, order)
}

/// A solid to cut into tetrahedra.
pub trait Solid {
    /// Whether `x` is inside it.
    fn contains(&self, x: DVec3) -> bool;
    /// The point of its surface nearest `x`.
    fn nearest_on_surface(&self, x: DVec3) -> DVec3;
}

/// A ball.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    /// Its centre, m.
    pub centre: DVec3,
    /// Its radius, m.
    pub radius: f64,
}

impl Solid for Ball {
    fn contains(&self, x: DVec3) -> bool {
        x.distance(self.centre) < self.radius
    }

    fn nearest_on_surface(&self, x: DVec3) -> DVec3 {
        self.centre + (x - self.centre).normalize_or(DVec3::X) * self.radius
    }
}

/// The least a tetrahedron may keep of its lattice volume when its surface nodes are moved
/// onto the solid's surface.
const KEPT_VOLUME: f64 = 0.2;

/// Passes of moving the surface nodes onto the solid's surface.
const SNAPS: usize = 3;

/// `solid`, within the box `half` about `centre` that holds it, cut at `resolution` into
/// tetrahedra of `order`: the lattice's tetrahedra whose middles are inside, their surface
/// nodes then moved onto the solid's surface as far as each may go (up to the whole way,
/// halving the move while any tetrahedron around the node would keep less than a fifth of
/// its volume).
pub fn cut_solid(
    solid: &impl Solid,
    centre: DVec3,
    half: DVec3,
    resolution: f64,
    order: Order,
) -> TetMesh {
    let (nodes, corners, cell) = lattice(centre, half, resolution);
    let inside: Vec<[u32; 4]> = corners
        .into_iter()
        .filter(|tet| solid.contains(tet.iter().map(|&i| nodes[i as usize]).sum::<DVec3>() / 4.0))
        .collect();
    let inside = face_connected(inside);
    // Only the nodes the kept tetrahedra use, renumbered in their order.
    let mut renumbered = vec![u32::MAX; nodes.len()];
    let mut kept = Vec::new();
    let corners: Vec<[u32; 4]> = inside
        .iter()
        .map(|tet| {
            tet.map(|i| {
                if renumbered[i as usize] == u32::MAX {
                    renumbered[i as usize] = kept.len() as u32;
                    kept.push(nodes[i as usize]);
                }
                renumbered[i as usize]
            })
        })
        .collect();
    let mut nodes = kept;
    let mut around: Vec<Vec<usize>> = vec![Vec::new(); nodes.len()];
    for (t, tet) in corners.iter().enumerate() {
        for &i in tet {
            around[i as usize].push(t);
        }
    }
    let least = KEPT_VOLUME * cell.x * cell.y * cell.z / 6.0;
    let outer: BTreeSet<u32> = outer_faces(&corners).into_iter().flatten().collect();
    // A node held back may go on once its neighbours have moved.
    for _ in 0..SNAPS {
        for &node in &outer {
            let i = node as usize;
            let (from, to) = (nodes[i], solid.nearest_on_surface(nodes[i]));
            for share in [1.0, 0.5, 0.25, 0.125] {
                nodes[i] = from + (to - from) * share;
                let kept = around[i]
                    .iter()
                    .all(|&t| volume(&nodes, corners[t]) >= least);
                if kept {
                    break;
                }
                nodes[i] = from;
            }
        }
    }
    with_order(nodes, &corners, order)
}

/// The lattice of the box `half` about `centre` at `resolution`: its nodes, its cubes cut
/// into tetrahedra, and its cells' size.
fn lattice(centre: DVec3, half: DVec3, resolution: f64) -> (Vec<DVec3>, Vec<[u32; 4]>, DVec3) {
    // A side that is a whole number of resolutions is cut into that many, not one more
    // for the last bit of rounding.
    let cells = (2.0 * half / resolution * (1.0 - 1e-9))
        .ceil()
        .max(DVec3::ONE);
    let n = [cells.x as usize, cells.y as usize, cells.z as usize];
    let step = 2.0 * half / cells;
    let index = |i: usize, j: usize, k: usize| (i + (n[0] + 1) * (j + (n[1] + 1) * k)) as u32;
    let mut nodes = Vec::with_capacity((n[0] + 1) * (n[1] + 1) * (n[2] + 1));
    for k in 0..=n[2] {
        for j in 0..=n[1] {
            for i in 0..=n[0] {
                let at = DVec3::new(i as f64, j as f64, k as f64) * step;
                nodes.push(centre - half + at);
            }
        }
    }
    let mut corners: Vec<[u32; 4]> = Vec::with_capacity(6 * n[0] * n[1] * n[2]);
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                for axes in [
                    [0, 1, 2],
                    [0, 2, 1],
                    [1, 0, 2],
                    [1, 2, 0],
                    [2, 0, 1],
                    [2, 1, 0],
                ] {
                    // From the cube's low corner to its high one, one axis at a time.
                    let mut at = [i, j, k];
                    let mut tet = [index(i, j, k); 4];
                    for (s, &axis) in axes.iter().enumerate() {
                        at[axis] += 1;
                        tet[s + 1] = index(at[0], at[1], at[2]);
                    }
                    corners.push(turned_positively(&nodes, tet));
                }
            }
        }
    }
    (nodes, corners, step)
}

/// The signed volume of the tetrahedron `tet` of `nodes`.
fn volume(nodes: &[DVec3], tet: [u32; 4]) -> f64 {
    signed_volume(tet.map(|i| nodes[i as usize]))
}

/// The faces of `tet`: each as a key the tetrahedron beside it shares (its corners
/// sorted), and turned outward.
fn faces_of(tet: &[u32; 4]) -> impl Iterator<Item = ([u32; 3], [u32; 3])> + '_ {
    FACES.into_iter().map(|face| {
        let turned = face.map(|c| tet[c]);
        let mut key = turned;
        key.sort_unstable();
        (key, turned)
    })
}

/// The faces of `corners` that one tetrahedron alone has, turned outward.
fn outer_faces(corners: &[[u32; 4]]) -> Vec<[u32; 3]> {
    let mut faces: HashMap<[u32; 3], (usize, [u32; 3])> = HashMap::new();
    for tet in corners {
        for (key, turned) in faces_of(tet) {
            faces
                .entry(key)
                .and_modify(|f| f.0 += 1)
                .or_insert((1, turned));
        }
    }
    let mut outer: Vec<[u32; 3]> = faces
        .into_values()
        .filter(|(count, _)| *count == 1)
        .map(|(_, face)| face)
        .collect();
    outer.sort_unstable();
    outer
}

/// The largest of `tets`' sets joined face to face: a tetrahedron that meets the rest
/// only at a corner or an edge would swing freely about it, holding nothing, and no turn
/// of its neighbours' would describe it (a soft Stanford bunny kept 17 such of 1 033, and
/// its tick's solve ran out of iterations 10 to 100 times off its tolerance).
fn face_connected(tets: Vec<[u32; 4]>) -> Vec<[u32; 4]> {
    let mut root: Vec<usize> = (0..tets.len()).collect();
    fn find(root: &mut [usize], mut t: usize) -> usize {
        while root[t] != t {
            root[t] = root[root[t]];
            t = root[t];
        }
        t
    }
    let mut first_with: HashMap<[u32; 3], usize> = HashMap::new();
    for (t, tet) in tets.iter().enumerate() {
        for (key, _) in faces_of(tet) {
            match first_with.get(&key) {
                Some(&other) => {
                    let (a, b) = (find(&mut root, t), find(&mut root, other));
                    root[a] = b;
                }
                None => {
                    first_with.insert(key, t);
                }
            }
        }
    }
    let mut size = vec![0usize; tets.len()];
    for t in 0..tets.len() {
        size[find(&mut root, t)] += 1;
    }
    let largest = (0..tets.len()).max_by_key(|&t| size[t]);
    tets.iter()
        .enumerate()
        .filter(|&(t, _)| Some(find(&mut root, t)) == largest)
        .map(|(_, tet)| *tet)
        .collect()
}

/// `tet` with its corners in an order that gives it a positive volume.
fn turned_positively(nodes: &[DVec3], mut tet: [u32; 4]) -> [u32; 4] {
    if volume(nodes, tet) < 0.0 {
        tet.swap(1, 2);
    }
    tet
}

/// The mesh of the tetrahedra `corners` over `nodes`, with the middles of edges added for
/// a quadratic one, and its outer surface.
fn with_order(mut nodes: Vec<DVec3>, corners: &[[u32; 4]], order: Order) -> TetMesh {
    let mut middles: HashMap<(u32, u32), u32> = HashMap::new();
    let mut middle = |nodes: &mut Vec<DVec3>, a: u32, b: u32| {
        *middles.entry((a.min(b), a.max(b))).or_insert_with(|| {
            nodes.push((nodes[a as usize] + nodes[b as usize]) / 2.0);
            (nodes.len() - 1) as u32
        })
    };
    let mut elements = Vec::with_capacity(corners.len() * order.nodes());
    for tet in corners {
        elements.extend_from_slice(tet);
        if order == Order::Quadratic {
            for &(i, j) in &EDGES {
                let m = middle(&mut nodes, tet[i], tet[j]);
                elements.push(m);
            }
        }
    }
    let outer = outer_faces(corners);
    let surface = match order {
        Order::Linear => outer,
        Order::Quadratic => outer
            .iter()
            .flat_map(|&[a, b, c]| {
                let [ab, bc, ca] = [(a, b), (b, c), (c, a)].map(|(p, q)| middle(&mut nodes, p, q));
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect(),
    };
    TetMesh {
        order,
        nodes,
        elements,
        surface,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::barycentric_gradients;

    /// The volume `mesh`'s surface encloses (the divergence theorem): its elements' where
    /// the surface is closed and turned outward.
    fn enclosed(mesh: &TetMesh) -> f64 {
        mesh.surface
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| mesh.nodes[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// The cut fills the box: every element positive, their volumes summing to the box's;
    /// its surface closed and outward, enclosing that volume (the divergence theorem); a
    /// quadratic mesh's middles are each shared, not repeated.
    #[test]
    fn a_cut_box_is_filled_and_closed() {
        let (centre, half) = (DVec3::new(0.1, -0.2, 0.3), DVec3::new(0.05, 0.02, 0.11));
        for order in [Order::Linear, Order::Quadratic] {
            let mesh = cut_box(centre, half, 0.013, order);
            let mut volume = 0.0;
            for e in 0..mesh.element_count() {
                let c = mesh.element(e);
                let (_, v) = barycentric_gradients([0, 1, 2, 3].map(|k| mesh.nodes[c[k] as usize]));
                assert!(v > 0.0);
                volume += v;
            }
            let boxed = 8.0 * half.x * half.y * half.z;
            assert!((volume / boxed - 1.0).abs() < 1e-12, "{volume}");
            let enclosed = enclosed(&mesh);
            assert!((enclosed / boxed - 1.0).abs() < 1e-12, "{enclosed}");
            // Every surface edge is met twice, once each way.
            let mut edges = HashMap::new();
            for t in &mesh.surface {
                for k in 0..3 {
                    *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
                }
            }
            assert!(
                edges
                    .iter()
                    .all(|(&(a, b), &n)| n == 1 && edges.get(&(b, a)) == Some(&1))
            );
            let cells = [8, 4, 17];
            assert_eq!(
                cut_box(centre, half, 0.02, order).element_count(),
                6 * 5 * 2 * 11
            );
            let grid = (cells[0] + 1) * (cells[1] + 1) * (cells[2] + 1);
            let expected = match order {
                Order::Linear => grid,
                // Each lattice edge, and each cube's diagonals: three faces' and one inside.
                Order::Quadratic => {
                    let [x, y, z] = cells;
                    let lattice =
                        x * (y + 1) * (z + 1) + (x + 1) * y * (z + 1) + (x + 1) * (y + 1) * z;
                    let faces = x * y * (z + 1) + x * (y + 1) * z + (x + 1) * y * z;
                    grid + lattice + faces + x * y * z
                }
            };
            assert_eq!(mesh.nodes.len(), expected);
        }
    }

    /// A ball cut at a tenth of its diameter: every tetrahedron positive, its surface
    /// closed, its volume within 2 % of the ball's (measured 0.17 % over); most surface
    /// nodes on the sphere, those held back where moving them would flatten a tetrahedron
    /// within 5.7 mm of it (the cells are 10 mm).
    #[test]
    fn a_cut_ball_fills_the_ball() {
        let ball = Ball {
            centre: DVec3::new(0.01, 0.02, -0.03),
            radius: 0.05,
        };
        let mesh = cut_solid(&ball, ball.centre, DVec3::splat(0.06), 0.01, Order::Linear);
        let mut total = 0.0;
        for e in 0..mesh.element_count() {
            let c = mesh.element(e);
            let v = volume(&mesh.nodes, [c[0], c[1], c[2], c[3]]);
            assert!(v > 0.0);
            total += v;
        }
        let exact = 4.0 / 3.0 * std::f64::consts::PI * ball.radius.powi(3);
        let on: Vec<f64> = mesh
            .surface
            .iter()
            .flatten()
            .map(|&i| (mesh.nodes[i as usize].distance(ball.centre) - ball.radius).abs())
            .collect();
        let held = on.iter().filter(|&&d| d > 1e-12).count();
        println!(
            "{} elements, volume {:.4} of the ball's, {held} of {} surface corners off the sphere, \
             by {:.2e} m at most",
            mesh.element_count(),
            total / exact,
            on.len(),
            on.iter().cloned().fold(0.0, f64::max)
        );
        assert!((total / exact - 1.0).abs() < 0.02);
        assert!((enclosed(&mesh) / total - 1.0).abs() < 1e-12);
    }

    /// A bar of two lattice cells and a third cell that meets its end along an edge only,
    /// cut as one solid: the bar's 12 tetrahedra are kept, the cell hinged on the edge
    /// left out, and a face-joined mesh comes out as it went in.
    #[test]
    fn only_tetrahedra_joined_face_to_face_are_kept() {
        /// Boxes of lattice cells: every outer node of their cut is on a face already.
        struct Cells(Vec<(DVec3, DVec3)>);
        impl Solid for Cells {
            fn contains(&self, x: DVec3) -> bool {
                self.0
                    .iter()
                    .any(|&(low, high)| x.cmpgt(low).all() && x.cmplt(high).all())
            }
            fn nearest_on_surface(&self, x: DVec3) -> DVec3 {
                x
            }
        }
        let cells = Cells(vec![
            (DVec3::ZERO, DVec3::new(2.0, 1.0, 1.0)),
            (DVec3::new(2.0, 1.0, 0.0), DVec3::new(3.0, 2.0, 1.0)),
        ]);
        let half = DVec3::new(1.5, 1.0, 0.5);
        let cut = cut_solid(&cells, half, half, 1.0, Order::Linear);
        assert_eq!(cut.element_count(), 12);
        assert!(cut.nodes.iter().all(|p| p.x <= 2.0 && p.y <= 1.0));
        let bar = cut_box(
            DVec3::new(1.0, 0.5, 0.5),
            DVec3::new(1.0, 0.5, 0.5),
            1.0,
            Order::Linear,
        );
        let tets: Vec<[u32; 4]> = (0..bar.element_count())
            .map(|e| bar.element(e).try_into().unwrap())
            .collect();
        assert_eq!(face_connected(tets.clone()), tets);
    }
}
