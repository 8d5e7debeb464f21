//! Two network namespaces joined by a veth pair, made by a test and removed when it ends: a
//! network of its own between the machines of a network test, traffic that never leaves
//! them. Each side has its address on the pair and its own loopback.

use std::fs::File;
use std::net::Ipv4Addr;
use std::os::unix::process::CommandExt;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};

use nix::sched::{CloneFlags, setns};

/// One side of the pair: a namespace, and its address on the veth link.
#[derive(Clone)]
pub struct Namespace {
    name: String,
    /// This side's address on the link (a /30 of the namespaces alone).
    pub address: Ipv4Addr,
}

impl Namespace {
    /// The namespace as a file to enter.
    fn file(&self) -> File {
        File::open(format!("/run/netns/{}", self.name))
            .unwrap_or_else(|e| panic!("network namespace {}: {e}", self.name))
    }

    /// `command` to start in this namespace.
    pub fn enter<'a>(&self, command: &'a mut Command) -> &'a mut Command {
        let namespace = self.file();
        // SAFETY: setns is one system call, safe between fork and exec.
        unsafe {
            command.pre_exec(move || {
                setns(&namespace, CloneFlags::CLONE_NEWNET).map_err(std::io::Error::from)
            })
        }
    }

    /// Move the calling thread into this namespace: the sockets it opens from now on are the
    /// namespace's.
    pub fn enter_this_thread(&self) {
        setns(self.file(), CloneFlags::CLONE_NEWNET)
            .unwrap_or_else(|e| panic!("entering network namespace {}: {e}", self.name));
    }
}

/// Two namespaces joined by a veth pair; deleted (and the pair with them) when dropped.
pub struct Pair {
    /// One side (for a test of shared worlds: the world host's).
    pub near: Namespace,
    /// The other side (the haptic hosts').
    pub far: Namespace,
}

impl Pair {
    /// Two namespaces of this process's own, joined by a veth pair; `None` where the machine
    /// does not let this process make them (not root, or no `ip`). Namespaces left by test
    /// processes that were killed before they could delete theirs go first.
    pub fn create() -> Option<Pair> {
        static MADE: AtomicU32 = AtomicU32::new(0);
        delete_orphans();
        let (pid, made) = (std::process::id(), MADE.fetch_add(1, Ordering::Relaxed));
        let [near, far] = [0u8, 1].map(|k| Namespace {
            name: format!("{PREFIX}{pid}-{made}-{k}"),
            address: Ipv4Addr::new(10, 213, 0, k + 1),
        });
        if !ip(&["netns", "add", &near.name]) {
            return None;
        }
        let pair = Pair { near, far };
        // Link names have at most 15 bytes; they go with their namespace.
        let [near_link, far_link] = [0, 1].map(|k| format!("hv{pid:x}{made:x}{k}"));
        let made = ip(&["netns", "add", &pair.far.name])
            && ip(&[
                "link",
                "add",
                &near_link,
                "netns",
                &pair.near.name,
                "type",
                "veth",
                "peer",
                "name",
                &far_link,
                "netns",
                &pair.far.name,
            ])
            && [(&pair.near, &near_link), (&pair.far, &far_link)]
                .iter()
                .all(|(side, link)| {
                    ip(&["-n", &side.name, "link", "set", "lo", "up"])
                        && ip(&[
                            "-n",
                            &side.name,
                            "addr",
                            "add",
                            &format!("{}/30", side.address),
                            "dev",
                            link,
                        ])
                        && ip(&["-n", &side.name, "link", "set", link, "up"])
                });
        made.then_some(pair)
    }
}

impl Drop for Pair {
    fn drop(&mut self) {
        for side in [&self.near, &self.far] {
            ip(&["netns", "delete", &side.name]);
        }
    }
}

/// How the names of the tests' namespaces begin; the test process's id follows.
const PREFIX: &str = "hapticd-test-";

/// Delete the namespaces of test processes that no longer run (killed, they never dropped
/// their pairs); another test run's live namespaces stay.
fn delete_orphans() {
    let Ok(entries) = std::fs::read_dir("/run/netns") else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = name
            .strip_prefix(PREFIX)
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if !std::path::Path::new(&format!("/proc/{pid}")).exists() {
            ip(&["netns", "delete", &name]);
        }
    }
}

/// `ip ARGS` succeeded (iproute2, installed by `make check`).
fn ip(args: &[&str]) -> bool {
    Command::new("ip")
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}
