//! The haptic thread's system calls and CPU, and one bus per test.

use super::*;

#[test]
fn the_haptic_thread_makes_no_system_call_but_its_sleep() {
    let hand = press();
    let daemon = |at: &Isolated| {
        hapticd(
            at,
            &["--sim", "spidar-g", "--hand", &hand, "--duration", "1.5"],
        )
    };
    let threads = haptic_system_calls("strace", on_bus("strace"), daemon);
    assert_eq!(threads.len(), 1);
}

/// Two haptic threads, of two devices in one world (the shipped `two-hands` scene, stepped
/// by the daemon's world thread, the left hand pushing the block): each makes no system call
/// but its sleep.
#[test]
fn two_haptic_threads_in_one_world_make_no_system_call_but_their_sleep() {
    let (scene, hands) = (
        repo_dir().join("config/scenes/two-hands.yaml"),
        repo_dir().join("config/hands"),
    );
    let (left, right) = (
        hands.join("two-hands-left.yaml"),
        hands.join("two-hands-right.yaml"),
    );
    let daemon = |at: &Isolated| {
        hapticd_with_scene(
            at,
            &plugin_path("hapticd-scene-rapier"),
            &[
                "--sim",
                "spidar-g",
                "--sim",
                "spidar-g",
                "--scene-file",
                scene.to_str().unwrap(),
                "--hand",
                left.to_str().unwrap(),
                "--hand",
                right.to_str().unwrap(),
                "--duration",
                "2",
            ],
        )
    };
    // Two loops on both CPUs: alone.
    let threads = haptic_system_calls("strace-two", on_bus("strace-two").alone(), daemon);
    assert_eq!(threads.len(), 2);
}

/// Under strace, hapticd as `daemon` builds it on the bus of `at`, recording every frame
/// (the files called after `name`): asserts that each haptic thread, between its first sleep
/// and its last, called nothing but sleeps, and returns each one's sleeps.
fn haptic_system_calls(
    name: &str,
    at: Isolated,
    daemon: impl Fn(&Isolated) -> Command,
) -> Vec<usize> {
    // strace sees every system call of every thread; a haptic thread names itself first.
    let (trace, csv) = (
        scratch_file(&format!("{name}.strace")),
        scratch_file(&format!("{name}.csv")),
    );
    let daemon = daemon(&at);
    let mut strace = Command::new("strace");
    strace
        .args(["-f", "-qq", "-o"])
        .arg(&trace)
        .arg(daemon.get_program())
        .args(daemon.get_args())
        .arg("--record")
        .arg(&csv);
    for (name, value) in daemon.get_envs() {
        match value {
            Some(value) => strace.env(name, value),
            None => strace.env_remove(name),
        };
    }
    let out = strace
        .output()
        .expect("strace is installed (Debian package strace; `make check` installs it)");
    support::succeeded(out);
    let trace = std::fs::read_to_string(&trace).unwrap();
    let threads: Vec<&str> = trace
        .lines()
        .filter(|l| l.contains("PR_SET_NAME, \"hapticd-rt\""))
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert!(!threads.is_empty(), "no haptic thread named itself");
    let sleeps = threads
        .iter()
        .map(|thread| {
            // The thread's calls in order; "<... resumed>" lines only finish a call already
            // counted, and a sleep that the tracer interrupted goes on as `restart_syscall`.
            let calls: Vec<&str> = trace
                .lines()
                .filter_map(|l| l.strip_prefix(thread)?.strip_prefix(' '))
                .map(str::trim_start)
                .filter(|l| {
                    !l.starts_with("<...") && !l.starts_with("---") && !l.starts_with("+++")
                })
                .map(
                    |l| match l.contains("resuming interrupted clock_nanosleep") {
                        true => "clock_nanosleep",
                        false => l.split('(').next().unwrap(),
                    },
                )
                .collect();
            let first = calls.iter().position(|c| *c == "clock_nanosleep").unwrap();
            let last = calls.iter().rposition(|c| *c == "clock_nanosleep").unwrap();
            // Between its first sleep and its last, through the hands' scripts while every
            // frame is recorded: nothing but sleeps (the clock is read through the vDSO).
            let ticking = &calls[first..=last];
            assert!(ticking.len() > 500, "{thread}: {} sleeps", ticking.len());
            let mut others = std::collections::BTreeMap::new();
            for call in ticking.iter().filter(|c| **c != "clock_nanosleep") {
                *others.entry(*call).or_insert(0) += 1;
            }
            assert!(
                others.is_empty(),
                "haptic thread {thread} called (times): {others:?}"
            );
            ticking.len()
        })
        .collect();
    std::fs::remove_file(csv).ok();
    sleeps
}

/// Every thread of process `pid`: its name, CPUs and scheduling policy ([`thread_cpus`]).
fn every_thread(pid: u32) -> Vec<(String, Vec<usize>, u32)> {
    std::fs::read_dir(format!("/proc/{pid}/task"))
        .unwrap()
        .filter_map(|t| t.ok())
        .map(|t| thread_cpus(pid, &t.file_name().to_string_lossy()))
        .collect()
}

/// The CPUs thread `tid` of process `pid` may run on, and its name.
/// A thread's name, the CPUs it may run on, and its scheduling policy (1: SCHED_FIFO).
fn thread_cpus(pid: u32, tid: &str) -> (String, Vec<usize>, u32) {
    let status = std::fs::read_to_string(format!("/proc/{pid}/task/{tid}/status")).unwrap();
    // Field 41 of stat, counted after the parenthesised name (which may hold spaces).
    let stat = std::fs::read_to_string(format!("/proc/{pid}/task/{tid}/stat")).unwrap();
    let after_name = &stat[stat.rfind(')').unwrap() + 2..];
    let policy = after_name.split(' ').nth(38).unwrap().parse().unwrap();
    let field = |name: &str| {
        status
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .unwrap()
            .trim()
            .to_string()
    };
    let mut cpus = Vec::new();
    for range in field("Cpus_allowed_list:").split(',') {
        let (a, b) = range.split_once('-').unwrap_or((range, range));
        cpus.extend(a.parse::<usize>().unwrap()..=b.parse::<usize>().unwrap());
    }
    (field("Name:"), cpus, policy)
}

#[test]
fn the_haptic_thread_has_a_cpu_the_daemon_keeps_off() {
    let allowed = hapticd_service::cpus::allowed().unwrap();
    // A multi-rate scene: its physics thread keeps off the haptic CPU too.
    let balls = repo_dir().join("config/scenes/balls.yaml");
    let at = on_bus("cpus");
    let child = hapticd_with_scene(
        &at,
        &plugin_path("hapticd-scene-rapier"),
        &[
            "--sim",
            "spidar-g",
            "--duration",
            "3",
            "--scene-file",
            balls.to_str().unwrap(),
        ],
    )
    .spawn()
    .unwrap();
    let pid = child.id();
    // Once started, list every thread's CPUs.
    let started = std::time::Instant::now();
    let threads = loop {
        let threads = every_thread(pid);
        let named = |n: &str| threads.iter().any(|t| t.0 == n);
        // The physics thread turns real-time after its first steps: wait for that, a while.
        let physics_fifo = threads.iter().any(|t| t.0 == "hapticd-physics" && t.2 == 1);
        let waited = started.elapsed().as_secs_f64() > 1.5;
        if named("hapticd-rt") && named("hapticd-physics") && (physics_fifo || waited) {
            break threads;
        }
        assert!(started.elapsed().as_secs() < 10, "no haptic thread");
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let out = finish(child);
    if allowed.len() < 2 {
        return; // One CPU: nothing to set apart.
    }
    let haptic = *allowed.last().unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    for (name, cpus, policy) in &threads {
        if name == "hapticd-rt" {
            assert_eq!(cpus, &[haptic]);
        } else {
            assert!(!cpus.contains(&haptic), "{name} may run on CPU {haptic}");
        }
        // Where real-time scheduling is allowed, the physics thread has it too, lowest.
        if name == "hapticd-physics" && log.contains("SCHED_FIFO 80") {
            assert_eq!(*policy, 1, "the physics thread is not SCHED_FIFO");
        }
    }
    assert!(
        log.contains(&format!("runs on CPU {haptic} alone")),
        "{log}"
    );
}

/// Two devices: each haptic thread on a CPU of its own, never the same one, and (with a CPU
/// to spare for them) every other thread off both.
#[test]
fn two_haptic_threads_have_cpus_of_their_own() {
    let allowed = hapticd_service::cpus::allowed().unwrap();
    // Two loops on both CPUs: alone.
    let at = on_bus("cpus-two").alone();
    let child = hapticd(
        &at,
        &["--sim", "spidar-g", "--sim", "spidar-ii", "--duration", "2"],
    )
    .spawn()
    .unwrap();
    let pid = child.id();
    let started = std::time::Instant::now();
    let threads = loop {
        let threads = every_thread(pid);
        if threads.iter().filter(|t| t.0 == "hapticd-rt").count() == 2 {
            break threads;
        }
        assert!(started.elapsed().as_secs() < 10, "no two haptic threads");
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let out = finish(child);
    let log = String::from_utf8_lossy(&out.stderr);
    if allowed.len() < 2 {
        assert!(
            log.contains("2 haptic threads on 1 CPUs: they share"),
            "{log}"
        );
        return;
    }
    let haptic: Vec<usize> = threads
        .iter()
        .filter(|t| t.0 == "hapticd-rt")
        .map(|t| {
            assert_eq!(t.1.len(), 1, "a haptic thread may run on {:?}", t.1);
            t.1[0]
        })
        .collect();
    assert_ne!(haptic[0], haptic[1]);
    if allowed.len() == 2 {
        assert!(
            log.contains("each has a CPU of its own, which the daemon's other threads share"),
            "{log}"
        );
        return;
    }
    for (name, cpus, _) in threads.iter().filter(|t| t.0 != "hapticd-rt") {
        assert!(
            !cpus.iter().any(|c| haptic.contains(c)),
            "{name} may run on {cpus:?}, the haptic threads on {haptic:?}"
        );
    }
}

/// Every place a test starts hapticd names the bus it serves on: one started without `--bus`
/// serves on the system bus, where the machine's own hapticd makes it refuse to start (and
/// with none there, it takes the name the machine's would). The block around each start
/// must say `--bus`; and a command line of hapticd is built in one place alone,
/// `support::daemon::command` (the program handed to umockdev aside), with a configuration
/// of the test's own and none of the host's environment.
#[test]
fn every_test_starts_hapticd_on_a_bus_of_its_own() {
    let binary = "\"hapticd\"";
    let starts = [format!("artifact({binary})"), format!("run({binary}")];
    let built = format!("Command::new(artifact({binary}))");
    let mut unbound = Vec::new();
    let mut elsewhere = Vec::new();
    let sources = rust_files(&repo_dir().join("tests"));
    assert!(sources.len() > 40, "{sources:?}");
    for path in sources {
        let text = std::fs::read_to_string(&path).unwrap();
        let qualified = text.replace("support::artifact(", "artifact(");
        if qualified.contains(&built) && !path.ends_with("support/daemon.rs") {
            elsewhere.push(path.display().to_string());
        }
        for start in &starts {
            for (at, _) in text.match_indices(start.as_str()) {
                let rest = &text[at + start.len()..];
                // Where the binary lies, not a run of it.
                if rest.starts_with(".parent()") || rest.starts_with(".display()") {
                    continue;
                }
                // A bus given by hand, or a private bus the function starts for it
                // (its arguments name it).
                let function = text[..at].rfind("\nfn ").unwrap_or(0);
                let block = &text[function..at + start.len() + enclosing_block_rest(rest).len()];
                if !block.contains("--bus") && !block.contains("private_bus(") {
                    let line = text[..at].lines().count();
                    unbound.push(format!("{}:{line}", path.display()));
                }
            }
        }
    }
    assert!(
        unbound.is_empty(),
        "hapticd started without --bus (start it through support::daemon::Isolated): {unbound:?}"
    );
    assert!(
        elsewhere.is_empty(),
        "hapticd's command line built outside support::daemon::command: {elsewhere:?}"
    );
}

/// The Rust files under `dir`, at any depth.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(rust_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files
}

/// `text` up to the brace that closes the block it starts in.
fn enclosing_block_rest(text: &str) -> &str {
    let mut depth = 0;
    for (i, c) in text.char_indices() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => return &text[..i],
            '}' => depth -= 1,
            _ => {}
        }
    }
    text
}
