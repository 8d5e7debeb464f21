//! A private system-like bus: a real `dbus-daemon` with the system bus's default policy and
//! a hapticd policy file, on a socket in a test's directory.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The name hapticd owns.
pub const NAME: &str = "org.hapticd.Hapticd1";
/// The name hapticd-render owns.
pub const RENDERER: &str = "org.hapticd.Renderer1";

/// A running `dbus-daemon`, stopped (and its directory removed) when dropped.
pub struct PrivateBus {
    dir: PathBuf,
    /// Its D-Bus address.
    pub address: String,
    daemon: Child,
}

impl PrivateBus {
    /// A bus whose socket and configuration live in `dir`, applying the hapticd `policy`.
    pub fn start(dir: &Path, policy: &Path) -> PrivateBus {
        Self::with_policies(dir, &[policy])
    }

    /// A bus whose socket and configuration live in `dir`, applying `policies`.
    pub fn with_policies(dir: &Path, policies: &[&Path]) -> PrivateBus {
        let socket = dir.join("bus");
        // Running as an ordinary user, the tests stand in for root in the policy.
        let me = if nix::unistd::geteuid().is_root() {
            String::new()
        } else {
            format!(
                r#"<policy user="{}"><allow own="{NAME}"/><allow send_destination="{NAME}"/><allow own="{RENDERER}"/></policy>"#,
                nix::unistd::geteuid()
            )
        };
        let config = format!(
            r#"<!DOCTYPE busconfig PUBLIC "-//freedesktop//DTD D-BUS Bus Configuration 1.0//EN"
 "http://www.freedesktop.org/standards/dbus/1.0/busconfig.dtd">
<busconfig>
  <listen>unix:path={socket}</listen>
  <auth>EXTERNAL</auth>
  <policy context="default">
    <allow user="*"/>
    <deny own="*"/>
    <deny send_type="method_call"/>
    <allow send_type="signal"/>
    <allow send_requested_reply="true" send_type="method_return"/>
    <allow send_requested_reply="true" send_type="error"/>
    <allow receive_type="method_call"/>
    <allow receive_type="method_return"/>
    <allow receive_type="error"/>
    <allow receive_type="signal"/>
    <allow send_destination="org.freedesktop.DBus" send_interface="org.freedesktop.DBus"/>
    <allow send_destination="org.freedesktop.DBus" send_interface="org.freedesktop.DBus.Introspectable"/>
  </policy>
  {policies}
  {me}
</busconfig>
"#,
            socket = socket.display(),
            policies = policies
                .iter()
                .map(|p| format!("<include>{}</include>", p.display()))
                .collect::<String>(),
        );
        let file = dir.join("bus.conf");
        std::fs::write(&file, config).unwrap();
        // It carries every test client's messages: off the haptic CPU, as a test's load.
        let daemon = super::haptic_cpu::keep_off(&mut Command::new("dbus-daemon"))
            .arg(format!("--config-file={}", file.display()))
            .arg("--nofork")
            .stdout(Stdio::null())
            .spawn()
            .expect("dbus-daemon (package dbus-daemon) is installed by `make check`");
        let started = Instant::now();
        while !socket.exists() {
            assert!(started.elapsed() < Duration::from_secs(10), "no bus socket");
            std::thread::sleep(Duration::from_millis(20));
        }
        PrivateBus {
            dir: dir.to_path_buf(),
            address: format!("unix:path={}", socket.display()),
            daemon,
        }
    }
}

impl Drop for PrivateBus {
    fn drop(&mut self) {
        let _ = self.daemon.kill();
        let _ = self.daemon.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The picture a `busctl --json=short call … Snapshot …` printed (its `ay` reply, a PNG).
pub fn snapshot_of_busctl_json(stdout: &[u8]) -> Result<hapticd_render::picture::Picture, String> {
    let reply: serde_json::Value =
        serde_json::from_slice(stdout).map_err(|e| format!("not busctl's JSON: {e}"))?;
    let bytes: Vec<u8> = reply["data"][0]
        .as_array()
        .ok_or("no byte array in the reply")?
        .iter()
        .map(|b| b.as_u64().unwrap_or_default() as u8)
        .collect();
    hapticd_render::picture::Picture::from_png(&bytes).map_err(|e| e.to_string())
}
