//! The point of a triangle nearest a point, as weights of its corners: what an enclosure
//! measures a surface by, and where a finger meets a soft body's deforming surface (the
//! weights share a push among the corners' nodes).

use glam::DVec3;

/// The weights (summing to 1) of triangle `[a, b, c]`'s corners at its point nearest `x`:
/// in its face, on an edge, or a corner.
pub fn nearest_weights(x: DVec3, [a, b, c]: [DVec3; 3]) -> [f64; 3] {
    let (ab, ac, ap) = (b - a, c - a, x - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = x - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return [1.0 - t, t, 0.0];
    }
    let cp = x - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return [1.0 - t, 0.0, t];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - t, t];
    }
    let sum = va + vb + vc;
    if sum <= 0.0 {
        // A triangle of no area: its corners' nearest.
        let nearest = [a, b, c]
            .iter()
            .enumerate()
            .min_by(|p, q| p.1.distance(x).total_cmp(&q.1.distance(x)))
            .map_or(0, |(k, _)| k);
        let mut w = [0.0; 3];
        w[nearest] = 1.0;
        return w;
    }
    [va / sum, vb / sum, vc / sum]
}

/// Triangle `corners`' point nearest `x`.
pub fn nearest_point(x: DVec3, corners: [DVec3; 3]) -> DVec3 {
    let w = nearest_weights(x, corners);
    corners[0] * w[0] + corners[1] * w[1] + corners[2] * w[2]
}
