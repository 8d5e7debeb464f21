//! Closest points of two separated convex polytopes (Gilbert–Johnson–Keerthi): the search
//! runs on their Minkowski difference, whose point nearest the origin gives the distance,
//! and the simplex's barycentric weights give the two witness points.

use glam::DVec3;

/// A point of the Minkowski difference with the two points it came from.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Support {
    w: DVec3,
    a: DVec3,
    b: DVec3,
}

fn farthest(points: &[DVec3], d: DVec3) -> DVec3 {
    points
        .iter()
        .copied()
        .max_by(|p, q| p.dot(d).total_cmp(&q.dot(d)))
        .unwrap_or(DVec3::ZERO)
}

fn support(a: &[DVec3], b: &[DVec3], offset: DVec3, d: DVec3) -> Support {
    let (pa, pb) = (farthest(a, d), farthest(b, -d) + offset);
    Support {
        w: pa - pb,
        a: pa,
        b: pb,
    }
}

/// The point of the simplex's affine hull nearest the origin, as weights over the simplex,
/// if it lies inside the simplex (all weights ≥ 0).
fn project(simplex: &[Support]) -> Option<([f64; 4], DVec3)> {
    let n = simplex.len();
    let w0 = simplex[0].w;
    // Solve for weights λ1.. of edges ei = wi − w0 minimising |w0 + Σ λi ei|².
    let mut edges = [DVec3::ZERO; 3];
    for (e, s) in edges.iter_mut().zip(&simplex[1..]) {
        *e = s.w - w0;
    }
    let m = n - 1;
    let mut a = [[0.0; 3]; 3];
    let mut rhs = [0.0; 3];
    for r in 0..m {
        for c in 0..m {
            a[r][c] = edges[r].dot(edges[c]);
        }
        rhs[r] = -edges[r].dot(w0);
    }
    let lambda = solve(a, rhs, m)?;
    let mut weights = [0.0; 4];
    weights[0] = 1.0 - lambda[..m].iter().sum::<f64>();
    weights[1..n].copy_from_slice(&lambda[..m]);
    if weights[..n].iter().any(|w| *w < -1e-12) {
        return None;
    }
    let point = simplex
        .iter()
        .zip(weights)
        .fold(DVec3::ZERO, |p, (s, l)| p + s.w * l);
    Some((weights, point))
}

fn solve(mut a: [[f64; 3]; 3], mut b: [f64; 3], n: usize) -> Option<[f64; 3]> {
    for c in 0..n {
        let p = (c..n).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if a[p][c].abs() < 1e-18 {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in 0..n {
            if r != c {
                let f = a[r][c] / a[c][c];
                let pivot = a[c];
                for (x, y) in a[r].iter_mut().zip(pivot) {
                    *x -= f * y;
                }
                b[r] -= f * b[c];
            }
        }
    }
    let mut x = [0.0; 3];
    for i in 0..n {
        x[i] = b[i] / a[i][i];
    }
    Some(x)
}

/// A simplex of up to four support points.
#[derive(Debug, Clone, Copy)]
struct Simplex {
    points: [Support; 4],
    len: usize,
}

impl Simplex {
    fn points(&self) -> &[Support] {
        &self.points[..self.len]
    }

    fn push(&mut self, s: Support) {
        self.points[self.len] = s;
        self.len += 1;
    }
}

/// Reduce `simplex` to its sub-simplex nearest the origin; returns that nearest point.
/// The point just added is always part of it (it is what brought the simplex closer), so
/// only the sub-simplices holding it are tried.
fn reduce(simplex: &mut Simplex) -> DVec3 {
    let n = simplex.len;
    let empty = Simplex {
        points: [simplex.points[0]; 4],
        len: 0,
    };
    let newest = 1u32 << (n - 1);
    let mut best: Option<(f64, Simplex, DVec3)> = None;
    for mask in (1u32..(1 << n)).filter(|mask| mask & newest != 0) {
        let mut sub = empty;
        for i in (0..n).filter(|i| mask & (1 << i) != 0) {
            sub.push(simplex.points[i]);
        }
        if let Some((weights, point)) = project(sub.points()) {
            // Keep only points with weight: the others do not support the nearest point.
            let mut kept = empty;
            for (s, w) in sub.points().iter().zip(weights) {
                if w > 1e-15 {
                    kept.push(*s);
                }
            }
            let d = point.length_squared();
            if kept.len > 0 && best.as_ref().is_none_or(|b| d < b.0) {
                best = Some((d, kept, point));
            }
        }
    }
    let (_, kept, point) = best.expect("a single vertex always projects onto itself");
    *simplex = kept;
    point
}

/// Closest points (on `a`, on `b` moved by `offset`) of two convex vertex sets, or `None`
/// when they overlap.
pub fn closest_points(a: &[DVec3], b: &[DVec3], offset: DVec3) -> Option<(DVec3, DVec3)> {
    // b moved apart along `offset` has its points nearest a that way: start the search
    // there (at rest, where the last step's normal moved it, it then ends in a step or two).
    let first = support(a, b, offset, offset.try_normalize().unwrap_or(DVec3::X));
    let mut simplex = Simplex {
        points: [first; 4],
        len: 1,
    };
    let mut nearest = first.w;
    for _ in 0..64 {
        if nearest.length_squared() < 1e-24 {
            return None;
        }
        let next = support(a, b, offset, -nearest);
        // No progress toward the origin, or a support point already in the simplex (faces
        // parallel to the search direction offer many equally near ones, and the search
        // would cycle among them): `nearest` is the minimum.
        let progress = nearest.length_squared() - nearest.dot(next.w);
        if progress <= 1e-12 * nearest.length_squared()
            || simplex.points().iter().any(|s| s.w == next.w)
        {
            break;
        }
        let (previous, before) = (simplex, nearest.length_squared());
        simplex.push(next);
        nearest = reduce(&mut simplex);
        // Rounding can stall the search just short of the minimum: keep the better simplex.
        if nearest.length_squared() >= before {
            simplex = previous;
            break;
        }
        if simplex.len == 4 {
            return None;
        }
    }
    // Witness points from the simplex weights.
    let points = simplex.points();
    let (weights, _) = project(points).unwrap_or(([1.0, 0.0, 0.0, 0.0], points[0].w));
    let pa = points
        .iter()
        .zip(weights)
        .fold(DVec3::ZERO, |p, (s, w)| p + s.a * w);
    let pb = points
        .iter()
        .zip(weights)
        .fold(DVec3::ZERO, |p, (s, w)| p + s.b * w);
    Some((pa, pb))
}
