use super::*;
use glam::DQuat;

const RATE: f64 = 20.0;
const TICK: f64 = 1e-3;

fn pointer(position: DVec3, velocity: DVec3) -> Pointer {
    Pointer {
        pose: Pose {
            position,
            ..Pose::default()
        },
        velocity,
    }
}

/// A set whose pointer 0 sees one plane of `object`.
fn set(sequence: u64, object: u32, point: DVec3, normal: DVec3, velocity: DVec3) -> PlaneSet {
    let mut s = PlaneSet {
        sequence,
        ..PlaneSet::default()
    };
    s.planes[0].count = 1;
    s.planes[0].planes[0] = HapticdPlane {
        object,
        point: point.to_array(),
        normal: normal.to_array(),
        velocity: velocity.to_array(),
    };
    s
}

#[test]
fn a_plane_halfway_through_the_period_is_halfway() {
    let above = [pointer(DVec3::new(0.0, 1.0, 0.0), DVec3::ZERO)];
    let mut r = PlaneRenderer::new(RATE, &above);
    let mut w = [Wrench::ZERO];
    let tilted = DVec3::new(1.0, 1.0, 0.0).normalize();
    let first = set(1, 7, DVec3::ZERO, DVec3::Y, DVec3::ZERO);
    let second = set(2, 7, DVec3::new(0.2, 0.1, 0.0), tilted, DVec3::X);
    assert!(r.tick(&first, &above, TICK, &mut w, |_| {}));
    assert!(r.tick(&second, &above, TICK, &mut w, |_| {}));
    let half = r.interpolated(0, 0, 0.5);
    assert!((half.point - DVec3::new(0.1, 0.05, 0.0)).length() < 1e-15);
    let bisector = (DVec3::Y + tilted).normalize();
    assert!((half.normal - bisector).length() < 1e-15, "{}", half.normal);
    assert!((half.velocity - DVec3::X * 0.5).length() < 1e-15);
    // Ticks move it along: 25 ticks into a 50 ms period is halfway.
    for _ in 0..25 {
        r.tick(&second, &above, TICK, &mut w, |_| {});
    }
    assert!((r.since_update / r.period - 0.5).abs() < 1e-12);
    // A plane of an object the set before did not have stands where it is.
    let other = set(3, 8, DVec3::new(0.0, 0.3, 0.0), DVec3::Y, DVec3::ZERO);
    r.tick(&other, &above, TICK, &mut w, |_| {});
    assert_eq!(r.interpolated(0, 0, 0.5).point, DVec3::new(0.0, 0.3, 0.0));
}

#[test]
fn a_finger_on_a_plane_touches_the_body_of_its_object_along_its_normal() {
    let above = [pointer(DVec3::new(0.01, 0.01, 0.0), DVec3::ZERO)];
    let pressed = [pointer(DVec3::new(0.01, -0.002, 0.0), DVec3::ZERO)];
    let mut r = PlaneRenderer::new(RATE, &above);
    let mut w = [Wrench::ZERO];
    let tilted = DVec3::new(0.0, 1.0, 0.2).normalize();
    let floor = set(1, 3, DVec3::ZERO, tilted, DVec3::ZERO);
    // Objects 0 to 3 belong to bodies 0, 0, 1 and 5.
    let bodies = [0, 0, 1, 5];
    let mut touches = [Touch::NONE];
    r.tick(&floor, &above, TICK, &mut w, |_| {});
    r.write_touches(&bodies, &mut touches);
    assert!(!touches[0].touching, "{touches:?}");
    r.tick(&floor, &pressed, TICK, &mut w, |_| {});
    r.write_touches(&bodies, &mut touches);
    let t = touches[0];
    assert!(t.touching && t.body == 5, "{t:?}");
    assert!((t.normal - tilted).length() < 1e-12, "{t:?}");
    assert!(t.point.dot(tilted).abs() < 1e-12, "on the plane: {t:?}");
    // An object past the table is of no body it knows.
    r.write_touches(&bodies[..2], &mut touches);
    assert_eq!(touches[0].body, Touch::NONE.body);
}

#[test]
fn a_body_halfway_between_two_steps_is_halfway_along_and_halfway_turned() {
    let before = Pose {
        position: DVec3::ZERO,
        orientation: DQuat::IDENTITY,
    };
    let after = Pose {
        position: DVec3::new(0.2, 0.0, -0.1),
        orientation: DQuat::from_rotation_y(1.0),
    };
    let half = pose_between(&before, &after, 0.5);
    assert!((half.position - DVec3::new(0.1, 0.0, -0.05)).length() < 1e-15);
    let turned = half.orientation.to_scaled_axis();
    assert!((turned - DVec3::Y * 0.5).length() < 1e-12, "{turned}");
    assert_eq!(pose_between(&before, &after, 1.0).position, after.position);
}

#[test]
fn the_impulse_handed_back_is_minus_the_force_displayed_times_the_tick_summed() {
    // The finger 2 mm into a floor that stays put.
    let pressed = [pointer(DVec3::new(0.01, -0.002, 0.0), DVec3::ZERO)];
    let mut r = PlaneRenderer::new(RATE, &[pointer(DVec3::new(0.01, 0.01, 0.0), DVec3::ZERO)]);
    let mut w = [Wrench::ZERO];
    let floor = |sequence| set(sequence, 3, DVec3::ZERO, DVec3::Y, DVec3::ZERO);
    let mut sent = Vec::new();
    let mut displayed = DVec3::ZERO;
    // The finger comes from above (a grip that starts inside feels nothing).
    let above = [pointer(DVec3::new(0.01, 0.01, 0.0), DVec3::ZERO)];
    r.tick(&floor(1), &above, TICK, &mut w, |_| {});
    for sequence in 1..=3 {
        for _ in 0..50 {
            r.tick(&floor(sequence), &pressed, TICK, &mut w, |i| {
                if let HandBack::Impulse(i) = i {
                    sent.push(i)
                }
            });
            if sequence == 2 {
                displayed += w[0].force * TICK;
            }
        }
    }
    // The first set's impulse came with the second, the second's with the third.
    assert_eq!(sent.len(), 2, "{sent:?}");
    let second = sent[1];
    assert_eq!(second.object, 3);
    assert!((DVec3::from(second.impulse) + displayed).length() < 1e-12);
    // 2 kN/m × 2 mm for 50 ms, down into the floor, where the finger rests.
    assert!((DVec3::from(second.impulse) - DVec3::new(0.0, -0.2, 0.0)).length() < 1e-9);
    assert!((DVec3::from(second.point) - DVec3::new(0.01, 0.0, 0.0)).length() < 1e-9);
}

#[test]
fn a_finger_resting_on_a_moving_surface_moves_with_it() {
    // A conveyor: a floor whose surface runs at 0.1 m/s along x; the finger presses
    // 2 mm into it and keeps still. Static friction (μ0 = 0.3 at 4 N against 0.3 × 4 N)
    // holds the proxy on the belt until the pull exceeds the friction cone.
    let at = DVec3::new(0.0, 0.01, 0.0);
    let mut r = PlaneRenderer::new(RATE, &[pointer(at, DVec3::ZERO)]);
    let pressed = [pointer(DVec3::new(0.0, -0.002, 0.0), DVec3::ZERO)];
    let mut w = [Wrench::ZERO];
    let belt = |sequence| set(sequence, 1, DVec3::ZERO, DVec3::Y, DVec3::X * 0.1);
    let mut sideways: f64 = 0.0;
    r.tick(&belt(1), &[pointer(at, DVec3::ZERO)], TICK, &mut w, |_| {});
    for tick in 0..100 {
        r.tick(&belt(1 + tick / 50), &pressed, TICK, &mut w, |_| {});
        sideways = sideways.max(w[0].force.x);
    }
    let parameters = r.parameters();
    let normal = parameters.stiffness * 0.002;
    // The belt drags the finger along until friction slips, at the dynamic cone, and
    // the damper pulls it along at the belt's speed.
    assert!(
        sideways > 0.5 * parameters.dynamic_friction * normal,
        "{sideways} N"
    );
    let damper = parameters.damping * 0.1;
    assert!(sideways <= parameters.static_friction * normal + damper + 1e-9);
}

#[test]
fn a_world_that_steps_late_is_rendered_at_its_own_pace_and_a_stall_still_found() {
    // Sets every 160 ms from a world of 20 Hz (50 ms): stale (3 × 50 ms) at first, then
    // rendered as its pace doubles to the 160 ms it keeps.
    let p = [pointer(DVec3::new(0.0, 0.01, 0.0), DVec3::ZERO)];
    let mut r = PlaneRenderer::new(RATE, &p);
    let mut w = [Wrench::ZERO];
    let floor = |sequence| set(sequence, 1, DVec3::ZERO, DVec3::Y, DVec3::ZERO);
    let mut fresh = Vec::new();
    for k in 1..=8 {
        for _ in 0..160 {
            fresh.push(r.tick(&floor(k), &p, TICK, &mut w, |_| {}));
        }
    }
    let stale_at = |from: usize| fresh[from..].iter().filter(|f| !**f).count();
    // 50 → 100 → 160 ms: stale for the rest of the first two sets only.
    assert!(stale_at(0) > 0 && stale_at(2 * 160) == 0, "{}", stale_at(0));
    assert!((r.pace - 0.16).abs() < 1e-9, "{}", r.pace);
    // Halfway to the next set, the world felt is halfway there.
    let mut r2 = r.clone();
    for _ in 0..80 {
        r2.tick(&floor(9), &p, TICK, &mut w, |_| {});
    }
    assert!(
        (r2.fraction() - 80.0 / 160.0).abs() < 0.01,
        "{}",
        r2.fraction()
    );
    // It stops: stale after three of its own periods, not later.
    let mut ticks = 0;
    while r.tick(&floor(8), &p, TICK, &mut w, |_| {}) {
        ticks += 1;
    }
    assert!(ticks + 160 <= (3.0 * 0.16 / TICK) as usize + 1, "{ticks}");
    // Back after a 2 s stall, then at its rate again: the stall is not its pace.
    for _ in 0..2000 {
        r.tick(&floor(8), &p, TICK, &mut w, |_| {});
    }
    r.tick(&floor(9), &p, TICK, &mut w, |_| {});
    assert!((r.pace - 0.32).abs() < 1e-9, "{}", r.pace);
    // Then it takes a tenth off a set, down to the nominal period.
    for k in 10..=40 {
        for _ in 0..50 {
            r.tick(&floor(k), &p, TICK, &mut w, |_| {});
        }
        let expected = (0.32 * PACE_DECAY.powi((k - 9) as i32)).max(0.05);
        assert!((r.pace - expected).abs() < 1e-9, "set {k}: {}", r.pace);
    }
    assert!((r.pace - 0.05).abs() < 1e-9, "{}", r.pace);
    // A set whose step took 120 ms says the next comes no sooner than 240 ms.
    let slow = PlaneSet {
        step: 0.12,
        ..floor(41)
    };
    r.tick(&slow, &p, TICK, &mut w, |_| {});
    assert!((r.pace - 0.24).abs() < 1e-9, "{}", r.pace);
    for _ in 0..239 {
        assert!(r.tick(&slow, &p, TICK, &mut w, |_| {}));
    }
}

#[test]
fn a_world_too_large_for_its_rate_is_waited_for_as_long_as_the_slowest_pace() {
    // A 20 Hz world whose thread yields to others: its next set, held off for a second by the
    // CPU's other threads, finds the planes still rendered; it stops for good: stale
    // after three of the longest paces.
    let p = [pointer(DVec3::new(0.0, 0.01, 0.0), DVec3::ZERO)];
    let mut r = PlaneRenderer::new(RATE, &p);
    let mut w = [Wrench::ZERO];
    let floor = |sequence| PlaneSet {
        yielding: true,
        ..set(sequence, 1, DVec3::ZERO, DVec3::Y, DVec3::ZERO)
    };
    for k in 1..=3 {
        for _ in 0..50 {
            assert!(r.tick(&floor(k), &p, TICK, &mut w, |_| {}));
        }
    }
    for _ in 0..1000 {
        assert!(r.tick(&floor(3), &p, TICK, &mut w, |_| {}));
    }
    let mut ticks = 0;
    while r.tick(&floor(4), &p, TICK, &mut w, |_| {}) {
        ticks += 1;
    }
    let patience = STALE_PERIODS * MAX_PACE;
    assert!(
        (ticks as f64 * TICK - patience).abs() <= 1.5 * TICK,
        "{ticks}"
    );
}

#[test]
fn no_planes_yet_or_stale_planes_render_nothing_and_say_so() {
    let p = [pointer(DVec3::new(0.0, -0.002, 0.0), DVec3::ZERO)];
    let mut r = PlaneRenderer::new(RATE, &p);
    let mut w = [Wrench::force(DVec3::X)];
    assert!(!r.tick(&PlaneSet::default(), &p, TICK, &mut w, |_| {}));
    assert_eq!(w[0], Wrench::ZERO);
    let floor = set(1, 1, DVec3::ZERO, DVec3::Y, DVec3::ZERO);
    let ticks = (STALE_PERIODS / RATE / TICK).round() as usize;
    for _ in 0..ticks {
        assert!(r.tick(&floor, &p, TICK, &mut w, |_| {}));
    }
    assert!(!r.tick(&floor, &p, TICK, &mut w, |_| {}));
    assert_eq!(w[0], Wrench::ZERO);
}

/// A giving plane (compliance c, standing under a press F₀) held still, a grip pressed d
/// behind it: the proxy's spring k and the surface in series, the hand feels exactly
/// k·(d + c·F₀)/(1 + c·k); a grip in front of the plane by less than c·F₀ still presses
/// (the surface stood pressed down), and one clear of that feels nothing. A set whose
/// surface stands lower under more press takes over without a step in the force.
#[test]
fn a_giving_plane_pushes_back_as_the_spring_and_the_surface_in_series() {
    let k = ProxyParameters::default().stiffness;
    let (c, load) = (5e-4, 0.8);
    let giving = |sequence, depth: f64, load: f64| {
        let mut s = set(sequence, 2, DVec3::NEG_Y * depth, DVec3::Y, DVec3::ZERO);
        s.compliances[0][0] = HapticdPlaneCompliance {
            compliance: c,
            load,
        };
        s
    };
    let above = [pointer(DVec3::new(0.0, 0.01, 0.0), DVec3::ZERO)];
    let mut r = PlaneRenderer::new(RATE, &above);
    let mut w = [Wrench::ZERO];
    // A set a tick, all the same: the world stays fresh.
    let mut sequence = 0;
    let mut hold = |r: &mut PlaneRenderer, grip: f64, ticks: usize, w: &mut [Wrench; 1]| {
        let at = [pointer(DVec3::new(0.0, grip, 0.0), DVec3::ZERO)];
        for _ in 0..ticks {
            sequence += 1;
            r.tick(&giving(sequence, 0.0, load), &at, TICK, w, |_| {});
        }
    };
    hold(&mut r, 0.01, 1, &mut w);
    for d in [0.002, 0.0005, -0.0002] {
        // The proxy walks to where it rests, then is held.
        hold(&mut r, -d, 200, &mut w);
        let exact = k * (d + c * load) / (1.0 + c * k);
        println!("{d} m behind: {} N, exactly {exact} N", w[0].force.y);
        assert!(
            (w[0].force.y - exact).abs() < 1e-9,
            "{} vs {exact}",
            w[0].force.y
        );
    }
    hold(&mut r, c * load + 1e-4, 1, &mut w);
    assert_eq!(w[0].force, DVec3::ZERO);
    hold(&mut r, -0.001, 200, &mut w);
    let before = w[0].force.y;
    let lower = giving(sequence + 1, c * load, 2.0 * load);
    let pressed = [pointer(DVec3::new(0.0, -0.001, 0.0), DVec3::ZERO)];
    r.tick(&lower, &pressed, TICK, &mut w, |_| {});
    assert!(
        (w[0].force.y - before).abs() < 1e-9,
        "{before} then {}",
        w[0].force.y
    );
}
