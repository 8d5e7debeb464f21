//! Triangles to draw, in world coordinates, each vertex with its outward normal and colour.

use glam::{DQuat, DVec3};

/// One vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vertex {
    /// Position, metres.
    pub position: DVec3,
    /// Outward unit normal (zero: drawn unshaded).
    pub normal: DVec3,
    /// Linear RGBA, 0 to 1.
    pub colour: [f32; 4],
}

/// Triangles, three vertices each, counter-clockwise seen from outside.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// The vertices, three per triangle.
    pub vertices: Vec<Vertex>,
}

impl Mesh {
    /// Add the flat triangle `a b c` (counter-clockwise from outside) in `colour`.
    pub fn triangle(&mut self, [a, b, c]: [DVec3; 3], colour: [f32; 4]) {
        let normal = (b - a).cross(c - a).normalize_or_zero();
        for position in [a, b, c] {
            self.vertices.push(Vertex {
                position,
                normal,
                colour,
            });
        }
    }

    /// Add the triangle `corners` (counter-clockwise from outside) in `colour`, shaded by
    /// the outward `normals` at its corners.
    pub fn shaded_triangle(&mut self, corners: [DVec3; 3], normals: [DVec3; 3], colour: [f32; 4]) {
        for (position, normal) in corners.into_iter().zip(normals) {
            self.vertices.push(Vertex {
                position,
                normal,
                colour,
            });
        }
    }

    /// Add the convex polygon `loop_` (counter-clockwise from outside) as a fan.
    pub fn polygon(&mut self, loop_: &[DVec3], colour: [f32; 4]) {
        for k in 1..loop_.len().saturating_sub(1) {
            self.triangle([loop_[0], loop_[k], loop_[k + 1]], colour);
        }
    }

    /// Add a box of half edges `half` at `centre`, turned by `rotation`.
    pub fn cuboid(&mut self, centre: DVec3, half: DVec3, rotation: DQuat, colour: [f32; 4]) {
        let corner = |x: f64, y: f64, z: f64| centre + rotation * (half * DVec3::new(x, y, z));
        // Each face: its outward axis and two in-face axes making a right-handed turn.
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut n = [0.0; 3];
                n[axis] = sign;
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let at = |a: f64, b: f64| {
                    let mut p = n;
                    p[u] = a;
                    p[v] = b;
                    corner(p[0], p[1], p[2])
                };
                let face = [at(-1.0, -1.0), at(1.0, -1.0), at(1.0, 1.0), at(-1.0, 1.0)];
                if sign > 0.0 {
                    self.polygon(&face, colour);
                } else {
                    self.polygon(&[face[0], face[3], face[2], face[1]], colour);
                }
            }
        }
    }

    /// Add a ball of `radius` at `centre`, smooth-shaded (`rings` latitude bands).
    pub fn ball(&mut self, centre: DVec3, radius: f64, rings: usize, colour: [f32; 4]) {
        let rings = rings.max(3);
        let segments = 2 * rings;
        let point = |i: usize, j: usize| {
            let theta = std::f64::consts::PI * i as f64 / rings as f64;
            let phi = std::f64::consts::TAU * j as f64 / segments as f64;
            DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            )
        };
        let mut push = |n: DVec3| {
            self.vertices.push(Vertex {
                position: centre + n * radius,
                normal: n,
                colour,
            })
        };
        for i in 0..rings {
            for j in 0..segments {
                let (a, b, c, d) = (
                    point(i, j),
                    point(i + 1, j),
                    point(i + 1, j + 1),
                    point(i, j + 1),
                );
                for n in [a, c, b, a, d, c] {
                    push(n);
                }
            }
        }
    }

    /// A floor of `size` square centred under `centre` at height `y`, striped every
    /// `stripe` metres along x and z (a distance scale, as the thesis' experiment had).
    pub fn floor(&mut self, centre: DVec3, y: f64, size: f64, stripe: f64, colours: [[f32; 4]; 2]) {
        let cells = (size / stripe).ceil().clamp(1.0, 400.0) as usize;
        let step = size / cells as f64;
        let start = centre - DVec3::new(size / 2.0, 0.0, size / 2.0);
        for i in 0..cells {
            for k in 0..cells {
                let (x, z) = (start.x + i as f64 * step, start.z + k as f64 * step);
                let corner = |dx: f64, dz: f64| DVec3::new(x + dx, y, z + dz);
                let quad = [
                    corner(0.0, 0.0),
                    corner(0.0, step),
                    corner(step, step),
                    corner(step, 0.0),
                ];
                self.polygon(&quad, colours[(i + k) % 2]);
            }
        }
    }

    /// Add a round bar of `radius` along the unit `axis` through `centre`, `length` long,
    /// capped at both ends.
    pub fn cylinder(
        &mut self,
        centre: DVec3,
        axis: DVec3,
        radius: f64,
        length: f64,
        colour: [f32; 4],
    ) {
        let axis = axis.normalize_or(DVec3::Y);
        let u = axis.any_orthonormal_vector();
        let v = axis.cross(u);
        let segments = 32;
        let (bottom, top) = (centre - axis * length / 2.0, centre + axis * length / 2.0);
        for j in 0..segments {
            let at = |k: usize| {
                let phi = std::f64::consts::TAU * k as f64 / segments as f64;
                u * phi.cos() + v * phi.sin()
            };
            let (a, b) = (at(j), at(j + 1));
            let side = [
                (bottom + a * radius, a),
                (bottom + b * radius, b),
                (top + b * radius, b),
                (bottom + a * radius, a),
                (top + b * radius, b),
                (top + a * radius, a),
            ];
            for (position, normal) in side {
                self.vertices.push(Vertex {
                    position,
                    normal,
                    colour,
                });
            }
            self.triangle([top, top + a * radius, top + b * radius], colour);
            self.triangle([bottom, bottom + b * radius, bottom + a * radius], colour);
        }
    }

    /// Add a square panel of side `size` through `point`, facing `normal` (a wall drawn
    /// where it is touched).
    pub fn panel(&mut self, point: DVec3, normal: DVec3, size: f64, colour: [f32; 4]) {
        let normal = normal.normalize_or(DVec3::Y);
        let u = normal.any_orthonormal_vector() * (size / 2.0);
        let v = normal.cross(u);
        self.polygon(
            &[point - u - v, point + u - v, point + u + v, point - u + v],
            colour,
        );
    }

    /// Add an arrow from `from` along `vector` (shaft and head), `width` across.
    pub fn arrow(&mut self, from: DVec3, vector: DVec3, width: f64, colour: [f32; 4]) {
        let length = vector.length();
        if length < 1e-9 {
            return;
        }
        let axis = vector / length;
        let head = (3.0 * width).min(0.5 * length);
        let shaft = length - head;
        self.cylinder(from + axis * shaft / 2.0, axis, width / 4.0, shaft, colour);
        let u = axis.any_orthonormal_vector();
        let v = axis.cross(u);
        let (base, tip) = (from + axis * shaft, from + vector);
        let segments = 16;
        for j in 0..segments {
            let at = |k: usize| {
                let phi = std::f64::consts::TAU * k as f64 / segments as f64;
                base + (u * phi.cos() + v * phi.sin()) * (width / 2.0)
            };
            self.triangle([at(j), at(j + 1), tip], colour);
            self.triangle([at(j + 1), at(j), base], colour);
        }
    }
}
