//! The workspace's layering, checked: the core links no I/O library, rapier3d stays in its
//! plugin, and no crate's modules import each other in a circle.

use crate::support;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

use support::repo_dir;

/// The packages `package` depends on to build (not to test), by name.
fn normal_dependencies(package: &str) -> BTreeSet<String> {
    let output = Command::new(env!("CARGO"))
        .current_dir(repo_dir())
        .args([
            "tree",
            "--offline",
            "--locked",
            "-e",
            "normal",
            "--prefix",
            "none",
        ])
        .args(["--format", "{p}", "-p", package])
        .output()
        .expect("cargo runs");
    let output = support::succeeded(output);
    String::from_utf8_lossy(&output.stdout)
        .lines()
        .filter_map(|line| line.split_whitespace().next())
        .map(str::to_string)
        .collect()
}

#[test]
fn the_core_links_no_io_library() {
    let core = normal_dependencies("hapticd-core");
    assert!(
        core.contains("glam"),
        "cargo tree lists dependencies: {core:?}"
    );
    let io = [
        "zbus",
        "rusb",
        "libloading",
        "clap",
        "png",
        "tracing-journald",
        "libc",
        "nix",
    ];
    let linked: Vec<_> = io.iter().filter(|c| core.contains(**c)).collect();
    assert!(linked.is_empty(), "hapticd-core links {linked:?}");
    // Physics is a library for plugins: it builds on the core alone.
    let physics = normal_dependencies("hapticd-physics");
    let linked: Vec<_> = io.iter().filter(|c| physics.contains(**c)).collect();
    assert!(linked.is_empty(), "hapticd-physics links {linked:?}");
}

/// The wire contract is all a client needs: the renderer links it, not the daemon, and it
/// links nothing of the daemon (no plugin loader, no physics) itself.
#[test]
fn the_renderer_and_clients_talk_to_hapticd_through_the_wire_contract_alone() {
    let renderer = normal_dependencies("hapticd-render-service");
    assert!(renderer.contains("hapticd-ipc"), "{renderer:?}");
    assert!(
        !renderer.contains("hapticd"),
        "the renderer links the daemon"
    );
    let ipc = normal_dependencies("hapticd-ipc");
    for daemon_only in [
        "hapticd",
        "hapticd-device",
        "hapticd-physics",
        "libloading",
        "clap",
    ] {
        assert!(
            !ipc.contains(daemon_only),
            "hapticd-ipc links {daemon_only}"
        );
    }
}

/// The network stays out of the process that pulls the strings: only the bridge, the world
/// host (and hapticctl, for --remote) link Zenoh, and the bridge reaches hapticd through the
/// wire contract, like any client. The world host runs physics and no part of the daemon.
#[test]
fn only_the_bridge_links_zenoh_and_it_links_no_part_of_the_daemon() {
    for package in ["hapticd", "hapticd-core", "hapticd-ipc", "hapticd-ros2"] {
        let linked = normal_dependencies(package);
        assert!(!linked.contains("zenoh"), "{package} links zenoh");
    }
    let bridge = normal_dependencies("hapticd-zenoh");
    assert!(
        bridge.contains("zenoh") && bridge.contains("hapticd-ipc"),
        "{bridge:?}"
    );
    for daemon_only in [
        "hapticd",
        "hapticd-device",
        "hapticd-physics",
        "hapticd-mesh",
    ] {
        assert!(
            !bridge.contains(daemon_only),
            "hapticd-zenoh links {daemon_only}"
        );
    }
    let world = normal_dependencies("hapticd-world");
    assert!(
        world.contains("zenoh") && world.contains("hapticd-rapier"),
        "{world:?}"
    );
    for daemon_only in ["hapticd", "hapticd-device"] {
        assert!(
            !world.contains(daemon_only),
            "hapticd-world links {daemon_only}"
        );
    }
}

/// The command-line client links the wire contract and the installation's description
/// (`hapticd-config`), never the daemon: not its bus service, scene loader or real-time
/// thread.
#[test]
fn hapticctl_does_not_link_the_daemon() {
    let linked = normal_dependencies("hapticctl");
    assert!(
        linked.contains("hapticd-ipc") && linked.contains("hapticd-config"),
        "{linked:?}"
    );
    assert!(!linked.contains("hapticd"), "hapticctl links the daemon");
    let config = normal_dependencies("hapticd-config");
    assert!(
        !config.contains("hapticd"),
        "hapticd-config links the daemon"
    );
}

/// Scene files belong to their plugins: the daemon reads a file's engine and nothing else,
/// and pictures come from the solids plugins publish, so neither the daemon nor the renderer
/// links the physics of any engine.
#[test]
fn the_daemon_and_the_renderer_know_no_engine() {
    for package in [
        "hapticd",
        "hapticd-render",
        "hapticd-render-service",
        "hapticd-ipc",
    ] {
        let linked = normal_dependencies(package);
        assert!(
            !linked.contains("hapticd-physics"),
            "{package} links hapticd-physics"
        );
    }
}

/// rapier3d lives in its scene plugin (and hapticctl, and the world host that steps a world
/// for other machines), loaded into the daemon only when a rapier scene runs: neither the
/// daemon nor the core the haptic thread runs links it.
#[test]
fn only_the_rapier_plugin_hapticctl_and_the_world_host_link_rapier() {
    for package in [
        "hapticd",
        "hapticd-core",
        "hapticd-physics",
        "hapticd-scene-penalty",
    ] {
        assert!(
            !normal_dependencies(package).contains("rapier3d"),
            "{package} links rapier3d"
        );
    }
    for package in ["hapticd-scene-rapier", "hapticctl", "hapticd-world"] {
        assert!(
            normal_dependencies(package).contains("rapier3d"),
            "{package}"
        );
    }
}

/// The module a source file defines, as path segments from the crate root.
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let relative = file.strip_prefix(src).expect("file under src");
    let mut segments: Vec<String> = relative
        .with_extension("")
        .iter()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    if matches!(
        segments.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        segments.pop();
    }
    segments
}

/// Every path a `use` or expression names after `crate::` or `super::` in `text`, expanded
/// from `{…}` groups, as segments from the crate root.
fn paths_named(text: &str, module: &[String]) -> Vec<Vec<String>> {
    let mut found = Vec::new();
    // In `a/b.rs` and in `a/b/mod.rs` alike (module a::b), super is `a`.
    let parent = module[..module.len().saturating_sub(1)].to_vec();
    for (anchor, base) in [("crate::", Vec::new()), ("super::", parent)] {
        let mut rest = text;
        while let Some(at) = rest.find(anchor) {
            let before = rest[..at].chars().next_back();
            rest = &rest[at + anchor.len()..];
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            expand(rest, &base, &mut found);
        }
    }
    found
}

/// Expand the path that starts `text` (after an anchor) onto `base`.
fn expand(text: &str, base: &[String], found: &mut Vec<Vec<String>>) {
    let mut path = base.to_vec();
    let mut rest = text;
    loop {
        if let Some(group) = rest.strip_prefix('{') {
            let mut depth = 1;
            let end = group
                .char_indices()
                .find(|&(_, c)| {
                    depth += match c {
                        '{' => 1,
                        '}' => -1,
                        _ => 0,
                    };
                    depth == 0
                })
                .map_or(group.len(), |(i, _)| i);
            let mut depth = 0;
            let mut start = 0;
            let inner = &group[..end];
            for (i, c) in inner.char_indices().chain([(inner.len(), ',')]) {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        expand(inner[start..i].trim(), &path, found);
                        start = i + 1;
                    }
                    _ => {}
                }
            }
            return;
        }
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if name.is_empty() || name == "self" {
            break;
        }
        rest = &rest[name.len()..];
        path.push(name);
        match rest.strip_prefix("::") {
            Some(more) => rest = more,
            None => break,
        }
    }
    found.push(path);
}

/// Source files under `dir`, leaving out the binaries' own modules.
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("readable source directory") {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            if path.file_name().is_some_and(|n| n != "bin") {
                sources(&path, out);
            }
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The edges between modules of the crate at `src`, at `depth` segments (1: top-level
/// modules), unit tests left out.
fn module_graph(src: &Path, depth: usize) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    sources(src, &mut files);
    let known: BTreeSet<Vec<String>> = files.iter().map(|f| module_of(src, f)).collect();
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in &files {
        let module = module_of(src, file);
        if module.is_empty() {
            continue;
        }
        let text = std::fs::read_to_string(file).expect("readable source");
        let code = text.split("#[cfg(test)]").next().unwrap_or_default();
        let from = module[..module.len().min(depth)].join("::");
        for path in paths_named(code, &module) {
            // The longest prefix that is a module of this crate.
            let Some(target) = (1..=path.len())
                .rev()
                .map(|n| path[..n].to_vec())
                .find(|p| known.contains(p))
            else {
                continue;
            };
            let to = target[..target.len().min(depth)].join("::");
            // A module owning its submodules is no import.
            if to != from && !to.starts_with(&format!("{from}::")) {
                edges.entry(from.clone()).or_default().insert(to);
            }
        }
    }
    edges
}

/// A circle of imports in `edges`, if there is one.
fn find_cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        stack: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(at) = stack.iter().position(|n| n == node) {
            let mut cycle = stack[at..].to_vec();
            cycle.push(node.to_string());
            return Some(cycle);
        }
        if done.contains(node) {
            return None;
        }
        stack.push(node.to_string());
        for next in edges.get(node).into_iter().flatten() {
            if let Some(cycle) = visit(next, edges, stack, done) {
                return Some(cycle);
            }
        }
        stack.pop();
        done.insert(node.to_string());
        None
    }
    let mut done = BTreeSet::new();
    edges
        .keys()
        .find_map(|n| visit(n, edges, &mut Vec::new(), &mut done))
}

/// The source roots of every crate of the workspace: each member's `src`, and each of its
/// binaries' own directory under `src/bin`.
fn crate_roots() -> Vec<PathBuf> {
    let manifest = std::fs::read_to_string(repo_dir().join("Cargo.toml")).expect("Cargo.toml");
    let members = manifest
        .split("members = [")
        .nth(1)
        .and_then(|m| m.split(']').next())
        .expect("a members list");
    let mut roots = Vec::new();
    for member in members.split(',').map(|m| m.trim().trim_matches('"')) {
        let src = repo_dir().join(member).join("src");
        if member.is_empty() || !src.is_dir() {
            continue;
        }
        if let Ok(bins) = std::fs::read_dir(src.join("bin")) {
            roots.extend(bins.flatten().map(|b| b.path()).filter(|p| p.is_dir()));
        }
        roots.push(src);
    }
    roots
}

#[test]
fn no_modules_import_each_other_in_a_circle() {
    let roots = crate_roots();
    for dir in [
        "daemon/core/src",
        "daemon/render-service/src",
        "plugins/lib/rapier/src",
    ] {
        assert!(
            roots.contains(&repo_dir().join(dir)),
            "{dir} is not looked at"
        );
    }
    for src in roots {
        for depth in [1, 2] {
            let edges = module_graph(&src, depth);
            // The core's layers import one another: a finder that sees nothing is broken.
            assert!(
                !edges.is_empty() || !src.ends_with("daemon/core/src"),
                "{}: no imports found",
                src.display()
            );
            if let Some(cycle) = find_cycle(&edges) {
                panic!(
                    "{}: modules import each other: {}",
                    src.display(),
                    cycle.join(" → ")
                );
            }
        }
    }
}

#[test]
fn the_circle_finder_finds_circles() {
    let graph = |pairs: &[(&str, &str)]| {
        let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b) in pairs {
            edges
                .entry(a.to_string())
                .or_default()
                .insert(b.to_string());
        }
        edges
    };
    assert_eq!(
        find_cycle(&graph(&[("a", "b"), ("b", "c"), ("c", "a")])),
        Some(vec!["a".into(), "b".into(), "c".into(), "a".into()])
    );
    assert_eq!(
        find_cycle(&graph(&[("a", "b"), ("b", "c"), ("a", "c")])),
        None
    );
    let module = vec!["solver".to_string(), "tension".to_string()];
    let named = paths_named(
        "use super::box_qp::{self, Matrix};\nuse crate::{kinematics::Pose, mechanism};",
        &module,
    );
    assert!(
        named.contains(&vec!["solver".into(), "box_qp".into()]),
        "{named:?}"
    );
    assert!(
        named.contains(&vec!["kinematics".into(), "Pose".into()]),
        "{named:?}"
    );
    assert!(named.contains(&vec!["mechanism".into()]), "{named:?}");
}
