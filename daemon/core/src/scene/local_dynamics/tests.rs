use super::*;
use hapticd_plugin_api::HapticdBodyContact;

const DT: f64 = 1e-3;

/// A 2 × 4 × 6 cm box of `mass`, at rest at the origin, under `gravity`.
fn brick(mass: f64, gravity: DVec3) -> (HapticdLocalBody, DVec3) {
    let (a, b, c) = (0.02, 0.04, 0.06);
    let inertia = DVec3::new(b * b + c * c, a * a + c * c, a * a + b * b) * (mass / 12.0);
    let inverse = DMat3::from_diagonal(inertia.recip());
    (
        HapticdLocalBody {
            body: 3,
            first_object: 5,
            object_count: 2,
            orientation: [1.0, 0.0, 0.0, 0.0],
            inverse_mass: 1.0 / mass,
            inverse_inertia: inverse.transpose().to_cols_array(),
            acceleration: gravity.to_array(),
            ..HapticdLocalBody::default()
        },
        inertia,
    )
}

/// The brick standing on a floor at y = −0.02: its four bottom corners touch it.
fn on_floor(body: &mut HapticdLocalBody, friction: f64) {
    body.contact_count = 4;
    for (k, (x, z)) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .into_iter()
        .enumerate()
    {
        body.contacts[k] = HapticdBodyContact {
            point: [0.01 * x, -0.02, 0.03 * z],
            normal: [0.0, 1.0, 0.0],
            gap: 0.0,
            friction,
        };
    }
}

/// A light brick on a floor pressed hard at a top corner: it is pinned, and however its
/// contacts settle in a few sweeps, no point of it (its corners) moves faster than the
/// hand relative to the brick without the hand; unbounded but along the push, a corner
/// went at several times the hand's speed.
#[test]
fn no_point_of_a_pressed_body_moves_faster_than_the_hand() {
    let (mut record, _) = brick(0.039, DVec3::new(0.0, -9.81, 0.0));
    on_floor(&mut record, 0.4);
    let mut body = LocalBody::new((&record, None), &Change::default(), 0.05, None).unwrap();
    let corners: Vec<DVec3> = (0..8)
        .map(|k| {
            let sign = |bit: usize| if k & bit == 0 { -1.0 } else { 1.0 };
            DVec3::new(0.01 * sign(1), 0.02 * sign(2), 0.03 * sign(4))
        })
        .collect();
    let speed = 0.05;
    let mut fastest: f64 = 0.0;
    for tick in 0..50 {
        let m = body.motion();
        let at = m.position + m.orientation * DVec3::new(0.01, 0.02, 0.03);
        // 28 N pressing down and aslant onto the corner, turning as it goes.
        let force = DVec3::new(-8.0, -28.0, 6.0 * f64::from(tick % 7) / 7.0);
        body.step(
            DVec3::ZERO,
            DVec3::ZERO,
            &[Push {
                point: at,
                force,
                speed,
            }],
            DT,
        );
        let (hand, free) = (body.motion(), body.free);
        for c in &corners {
            let r = hand.orientation * *c;
            let relative = (hand.velocity - free.velocity) + (hand.spin - free.spin).cross(r);
            fastest = fastest.max(relative.length());
        }
    }
    assert!(fastest <= speed * (1.0 + 1e-9), "{fastest} m/s");
}

/// A deep finger's spring on a light body: the push gives the point it acts at, along
/// the push, at most the hand's speed, however large the force (through the centre,
/// exactly the hand's speed); on a heavy body the force acts whole (F·t/m), as no speed
/// bound is reached.
#[test]
fn a_hand_pushes_a_body_no_faster_than_it_moves_itself() {
    let push = |at: DVec3, force: DVec3| Push {
        point: at,
        force,
        speed: 0.16,
    };
    // 28 N (2 kN/m at 14 mm) on 39 g: unbounded, 0.7 m/s in one tick.
    let fastest_at = |at: DVec3| {
        let (record, _) = brick(0.039, DVec3::ZERO);
        let mut body = LocalBody::new((&record, None), &Change::default(), 0.05, None).unwrap();
        let mut fastest: f64 = 0.0;
        for _ in 0..50 {
            let m = body.motion();
            let point = at + (m.position - DVec3::ZERO);
            body.step(
                DVec3::ZERO,
                DVec3::ZERO,
                &[push(point, DVec3::Y * -28.0)],
                DT,
            );
            let m = body.motion();
            let along = (m.velocity + m.spin.cross(point - m.position)).dot(-DVec3::Y);
            fastest = fastest.max(along);
        }
        fastest
    };
    let through_centre = fastest_at(DVec3::new(0.0, 0.02, 0.0));
    assert!(
        (through_centre - 0.16).abs() < 1e-9,
        "the hand's speed is reached: {through_centre} m/s"
    );
    // Off the centre the whole body is bounded (no point within the push's reach of
    // the centre faster than the hand), so the point pushed goes slower: 0.114 m/s.
    let off_centre = fastest_at(DVec3::new(0.008, 0.02, 0.01));
    assert!((0.1..=0.16).contains(&off_centre), "{off_centre} m/s");
    // 0.5 N on 5 kg: 1 mm/s a tick's worth, far below the hand.
    let (record, _) = brick(5.0, DVec3::ZERO);
    let mut body = LocalBody::new((&record, None), &Change::default(), 0.05, None).unwrap();
    for _ in 0..10 {
        body.step(
            DVec3::ZERO,
            DVec3::ZERO,
            &[push(DVec3::ZERO, DVec3::Y * -0.5)],
            DT,
        );
    }
    let v = body.motion().velocity;
    assert!(
        (v - DVec3::Y * (-0.5 * 10.0 * DT / 5.0)).length() < 1e-15,
        "{v}"
    );
}

#[test]
fn a_free_body_answers_a_force_with_its_mass_and_a_torque_with_its_inertia() {
    let (record, inertia) = brick(0.5, DVec3::ZERO);
    let mut body = LocalBody::new((&record, None), &Change::default(), 0.05, None).unwrap();
    let (f, tau) = (DVec3::new(0.3, -0.2, 0.1), DVec3::new(0.0, 0.0, 2e-4));
    let ticks = 50;
    for _ in 0..ticks {
        body.step(f, tau, &[], DT);
    }
    let t = ticks as f64 * DT;
    let m = body.motion();
    // v = F t / m; about a principal axis, ω = τ t / I.
    assert!(
        (m.velocity - f / 0.5 * t).length() < 1e-12,
        "{}",
        m.velocity
    );
    assert!(
        (m.spin.z - tau.z / inertia.z * t).abs() < 1e-9,
        "{}",
        m.spin
    );
    // Symplectic Euler: x = F/m · dt² · n(n+1)/2, exactly.
    let x = f / 0.5 * DT * DT * (ticks * (ticks + 1)) as f64 / 2.0;
    assert!((m.position - x).length() < 1e-12);
    // The twin without the hand stayed put: the change is the whole motion.
    let change = body.change();
    assert!((change.velocity - m.velocity).length() < 1e-15);
    assert!((change.displacement - m.position).length() < 1e-15);
}

#[test]
fn a_body_on_a_floor_neither_sinks_nor_sticks_and_slides_at_the_coulomb_rate() {
    let g = DVec3::new(0.0, -9.81, 0.0);
    let (mut record, _) = brick(1.0, g);
    on_floor(&mut record, 0.3);
    let mut body = LocalBody::new((&record, None), &Change::default(), 0.1, None).unwrap();
    // Gravity alone: it stays where it is (to a tenth of a micrometre while the
    // contacts' impulses settle in the first ticks).
    for _ in 0..100 {
        body.step(DVec3::ZERO, DVec3::ZERO, &[], DT);
    }
    assert!(
        body.motion().position.length() < 1e-7,
        "{:?}",
        body.motion()
    );
    assert!(
        body.motion().velocity.length() < 1e-12,
        "{:?}",
        body.motion()
    );
    // Pushed along x through the centre by less than μ m g: held by friction.
    for _ in 0..100 {
        body.step(DVec3::X * 2.0, DVec3::ZERO, &[], DT);
    }
    assert!(
        body.motion().velocity.length() < 1e-9,
        "{:?}",
        body.motion()
    );
    // By more: a = (F − μ m g) / m, exactly, and it still does not sink.
    let mut body = LocalBody::new((&record, None), &Change::default(), 0.1, None).unwrap();
    for _ in 0..100 {
        body.step(DVec3::X * 5.0, DVec3::ZERO, &[], DT);
    }
    let v = body.motion().velocity;
    let expected = (5.0 - 0.3 * 9.81) * 100.0 * DT;
    assert!((v.x - expected).abs() < 1e-6, "{v} vs {expected}");
    assert!(
        v.y.abs() < 1e-9 && body.motion().position.y.abs() < 1e-6,
        "{:?}",
        body.motion()
    );
    // Lifted harder than its weight, it leaves the floor at (F − m g)/m.
    let mut body = LocalBody::new((&record, None), &Change::default(), 0.1, None).unwrap();
    for _ in 0..100 {
        body.step(DVec3::Y * 12.0, DVec3::ZERO, &[], DT);
    }
    let lift = (12.0 - 9.81) * 100.0 * DT;
    assert!((body.motion().velocity.y - lift).abs() < 1e-9);
}

#[test]
fn what_goes_back_is_the_difference_from_the_next_step_not_only_the_hands_part() {
    // A brick slides at 0.25 m/s on a floor of μ = 0.3, untouched, for a 10 Hz period:
    // here it stops after v/(μg) = 85 ms, having slid v²/(2μg) = 10.6 mm. The step
    // stopped it with one period's friction impulse where it was.
    let (g, mu, v) = (9.81, 0.3, 0.25);
    let (mut record, _) = brick(1.0, DVec3::new(0.0, -g, 0.0));
    on_floor(&mut record, mu);
    record.velocity = [v, 0.0, 0.0];
    let mut body = LocalBody::new((&record, None), &Change::default(), 0.1, None).unwrap();
    for _ in 0..100 {
        body.step(DVec3::ZERO, DVec3::ZERO, &[], DT);
    }
    let slid = v * v / (2.0 * mu * g);
    assert!(
        (body.motion().position.x - slid).abs() < 2e-4,
        "{:?}",
        body.motion()
    );
    assert!(body.change().is_zero());
    let next = HapticdLocalBody {
        velocity: [0.0; 3],
        ..record
    };
    let back = body.change_to(&next, &Change::default()).unwrap();
    assert!((back.displacement.x - body.motion().position.x).abs() < 1e-12);
    assert!(back.velocity.length() < 1e-6, "{back:?}");
    // With a change still pending, only the rest goes back.
    let pending = Change {
        displacement: DVec3::X * 0.004,
        ..Change::default()
    };
    let rest = body.change_to(&next, &pending).unwrap();
    assert!((rest.displacement.x - (back.displacement.x - 0.004)).abs() < 1e-12);
    let broken = HapticdLocalBody {
        position: [f64::NAN, 0.0, 0.0],
        ..record
    };
    assert_eq!(body.change_to(&broken, &Change::default()), None);
}

#[test]
fn a_ball_pushed_over_its_top_rolls_on_the_floor_without_sinking_into_it() {
    // A steel ball of 12 mm on a floor, pressed down at its top by 10 N and pushed along
    // by 1 N there. Rolling without slipping (μ N = 3.2 N is far above the 3F/7 it
    // needs): m a = F + f and (2/5) m R² a / R = (F − f) R, so a = 10 F / (7 m).
    let (radius, mass) = (0.012, 0.0565);
    let inertia = 0.4 * mass * radius * radius;
    let mut record = HapticdLocalBody {
        body: 1,
        object_count: 1,
        orientation: [1.0, 0.0, 0.0, 0.0],
        inverse_mass: 1.0 / mass,
        inverse_inertia: DMat3::from_diagonal(DVec3::splat(1.0 / inertia)).to_cols_array(),
        acceleration: [0.0, -9.81, 0.0],
        contact_count: 1,
        ..HapticdLocalBody::default()
    };
    record.contacts[0] = HapticdBodyContact {
        point: [0.0, -radius, 0.0],
        normal: [0.0, 1.0, 0.0],
        gap: 0.0,
        friction: 0.3,
    };
    let mut body = LocalBody::new((&record, None), &Change::default(), 0.1, None).unwrap();
    let (push, down) = (1.0, 10.0);
    let top = DVec3::new(0.0, radius, 0.0);
    for _ in 0..100 {
        let at = top + body.motion().position;
        let force = DVec3::new(push, -down, 0.0);
        body.step(force, (at - body.motion().position).cross(force), &[], DT);
    }
    let m = body.motion();
    let expected = 10.0 * push / (7.0 * mass) * 100.0 * DT;
    assert!(
        (m.velocity.x - expected).abs() < 1e-6 * expected,
        "{m:?} vs {expected}"
    );
    // Rolling: the bottom point stands still, so the spin is v / R about −z.
    assert!(
        (m.spin.z + m.velocity.x / radius).abs() < 1e-4 * m.spin.z.abs(),
        "{m:?}"
    );
    // It turned by more than half a radian and its bottom stays on the floor.
    assert!(m.spin.z.abs() * 0.05 > 0.5);
    assert!(
        m.position.y.abs() < 1e-7 && m.velocity.y.abs() < 1e-9,
        "{m:?}"
    );
}

#[test]
fn a_gap_is_closed_not_jumped() {
    // The brick 1 cm above the floor, falling: it lands on it instead of stopping short
    // or passing through (to a micrometre: the impact's impulses take a few ticks).
    let g = DVec3::new(0.0, -9.81, 0.0);
    let (mut record, _) = brick(1.0, g);
    on_floor(&mut record, 0.3);
    for c in &mut record.contacts[..4] {
        c.gap = 0.01;
    }
    let mut body = LocalBody::new((&record, None), &Change::default(), 0.1, None).unwrap();
    for _ in 0..200 {
        body.step(DVec3::ZERO, DVec3::ZERO, &[], DT);
    }
    let y = body.motion().position.y;
    assert!((y + 0.01).abs() < 1e-6, "{y}");
    assert!(body.motion().velocity.length() < 1e-9);
}

#[test]
fn a_restart_keeps_what_is_shown_and_fades_the_jump_out_over_a_period() {
    let (record, _) = brick(1.0, DVec3::ZERO);
    let pending = Change {
        displacement: DVec3::new(0.002, 0.0, 0.0),
        velocity: DVec3::new(0.1, 0.0, 0.0),
        ..Change::default()
    };
    let shown = Pose {
        position: DVec3::new(0.003, 0.0, 0.0),
        ..Pose::default()
    };
    let mut body = LocalBody::new((&record, None), &pending, 0.05, Some(shown)).unwrap();
    // Nothing jumps: it is shown where it was.
    assert!((body.shown().position - shown.position).length() < 1e-15);
    // The pending change is in the state: it moves at 0.1 m/s from 2 mm.
    assert_eq!(body.motion().position, pending.displacement);
    assert_eq!(body.motion().velocity, pending.velocity);
    for _ in 0..50 {
        body.step(DVec3::ZERO, DVec3::ZERO, &[], DT);
    }
    // A period later the 1 mm of difference is gone.
    let end = 0.002 + 0.1 * 0.05;
    assert!((body.shown().position.x - end).abs() < 1e-12);
    // Planes found at the published state are carried along with it.
    let (at, normal, velocity) = body.carry(DVec3::new(0.01, 0.0, 0.0), DVec3::X);
    assert!((at.x - (end + 0.01)).abs() < 1e-12);
    assert_eq!(normal, DVec3::X);
    assert!((velocity.x - 0.1).abs() < 1e-12);
    assert!(body.owns(5) && body.owns(6) && !body.owns(7) && !body.owns(4));
}

#[test]
fn an_orientation_written_with_the_other_sign_is_the_same_orientation() {
    // q and −q are one rotation; a plugin may write either. Shown at 0.3 rad about y,
    // published at 0.31 rad written as −q: the jump to fade is −0.01 rad, not nearly a
    // whole turn the other way (which would spin the surface under a finger at 125 rad/s).
    let (mut record, _) = brick(1.0, DVec3::ZERO);
    let published = -DQuat::from_rotation_y(0.31);
    record.orientation = [published.w, published.x, published.y, published.z];
    let shown = Pose {
        orientation: DQuat::from_rotation_y(0.3),
        ..Pose::default()
    };
    let body = LocalBody::new((&record, None), &Change::default(), 0.05, Some(shown)).unwrap();
    assert!(
        (body.shown().spin - DVec3::Y * 0.2).length() < 1e-9,
        "{:?}",
        body.shown()
    );
    assert!(body.shown().orientation.angle_between(shown.orientation) < 1e-9);
    // The next step writes its 0.32 rad with the usual sign: the hand is 0.01 rad short.
    let turned = DQuat::from_rotation_y(0.32);
    let next = HapticdLocalBody {
        orientation: [turned.w, turned.x, turned.y, turned.z],
        ..record
    };
    let back = body.change_to(&next, &Change::default()).unwrap();
    assert!(
        (back.rotation + DVec3::Y * 0.01).length() < 1e-12,
        "{back:?}"
    );
}

#[test]
fn a_record_that_is_not_finite_or_has_no_mass_is_refused() {
    let (mut record, _) = brick(1.0, DVec3::ZERO);
    record.velocity[1] = f64::NAN;
    assert!(LocalBody::new((&record, None), &Change::default(), 0.05, None).is_none());
    let (mut record, _) = brick(1.0, DVec3::ZERO);
    record.inverse_mass = 0.0;
    assert!(LocalBody::new((&record, None), &Change::default(), 0.05, None).is_none());
}

/// The mobility of a slab of `mass`, `width` × `thickness` (tall along y), hinged along y
/// through the origin, its centre `width / 2` along x, written as a plugin gives it: the
/// twist S = (a × c, a) of a unit rate about the hinge, over the moment about it, S·Sᵀ / I.
fn door(mass: f64, width: f64, thickness: f64) -> (HapticdLocalBody, HapticdMobility, f64) {
    let centre = DVec3::new(width / 2.0, 0.0, 0.0);
    let moment = mass * ((width * width + thickness * thickness) / 12.0 + width * width / 4.0);
    let (v, w) = (DVec3::Y.cross(centre), DVec3::Y);
    let twist = [v.x, v.y, v.z, w.x, w.y, w.z];
    let mut mobility = HapticdMobility::default();
    for (r, row) in mobility.mobility.iter_mut().enumerate() {
        for (c, x) in row.iter_mut().enumerate() {
            *x = twist[r] * twist[c] / moment;
        }
    }
    let (mut record, _) = brick(mass, DVec3::ZERO);
    record.position = centre.to_array();
    (record, mobility, moment)
}

/// A hinged door pushed at its handle, 15 N for a 50 ms period: it turns about its hinge as
/// its moment there says (τ·t / I), its hinge stays where it is, and a push along the hinge
/// moves it not at all; the same door as a free slab moves off.
#[test]
fn a_jointed_door_turns_about_its_hinge_by_its_moment_there() {
    let (record, mobility, moment) = door(2.4, 0.4, 0.02);
    let handle = DVec3::new(0.35, 0.1, 0.0);
    let hinge = DVec3::new(0.0, 0.1, 0.0);
    let push = |force: DVec3| Push {
        point: handle,
        force,
        speed: 10.0,
    };
    let mut body =
        LocalBody::new((&record, Some(&mobility)), &Change::default(), 0.05, None).unwrap();
    let force = DVec3::new(0.0, 0.0, 15.0);
    for _ in 0..50 {
        body.step(DVec3::ZERO, DVec3::ZERO, &[push(force)], DT);
    }
    let m = body.motion();
    let expected = (handle - hinge).cross(force).y * 0.05 / moment;
    println!("spin {:.6} rad/s, τ·t/I {expected:.6} rad/s", m.spin.y);
    assert!((m.spin.y / expected - 1.0).abs() < 1e-9);
    assert!(m.spin.x.abs() + m.spin.z.abs() < 1e-12);
    // The hinge's point of the door: still, and where it was.
    let at_hinge = m.velocity + m.spin.cross(hinge - m.position);
    let turn = m.orientation * quat_from_wxyz(record.orientation).inverse();
    let moved = m.position + turn * (hinge - DVec3::from(record.position)) - hinge;
    println!(
        "hinge: {:.2e} m/s, {:.2e} m off",
        at_hinge.length(),
        moved.length()
    );
    assert!(at_hinge.length() < 1e-12);
    // A first-order step of 50 ticks off the circle by (ω·dt)²/2 a tick at most.
    assert!(moved.length() < 50.0 * (m.spin.y * DT).powi(2) * 0.35);
    let mut along =
        LocalBody::new((&record, Some(&mobility)), &Change::default(), 0.05, None).unwrap();
    along.step(DVec3::ZERO, DVec3::ZERO, &[push(DVec3::Y * 15.0)], DT);
    assert!(along.motion().velocity.length() < 1e-12);
    assert_eq!(along.motion().spin, DVec3::ZERO);
    let mut free = LocalBody::new((&record, None), &Change::default(), 0.05, None).unwrap();
    free.step(DVec3::ZERO, DVec3::ZERO, &[push(DVec3::Y * 15.0)], DT);
    assert!(free.motion().velocity.y > 0.0);
}

/// A mobility that is not finite, not symmetric or moves a point against a push is no
/// jointed body's.
#[test]
fn an_unsound_mobility_is_refused() {
    let (record, mobility, _) = door(2.4, 0.4, 0.02);
    assert!(Mobility::jointed(&mobility).is_some());
    let mut broken = [mobility; 3];
    broken[0].mobility[2][3] = f64::NAN;
    broken[1].mobility[0][5] += 1.0;
    broken[2].mobility[4][4] = -1.0;
    for m in broken {
        assert!(Mobility::jointed(&m).is_none());
        assert!(LocalBody::new((&record, Some(&m)), &Change::default(), 0.05, None).is_none());
    }
}
