//! `hapticctl mesh` as a user runs it: a shipped mesh inspected, cut into pieces kept where
//! scenes find them, and files it cannot take refused with why.

use crate::support;

use std::path::Path;
use std::process::Output;

use serde_json::Value;
use support::{hapticctl, repo_dir, scratch_root};

fn run(args: &[&str]) -> Output {
    hapticctl().args(args).output().expect("hapticctl runs")
}

fn json(args: &[&str]) -> Value {
    let out = run(args);
    assert!(out.status.success(), "{args:?}: {out:?}");
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn a_mesh_is_inspected_cut_and_its_pieces_kept_where_scenes_find_them() {
    let cache = scratch_root().join(format!("mesh-cli-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&cache);
    let bracket = repo_dir().join("config/scenes/meshes/bracket.obj");
    let (file, dir) = (bracket.to_str().unwrap(), cache.to_str().unwrap());
    let before = json(&["mesh", "inspect", file, "--cache", dir, "--json"]);
    assert_eq!(before["triangles"], 256);
    assert_eq!(before["closed"], true);
    assert_eq!(before["pieces"], Value::Null);
    // The plate 50 × 50 × 6 mm less its hole of 8 mm radius, drawn as a 32-gon (a regular
    // polygon of area n/2·r²·sin(2π/n)).
    let hole = 16.0 * 0.008f64.powi(2) * (std::f64::consts::TAU / 32.0).sin();
    let volume = (0.05 * 0.05 - hole) * 0.006;
    let measured = before["volume"].as_f64().unwrap();
    assert!(
        (measured / volume - 1.0).abs() < 1e-9,
        "{measured} vs {volume}"
    );
    let cut = json(&["mesh", "decompose", file, "--cache", dir, "--json"]);
    let pieces = cut["pieces"].as_u64().unwrap();
    assert!(
        pieces >= 2,
        "a plate with a hole is no convex piece: {pieces}"
    );
    assert!(cut["pieces_volume"].as_f64().unwrap() >= measured);
    assert!(Path::new(cut["kept"].as_str().unwrap()).starts_with(&cache));
    let after = json(&["mesh", "inspect", file, "--cache", dir, "--json"]);
    assert_eq!(after["pieces"].as_u64(), Some(pieces));
    // Another resolution or scale is not what scenes read: nothing kept.
    let finer = json(&[
        "mesh",
        "decompose",
        file,
        "--cache",
        dir,
        "--resolution",
        "32",
        "--json",
    ]);
    assert_eq!(finer["kept"], Value::Null);
    std::fs::remove_dir_all(&cache).unwrap();
}

#[test]
fn files_a_body_cannot_be_made_of_are_refused_with_why() {
    let dir = scratch_root().join(format!("mesh-cli-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let open = dir.join("open.obj");
    std::fs::write(&open, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let inward = dir.join("inward.obj");
    std::fs::write(
        &inward,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 4 3\n",
    )
    .unwrap();
    let missing = dir.join("missing.obj");
    std::fs::write(&missing, "v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap();
    for (file, expected) in [
        (&open, "the surface is not closed"),
        (&inward, "its faces point inwards"),
        (&missing, "face vertex index out of bounds"),
    ] {
        let out = run(&["mesh", "decompose", file.to_str().unwrap()]);
        let said = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && said.contains(expected),
            "{file:?}: {said}"
        );
    }
    let out = run(&["mesh", "inspect", open.to_str().unwrap()]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("closed: no (3 open edges"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// V-HACD (parry3d 0.31) fails on the shipped mug at 161 voxels, in the hull of a part it
/// clipped: the mug is refused with why, the command ends as any refusal does (not as a
/// crash) and nothing is kept. The daemon and the scene plugins cut through the same
/// function.
#[test]
fn a_mesh_the_decomposition_fails_on_is_refused_with_why() {
    let cache = scratch_root().join(format!("mesh-cli-uncut-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&cache);
    let mug = repo_dir().join("config/scenes/meshes/mug.obj");
    let out = run(&[
        "mesh",
        "decompose",
        mug.to_str().unwrap(),
        "--resolution",
        "161",
        "--cache",
        cache.to_str().unwrap(),
    ]);
    let said = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert!(
        said.contains("mug.obj: V-HACD failed to cut it into convex pieces at 161 voxels"),
        "{said}"
    );
    assert!(!cache.join("meshes").exists());
}

/// Public models as a new user tries them: Khronos' cube (turned by its root node, its
/// corners split for texturing, its buffer beside the `.gltf` named from the file's own
/// directory) is one closed convex solid of the cube's exact mass and inertia at a density,
/// cut into one piece of its own volume (V-HACD made 9 pieces of +26 %); assimp's recursive
/// node graph is refused by name; the bunny is closed but not convex.
#[test]
fn public_models_are_inspected_as_solids_with_their_mass_and_inertia() {
    let corpus = repo_dir().join("tests/corpus");
    let cache = scratch_root().join(format!("mesh-cli-corpus-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&cache);
    let dir = cache.to_str().unwrap();
    for cube in ["BoxTextured.glb", "BoxTextured.gltf"] {
        // Given by its bare name, from its own directory, as a user in that directory would.
        let out = hapticctl()
            .current_dir(&corpus)
            .args(["mesh", "inspect", cube, "--density", "1000", "--json"])
            .output()
            .unwrap();
        assert!(out.status.success(), "{cube}: {out:?}");
        let seen: Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(
            (seen["closed"].clone(), seen["convex"].clone()),
            (true.into(), true.into())
        );
        // The unit cube at 1000 kg/m³: 1000 kg, and m·(1² + 1²)/12 about each axis.
        assert!(
            (seen["mass"].as_f64().unwrap() - 1000.0).abs() < 1e-9,
            "{seen}"
        );
        let inertia = &seen["body_inertia"];
        for k in 0..3 {
            let moment = inertia[k][k].as_f64().unwrap();
            assert!(
                (moment - 1000.0 * 2.0 / 12.0).abs() < 1e-9,
                "{cube}: {inertia}"
            );
        }
        let file = corpus.join(cube);
        let cut = json(&[
            "mesh",
            "decompose",
            file.to_str().unwrap(),
            "--cache",
            dir,
            "--json",
        ]);
        assert_eq!(cut["pieces"], 1, "{cube}: {cut}");
        assert!(
            (cut["pieces_volume"].as_f64().unwrap() - 1.0).abs() < 1e-12,
            "{cut}"
        );
    }
    let refused = run(&[
        "mesh",
        "inspect",
        corpus.join("RecursiveNodes.gltf").to_str().unwrap(),
    ]);
    assert!(!refused.status.success());
    assert!(
        String::from_utf8_lossy(&refused.stderr).contains("node 0 is its own ancestor"),
        "{refused:?}"
    );
    let bunny = json(&[
        "mesh",
        "inspect",
        corpus.join("bunny.obj").to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(
        (bunny["closed"].clone(), bunny["convex"].clone()),
        (true.into(), false.into())
    );
    for open in [
        "Wuson.stl",
        "Spider_binary.stl",
        "sphereWithHole.stl",
        "teapot.obj",
    ] {
        let seen = json(&[
            "mesh",
            "inspect",
            corpus.join(open).to_str().unwrap(),
            "--json",
        ]);
        assert_eq!(seen["closed"], false, "{open}");
    }
    std::fs::remove_dir_all(&cache).unwrap();
}
