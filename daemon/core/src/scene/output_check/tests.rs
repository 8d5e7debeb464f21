use super::*;
use hapticd_plugin_api::HapticdPlane;

/// A floor under pointer 0 and a wall beside it.
fn planes() -> [HapticdPlanes; 2] {
    let mut set = [HapticdPlanes::default(); 2];
    set[0].count = 2;
    set[0].planes[0] = HapticdPlane {
        object: 1,
        point: [0.0, -0.03, 0.0],
        normal: [0.0, 1.0, 0.0],
        velocity: [0.0, 0.0, 0.0],
    };
    set[0].planes[1] = HapticdPlane {
        object: 2,
        point: [0.05, 0.0, 0.0],
        normal: [-1.0, 0.0, 0.0],
        velocity: [0.0, 0.5, 0.0],
    };
    set[1].count = 1;
    set[1].planes[0] = set[0].planes[0];
    set
}

#[test]
fn planes_a_world_publishes_pass() {
    let mut set = planes();
    assert_eq!(check_planes(&set), Ok(()));
    // A full set, a normal rounded in single precision, a body flung at 99 m/s, a surface
    // far away: all fine.
    set[0].count = HAPTICD_MAX_PLANES as u32;
    for k in 0..HAPTICD_MAX_PLANES {
        set[0].planes[k] = HapticdPlane {
            object: 10 + k as u32,
            ..set[0].planes[0]
        };
    }
    let n = DVec3::new(1.0, 2.0, 3.0).as_vec3().normalize().as_dvec3();
    set[0].planes[3].normal = n.to_array();
    set[0].planes[4].velocity = [-70.0, 70.0, 0.0];
    set[0].planes[5].point = [1e6, 0.0, 0.0];
    assert_eq!(check_planes(&set), Ok(()));
    // The same object under two pointers is one object touched twice.
    set[1].planes[0].object = 10;
    assert_eq!(check_planes(&set), Ok(()));
    // Slots past the count are not looked at.
    set[1].planes[5].normal = [f64::NAN; 3];
    assert_eq!(check_planes(&set), Ok(()));
}

/// Two bodies a world publishes: a 1 kg brick resting on a floor and a ball rolling.
fn bodies() -> [HapticdLocalBody; 2] {
    let mut brick = HapticdLocalBody {
        body: 3,
        orientation: [1.0, 0.0, 0.0, 0.0],
        inverse_mass: 1.0,
        inverse_inertia: glam::DMat3::from_diagonal(DVec3::splat(600.0)).to_cols_array(),
        acceleration: [0.0, -9.81, 0.0],
        contact_count: 1,
        ..HapticdLocalBody::default()
    };
    brick.contacts[0].normal = [0.0, 1.0, 0.0];
    let ball = HapticdLocalBody {
        body: 4,
        velocity: [0.5, 0.0, 0.0],
        spin: [0.0, 0.0, -40.0],
        ..brick
    };
    [brick, ball]
}

#[test]
fn each_bad_local_body_is_named() {
    let with = |count: u32, change: &dyn Fn(&mut [HapticdLocalBody; 2])| {
        let mut set = bodies();
        change(&mut set);
        check_bodies(&set, count)
    };
    assert_eq!(with(2, &|_| {}), Ok(()));
    assert_eq!(
        with(9, &|_| {}),
        Err(OutputFault::TooManyBodies { count: 9 })
    );
    assert_eq!(
        with(2, &|s| s[1].contact_count = 17),
        Err(OutputFault::TooManyContacts {
            index: 1,
            count: 17
        })
    );
    type Change = dyn Fn(&mut [HapticdLocalBody; 2]);
    let not_finite: [(usize, &Change); 4] = [
        (0, &|s| s[0].position[1] = f64::NAN),
        (0, &|s| s[0].inverse_inertia[4] = f64::INFINITY),
        (0, &|s| s[0].contacts[0].gap = f64::NAN),
        (1, &|s| s[1].orientation[0] = f64::NAN),
    ];
    for (index, change) in not_finite {
        assert_eq!(with(2, change), Err(OutputFault::BodyNotFinite { index }));
    }
    assert_eq!(
        with(2, &|s| s[1].inverse_mass = 0.0),
        Err(OutputFault::BodyWithoutMass { index: 1 })
    );
    assert_eq!(
        with(2, &|s| s[0].inverse_inertia[8] = -1.0),
        Err(OutputFault::BodyWithoutMass { index: 0 })
    );
    assert_eq!(
        with(2, &|s| s[1].velocity = [0.0, 1e300, 0.0]),
        Err(OutputFault::BodyTooFast {
            index: 1,
            speed: 1e300,
            spin: 40.0
        })
    );
    assert!(matches!(
        with(2, &|s| s[0].spin = [2e4, 0.0, 0.0]),
        Err(OutputFault::BodyTooFast { index: 0, .. })
    ));
    assert_eq!(
        with(2, &|s| s[1].body = 3),
        Err(OutputFault::DuplicateBody { body: 3 })
    );
    // Contacts past the count are not looked at.
    assert_eq!(with(2, &|s| s[0].contacts[5].gap = f64::NAN), Ok(()));
    assert!(
        OutputFault::BodyTooFast {
            index: 1,
            speed: 1e300,
            spin: 40.0
        }
        .to_string()
        .contains("local body 1: it moves at 1.000e300 m/s")
    );
}

#[test]
fn each_bad_plane_is_named() {
    let with = |change: &dyn Fn(&mut [HapticdPlanes; 2])| {
        let mut set = planes();
        change(&mut set);
        check_planes(&set)
    };
    assert_eq!(
        with(&|s| s[1].count = 9),
        Err(OutputFault::TooManyPlanes {
            pointer: 1,
            count: 9
        })
    );
    assert_eq!(
        with(&|s| s[0].planes[1].point[2] = f64::INFINITY),
        Err(OutputFault::PointNotFinite {
            pointer: 0,
            plane: 1
        })
    );
    assert_eq!(
        with(&|s| s[0].planes[0].normal = [0.0, 2.0, 0.0]),
        Err(OutputFault::NormalNotUnit {
            pointer: 0,
            plane: 0,
            length: 2.0
        })
    );
    assert_eq!(
        with(&|s| s[0].planes[0].normal = [0.0, 1.0011, 0.0]).map_err(|_| ()),
        Err(())
    );
    assert!(matches!(
        with(&|s| s[0].planes[0].normal = [f64::NAN, 1.0, 0.0]),
        Err(OutputFault::NormalNotUnit { length, .. }) if length.is_nan()
    ));
    assert!(matches!(
        with(&|s| s[0].planes[0].normal = [0.0; 3]),
        Err(OutputFault::NormalNotUnit { length: 0.0, .. })
    ));
    // The 1e300 m/s, just over the bound, and NaN.
    assert_eq!(
        with(&|s| s[0].planes[1].velocity = [0.0, 1e300, 1e300]),
        Err(OutputFault::SurfaceTooFast {
            pointer: 0,
            plane: 1,
            speed: 1e300 * 2f64.sqrt()
        })
    );
    assert_eq!(
        with(&|s| s[1].planes[0].velocity = [60.0, 60.0, 60.0]).map_err(|_| ()),
        Err(())
    );
    assert!(matches!(
        with(&|s| s[0].planes[0].velocity = [0.0, f64::NAN, 0.0]),
        Err(OutputFault::SurfaceTooFast { pointer: 0, plane: 0, speed }) if speed.is_nan()
    ));
    assert_eq!(
        with(&|s| s[0].planes[1].object = 1),
        Err(OutputFault::DuplicateObject {
            pointer: 0,
            object: 1
        })
    );
}

fn force(x: f64, y: f64) -> [Wrench; 1] {
    [Wrench::force(DVec3::new(x, y, 0.0))]
}

/// Run `wrench(tick)` through a fresh checker for `ticks`; the tick of the first fault.
fn first_fault(
    ticks: usize,
    wrench: impl Fn(usize) -> [Wrench; 1],
) -> Option<(usize, OutputFault)> {
    let mut checker = WrenchChecker::default();
    (0..ticks).find_map(|t| checker.check(&wrench(t)).err().map(|f| (t, f)))
}

#[test]
fn wrenches_beyond_a_hundred_times_the_limits_or_not_finite_are_faults() {
    let mut checker = WrenchChecker::default();
    // Twice MaxForce (a hand through a penalty floor) and 500 N are clamped, not faults.
    assert_eq!(checker.check(&force(0.0, 20.0)), Ok(()));
    assert_eq!(checker.check(&force(0.0, 500.0)), Ok(()));
    assert_eq!(checker.check(&force(0.0, -1000.0)), Ok(()));
    assert_eq!(
        checker.check(&force(0.0, 1e30)),
        Err(OutputFault::ForceTooLarge {
            pointer: 0,
            force: 1e30,
            limit: 1000.0
        })
    );
    let torque = [Wrench {
        force: DVec3::ZERO,
        torque: DVec3::new(0.0, 0.0, -31.0),
    }];
    assert!(matches!(
        checker.check(&torque),
        Err(OutputFault::TorqueTooLarge { pointer: 0, torque: 31.0, limit })
            if (limit - 30.0).abs() < 1e-9
    ));
    let two = [Wrench::ZERO, Wrench::force(DVec3::new(f64::NAN, 0.0, 0.0))];
    assert_eq!(
        checker.check(&two),
        Err(OutputFault::WrenchNotFinite { pointer: 1 })
    );
    // The bound follows MaxForce; MaxForce 0 still lets scenes ask for 100 N.
    checker.set_limits(2.0, 0.3);
    assert!(checker.check(&force(0.0, 201.0)).is_err());
    checker.set_limits(0.0, 0.0);
    assert_eq!(checker.check(&force(0.0, 100.0)), Ok(()));
    assert!(checker.check(&force(0.0, 100.1)).is_err());
}

#[test]
fn a_wrench_that_zig_zags_by_newtons_for_twenty_ticks_is_a_buzz() {
    // The issue's ±9 N each tick: from rest, changes of 9 N then 18 N, each reversing the
    // last from the second tick on.
    let alternating = |t: usize| force(if t.is_multiple_of(2) { 9.0 } else { -9.0 }, 3.0);
    assert_eq!(
        first_fault(100, alternating),
        Some((
            20,
            OutputFault::ZigZag {
                pointer: 0,
                axis: 0,
                step: 9.0
            }
        ))
    );
    // Around an offset, without a change of sign: 12 N / 7 N.
    let offset = |t: usize| force(0.0, if t.is_multiple_of(2) { 12.0 } else { 7.0 });
    assert!(matches!(
        first_fault(100, offset),
        Some((20, OutputFault::ZigZag { axis: 1, .. }))
    ));
    // A torque buzz of ±0.1 N·m.
    let twist = |t: usize| {
        [Wrench {
            force: DVec3::ZERO,
            torque: DVec3::new(0.0, if t.is_multiple_of(2) { 0.1 } else { -0.1 }, 0.0),
        }]
    };
    assert!(matches!(
        first_fault(100, twist),
        Some((20, OutputFault::ZigZag { axis: 4, .. }))
    ));
}

#[test]
fn vibrations_short_buzzes_and_small_noise_are_no_zig_zag() {
    let tick = 1e-3;
    let sine = |hz: f64, amplitude: f64| {
        move |t: usize| {
            force(
                (std::f64::consts::TAU * hz * t as f64 * tick).sin() * amplitude,
                0.0,
            )
        }
    };
    // A 5 Hz shake and a 250 Hz vibration of ±9 N (a texture) at 1 kHz.
    assert_eq!(first_fault(5000, sine(5.0, 9.0)), None);
    assert_eq!(first_fault(5000, sine(250.0, 9.0)), None);
    // ±1.9 N each tick for ever: changes of 3.8 N, under the step.
    assert_eq!(
        first_fault(5000, |t| force(
            if t.is_multiple_of(2) { 1.9 } else { -1.9 },
            5.0
        )),
        None
    );
    // ±9 N for 20 ticks (19 reversals), then steady, again and again.
    let bursts = |t: usize| {
        force(
            if t % 40 < 19 && t.is_multiple_of(2) {
                9.0
            } else {
                -9.0
            },
            0.0,
        )
    };
    assert_eq!(first_fault(5000, bursts), None);
}

/// A grip of `mass` held by a hand spring pressed by the hand into a damped penalty wall
/// (`stiffness`, `damping`, solid below y = 0, pulling too when leaving fast: no one-sided
/// clamp), read through encoder steps of `quantum` and the loop's 200 Hz velocity filter,
/// the force clamped to 10 N as the guard does, at `rate`; the hand presses, holds, shakes
/// at 5 Hz and pulls out. The checker's objection, if any.
fn damped_contact(
    rate: f64,
    mass: f64,
    (stiffness, damping): (f64, f64),
    quantum: f64,
) -> Option<OutputFault> {
    let dt = 1.0 / rate;
    let (hand_k, hand_b) = (300.0, 3.0);
    let alpha = (-std::f64::consts::TAU * 200.0 * dt).exp();
    let mut checker = WrenchChecker::default();
    let (mut y, mut v, mut measured, mut filtered) = (0.01, 0.0, 0.01, 0.0);
    for t in 0..(3.0 * rate) as usize {
        let time = t as f64 * dt;
        let hand = match time {
            s if s < 1.0 => 0.01 - 0.03 * s,
            s if s < 2.0 => -0.02 + 0.005 * (std::f64::consts::TAU * 5.0 * s).sin(),
            s => -0.02 + 0.06 * (s - 2.0),
        };
        let read = (y / quantum).round() * quantum;
        filtered = alpha * filtered + (1.0 - alpha) * (read - measured) / dt;
        measured = read;
        let wall = if read < 0.0 {
            -stiffness * read - damping * filtered
        } else {
            0.0
        };
        if let Err(fault) = checker.check(&force(0.0, wall)) {
            return Some(fault);
        }
        let shown = wall.clamp(-10.0, 10.0);
        let a = (shown + hand_k * (hand - y) - hand_b * v) / mass;
        v += a * dt;
        y += v * dt;
    }
    None
}

#[test]
fn a_damped_contact_pressed_shaken_and_left_never_zig_zags() {
    // The shipped point model (1000 N/m, 50 N·s/m), a proxy's 2000 N/m with light and
    // heavy damping, and twice the point model's damper, on SPIDAR's and SPIDAR-G's
    // encoder steps, on the bare 50 g grip and one a hand holds, at USB and simulator
    // rates. (The longest zig-zag: 8 ticks, 100 N·s/m on the bare grip at 1 kHz.)
    for rate in [1000.0, 4000.0, 10_000.0] {
        for contact in [
            (1000.0, 50.0),
            (2000.0, 5.0),
            (2000.0, 20.0),
            (500.0, 100.0),
        ] {
            for mass in [0.05, 0.3] {
                for quantum in [2.924e-5, 1.66555e-5] {
                    assert_eq!(
                        damped_contact(rate, mass, contact, quantum),
                        None,
                        "{rate} Hz, {contact:?}, {mass} kg, {quantum} m"
                    );
                }
            }
        }
    }
}

#[test]
fn a_damper_the_loop_cannot_render_is_caught_buzzing() {
    // 200 N·s/m on the bare grip at 1 kHz: b·T/m = 4, past the 2 at which a sampled
    // damper turns every tick's motion back harder than it came, so the loop itself
    // oscillates at the Nyquist frequency against the 10 N clamp.
    assert!(matches!(
        damped_contact(1000.0, 0.05, (500.0, 200.0), 2.924e-5),
        Some(OutputFault::ZigZag { axis: 1, .. })
    ));
}

/// A jointed body's mobility that is not finite or not symmetric is a fault of the world
/// at its place; free bodies (none given) and sound ones pass.
#[test]
fn an_unsound_mobility_is_a_fault_at_its_place() {
    let mut sound = HapticdMobility::default();
    sound.mobility[3][3] = 2.0;
    let mut mobilities = [None, Some(sound), None];
    assert_eq!(check_mobilities(&mobilities, 3), Ok(()));
    let mut broken = sound;
    broken.mobility[3][4] = 1.0;
    mobilities[2] = Some(broken);
    assert_eq!(
        check_mobilities(&mobilities, 3),
        Err(OutputFault::MobilityUnsound { index: 2 })
    );
    assert_eq!(check_mobilities(&mobilities, 2), Ok(()));
    broken.acceleration[0] = f64::NAN;
    broken.mobility[3][4] = 0.0;
    mobilities[0] = Some(broken);
    assert_eq!(
        check_mobilities(&mobilities, 3),
        Err(OutputFault::MobilityUnsound { index: 0 })
    );
}

/// How a plane gives that is not finite, below zero or past its bounds is a fault of the
/// world at its place; a rigid one and a jelly's pass, and what lies past a pointer's
/// planes in use is not read.
#[test]
fn an_unsound_compliance_is_a_fault_at_its_place() {
    let set = planes();
    let jelly = HapticdPlaneCompliance {
        compliance: 5e-4,
        load: 1.5,
    };
    let mut gives = [[HapticdPlaneCompliance::default(); HAPTICD_MAX_PLANES]; 2];
    gives[0][1] = jelly;
    assert_eq!(check_compliances(&set, &gives), Ok(()));
    for (compliance, load) in [
        (f64::NAN, 1.0),
        (-1e-4, 1.0),
        (2.0 * MAX_COMPLIANCE, 1.0),
        (1e-4, f64::INFINITY),
        (1e-4, -0.5),
        (1e-4, 2.0 * MAX_LOAD),
    ] {
        let mut broken = gives;
        broken[0][1] = HapticdPlaneCompliance { compliance, load };
        assert_eq!(
            check_compliances(&set, &broken),
            Err(OutputFault::ComplianceUnsound {
                pointer: 0,
                plane: 1
            }),
            "{compliance} m/N under {load} N"
        );
        // Past the planes in use: not read.
        let mut unused = gives;
        unused[0][5] = HapticdPlaneCompliance { compliance, load };
        assert_eq!(check_compliances(&set, &unused), Ok(()));
    }
}
