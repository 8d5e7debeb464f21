//! Property-based calls of hapticd's bus: every method and property of
//! `org.hapticd.Hapticd1.Manager`, `org.hapticd.Hapticd1.Device` and the running world's
//! `org.hapticd.Hapticd1.Scene` (masses, poses, forces on its bodies), as the running daemon
//! introspects them (so that new ones are covered without a change here), called through
//! real `dbus-send` with random values of random types, between random scene switches, while
//! the simulated hand presses on the floor again and again. The daemon must live, answer
//! every call with success or a named error (never `Failed` nor silence), and no D/A command
//! it sends may pass its string's `tension_max × volts_per_newton`.

use crate::support;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use hapticd_core::transport::dac_limit;
use hapticd_device::replay::{Direction, Recording};
use hapticd_device::sh4;
use support::bus::NAME;
use support::daemon::Isolated;
use support::{Rng, plugin_path, repo_dir, scratch_root, shipped};

const MANAGER_PATH: &str = "/org/hapticd/Hapticd1";
const MANAGER: &str = "org.hapticd.Hapticd1.Manager";
const DEVICE: &str = "org.hapticd.Hapticd1.Device";
const SCENE_PATH: &str = "/org/hapticd/Hapticd1/scene";
const SCENE: &str = "org.hapticd.Hapticd1.Scene";
const PROPERTIES: &str = "org.freedesktop.DBus.Properties";

/// At most this many calls...
const CALLS: usize = 1000;
/// ...within this long: the whole test stays under a minute on two busy cores.
const BUDGET: Duration = Duration::from_secs(30);

/// The errors of the D-Bus specification a client may be answered for a call that makes no
/// sense; anything else must be one of hapticd's own (`org.hapticd.Hapticd1.Error.*`).
const STANDARD_ERRORS: [&str; 5] = [
    "org.freedesktop.DBus.Error.InvalidArgs",
    "org.freedesktop.DBus.Error.UnknownProperty",
    "org.freedesktop.DBus.Error.UnknownMethod",
    "org.freedesktop.DBus.Error.UnknownInterface",
    "org.freedesktop.DBus.Error.PropertyReadOnly",
];

/// A method or property of an interface, as introspected.
#[derive(Debug, Clone)]
enum Member {
    /// A method and the signatures of its arguments in.
    Method { name: String, inputs: Vec<String> },
    /// A property, its signature, and whether it can be set.
    Property {
        name: String,
        signature: String,
        writable: bool,
    },
}

/// The members of `interface` in the introspection `xml`.
fn members(xml: &str, interface: &str) -> Vec<Member> {
    let start = xml
        .find(&format!("<interface name=\"{interface}\">"))
        .unwrap_or_else(|| panic!("{interface} is not introspected:\n{xml}"));
    let body = &xml[start..];
    let body = &body[..body.find("</interface>").unwrap()];
    let attribute = |tag: &str, key: &str| {
        let from = tag.find(&format!("{key}=\""))? + key.len() + 2;
        Some(tag[from..from + tag[from..].find('"')?].to_string())
    };
    let mut found = Vec::new();
    for (at, _) in body.match_indices('<') {
        let tag = &body[at..at + body[at..].find('>').unwrap()];
        if tag.starts_with("<method ") {
            let end = body[at..].find("</method>").unwrap();
            let inputs = body[at..at + end]
                .split("<arg ")
                .skip(1)
                .filter(|arg| attribute(arg, "direction").as_deref() != Some("out"))
                .map(|arg| attribute(arg, "type").unwrap())
                .collect();
            found.push(Member::Method {
                name: attribute(tag, "name").unwrap(),
                inputs,
            });
        } else if tag.starts_with("<property ") {
            found.push(Member::Property {
                name: attribute(tag, "name").unwrap(),
                signature: attribute(tag, "type").unwrap(),
                writable: attribute(tag, "access").is_some_and(|a| a.contains("write")),
            });
        }
    }
    found
}

/// A uniform index below `n`.
fn below(rng: &mut Rng, n: usize) -> usize {
    (rng.next_u64() % n as u64) as usize
}

/// A random number, from the edges of `f64` and over many scales around the ranges that
/// parameters accept.
fn number(rng: &mut Rng) -> f64 {
    const EDGES: [f64; 10] = [
        0.0,
        -0.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::MAX,
        f64::MIN,
        f64::MIN_POSITIVE,
        5e-324,
        1.0,
    ];
    match below(rng, 4) {
        0 => EDGES[below(rng, EDGES.len())],
        _ => rng.range(-1.0, 1.0) * 10f64.powi(below(rng, 13) as i32 - 4),
    }
}

/// A random string: a scene name, a path, or bytes of a few kinds.
fn text(rng: &mut Rng, scenes: &[String]) -> String {
    const ODD: [&str; 8] = [
        "",
        "/",
        "/dev/zero",
        "/proc/self/mem",
        "../../../etc/hapticd/hapticd.yaml",
        "static.yaml",
        "libhapticd_scene_penalty.so",
        "ünïcødé ✋ scene",
    ];
    match below(rng, 4) {
        0 if !scenes.is_empty() => scenes[below(rng, scenes.len())].clone(),
        1 => ODD[below(rng, ODD.len())].to_string(),
        _ => (0..below(rng, 24))
            .map(|_| char::from(b' ' + below(rng, 95) as u8))
            // dbus-send splits array elements at commas; a lone backslash escapes nothing.
            .filter(|c| !matches!(c, ',' | '\\'))
            .collect(),
    }
}

/// A `dbus-send` value of signature `signature` (a basic type or an array of one), or None
/// for one dbus-send cannot write.
fn typed(rng: &mut Rng, signature: &str, scenes: &[String]) -> Option<String> {
    let basic = |rng: &mut Rng, code: char| -> Option<String> {
        Some(match code {
            's' => text(rng, scenes),
            'd' => format!("{:e}", number(rng)),
            'i' => (rng.next_u64() as i32).to_string(),
            'u' => (rng.next_u64() as u32).to_string(),
            'x' => (rng.next_u64() as i64).to_string(),
            't' => rng.next_u64().to_string(),
            'y' => (rng.next_u64() as u8).to_string(),
            'n' => (rng.next_u64() as i16).to_string(),
            'q' => (rng.next_u64() as u16).to_string(),
            'b' => (below(rng, 2) == 0).to_string(),
            'o' => format!("/org/hapticd/Hapticd1/device/{}", below(rng, 3)),
            _ => return None,
        })
    };
    let name = |code: char| match code {
        's' => "string",
        'd' => "double",
        'i' => "int32",
        'u' => "uint32",
        'x' => "int64",
        't' => "uint64",
        'y' => "byte",
        'n' => "int16",
        'q' => "uint16",
        'b' => "boolean",
        _ => "objpath",
    };
    let mut chars = signature.chars();
    match (chars.next()?, chars.next(), chars.next()) {
        ('a', Some(code), None) => {
            let items: Option<Vec<String>> =
                (0..1 + below(rng, 4)).map(|_| basic(rng, code)).collect();
            Some(format!("array:{}:{}", name(code), items?.join(",")))
        }
        (code, None, None) => Some(format!("{}:{}", name(code), basic(rng, code)?)),
        _ => None,
    }
}

/// A value of a random basic type (or array of one).
fn any(rng: &mut Rng, scenes: &[String]) -> String {
    const SIGNATURES: [&str; 12] = ["s", "d", "i", "u", "x", "t", "y", "n", "q", "b", "o", "ad"];
    let signature = SIGNATURES[below(rng, SIGNATURES.len())];
    typed(rng, signature, scenes).unwrap()
}

/// A D-Bus value that `dbus-send` can wrap in a `variant:` (basic types only).
fn variant(rng: &mut Rng, signature: &str, scenes: &[String]) -> String {
    let value = match typed(rng, signature, scenes) {
        Some(v) if below(rng, 3) != 0 && !v.starts_with("array:") => v,
        _ => loop {
            let v = any(rng, scenes);
            if !v.starts_with("array:") {
                break v;
            }
        },
    };
    format!("variant:{value}")
}

/// The daemon under test and its bus.
struct Daemon {
    child: Child,
    at: Isolated,
    log: PathBuf,
}

impl Daemon {
    /// The answer to `method` of `path` with `args`: Ok(reply) or Err(error name, message).
    fn call(&self, path: &str, method: &str, args: &[String]) -> Result<String, (String, String)> {
        let out = Command::new("dbus-send")
            .arg(format!("--bus={}", self.at.address()))
            .args(["--print-reply", "--reply-timeout=20000"])
            .arg(format!("--dest={NAME}"))
            .arg(path)
            .arg(method)
            .args(args)
            .output()
            .expect("dbus-send (package dbus-bin) comes with dbus-daemon");
        let stdout = String::from_utf8_lossy(&out.stdout).to_string();
        let stderr = String::from_utf8_lossy(&out.stderr);
        if out.status.success() {
            return Ok(stdout);
        }
        let error = stderr.trim().strip_prefix("Error ").unwrap_or_else(|| {
            panic!("dbus-send refused {method} {args:?} itself (a generator bug): {stderr}")
        });
        let (name, message) = error.split_once(": ").unwrap_or((error, ""));
        Err((name.to_string(), message.to_string()))
    }

    /// The introspection XML of `path`.
    fn introspect(&self, path: &str) -> String {
        self.call(path, "org.freedesktop.DBus.Introspectable.Introspect", &[])
            .unwrap_or_else(|e| panic!("introspecting {path}: {e:?}"))
    }

    /// What the daemon logged so far.
    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

/// The strings of a `--print-reply` of an `as` in a variant.
fn strings_of(reply: &str) -> Vec<String> {
    reply
        .lines()
        .filter_map(|l| l.trim().strip_prefix("string \"")?.strip_suffix('"'))
        .map(str::to_string)
        .collect()
}

/// The simulated hand's script: press-floor.yaml's press, slide and lift, over and over.
fn pressing_again_and_again(dir: &Path) -> PathBuf {
    let script = std::fs::read_to_string(repo_dir().join("config/hands/press-floor.yaml")).unwrap();
    let steps: String = script
        .lines()
        .filter(|l| l.trim_start().starts_with("- "))
        .map(|l| format!("{l}\n"))
        .collect();
    let file = dir.join("pressing.yaml");
    std::fs::write(&file, format!("hands:\n  grip:\n{}", steps.repeat(20))).unwrap();
    file
}

#[test]
fn random_calls_of_every_method_and_property_leave_the_daemon_answering_within_limits() {
    let dir = scratch_root().join(format!("fuzz-bus-{}", std::process::id()));
    let mechanisms = dir.join("mechanisms");
    std::fs::create_dir_all(&mechanisms).unwrap();
    let plugin = plugin_path("hapticd-spidar-g");
    std::fs::copy(&plugin, mechanisms.join(plugin.file_name().unwrap())).unwrap();
    let hand = pressing_again_and_again(&dir);
    let traffic = dir.join("session.traffic");
    let log = dir.join("hapticd.log");
    let at = Isolated::on_private_bus(&dir.join("daemon"), &mechanisms);
    let child = at
        .hapticd(&[
            "--sim",
            "spidar-g",
            "--hand",
            hand.to_str().unwrap(),
            "--state-dir",
            dir.join("state").to_str().unwrap(),
            "--record-traffic",
            traffic.to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let mut daemon = Daemon { child, at, log };
    let started = Instant::now();
    // Its objects are on the bus once it says it is ready. (A call sent after it owns its
    // name but before then is never answered at all: that start-up window is not fuzzed.)
    while !daemon.log().contains("ready: driving") {
        assert!(
            daemon.child.try_wait().unwrap().is_none(),
            "hapticd stopped: {}",
            daemon.log()
        );
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "not ready: {}",
            daemon.log()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let device_path = format!("{MANAGER_PATH}/device/0");
    let get = |daemon: &Daemon, interface: &str, property: &str| {
        let path = match interface {
            MANAGER => MANAGER_PATH,
            SCENE => SCENE_PATH,
            _ => &device_path,
        };
        daemon
            .call(
                path,
                &format!("{PROPERTIES}.Get"),
                &[format!("string:{interface}"), format!("string:{property}")],
            )
            .unwrap_or_else(|e| panic!("{interface}.{property}: {e:?}"))
    };
    let scenes = strings_of(&get(&daemon, MANAGER, "Scenes"));
    assert!(scenes.contains(&"static".to_string()), "{scenes:?}");
    // Every member the daemon says it has, on its object.
    let mut targets: Vec<(&str, &str, Member)> = Vec::new();
    for (path, interface) in [
        (MANAGER_PATH, MANAGER),
        (device_path.as_str(), DEVICE),
        (SCENE_PATH, SCENE),
    ] {
        let found = members(&daemon.introspect(path), interface);
        assert!(
            found.iter().any(|m| matches!(m, Member::Method { .. })),
            "{interface} has no methods"
        );
        // Restart ends this daemon by design (the new image answers after a while): its
        // own test covers it.
        let fuzzed = found
            .into_iter()
            .filter(|m| !matches!(m, Member::Method { name, .. } if name == "Restart"));
        targets.extend(fuzzed.map(|m| (path, interface, m)));
    }
    // Another seed draws other cases: HAPTICD_FUZZ_SEED=N.
    let seed = std::env::var("HAPTICD_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x6275_735f_6675_7a7a);
    let mut rng = Rng::new(seed);
    // Strings drawn for members: the scenes' names, and the bodies of the shipped worlds (by
    // name and by id), so that scene control reaches real bodies under a pressing hand.
    let mut names = scenes.clone();
    names.extend(["block", "ball 1", "floor", "mug", "0", "1", "3"].map(String::from));
    // Per member: (successes, refusals), reported.
    let mut outcomes: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    let mut errors: BTreeMap<String, usize> = BTreeMap::new();
    let mut calls = 0;
    while calls < CALLS && started.elapsed() < BUDGET {
        let (path, interface, member) = &targets[calls % targets.len()];
        // Between every two calls one time in four, a scene switch: a name from Scenes or any
        // string.
        let (label, path, method, args) = if below(&mut rng, 4) == 0 {
            let scene = text(&mut rng, &scenes);
            (
                "SwitchScene (between)".to_string(),
                MANAGER_PATH,
                format!("{MANAGER}.SwitchScene"),
                vec![format!("string:{scene}")],
            )
        } else {
            match member {
                Member::Method { name, inputs } => {
                    // Mostly the declared arguments with random values; else any arguments.
                    let declared: Option<Vec<String>> =
                        inputs.iter().map(|s| typed(&mut rng, s, &names)).collect();
                    let mut args = match declared {
                        Some(args) if below(&mut rng, 4) != 0 => args,
                        _ => (0..below(&mut rng, 3))
                            .map(|_| any(&mut rng, &names))
                            .collect(),
                    };
                    // Half the time, a body the running world has, by name.
                    if *interface == SCENE
                        && inputs.first().is_some_and(|s| s == "s")
                        && !args.is_empty()
                        && below(&mut rng, 2) == 0
                    {
                        let bodies = strings_of(&get(&daemon, SCENE, "Bodies"));
                        if !bodies.is_empty() {
                            args[0] = format!("string:{}", bodies[below(&mut rng, bodies.len())]);
                        }
                    }
                    (
                        format!("{interface}.{name}"),
                        *path,
                        format!("{interface}.{name}"),
                        args,
                    )
                }
                Member::Property {
                    name,
                    signature,
                    writable,
                } => {
                    let mut value = variant(&mut rng, signature, &names);
                    // A writable number near its value now, as often as not: in range.
                    if *writable && signature == "d" && below(&mut rng, 2) == 0 {
                        let now = get(&daemon, interface, name);
                        let now: f64 = now.split_whitespace().last().unwrap().parse().unwrap();
                        value = format!("variant:double:{:e}", now * rng.range(0.5, 1.5));
                    }
                    // Now and then another interface's name, or no such property.
                    let (on, property) = match below(&mut rng, 10) {
                        0 => ("org.hapticd.Hapticd1.Nothing", name.clone()),
                        1 => (*interface, text(&mut rng, &[])),
                        _ => (*interface, name.clone()),
                    };
                    let (on, property) = (format!("string:{on}"), format!("string:{property}"));
                    // Mostly set, else read it (or all) with the same names.
                    let (method, args) = match below(&mut rng, 8) {
                        0 => ("Get", vec![on, property]),
                        1 => ("GetAll", vec![on]),
                        _ => ("Set", vec![on, property, value]),
                    };
                    (
                        format!("{interface}.{name}"),
                        *path,
                        format!("{PROPERTIES}.{method}"),
                        args,
                    )
                }
            }
        };
        let answer = daemon.call(path, &method, &args);
        calls += 1;
        let entry = outcomes.entry(label.clone()).or_default();
        match &answer {
            Ok(_) => entry.0 += 1,
            Err((name, message)) => {
                entry.1 += 1;
                *errors.entry(name.clone()).or_default() += 1;
                assert!(
                    name.starts_with("org.hapticd.Hapticd1.Error.")
                        || STANDARD_ERRORS.contains(&name.as_str()),
                    "{method} {args:?} of {label}: {name}: {message}\n{}",
                    daemon.log()
                );
            }
        }
        assert!(
            daemon.child.try_wait().unwrap().is_none(),
            "hapticd stopped after {method} {args:?}: {}",
            daemon.log()
        );
    }
    // Reading every property still works.
    for (_, interface, member) in &targets {
        if let Member::Property { name, .. } = member {
            get(&daemon, interface, name);
        }
    }
    eprintln!(
        "seed {seed}: {calls} calls in {:.1} s; outcomes (ok, refused): {outcomes:?}; errors: {errors:?}",
        started.elapsed().as_secs_f64()
    );
    assert!(calls >= targets.len(), "only {calls} calls in the budget");
    // Every numeric setting, after all that, still takes its own value and refuses NaN.
    for (path, interface, member) in &targets {
        if let Member::Property {
            name,
            signature,
            writable: true,
        } = member
            && signature == "d"
        {
            let now = get(&daemon, interface, name);
            let now = now.split_whitespace().last().unwrap();
            let set = |value: &str| {
                daemon.call(
                    path,
                    &format!("{PROPERTIES}.Set"),
                    &[
                        format!("string:{interface}"),
                        format!("string:{name}"),
                        format!("variant:double:{value}"),
                    ],
                )
            };
            assert!(set(now).is_ok(), "{interface}.{name} refused its own {now}");
            let refused = set("nan").map_err(|(name, _)| name);
            assert_eq!(
                refused,
                Err("org.hapticd.Hapticd1.Error.NotFinite".to_string()),
                "{interface}.{name} = NaN"
            );
        }
    }

    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(daemon.child.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let status = daemon.child.wait().unwrap();
    let log = daemon.log();
    assert!(status.success(), "{log}");
    assert!(!log.contains("panicked"), "{log}");
    // Every D/A command within its string's limit, and some of them pushing.
    let mechanism = shipped("spidar-g");
    let limits: Vec<i16> = mechanism
        .strings
        .iter()
        .map(|s| dac_limit(s.tension_max, s.volts_per_newton))
        .collect();
    let (mut commands, mut pushing) = (0, 0);
    for (direction, bytes) in Recording::read(&traffic).unwrap().transfers() {
        if direction != Direction::Out {
            continue;
        }
        let dac = sh4::Command::decode(bytes).unwrap().dac;
        commands += 1;
        pushing += usize::from(dac.iter().any(|&d| d > 100));
        for (channel, &value) in dac.iter().enumerate() {
            let limit = limits.get(channel).copied().unwrap_or(0);
            assert!(
                value.unsigned_abs() <= limit.unsigned_abs(),
                "command {commands}, channel {channel}: {value} past {limit}"
            );
        }
    }
    assert!(
        commands > 5000 && pushing > 500,
        "{commands} commands, {pushing} pushing"
    );
    drop(daemon);
    let _ = std::fs::remove_dir_all(&dir);
}
