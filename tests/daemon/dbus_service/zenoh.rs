//! The Zenoh bridge: every tick for a Zenoh client, TLS, and commands as far as allowed.

use super::*;

/// The ROS 2 side of the bridge, as the real Zenoh client sees it: every tick of the pose
/// topic for 10 s at 1 kHz, in rmw_zenoh's keys and CDR; the twist (the angular velocity
/// of the hand's slow turn) and string topics; the node and its publishers announced by
/// liveliness tokens; the status answered, also to
/// `hapticctl --remote`, which records every tick through the bridge; a command refused by a
/// bridge that takes none.
#[test]
fn the_zenoh_bridge_publishes_every_tick_for_a_zenoh_client_and_answers_its_status() {
    let dir = support::shared_scratch("dbus", "zenoh");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    // The wrist turns the grip slowly about the vertical (at most 2 rad in all).
    let hand = dir.join("turn.yaml");
    std::fs::write(
        &hand,
        "hands:\n  grip:\n    - hold: { seconds: 0.5 }\n    - turn: { rate: [0, 0.1, 0], seconds: 20 }\n",
    )
    .unwrap();
    let daemon = Hapticd::start(
        &bus,
        &setup,
        &["--sim", "spidar-g", "--hand", hand.to_str().unwrap()],
    );
    let (mut bridge, endpoint) = zenoh_bridge(&bus, &dir, "rate: 1000\n", None, None);
    // The topics' subscriber is declared before the telemetry's and undeclared after it, so
    // that every tick counted was published while the topics were heard: declared the
    // other way round, a loaded machine counted three ticks the topics' subscriber had not
    // yet been declared for.
    // A conformance check written from rmw_zenoh's rules, not from the bridge's code: each
    // publisher numbers its own messages 1, 2, 3… and attaches its GID, the XXH3-128 of its
    // liveliness token (low half first); the tick is in hapticd's own telemetry.
    let follow = "import xxhash\n\
        samples = {}\n\
        def taken(sample):\n\
        \x20   attached = sample.attachment.to_bytes()\n\
        \x20   sequence = int.from_bytes(attached[:8], 'little')\n\
        \x20   kind = str(sample.key_expr).split('/')[4 if '/grip/' in str(sample.key_expr) else 3]\n\
        \x20   samples.setdefault(kind, []).append((str(sample.key_expr), sequence, sample.payload.to_bytes(), attached[16:].hex()))\n\
        ticks = []\n\
        subscriber = session.declare_subscriber('0/hapticd/sim_spidar_g_1/**', taken)\n\
        telemetry = session.declare_subscriber('hapticd/sim_spidar_g_1/telemetry/**', lambda s: ticks.append(int.from_bytes(s.payload.to_bytes()[:8], 'little')))\n\
        start = json.loads(ask('hapticd/sim_spidar_g_1/status', None)[0])['tick']\n\
        time.sleep(10)\n\
        end = json.loads(ask('hapticd/sim_spidar_g_1/status', None)[0])['tick']\n\
        time.sleep(0.2)\n\
        telemetry.undeclare()\n\
        time.sleep(0.2)\n\
        subscriber.undeclare()\n\
        status = ask('hapticd/sim_spidar_g_1/status', None)\n\
        tokens = sorted(str(r.ok.key_expr) for r in session.liveliness().get('@ros2_lv/0/**') if r.ok)\n\
        refused = ask('hapticd/sim_spidar_g_1/set/Stiffness', '1500')\n\
        gaps = sum(1 for a, b in zip(ticks, ticks[1:]) if b != a + 1)\n\
        numbered = {k: sum(1 for a, b in zip(v, v[1:]) if b[1] != a[1] + 1) for k, v in samples.items()}\n\
        gid = lambda token: '10' + xxhash.xxh3_128_intdigest(token.encode()).to_bytes(16, 'little').hex()\n\
        announced = {t.split('/')[9]: gid(t) for t in tokens if t.split('/')[5] == 'MP'}\n\
        topic = lambda key: '%' + '%'.join(key.split('/')[1:-2])\n\
        named = {k: sorted({a for _, _, _, a in v} - {announced.get(topic(v[0][0]))}) for k, v in samples.items()}\n\
        key, _, payload, _ = samples['pose'][-1]\n\
        twists = [struct.unpack_from('<3d', p, len(p) - 24) for _, _, p, _ in samples['twist'][-3000:]]\n\
        angular = [sum(w[i] for w in twists) / len(twists) for i in range(3)]\n\
        print(json.dumps({'count': len(ticks), 'gaps': gaps, 'key': key, \
        'first': ticks[0], 'last': ticks[-1], 'start': start, 'end': end, \
        'kinds': {k: len(v) for k, v in samples.items()}, 'twist': samples['twist'][-1][0], \
        'angular': angular, \
        'header': payload[:4].hex(), 'position': struct.unpack_from('<3d', payload, 16 + len('hapticd_sim_spidar_g_1') + 1 + (4 - 16 - len('hapticd_sim_spidar_g_1') - 1) % 8), \
        'strings': samples['strings'][-1][2].hex(), 'state': samples['state'][-1][2].hex(), \
        'numbered': numbered, 'named': named, 'gids': len({a for v in samples.values() for _, _, _, a in v}), \
        'status': json.loads(status[0]), 'tokens': tokens, 'refused': refused}))\n";
    let said = zenoh_client(follow, &endpoint, &[], None);
    // hapticctl reaches the same daemon through the bridge alone: its status, and 2 s of
    // its ticks in the CSV a local `record` writes.
    let remote = |args: &[&str]| {
        let out = hapticctl()
            .args(["--bus", "unix:path=/nonexistent", "--remote", &endpoint])
            .args(args)
            .output()
            .unwrap();
        assert!(out.status.success(), "{args:?}: {out:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let status = remote(&["status"]);
    assert!(
        status.contains("sim-spidar-g-1: running, 1000 Hz, tick "),
        "{status}"
    );
    let statuses: serde_json::Value = serde_json::from_str(&remote(&["status", "--json"])).unwrap();
    assert_eq!(statuses[0]["identity"], "sim-spidar-g-1");
    let csv = dir.join("remote.csv");
    remote(&["record", "--duration", "2", csv.to_str().unwrap()]);
    let recorded = std::fs::read_to_string(&csv).unwrap();
    let mut lines = recorded.lines();
    assert!(lines.next().unwrap().starts_with("tick,time,state,pose_x,"));
    let ticks: Vec<u64> = lines
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(ticks.len() > 1900, "{} rows", ticks.len());
    assert!(
        ticks.windows(2).all(|w| w[1] == w[0] + 1),
        "every tick, in order"
    );
    let refused = hapticctl()
        .args(["--remote", &endpoint, "set", "Stiffness", "1"])
        .output()
        .unwrap();
    assert_eq!(refused.status.code(), Some(2), "{refused:?}");
    let _ = bridge.kill();
    let _ = bridge.wait();
    println!("{said}");
    // Every tick of the ten seconds, in order: from the one after the tick the bridge had
    // when the subscription was in place (its status, asked after subscribing) to the one
    // it had at the end, however many a loaded machine let the loop make.
    let tick = |key: &str| said[key].as_u64().unwrap();
    assert!(tick("first") <= tick("start") + 1, "{said}");
    assert!(tick("last") >= tick("end"), "{said}");
    assert!(tick("end") - tick("start") > 1000, "{said}");
    assert_eq!(said["gaps"], 0, "{said}");
    // Each publisher's own numbers, 1 up without a gap, and its own GID, the one its token
    // gives: as many GIDs as topics heard.
    let kinds = said["kinds"].as_object().unwrap();
    for kind in kinds.keys() {
        assert_eq!(said["numbered"][kind], 0, "{kind}: {said}");
        assert_eq!(said["named"][kind], serde_json::json!([]), "{kind}: {said}");
    }
    assert_eq!(
        said["gids"].as_u64().unwrap() as usize,
        kinds.len(),
        "{said}"
    );
    let key = said["key"].as_str().unwrap();
    assert!(
        key.starts_with(
            "0/hapticd/sim_spidar_g_1/grip/pose/geometry_msgs::msg::dds_::PoseStamped_/RIHS01_"
        ),
        "{key}"
    );
    assert!(said["twist"].as_str().unwrap().starts_with(
        "0/hapticd/sim_spidar_g_1/grip/twist/geometry_msgs::msg::dds_::TwistStamped_/"
    ));
    let count = said["count"].as_u64().unwrap();
    for kind in ["pose", "twist", "wrench", "strings"] {
        assert!(said["kinds"][kind].as_u64().unwrap() + 2 >= count, "{said}");
    }
    // The twist's angular part, the last 24 bytes, over its last three seconds: the turn.
    let angular: Vec<f64> = said["angular"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(
        angular[0].abs() < 0.01 && (angular[1] - 0.1).abs() < 0.01 && angular[2].abs() < 0.01,
        "{angular:?}"
    );
    // The world's bodies (none in the static scene) as often as its picture: 60 a second.
    let bodies = said["kinds"]["bodies"].as_u64().unwrap();
    assert!((500..=650).contains(&bodies), "{said}");
    // The state once a second and when it changes.
    assert!(
        (9..=12).contains(&said["kinds"]["state"].as_u64().unwrap()),
        "{said}"
    );
    assert_eq!(said["header"], "00010000", "little-endian CDR");
    // The simulated grip turns where it was calibrated, at the frame's centre.
    let position: Vec<f64> = said["position"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert!(position.iter().all(|x| x.abs() < 1e-3), "{position:?}");
    // SPIDAR-G's eight strings by name, in a JointState; "running" in a String.
    let strings = hex_bytes(said["strings"].as_str().unwrap());
    let decoded = JointState::decode(&strings).unwrap();
    assert_eq!(decoded.name.len(), 8);
    assert_eq!(decoded.name[7], "string7");
    assert_eq!(decoded.effort.len(), 8);
    assert!(decoded.effort.iter().all(|t| t.is_finite() && *t >= 0.0));
    let state = StringMessage::decode(&hex_bytes(said["state"].as_str().unwrap())).unwrap();
    assert_eq!(state.data, "running");
    let status = &said["status"];
    assert_eq!(status["identity"], "sim-spidar-g-1");
    assert_eq!(status["state"], "running");
    assert_eq!(status["rate"], 1000.0);
    assert_eq!(status["commands"], false);
    // `ros2 node list` and `ros2 topic list` find the node and its eight publishers.
    let tokens: Vec<&str> = said["tokens"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    assert_eq!(tokens.len(), 9, "{tokens:?}");
    assert!(
        tokens
            .iter()
            .any(|t| t.contains("/NN/%/%/hapticd_sim_spidar_g_1")
                && t.ends_with("hapticd_sim_spidar_g_1")),
        "{tokens:?}"
    );
    assert!(
        tokens.iter().any(|t| t.contains(
            "/MP/%/%/hapticd_sim_spidar_g_1/%hapticd%sim_spidar_g_1%grip%pose/geometry_msgs::msg::dds_::PoseStamped_/"
        ) && t.ends_with("/::,:,:,:,,")),
        "{tokens:?}"
    );
    let refused = said["refused"][0].as_str().unwrap();
    assert!(refused.starts_with("error: refused"), "{refused}");
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 2000", "nothing changed");
    daemon.stop();
}

/// `openssl ARGS` in `dir`, which must succeed.
fn openssl(dir: &Path, args: &[&str]) {
    let out = Command::new("openssl")
        .current_dir(dir)
        .args(args)
        .output()
        .expect("openssl is installed by `make check`");
    assert!(out.status.success(), "openssl {args:?}: {out:?}");
}

/// A certificate authority `ca` (ca.pem, ca.key) in `dir`, and a certificate of it for each of
/// `holders` (NAME.pem, NAME.key) naming 127.0.0.1: P-256 keys, valid for a day.
fn certificates(dir: &Path, ca: &str, holders: &[&str]) {
    let key = [
        "-newkey",
        "ec",
        "-pkeyopt",
        "ec_paramgen_curve:P-256",
        "-nodes",
    ];
    let (ca_pem, ca_key) = (format!("{ca}.pem"), format!("{ca}.key"));
    let subject = format!("/CN={ca}");
    openssl(
        dir,
        &[
            &["req", "-x509"][..],
            &key,
            &[
                "-keyout", &ca_key, "-out", &ca_pem, "-days", "1", "-subj", &subject,
            ],
        ]
        .concat(),
    );
    std::fs::write(dir.join("holder.ext"), "subjectAltName=IP:127.0.0.1\n").unwrap();
    for holder in holders {
        let (pem, private, request) = (
            format!("{holder}.pem"),
            format!("{holder}.key"),
            format!("{holder}.csr"),
        );
        let subject = format!("/CN={holder}");
        openssl(
            dir,
            &[
                &["req"][..],
                &key,
                &["-keyout", &private, "-out", &request, "-subj", &subject],
            ]
            .concat(),
        );
        openssl(
            dir,
            &[
                "x509",
                "-req",
                "-in",
                &request,
                "-CA",
                &ca_pem,
                "-CAkey",
                &ca_key,
                "-CAcreateserial",
                "-out",
                &pem,
                "-days",
                "1",
                "-extfile",
                "holder.ext",
            ],
        );
    }
}

/// The bridge over mutual TLS, configured by the network chapter's own `zenoh` file: a client holding
/// a certificate of the administrator's CA reads the status, and so does `hapticctl --remote`
/// given the same certificate in its `--remote-config`; one holding another CA's certificate,
/// one speaking plain TCP to the same port, and hapticctl without the file get no session.
#[test]
fn the_zenoh_bridge_over_tls_answers_only_holders_of_its_certificates() {
    let dir = support::shared_scratch("dbus", "zenoh-tls");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    let tls = dir.join("tls");
    std::fs::create_dir_all(&tls).unwrap();
    certificates(&tls, "ca", &["bridge", "operator"]);
    certificates(&tls, "stranger-ca", &["stranger"]);
    let chapter = std::fs::read_to_string(repo_dir().join("docs/network.md")).unwrap();
    let tls_text = chapter
        .split("```json5\n")
        .filter_map(|block| block.split("```").next())
        .find(|block| block.contains("tls:"))
        .expect("docs/network.md shows a zenoh file for TLS");
    let credentials = "/run/credentials/hapticd-zenoh.service/";
    assert!(tls_text.contains(credentials), "{tls_text}");
    let zenoh_file = dir.join("tls.json5");
    std::fs::write(
        &zenoh_file,
        tls_text.replace(credentials, &format!("{}/", tls.display())),
    )
    .unwrap();
    let (_, port) = support::loopback_endpoint();
    let endpoint = format!("tls/127.0.0.1:{port}");
    let config = format!("listen: [{endpoint}]\nzenoh: {}\n", zenoh_file.display());
    let mut bridge = zenoh_bridge_on(&bus, &dir, &config, port, None, None);
    let client = |endpoint: &str, holder: Option<(&str, &str)>| {
        let mut settings = serde_json::json!({ "transport/unicast/open_timeout": 3000 });
        if let Some((ca, holder)) = holder {
            let at = |file: String| tls.join(file).display().to_string();
            settings["transport/link/tls/root_ca_certificate"] = at(format!("{ca}.pem")).into();
            settings["transport/link/tls/connect_certificate"] = at(format!("{holder}.pem")).into();
            settings["transport/link/tls/connect_private_key"] = at(format!("{holder}.key")).into();
            settings["transport/link/tls/enable_mtls"] = true.into();
        }
        zenoh_client_with(
            "print(json.dumps({'status': ask('hapticd/sim_spidar_g_1/status', None)}))\n",
            endpoint,
            &[],
            None,
            &settings,
        )
    };
    let operator = client(&endpoint, Some(("ca", "operator")));
    // Another CA's holder trusts the bridge's certificate (it has the CA), but the bridge
    // does not trust the holder's.
    let stranger = client(&endpoint, Some(("ca", "stranger")));
    let plain = client(&format!("tcp/127.0.0.1:{port}"), None);
    // hapticctl --remote, with the operator's certificates in a Zenoh file of its own.
    let operator_file = dir.join("operator.json5");
    let at = |file: &str| tls.join(file).display().to_string();
    std::fs::write(
        &operator_file,
        serde_json::json!({ "transport": { "link": { "tls": {
            "root_ca_certificate": at("ca.pem"),
            "connect_certificate": at("operator.pem"),
            "connect_private_key": at("operator.key"),
            "enable_mtls": true,
        } } } })
        .to_string(),
    )
    .unwrap();
    let remote_status = |file: Option<&Path>| {
        let mut command = support::hapticctl();
        command.args(["--remote", &endpoint]);
        if let Some(file) = file {
            command.arg("--remote-config").arg(file);
        }
        command.arg("status").output().unwrap()
    };
    let (ctl, ctl_without) = (remote_status(Some(&operator_file)), remote_status(None));
    let _ = bridge.kill();
    let _ = bridge.wait();
    eprintln!("operator: {operator}\nstranger: {stranger}\nplain TCP: {plain}");
    let status: serde_json::Value =
        serde_json::from_str(operator["status"][0].as_str().unwrap()).unwrap();
    assert_eq!(status["identity"], "sim-spidar-g-1", "{operator}");
    assert_eq!(status["state"], "running", "{operator}");
    for refused in [&stranger, &plain] {
        assert!(refused["unreachable"].is_string(), "{refused}");
    }
    let said = String::from_utf8_lossy(&ctl.stdout);
    assert!(ctl.status.success(), "{ctl:?}");
    assert!(said.contains("sim-spidar-g-1: running, 1000 Hz"), "{said}");
    let refused = String::from_utf8_lossy(&ctl_without.stderr);
    assert_eq!(ctl_without.status.code(), Some(1), "{ctl_without:?}");
    assert!(refused.contains("cannot reach"), "{refused}");
    daemon.stop();
}

/// Commands through a bridge that takes them: refused by the bus for a bridge whose user has
/// no rights, kept from the bridge by Zenoh's access control as docs/network.md configures it,
/// and carried out (parameters checked as the bus checks them, a push felt, bounded, ramped
/// and let go when no command comes) by a bridge with the rights.
#[test]
fn the_zenoh_bridge_takes_commands_only_as_far_as_it_is_allowed() {
    let dir = support::shared_scratch("dbus", "zenoh-commands");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    // Each command also pushes on the grip through its wrench_command topic: 2 N up for a
    // second, then a million newtons for half a second, then nothing; the displayed wrench
    // topic says what the hand felt, tick by tick.
    let command = "print(json.dumps({'set': ask('hapticd/sim_spidar_g_1/set/Stiffness', '1500'), \
        'bad': ask('hapticd/sim_spidar_g_1/set/Stiffness', 'nan'), \
        'malformed': ask('hapticd/scene/body/x/pose', '[1]'), \
        'effect': ask('hapticd/sim_spidar_g_1/effect/add', '{kind: damper, damping: 2}'), \
        'bad_effect': ask('hapticd/sim_spidar_g_1/effect/add', '{kind: damper, damping: -2}'), \
        'cleared': ask('hapticd/sim_spidar_g_1/effect/clear', ''), 'felt': push()}))\n";
    let push = "def push():\n\
        \x20   shown = []\n\
        \x20   def displayed(sample):\n\
        \x20       b = sample.payload.to_bytes()\n\
        \x20       n = int.from_bytes(b[12:16], 'little')\n\
        \x20       at = 4 + -(-(12 + n) // 8) * 8\n\
        \x20       shown.append((time.monotonic(), struct.unpack_from('<d', b, at + 8)[0]))\n\
        \x20   sub = session.declare_subscriber('0/hapticd/sim_spidar_g_1/grip/wrench/**', displayed)\n\
        \x20   pub = session.declare_publisher(sys.argv[2])\n\
        \x20   phases = {}\n\
        \x20   for name, payload, seconds in [('push', sys.argv[3], 1.0), ('huge', sys.argv[4], 0.5), ('quiet', None, 0.6)]:\n\
        \x20       start = phases[name] = time.monotonic()\n\
        \x20       while time.monotonic() - start < seconds:\n\
        \x20           if payload:\n\
        \x20               pub.put(bytes.fromhex(payload))\n\
        \x20           time.sleep(0.005)\n\
        \x20   sub.undeclare()\n\
        \x20   ends = {'push': phases['huge'], 'huge': phases['quiet'], 'quiet': phases['quiet'] + 0.6}\n\
        \x20   def during(name, after=0.0, until=None):\n\
        \x20       end = ends[name] if until is None else phases[name] + until\n\
        \x20       return [f for t, f in shown if phases[name] + after <= t < end]\n\
        \x20   rising = [f for f in during('push') if f > 1e-9]\n\
        \x20   return {'first': rising[:3], 'push_end': during('push', 0.5), 'huge_max': max(during('huge') or [0]), \
        'held': during('quiet', 0.0, 0.05), 'gone': during('quiet', 0.3)}\n";
    let key = hapticd_ros2::keys::topic_key::<WrenchStamped>(
        Default::default(),
        "/hapticd/sim_spidar_g_1/grip/wrench_command",
    );
    let wrench = |newtons: f64| {
        let message = WrenchStamped {
            header: Header {
                stamp: Time::from_nanos(1),
                frame_id: "remote".into(),
            },
            force: [0.0, newtons, 0.0],
            torque: [0.0; 3],
        };
        message
            .encode()
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<String>()
    };
    let args = [key, wrench(2.0), wrench(1e6)];
    let script = format!("{push}{command}");
    if is_root() {
        let (mut bridge, endpoint) =
            zenoh_bridge(&bus, &dir, "commands: true\n", Some(65534), None);
        let said = zenoh_client(&script, &endpoint, &args, None);
        let _ = bridge.kill();
        let _ = bridge.wait();
        let denied = said["set"][0].as_str().unwrap();
        assert!(
            denied.contains("org.freedesktop.DBus.Error.AccessDenied"),
            "{said}"
        );
        assert_eq!(bus.get(DEVICE, "Stiffness"), "d 2000", "nothing changed");
        // Without the rights, the wrench input is not opened: nothing pushes on the hand.
        assert_eq!(said["felt"]["first"], serde_json::json!([]), "{said}");
        assert_eq!(bus.get(DEVICE, "WrenchCommand"), "s \"none\"");
    }
    // Commands on, and Zenoh's access control as docs/network.md shows it: the status is
    // answered; no command, parameter or push reaches the bridge.
    let chapter = std::fs::read_to_string(repo_dir().join("docs/network.md")).unwrap();
    let acl_text = chapter
        .split("```json5\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .unwrap();
    let acl = dir.join("acl.json5");
    std::fs::write(&acl, acl_text).unwrap();
    let guarded = format!("commands: true\nzenoh: {}\n", acl.display());
    let (mut bridge, endpoint) = zenoh_bridge(&bus, &dir, &guarded, None, None);
    let said = zenoh_client(
        &format!(
            "{push}print(json.dumps({{'status': ask('hapticd/sim_spidar_g_1/status', None), \
         'set': ask('hapticd/sim_spidar_g_1/set/Stiffness', '1500'), 'felt': push()}}))\n"
        ),
        &endpoint,
        &args,
        None,
    );
    let _ = bridge.kill();
    let _ = bridge.wait();
    assert!(
        said["status"][0]
            .as_str()
            .unwrap()
            .contains("\"commands\":true"),
        "{said}"
    );
    assert_eq!(said["set"], serde_json::json!([]), "{said}");
    // The displayed wrench came through all along, and stayed zero.
    let shown = said["felt"]["push_end"].as_array().unwrap();
    assert!(
        !shown.is_empty() && shown.iter().all(|f| f.as_f64() == Some(0.0)),
        "{said}"
    );
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 2000", "nothing changed");
    let (mut bridge, endpoint) = zenoh_bridge(&bus, &dir, "commands: true\n", None, None);
    let said = zenoh_client(&script, &endpoint, &args, None);
    let _ = bridge.kill();
    let _ = bridge.wait();
    println!("{said}");
    assert_eq!(
        said["set"][0].as_str().unwrap(),
        r#"{"set":"Stiffness","value":1500.0}"#,
        "{said}"
    );
    assert_eq!(bus.get(DEVICE, "Stiffness"), "d 1500");
    assert!(
        said["bad"][0]
            .as_str()
            .unwrap()
            .contains("org.hapticd.Hapticd1.Error.NotFinite"),
        "{said}"
    );
    assert!(
        said["malformed"][0]
            .as_str()
            .unwrap()
            .starts_with("error: ")
    );
    // Effects from the network: started (their id answered), refused by name, cleared.
    assert_eq!(said["effect"][0].as_str().unwrap(), r#"{"id":0}"#, "{said}");
    assert!(
        said["bad_effect"][0]
            .as_str()
            .unwrap()
            .contains("org.hapticd.Hapticd1.Error.InvalidEffect"),
        "{said}"
    );
    assert_eq!(said["cleared"][0].as_str().unwrap(), r#"{"cleared":true}"#);
    assert_eq!(bus.get(DEVICE, "Effects"), "a(us) 0");
    // The push ramps in (the first samples felt are a fraction of it), then is felt whole;
    // the million newtons are MaxForce; once nothing comes, it is held for 0.1 s (a late
    // packet is no fault) and then ramped out.
    let felt = &said["felt"];
    let numbers = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let first = numbers(&felt["first"]);
    assert!(!first.is_empty() && first[0] < 1.0, "{felt}");
    let whole = numbers(&felt["push_end"]);
    assert!(
        !whole.is_empty() && whole.iter().all(|f| (f - 2.0).abs() < 1e-6),
        "{felt}"
    );
    let huge = felt["huge_max"].as_f64().unwrap();
    assert!((huge - 10.0).abs() < 1e-6, "MaxForce, not {huge}");
    let gone = numbers(&felt["gone"]);
    assert!(
        !gone.is_empty() && gone.iter().all(|f| f.abs() < 1e-9),
        "{felt}"
    );
    assert!(numbers(&felt["held"]).iter().any(|f| *f > 1.0), "{felt}");
    assert_eq!(bus.get(DEVICE, "WrenchCommand"), "s \"stale\"");
    daemon.stop();
}

/// Deployed as rmw_zenoh's nodes are: the bridge connects to the machine's Zenoh router, a
/// client of that router (as `ros2 topic echo` reaches one) hears its topics and tokens at
/// the default rate; and a bridge whose router is not there says so once, and publishes on.
#[test]
fn the_bridge_meets_nodes_through_a_router_and_says_when_none_answers() {
    let dir = support::shared_scratch("dbus", "zenoh-router");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let _daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g"]);
    // A Zenoh router, as rmw_zenohd runs one (router mode, listening, no scouting).
    let (router, port) = support::loopback_endpoint();
    let _router = support::Killed(
        Command::new("/usr/bin/python3")
            .args([
                "-c",
                "import json, sys, time, zenoh\n\
                 c = zenoh.Config()\n\
                 c.insert_json5('mode', '\"router\"')\n\
                 c.insert_json5('listen/endpoints', json.dumps([sys.argv[1]]))\n\
                 c.insert_json5('scouting/multicast/enabled', 'false')\n\
                 session = zenoh.open(c)\n\
                 time.sleep(120)\n",
                &router,
            ])
            .env("PYTHONPATH", support::python_package("eclipse-zenoh"))
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .spawn()
            .unwrap(),
    );
    let mut bridge = zenoh_bridge_on(
        &bus,
        &dir,
        &format!("connect: [{router}]\nlisten: [tcp/127.0.0.1:0]\n"),
        port,
        None,
        None,
    );
    // Every topic's samples over 4 s, by the topic's last word (pose, twist, … state).
    let follow = "heard = {}\n\
        listening = False\n\
        def taken(sample):\n\
        \x20   if listening:\n\
        \x20       topic = str(sample.key_expr).split('/')[-3]\n\
        \x20       heard[topic] = heard.get(topic, 0) + 1\n\
        subscriber = session.declare_subscriber('0/hapticd/sim_spidar_g_1/**', taken)\n\
        time.sleep(1)\n\
        listening = True\n\
        time.sleep(4)\n\
        listening = False\n\
        subscriber.undeclare()\n\
        tokens = [str(r.ok.key_expr) for r in session.liveliness().get('@ros2_lv/0/**', timeout=3.0) if r.ok]\n\
        rates = {topic: n / 4 for topic, n in heard.items()}\n\
        from zenoh import ext\n\
        def first_state(latched):\n\
        \x20   got, started = [], time.monotonic()\n\
        \x20   taken = lambda s: got.append((time.monotonic() - started, s.payload.to_bytes()[-8:].decode(), len(s.attachment.to_bytes())))\n\
        \x20   key = '0/hapticd/sim_spidar_g_1/state/**'\n\
        \x20   if latched:\n\
        \x20       sub = ext.declare_advanced_subscriber(session, key, taken, history=ext.HistoryConfig(detect_late_publishers=True, max_samples=1))\n\
        \x20   else:\n\
        \x20       sub = session.declare_subscriber(key, taken)\n\
        \x20   while not got and time.monotonic() - started < 3:\n\
        \x20       time.sleep(0.002)\n\
        \x20   sub.undeclare()\n\
        \x20   time.sleep(0.23)\n\
        \x20   return got[0] if got else None\n\
        late = [first_state(True) for _ in range(8)]\n\
        plain = [first_state(False) for _ in range(8)]\n\
        qos = [t.split('/')[-1] for t in tokens if '%state/' in t]\n\
        print(json.dumps({'rates': rates, 'tokens': len(tokens), 'late': late, 'plain': plain, 'qos': qos, 'status': ask('hapticd/sim_spidar_g_1/status', None)}), flush=True)\n\
        session.close()\n";
    let said = zenoh_client(follow, &router, &[], None);
    let _ = bridge.kill();
    let _ = bridge.wait();
    println!("through the router: {said}");
    // The default rate, 100 a second, as a subscriber at the router receives it.
    let rate = said["rates"]["pose"].as_f64().unwrap();
    assert!((90.0..=110.0).contains(&rate), "{said}");
    assert!(said["tokens"].as_u64().unwrap() > 5, "{said}");
    // `state` is transient-local, as ROS latches a state: announced so, and a subscription
    // with history (rmw_zenoh's for TRANSIENT_LOCAL, an advanced subscriber) that comes
    // late has the last state at once, with its attachment, where a plain one waits for the
    // next (up to a second; eight tries a quarter second apart, at every phase of it).
    assert_eq!(said["qos"], serde_json::json!([":1:,1:,:,:,,"]), "{said}");
    let waits = |kind: &str| -> Vec<f64> {
        said[kind]
            .as_array()
            .unwrap()
            .iter()
            .map(|got| {
                assert_eq!(got[1], "running\0", "{said}");
                assert_eq!(got[2], 33, "{said}");
                got[0].as_f64().unwrap()
            })
            .collect()
    };
    let (late, plain) = (waits("late"), waits("plain"));
    let slowest = late.iter().copied().fold(0.0, f64::max);
    let mean = |w: &[f64]| w.iter().sum::<f64>() / w.len() as f64;
    println!(
        "state: a late subscriber with history waits {:.1} ms at most, a plain one {:.0} ms on \
         average",
        slowest * 1e3,
        mean(&plain) * 1e3
    );
    // Through the router at most a few round trips on the loopback; a plain wait averages
    // half a second.
    assert!(slowest < 0.1, "{late:?}");
    assert!(mean(&plain) > 0.2, "{plain:?}");
    assert_eq!(said["status"].as_array().unwrap().len(), 1, "{said}");

    // No router where it connects: said once, and the bridge is up and publishing.
    let (nowhere, port) = support::loopback_endpoint();
    let log = dir.join("unmet.log");
    let file = dir.join("unmet.yaml");
    std::fs::write(
        &file,
        format!("connect: [{nowhere}]\nlisten: [tcp/127.0.0.1:0]\n"),
    )
    .unwrap();
    let mut command = Command::new(artifact("hapticd-zenoh"));
    command
        .arg("--config")
        .arg(&file)
        .args(["--bus", &bus.address, "--duration", "4"])
        .stderr(std::fs::File::create(&log).unwrap());
    let unmet = spawn_ready(command, &dir.join(format!("notify-{port}")))
        .wait_with_output()
        .unwrap();
    assert!(unmet.status.success(), "{unmet:?}");
    let said = std::fs::read_to_string(&log).unwrap();
    assert_eq!(
        said.matches("no Zenoh router or peer answers").count(),
        1,
        "{said}"
    );
}

/// The world's joints on the ROS 2 side: `sensor_msgs/JointState` on
/// `/hapticd/<device>/joint_states`, each hinge and slider by name with its position and
/// velocity, as a Zenoh client hears it: the joints scene's crank, turned by its motor at
/// 1 rad/s, counted past ±π and moving at its motor's rate.
#[test]
fn the_zenoh_bridge_publishes_the_worlds_joint_states() {
    let dir = support::shared_scratch("dbus", "zenoh-joints");
    let bus = Bus::start(&dir);
    let setup = Setup::new(&dir);
    let daemon = Hapticd::start(&bus, &setup, &["--sim", "spidar-g", "--scene", "joints"]);
    let (mut bridge, endpoint) = zenoh_bridge(&bus, &dir, "rate: 100\n", None, None);
    let follow = "heard = []\n\
        subscriber = session.declare_subscriber('0/hapticd/sim_spidar_g_1/joint_states/**', \
        lambda s: heard.append((str(s.key_expr), time.monotonic(), s.payload.to_bytes())))\n\
        time.sleep(4)\n\
        subscriber.undeclare()\n\
        print(json.dumps({'count': len(heard), 'key': heard[0][0], \
        'span': heard[-1][1] - heard[0][1], \
        'first': heard[0][2].hex(), 'last': heard[-1][2].hex()}))\n";
    let said = zenoh_client(follow, &endpoint, &[], None);
    let _ = bridge.kill();
    let _ = bridge.wait();
    daemon.stop();
    println!("{said}");
    let key = said["key"].as_str().unwrap();
    assert!(
        key.starts_with(
            "0/hapticd/sim_spidar_g_1/joint_states/sensor_msgs::msg::dds_::JointState_/RIHS01_"
        ),
        "{key}"
    );
    // 50 a second, less what a loaded machine takes: each is a call on the bus, and beside
    // other tests' daemons on two cores 70 came in the 4 s (17 a second); a bridge that
    // published only when the world's pictures change, or once a second, would send a few.
    let count = said["count"].as_u64().unwrap();
    assert!(count > 40, "{said}");
    let decode =
        |which: &str| JointState::decode(&hex_bytes(said[which].as_str().unwrap())).unwrap();
    let (first, last) = (decode("first"), decode("last"));
    assert_eq!(
        last.name,
        ["hinge", "runners", "pivot", "crank"],
        "the hinges and sliders, in the file's order"
    );
    assert_eq!((last.position.len(), last.velocity.len()), (4, 4));
    // Turning at its motor's rate, and never further than the clock lets it: the physics
    // thread keeps the clock's pace alone (1.00 of it measured) but may fall behind it on a
    // loaded two-core machine (0.49 measured beside other tests' daemons).
    let span = said["span"].as_f64().unwrap();
    let turned = last.position[3] - first.position[3];
    assert!(
        turned > 0.0 && turned / span < 1.1 && (last.velocity[3] - 1.0).abs() < 0.05,
        "the crank turned {turned} rad in {span} s, at {} rad/s",
        last.velocity[3]
    );
    assert!(
        last.position[3] > std::f64::consts::PI,
        "{:?}",
        last.position
    );
}
