//! The god-object (proxy) of thesis 4.1.1: a massless point that never enters a solid and
//! moves toward the grip under Coulomb friction. The force shown to the user is a
//! spring-damper between proxy and grip, so it always points out of the surface touched.
//!
//! Each tick the proxy walks toward the grip; when its path enters a shape, the entry's
//! tangent plane becomes a constraint and the walk continues toward the point of the
//! constrained set closest to the grip. Up to three planes are kept, which covers faces,
//! edges and corners. Friction then decides how much of that frictionless motion happens:
//! stuck while the grip stays inside the static friction cone (angle atan μ0), sliding so as
//! to stay on the dynamic cone (atan μ) otherwise, and stuck again once sliding stops.

use glam::DVec3;

use super::obstacle::{Entry, Obstacles, SURFACE};
use super::touch::Touch;
use crate::solver::linalg::{ldlt_factor, ldlt_solve};

/// Most constraint planes at once (a corner).
const MAX_PLANES: usize = 3;
/// Most walk segments per tick.
const MAX_WALKS: usize = 6;
/// Grip-to-proxy distance under which there is no contact force, metres.
const CONTACT: f64 = 1e-9;

/// Parameters of the proxy's coupling and friction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProxyParameters {
    /// Spring between proxy and grip, N/m.
    pub stiffness: f64,
    /// Damper between proxy and grip, N·s/m.
    pub damping: f64,
    /// Static friction coefficient μ0.
    pub static_friction: f64,
    /// Dynamic friction coefficient μ (≤ μ0).
    pub dynamic_friction: f64,
}

impl Default for ProxyParameters {
    fn default() -> Self {
        Self {
            stiffness: 2_000.0,
            damping: 5.0,
            static_friction: 0.3,
            dynamic_friction: 0.2,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Plane {
    point: DVec3,
    normal: DVec3,
}

impl Plane {
    fn distance(&self, p: DVec3) -> f64 {
        (p - self.point).dot(self.normal)
    }
}

/// The proxy of one effector.
#[derive(Debug, Clone, PartialEq)]
pub struct Proxy {
    position: DVec3,
    /// Where the last update left the proxy: its velocity counts a carry too, so the
    /// damper pulls against a surface that drags the finger, never along with it.
    rendered: DVec3,
    velocity: DVec3,
    sliding: bool,
    in_contact: bool,
}

/// What the proxy renders this tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProxyOutput {
    /// Force on the user's hand, newtons.
    pub force: DVec3,
    /// Proxy position.
    pub proxy: DVec3,
    /// Whether the proxy touches a surface.
    pub in_contact: bool,
    /// Whether it is sliding (dynamic friction).
    pub sliding: bool,
}

/// The point of {x : planes[i] · x ≥ 0 for all i} closest to `goal`, for up to three planes:
/// every subset of planes is tried as equalities; the one whose multipliers are all
/// non-negative and whose point violates no other plane is the optimum.
fn closest_feasible(goal: DVec3, planes: &[Plane]) -> DVec3 {
    let n = planes.len();
    let mut best: Option<(f64, DVec3)> = None;
    for mask in 0u32..(1 << n) {
        let mut active = [0; MAX_PLANES];
        let mut k = 0;
        for i in (0..n).filter(|i| mask & (1 << i) != 0) {
            active[k] = i;
            k += 1;
        }
        // Solve (N Nᵀ) λ = −(N goal − d) for x = goal + Nᵀλ on the active planes; a
        // singular Gram matrix (parallel planes) means the subset is redundant.
        let mut a = [[0.0; MAX_PLANES]; MAX_PLANES];
        let mut lambda = [0.0; MAX_PLANES];
        for r in 0..k {
            let pr = planes[active[r]];
            for c in 0..k {
                a[r][c] = pr.normal.dot(planes[active[c]].normal);
            }
            lambda[r] = -pr.distance(goal);
        }
        if !ldlt_factor(&mut a, k, 1e-9) {
            continue;
        }
        ldlt_solve(&a, k, &mut lambda);
        if lambda[..k].iter().any(|l| *l < -1e-12) {
            continue;
        }
        let mut x = goal;
        for r in 0..k {
            x += planes[active[r]].normal * lambda[r];
        }
        if planes.iter().any(|p| p.distance(x) < -1e-9) {
            continue;
        }
        let d = (x - goal).length_squared();
        if best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, x));
        }
    }
    best.map_or(goal, |(_, x)| x)
}

/// Where the segment from `a` to `b` first enters one of `shapes`. Where it meets several
/// faces at once at one point (a mesh's edge or corner, reached exactly), the surface there
/// is their bisector: the mean of their distinct normals, so that an edge pushes back
/// along its bisector instead of along whichever face came first in the list.
fn first_entry<O: Obstacles + ?Sized>(obstacles: &O, a: DVec3, b: DVec3) -> Option<Entry> {
    let mut first: Option<Entry> = None;
    let mut normals = [DVec3::ZERO; 3];
    let mut distinct = 0;
    obstacles.entries(a, b, &mut |e| match first {
        Some(f) if (e.point - f.point).length() <= SURFACE => {
            if distinct < normals.len()
                && !normals[..distinct]
                    .iter()
                    .any(|n| n.dot(e.normal) > 1.0 - 1e-12)
            {
                normals[distinct] = e.normal;
                distinct += 1;
            }
        }
        Some(f) if e.t >= f.t => {}
        _ => {
            first = Some(e);
            normals[0] = e.normal;
            distinct = 1;
        }
    });
    let first = first?;
    let normal = normals[..distinct]
        .iter()
        .sum::<DVec3>()
        .try_normalize()
        .unwrap_or(first.normal);
    Some(Entry { normal, ..first })
}

impl Proxy {
    /// A proxy at `position`, free.
    pub fn new(position: DVec3) -> Self {
        Self {
            position,
            rendered: position,
            velocity: DVec3::ZERO,
            sliding: false,
            in_contact: false,
        }
    }

    /// Where the proxy is.
    pub fn position(&self) -> DVec3 {
        self.position
    }

    /// What the proxy touches as of the last update: a point of no body, its outward
    /// normal unknown here, and whether it slides.
    pub fn touch(&self) -> Touch {
        Touch {
            touching: self.in_contact,
            point: self.position,
            slipping: self.in_contact && self.sliding,
            ..Touch::NONE
        }
    }

    /// Move the proxy to `position` without rendering, keeping its contact and friction
    /// state: a surface it rests on carried it there.
    pub fn carry(&mut self, position: DVec3) {
        self.position = position;
    }

    /// Put the proxy at `position`, free (after a scene change or a fault).
    pub fn reset(&mut self, position: DVec3) {
        *self = Self::new(position);
    }

    /// Move toward the grip at `grip` (velocity `grip_velocity`) among `shapes`, and return
    /// the force to render. `dt` is the tick period.
    pub fn update<O: Obstacles + ?Sized>(
        &mut self,
        grip: DVec3,
        grip_velocity: DVec3,
        shapes: &O,
        parameters: &ProxyParameters,
        dt: f64,
    ) -> ProxyOutput {
        let previous = self.position;
        let mut planes = [Plane {
            point: DVec3::ZERO,
            normal: DVec3::Y,
        }; MAX_PLANES];
        let mut count = 0;
        let mut position = previous;
        let mut met = None;
        for _ in 0..MAX_WALKS {
            let target = closest_feasible(grip, &planes[..count]);
            let Some(e) = first_entry(shapes, position, target) else {
                position = target;
                break;
            };
            position = e.point;
            met.get_or_insert(e.point);
            if count == MAX_PLANES {
                break;
            }
            planes[count] = Plane {
                point: e.point,
                normal: e.normal,
            };
            count += 1;
        }
        let in_contact = count > 0 && (grip - position).length() > CONTACT;
        if in_contact {
            // Friction holds the proxy where it was, or where it met the surface this tick.
            let anchor = if self.in_contact {
                previous
            } else {
                met.unwrap_or(position)
            };
            position = self.apply_friction(anchor, position, grip, &planes[..count], parameters);
        } else {
            self.sliding = false;
        }
        self.velocity = (position - self.rendered) / dt;
        self.position = position;
        self.rendered = position;
        self.in_contact = in_contact;
        let force = if in_contact {
            parameters.stiffness * (position - grip)
                + parameters.damping * (self.velocity - grip_velocity)
        } else {
            DVec3::ZERO
        };
        ProxyOutput {
            force,
            proxy: position,
            in_contact,
            sliding: self.sliding,
        }
    }

    /// Coulomb friction on the frictionless proxy position `free`: stay at `anchor` while
    /// the grip is inside the friction cone, else slide to the cone's edge.
    fn apply_friction(
        &mut self,
        anchor: DVec3,
        free: DVec3,
        grip: DVec3,
        planes: &[Plane],
        parameters: &ProxyParameters,
    ) -> DVec3 {
        // The anchor must lie on the constraint set (not across an edge just passed).
        let on_surface = planes.iter().all(|p| p.distance(anchor) >= -1e-9)
            && planes.iter().any(|p| p.distance(anchor).abs() <= 1e-7);
        if !on_surface {
            self.sliding = false;
            return free;
        }
        let depth = (free - grip).length();
        let slip = (anchor - free).length();
        let mu = if self.sliding {
            parameters.dynamic_friction
        } else {
            parameters.static_friction
        };
        if slip <= mu * depth {
            self.sliding = false;
            return anchor;
        }
        self.sliding = true;
        free + (anchor - free) * (parameters.dynamic_friction * depth / slip)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::haptics::obstacle::Shape;

    const DT: f64 = 1e-3;

    fn floor() -> Shape {
        Shape::HalfSpace {
            point: DVec3::ZERO,
            normal: DVec3::Y,
        }
    }

    fn frictionless() -> ProxyParameters {
        ProxyParameters {
            stiffness: 1000.0,
            damping: 0.0,
            static_friction: 0.0,
            dynamic_friction: 0.0,
        }
    }

    #[test]
    fn free_space_gives_no_force() {
        let mut p = Proxy::new(DVec3::new(0.0, 0.1, 0.0));
        let out = p.update(
            DVec3::new(0.01, 0.05, 0.0),
            DVec3::ZERO,
            &[floor()][..],
            &frictionless(),
            DT,
        );
        assert_eq!(out.force, DVec3::ZERO);
        assert_eq!(out.proxy, DVec3::new(0.01, 0.05, 0.0));
    }

    #[test]
    fn a_floor_pushes_back_in_proportion_to_depth() {
        let mut p = Proxy::new(DVec3::new(0.0, 0.01, 0.0));
        let out = p.update(
            DVec3::new(0.02, -0.003, 0.0),
            DVec3::ZERO,
            &[floor()][..],
            &frictionless(),
            DT,
        );
        assert!(
            (out.proxy - DVec3::new(0.02, 0.0, 0.0)).length() < 1e-9,
            "{}",
            out.proxy
        );
        assert!(
            (out.force - DVec3::new(0.0, 3.0, 0.0)).length() < 1e-6,
            "{}",
            out.force
        );
    }

    #[test]
    fn the_proxy_never_passes_through_a_thin_sphere_or_box_corner() {
        let shapes = [
            Shape::Sphere {
                centre: DVec3::ZERO,
                radius: 0.02,
            },
            Shape::Cuboid {
                centre: DVec3::new(0.1, 0.0, 0.0),
                half: DVec3::splat(0.02),
                rotation: glam::DQuat::IDENTITY,
            },
        ];
        let mut p = Proxy::new(DVec3::new(0.0, 0.05, 0.0));
        // The grip sweeps straight through both solids.
        for i in 0..400 {
            let x = -0.05 + 0.2 * i as f64 / 400.0;
            let grip = DVec3::new(x, 0.0, 0.005);
            let out = p.update(grip, DVec3::ZERO, &shapes[..], &frictionless(), DT);
            for s in &shapes {
                assert!(
                    s.signed_distance(out.proxy) > -1e-9,
                    "inside at x = {x}: {}",
                    out.proxy
                );
            }
        }
    }

    #[test]
    fn a_corner_holds_the_proxy_on_three_faces() {
        let cube = Shape::Cuboid {
            centre: DVec3::ZERO,
            half: DVec3::splat(0.05),
            rotation: glam::DQuat::IDENTITY,
        };
        let mut p = Proxy::new(DVec3::splat(0.08));
        // Approach the corner along the diagonal, then push in.
        for i in 0..100 {
            let grip = DVec3::splat(0.08 - 0.05 * i as f64 / 100.0);
            let out = p.update(grip, DVec3::ZERO, &[cube][..], &frictionless(), DT);
            assert!(cube.signed_distance(out.proxy) > -1e-9);
        }
        assert!(
            (p.position() - DVec3::splat(0.05)).length() < 1e-6,
            "{}",
            p.position()
        );
    }

    #[test]
    fn a_proxy_carried_by_its_surface_is_damped_against_the_carry() {
        // Pressed 2 mm into a floor that carries the proxy 0.1 mm a tick (0.1 m/s): the
        // damper sees the carry, so the hand is pulled along with the surface and the
        // surface held back by the hand. Counting only the proxy's own step would push the
        // surface on and feed whatever drives it (a light body spun up by a finger).
        let parameters = ProxyParameters {
            stiffness: 1000.0,
            damping: 5.0,
            static_friction: 0.5,
            dynamic_friction: 0.4,
        };
        let grip = DVec3::new(0.0, -0.002, 0.0);
        let mut p = Proxy::new(DVec3::new(0.0, 0.01, 0.0));
        p.update(grip, DVec3::ZERO, &[floor()][..], &parameters, DT);
        let rested = p.position();
        p.update(grip, DVec3::ZERO, &[floor()][..], &parameters, DT);
        let carry = DVec3::new(1e-4, 0.0, 0.0);
        p.carry(p.position() + carry);
        let out = p.update(grip, DVec3::ZERO, &[floor()][..], &parameters, DT);
        // Static friction holds it where it was carried to.
        assert!(
            (out.proxy - (rested + carry)).length() < 1e-12,
            "{}",
            out.proxy
        );
        let expected = parameters.stiffness * 1e-4 + parameters.damping * 0.1;
        assert!(
            (out.force.x - expected).abs() < 1e-9,
            "{} vs {expected}",
            out.force.x
        );
    }

    #[test]
    fn friction_sticks_inside_the_cone_and_slides_on_it_outside() {
        let parameters = ProxyParameters {
            stiffness: 1000.0,
            damping: 0.0,
            static_friction: 0.5,
            dynamic_friction: 0.3,
        };
        let mut p = Proxy::new(DVec3::new(0.0, 0.01, 0.0));
        p.update(
            DVec3::new(0.0, -0.01, 0.0),
            DVec3::ZERO,
            &[floor()][..],
            &parameters,
            DT,
        );
        // 10 mm deep; sideways by 4 mm: tangential 4 N ≤ 0.5 · 10 N, the proxy stays.
        let out = p.update(
            DVec3::new(0.004, -0.01, 0.0),
            DVec3::ZERO,
            &[floor()][..],
            &parameters,
            DT,
        );
        assert!(!out.sliding && out.proxy.x.abs() < 1e-9);
        assert!((out.force.x + 4.0).abs() < 1e-6);
        // Sideways by 8 mm: beyond μ0; it slides to the dynamic cone, 3 mm behind the grip.
        let out = p.update(
            DVec3::new(0.008, -0.01, 0.0),
            DVec3::ZERO,
            &[floor()][..],
            &parameters,
            DT,
        );
        assert!(out.sliding, "{out:?}");
        assert!((out.proxy.x - 0.005).abs() < 1e-9, "{}", out.proxy);
        assert!((out.force.x + 3.0).abs() < 1e-6 && (out.force.y - 10.0).abs() < 1e-6);
        // The grip stops: the proxy stays 3 mm behind, inside the dynamic cone, and sticks.
        let out = p.update(
            DVec3::new(0.008, -0.01, 0.0),
            DVec3::ZERO,
            &[floor()][..],
            &parameters,
            DT,
        );
        assert!(!out.sliding && (out.proxy.x - 0.005).abs() < 1e-9);
    }

    /// The box `centre` ± `half` as the triangles a proxy walks among.
    fn box_faces(centre: DVec3, half: DVec3) -> Vec<Shape> {
        super::super::fixtures::box_faces(centre, half)
            .into_iter()
            .map(|[a, b, c]| Shape::triangle(a, b, c).unwrap())
            .collect()
    }

    #[test]
    fn a_meshs_faces_press_and_rub_exactly_as_the_equal_box_does() {
        // Down onto the top of a box, pressing, then sliding diagonally across the seam of
        // its two top triangles and on: each tick the same force as the analytic box, with
        // friction, to 1e-9 N.
        let (centre, half) = (DVec3::new(0.0, -0.05, 0.0), DVec3::new(0.04, 0.05, 0.03));
        let mesh = box_faces(centre, half);
        let cuboid = [Shape::Cuboid {
            centre,
            half,
            rotation: glam::DQuat::IDENTITY,
        }];
        let parameters = ProxyParameters {
            stiffness: 800.0,
            damping: 2.0,
            static_friction: 0.4,
            dynamic_friction: 0.3,
        };
        let start = DVec3::new(-0.02, 0.01, -0.015);
        let (mut on_mesh, mut on_box) = (Proxy::new(start), Proxy::new(start));
        let mut worst = 0.0f64;
        let mut pressed = 0;
        for k in 0..600 {
            let s = k as f64 / 600.0;
            let grip = start + DVec3::new(0.05 * s, -0.02 * (4.0 * s).min(1.0), 0.03 * s);
            let velocity =
                DVec3::new(0.05, if s < 0.25 { -0.08 } else { 0.0 }, 0.03) / (600.0 * DT);
            let a = on_mesh.update(grip, velocity, &mesh[..], &parameters, DT);
            let b = on_box.update(grip, velocity, &cuboid[..], &parameters, DT);
            worst = worst.max((a.force - b.force).length());
            pressed += usize::from(a.in_contact);
        }
        assert!(pressed > 400, "{pressed} ticks pressed");
        assert!(worst < 1e-9, "the mesh differs from the box by {worst} N");
    }

    #[test]
    fn a_finger_pressed_20_n_into_a_2_mm_shell_never_gets_through() {
        // The grip jumps 5 mm a tick, more than the shell is thick, down to 5 cm below it.
        let mesh = box_faces(DVec3::ZERO, DVec3::new(0.05, 0.001, 0.05));
        let mut p = Proxy::new(DVec3::new(0.01, 0.02, 0.0));
        let mut force = DVec3::ZERO;
        for k in 0..15 {
            let grip = DVec3::new(0.01, 0.02 - 0.005 * f64::from(k), 0.0);
            let out = p.update(grip, DVec3::ZERO, &mesh[..], &frictionless(), DT);
            assert!(
                out.proxy.y >= 0.001 - 1e-9,
                "through the shell at tick {k}: {}",
                out.proxy
            );
            force = out.force;
        }
        // 5 cm below the top at 1000 N/m: 51 N, pushing up.
        assert!(
            (force - DVec3::new(0.0, 1000.0 * (0.001 + 0.05), 0.0)).length() < 1e-9,
            "{force}"
        );
    }

    #[test]
    fn a_meshs_edge_and_corner_push_along_their_bisectors() {
        let mesh = box_faces(DVec3::ZERO, DVec3::splat(0.02));
        let edge = DVec3::new(0.0, 0.02, 0.02);
        let corner = DVec3::splat(0.02);
        for (point, bisector) in [
            (edge, DVec3::new(0.0, 1.0, 1.0).normalize()),
            (corner, DVec3::ONE.normalize()),
        ] {
            // From outside along the bisector, pressed 5 mm past the edge or corner.
            let mut p = Proxy::new(point + bisector * 0.01);
            let out = p.update(
                point - bisector * 0.005,
                DVec3::ZERO,
                &mesh[..],
                &frictionless(),
                DT,
            );
            assert!((out.proxy - point).length() < 1e-9, "{}", out.proxy);
            assert!(
                (out.force - bisector * 5.0).length() < 1e-9,
                "{}",
                out.force
            );
        }
    }
}
