//! A bounded fuzzer for every parser of a file a person or a program hands hapticd: the
//! mechanism descriptor, the configuration, static and physics scenes, hand scripts and
//! traffic recordings. Each shipped file is mutated at random (numbers swapped for extreme
//! ones, lines dropped, doubled, swapped or re-indented, stray and control characters,
//! truncation, keys exchanged); no input may panic, and every accepted one must hold the
//! invariants the motors rely on. Each parser gets a fixed number of inputs or a few
//! seconds, whichever ends first; the counts are printed (`--nocapture`).

use crate::support;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::time::{Duration, Instant};

use glam::DVec3;
use hapticd_config::Config;
use hapticd_core::haptics::obstacle::Shape;
use hapticd_core::kinematics::Wrench;
use hapticd_core::mechanism::descriptor;
use hapticd_core::scene::static_scene::StaticSceneSpec;
use hapticd_core::transport::{AMPLIFIER_MAX_VOLTS, dac_limit};
use hapticd_device::replay::{Direction, MAGIC, Recording, Transfer, write_transfer};
use hapticd_device::sim::hand::{HandTrack, Script};
use hapticd_physics::coupling::Grip;
use hapticd_physics::scene::PenaltyScene;
use support::{Rng, repo_dir, scratch_root};

/// Inputs per parser, at most.
const CASES: usize = 5000;
/// Time per parser, at most.
const BUDGET: Duration = Duration::from_secs(6);

/// Numbers that break arithmetic somewhere: overflow, underflow, NaN, signs, sizes.
const EXTREMES: [&str; 16] = [
    "0",
    "-0",
    "-1",
    "1e308",
    "-1e308",
    ".nan",
    ".inf",
    "-.inf",
    "1e-320",
    "4294967296",
    "1e-12",
    "1e12",
    "2.5e-5",
    "18446744073709551616",
    "0x7fff",
    "1e400",
];

/// Characters that have tripped parsers and buses: NUL, controls, quotes, YAML syntax.
const STRAY: [&str; 12] = [
    "\0", "\u{7}", "\t", "\n", "\"", "'", ":", "- ", "{", "[", "*anchor", "&anchor ",
];

/// Byte offsets where numbers start and end in `text`.
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let bytes = text.as_bytes();
    let mut found = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let starts = bytes[i].is_ascii_digit()
            && (i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_'));
        if starts {
            let start = if i > 0 && bytes[i - 1] == b'-' {
                i - 1
            } else {
                i
            };
            let mut end = i;
            while end < bytes.len()
                && (bytes[end].is_ascii_digit() || b".eE+-".contains(&bytes[end]))
            {
                end += 1;
            }
            found.push((start, end));
            i = end;
        } else {
            i += 1;
        }
    }
    found
}

/// A byte offset on a character boundary of `text`.
fn boundary(rng: &mut Rng, text: &str) -> usize {
    let mut at = (rng.next_u64() % (text.len() as u64 + 1)) as usize;
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    at
}

fn pick<'a, T>(rng: &mut Rng, items: &'a [T]) -> &'a T {
    &items[(rng.next_u64() % items.len() as u64) as usize]
}

/// `seed` changed by one to four random mutations.
fn mutate(rng: &mut Rng, seed: &str) -> String {
    let mut text = seed.to_string();
    for _ in 0..1 + rng.next_u64() % 4 {
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        let line = |rng: &mut Rng, n: usize| (rng.next_u64() % n.max(1) as u64) as usize;
        match rng.next_u64() % 8 {
            0 | 1 => {
                let spots = numbers(&text);
                if let Some(&(start, end)) = (!spots.is_empty()).then(|| pick(rng, &spots)) {
                    let extreme: &&str = pick(rng, &EXTREMES);
                    text.replace_range(start..end, extreme);
                }
                continue;
            }
            2 if !lines.is_empty() => {
                let k = line(rng, lines.len());
                lines.remove(k);
            }
            3 if !lines.is_empty() => {
                let k = line(rng, lines.len());
                let copy = lines[k].clone();
                lines.insert(k, copy);
            }
            4 if lines.len() > 1 => {
                let (a, b) = (line(rng, lines.len()), line(rng, lines.len()));
                lines.swap(a, b);
            }
            5 if !lines.is_empty() => {
                let k = line(rng, lines.len());
                let shift = (rng.next_u64() % 4) as usize;
                lines[k] = format!("{}{}", " ".repeat(shift), lines[k].trim_start());
            }
            6 => {
                let at = boundary(rng, &text);
                let stray: &&str = pick(rng, &STRAY);
                text.insert_str(at, stray);
                continue;
            }
            _ => {
                let at = boundary(rng, &text);
                text.truncate(at);
                continue;
            }
        }
        text = lines.join("\n");
        text.push('\n');
    }
    text
}

/// Feed `parse` `CASES` mutations of each seed (or as many as `BUDGET` allows); it returns
/// Some(failure) for an accepted input that breaks an invariant. Panics fail the test with
/// the input that caused them. Returns how many inputs were tried.
fn fuzz(name: &str, seeds: &[String], mut parse: impl FnMut(&str) -> Option<String>) -> usize {
    let mut rng = Rng::new(name.bytes().map(u64::from).sum());
    let started = Instant::now();
    let mut tried = 0;
    let mut accepted = 0;
    while tried < CASES && started.elapsed() < BUDGET {
        let seed = &seeds[tried % seeds.len()];
        let input = mutate(&mut rng, seed);
        match catch_unwind(AssertUnwindSafe(|| parse(&input))) {
            Ok(None) => {}
            Ok(Some(failure)) if failure.is_empty() => accepted += 1,
            Ok(Some(failure)) => panic!("{name}: {failure}\ninput:\n{input}"),
            Err(_) => panic!("{name}: the parser panicked on\n{input}"),
        }
        tried += 1;
    }
    eprintln!("{name}: {tried} inputs, {accepted} accepted and checked");
    assert!(tried >= 100, "{name}: only {tried} inputs in {BUDGET:?}");
    tried
}

/// Accepted and sound: `Some("")`; accepted and broken: `Some(why)`; refused: `None`.
fn verdict<T>(
    result: Result<T, impl std::fmt::Display>,
    check: impl FnOnce(T) -> bool,
    why: &str,
) -> Option<String> {
    match result {
        Err(e) => {
            // A refusal must say something.
            (e.to_string().trim().is_empty()).then(|| "an empty error".to_string())
        }
        Ok(value) => Some(if check(value) {
            String::new()
        } else {
            why.to_string()
        }),
    }
}

fn shipped(relative: &str) -> String {
    std::fs::read_to_string(repo_dir().join(relative)).unwrap()
}

fn shipped_all(dir: &str) -> Vec<String> {
    let mut files: Vec<_> = std::fs::read_dir(repo_dir().join(dir))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    files.sort();
    files
        .iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect()
}

#[test]
fn descriptors() {
    fuzz(
        "descriptor",
        &[shipped("config/mechanisms/spidar-6s.yaml")],
        |text| {
            verdict(
                descriptor::parse(text, Path::new("m.yaml")),
                |m| {
                    m.strings.iter().all(|s| {
                        s.motor.is_finite()
                            && s.knot.is_finite()
                            && s.tension_min <= s.tension_max
                            && s.tension_max * s.volts_per_newton.abs() <= AMPLIFIER_MAX_VOLTS
                            && dac_limit(s.tension_max, s.volts_per_newton) > 0
                    }) && m.effectors.iter().all(|e| {
                        e.calibration.position.is_finite()
                            && e.calibration.orientation.is_normalized()
                    }) && !m.name.contains('\0')
                },
                "a string or pose out of bounds was accepted",
            )
        },
    );
}

#[test]
fn configurations() {
    fuzz("configuration", &[shipped("config/hapticd.yaml")], |text| {
        verdict(
            Config::parse(text, Path::new("c.yaml")),
            |c| {
                c.realtime.rate.is_finite()
                    && (100.0..=10_000.0).contains(&c.realtime.rate)
                    && c.safety.max_force.is_finite()
                    && c.safety.max_torque.is_finite()
            },
            "a rate or limit out of range was accepted",
        )
    });
}

fn finite_shape(shape: &Shape) -> bool {
    match *shape {
        Shape::HalfSpace { point, normal } => point.is_finite() && normal.is_normalized(),
        Shape::Sphere { centre, radius } => centre.is_finite() && radius.is_finite(),
        Shape::Cylinder {
            point,
            axis,
            radius,
        } => point.is_finite() && axis.is_normalized() && radius.is_finite(),
        Shape::Cuboid {
            centre,
            half,
            rotation,
        } => centre.is_finite() && half.is_finite() && rotation.is_normalized(),
        Shape::Triangle {
            corners, normal, ..
        } => corners.iter().all(|c| c.is_finite()) && normal.is_normalized(),
    }
}

#[test]
fn static_scenes() {
    fuzz(
        "static scene",
        &[shipped("config/scenes/static.yaml")],
        |text| {
            verdict(
                StaticSceneSpec::parse(text, Path::new("s.yaml")),
                |spec| {
                    let p = spec.proxy;
                    [
                        p.stiffness,
                        p.damping,
                        p.static_friction,
                        p.dynamic_friction,
                    ]
                    .iter()
                    .all(|v| v.is_finite())
                        && spec.shapes.iter().all(finite_shape)
                },
                "a non-finite scene was accepted",
            )
        },
    );
}

#[test]
fn physics_scenes() {
    // Every shipped scene but the static one, which has a format of its own.
    let seeds: Vec<String> = shipped_all("config/scenes")
        .into_iter()
        .filter(|text| !text.contains("shapes:"))
        .collect();
    let grip = Grip {
        position: DVec3::new(0.0, 0.05, 0.0),
        orientation: glam::DQuat::IDENTITY,
        velocity: DVec3::ZERO,
        spin: DVec3::ZERO,
    };
    fuzz("physics scene", &seeds, |text| {
        let pointers = usize::from(text.contains("pointer:"));
        verdict(
            PenaltyScene::parse(text, Path::new("s.yaml"), pointers),
            |mut scene| {
                // An accepted world steps without NaN, or says it cannot.
                let mut felt = vec![Wrench::ZERO; pointers];
                (0..5).all(|_| {
                    let grips = vec![grip; pointers];
                    !scene.step_pointers(1e-3, &grips, &mut felt)
                        || (scene.world.is_finite() && felt.iter().all(Wrench::is_finite))
                })
            },
            "a step reported success with a non-finite world",
        )
    });
}

#[test]
fn hand_scripts() {
    let seeds = shipped_all("config/hands");
    fuzz("hand script", &seeds, |text| {
        verdict(
            Script::parse(text, Path::new("h.yaml")),
            |script| {
                script.hands.into_values().all(|steps| {
                    let track = HandTrack::new(DVec3::ZERO, steps);
                    (0..50).all(|k| {
                        let c = track.at(f64::from(k) * 0.1);
                        c.target.is_finite() && c.velocity.is_finite() && c.push.is_finite()
                    })
                })
            },
            "a script drove the hand to a non-finite place",
        )
    });
}

#[test]
fn traffic_recordings() {
    // A short recording, as hapticd writes one, made printable so the text mutations apply.
    let mut seed = MAGIC.to_vec();
    for k in 0..6u8 {
        let direction = if k % 2 == 0 {
            Direction::Out
        } else {
            Direction::In
        };
        let transfer = Transfer::new(direction, &[b'a' + k; 5]);
        write_transfer(&mut seed, &transfer).unwrap();
    }
    let seed = String::from_utf8_lossy(&seed).into_owned();
    let file = scratch_root().join(format!("fuzz-traffic-{}.bin", std::process::id()));
    fuzz("traffic recording", &[seed], |text| {
        std::fs::write(&file, text.as_bytes()).unwrap();
        verdict(
            Recording::read(&file),
            |r| r.transfers().all(|(_, bytes)| bytes.len() <= 512),
            "a transfer longer than any recorded was accepted",
        )
    });
    std::fs::remove_file(file).ok();
}

/// A scratch directory holding the buffer of the corpus' Khronos cube (what a `.gltf` of it
/// written there reads), and the corpus.
fn beside_the_cube(name: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = scratch_root().join(format!("fuzz-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let corpus = repo_dir().join("tests/corpus");
    std::fs::copy(
        corpus.join("BoxTextured0.bin"),
        dir.join("BoxTextured0.bin"),
    )
    .unwrap();
    (dir, corpus)
}

/// The mesh readers on what users bring: OBJ, ASCII STL and glTF (its JSON, its buffer
/// beside it) as shipped and as public models have them, mutated. No input may make a
/// reader panic (one the loader catches counts here too), and an accepted mesh keeps the
/// limits with finite vertices.
#[test]
fn mesh_files() {
    let (dir, corpus) = beside_the_cube("meshes");
    let read = |path: &Path| std::fs::read_to_string(path).unwrap();
    for (kind, seeds) in [
        (
            "obj",
            vec![
                shipped("config/scenes/meshes/bracket.obj"),
                read(&corpus.join("teapot.obj")),
            ],
        ),
        ("stl", vec![read(&corpus.join("sphereWithHole.stl"))]),
        (
            "gltf",
            vec![
                shipped("config/scenes/meshes/bracket.gltf"),
                read(&corpus.join("BoxTextured.gltf")),
            ],
        ),
    ] {
        let file = dir.join(format!("fuzzed.{kind}"));
        fuzz(&format!("{kind} mesh"), &seeds, |text| {
            std::fs::write(&file, text.as_bytes()).unwrap();
            let limits = hapticd_mesh::Limits::DEFAULT;
            match hapticd_mesh::load(&file, 1.0, limits, None) {
                Err(e) if e.to_string().contains("its reader failed") => {
                    Some(format!("the reader panicked: {e}"))
                }
                result => verdict(
                    result,
                    |m| {
                        m.triangles.len() <= limits.triangles
                            && m.vertices.len() <= limits.vertices
                            && m.vertices.iter().all(|v| v.is_finite())
                    },
                    "an accepted mesh breaks the limits or is not finite",
                ),
            }
        });
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// glTF node graphs drawn at random over Khronos' cube (each node placing its mesh, or
/// not): a graph is read exactly when its nodes form trees under the scene's roots (each
/// node at most one parent, none its own ancestor, no root a child), as the format says,
/// and then holds the cube once for every node that places it; any other is refused by
/// name, at once, however many paths it has to the mesh.
#[test]
fn gltf_node_graphs_are_read_exactly_when_they_are_trees() {
    let (dir, corpus) = beside_the_cube("graphs");
    let base: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(corpus.join("BoxTextured.gltf")).unwrap())
            .unwrap();
    let mut rng = Rng::new(43);
    let (mut trees, mut refused) = (0, 0);
    for case in 0..400 {
        // A forest first (each node under an earlier one, or a root), then in half the
        // cases one edge that breaks it: a second parent, a loop, a root made a child.
        let n = 1 + (rng.next_u64() % 40) as usize;
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
        let mut roots = vec![0];
        for k in 1..n {
            if rng.next_u64().is_multiple_of(5) {
                roots.push(k);
            } else {
                children[(rng.next_u64() % k as u64) as usize].push(k);
            }
        }
        if rng.next_u64().is_multiple_of(2) {
            let (a, b) = (
                (rng.next_u64() % n as u64) as usize,
                (rng.next_u64() % n as u64) as usize,
            );
            children[a].push(b);
        }
        let places: Vec<bool> = (0..n).map(|_| rng.next_u64().is_multiple_of(2)).collect();
        let mut doc = base.clone();
        doc["nodes"] = (0..n)
            .map(|k| {
                let mut node = serde_json::json!({ "children": children[k] });
                if places[k] {
                    node["mesh"] = 0.into();
                }
                node
            })
            .collect();
        doc["scenes"][0]["nodes"] = roots.clone().into();
        let file = dir.join(format!("graph-{case}.gltf"));
        std::fs::write(&file, doc.to_string()).unwrap();
        // The oracle: parents counted, cycles walked, roots parentless, then a walk.
        let mut parents = vec![0usize; n];
        for list in &children {
            for &c in list {
                parents[c] += 1;
            }
        }
        let one_parent = parents.iter().all(|&p| p <= 1)
            && children
                .iter()
                .enumerate()
                .all(|(k, list)| !list.contains(&k));
        let acyclic = one_parent && {
            let parent_of = |c: usize| children.iter().position(|list| list.contains(&c));
            (0..n).all(|start| {
                let mut at = parent_of(start);
                let mut steps = 0;
                while let Some(p) = at {
                    if p == start || steps > n {
                        return false;
                    }
                    at = parent_of(p);
                    steps += 1;
                }
                true
            })
        };
        let forest = acyclic && roots.iter().all(|&r| parents[r] == 0);
        let loaded = hapticd_mesh::load(&file, 1.0, hapticd_mesh::Limits::DEFAULT, None);
        match (forest, loaded) {
            (true, Ok(mesh)) => {
                let mut placed = 0;
                let mut stack = roots.clone();
                while let Some(k) = stack.pop() {
                    placed += usize::from(places[k]);
                    stack.extend(&children[k]);
                }
                if placed > 0 {
                    assert_eq!(mesh.triangles.len(), 12 * placed, "case {case}: {doc}");
                }
                trees += 1;
            }
            // Only the empty case: trees that place nothing have no triangles to read.
            (true, Err(e)) => assert!(e.to_string().contains("no triangles"), "case {case}: {e}"),
            (false, Err(e)) => {
                let said = e.to_string();
                assert!(
                    said.contains("its own")
                        || said.contains("a child of both")
                        || said.contains("is a root of"),
                    "case {case}: {said}"
                );
                refused += 1;
            }
            (false, Ok(_)) => panic!("case {case}: a graph that is no forest was read: {doc}"),
        }
    }
    eprintln!("glTF node graphs: {trees} forests read, {refused} other graphs refused");
    assert!(
        trees > 40 && refused > 40,
        "{trees} forests, {refused} refused"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
