use super::files::O_NONBLOCK;
use super::*;

const TEXT: &str = "\
name: box
bodies:
  - shape: box
    size: [1, 2, 3]
  - { shape: sphere, radius: 0.5 }
nested:
  list:
    - - 1
      - 2
";

fn at(line: u64, column: u64) -> Option<Position> {
    Some(Position { line, column })
}

#[test]
fn paths_locate_keys_items_and_flow_collections() {
    let map = YamlMap::new(TEXT);
    assert_eq!(map.find("name"), at(1, 7));
    assert_eq!(map.find("bodies[0].size"), at(4, 11));
    assert_eq!(map.find("bodies[1].radius"), at(5, 30));
    assert_eq!(map.find("nested.list[0][1]"), at(9, 9));
    // An unknown path falls back to its nearest ancestor in the text.
    assert_eq!(map.find("bodies[1].mass"), map.find("bodies[1]"));
    assert_eq!(map.find("gravity"), None);
}

#[test]
fn findings_come_back_all_at_once_errors_first() {
    let map = YamlMap::new(TEXT);
    let locate = |f: &str| map.find(f);
    let mut f = Findings::new(Path::new("s.yaml"), &locate);
    f.warning("name", "short");
    f.error("bodies[0].size", "too big");
    f.finite("bodies[1].radius", &[f64::NAN]);
    let shown = f.finish().unwrap_err().to_string();
    let lines: Vec<_> = shown.lines().collect();
    assert_eq!(
        lines,
        [
            "s.yaml:4:11: error: bodies[0].size: too big",
            "s.yaml:5:30: error: bodies[1].radius: must be a finite number",
            "s.yaml:1:7: warning: name: short",
        ]
    );
}

#[test]
fn files_that_are_not_regular_are_refused_without_reading() {
    let e = read_text(Path::new("/dev/zero")).unwrap_err().to_string();
    assert!(e.ends_with("not a regular file"), "{e}");
    // A FIFO named like a descriptor: opening it would wait for a writer for ever.
    let fifo = std::env::temp_dir().join(format!("hapticd-fifo-{}.yaml", std::process::id()));
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|s| s.success()) {
        let e = read_text(&fifo).unwrap_err().to_string();
        std::fs::remove_file(&fifo).ok();
        assert!(e.ends_with("not a regular file"), "{e}");
    }
}

#[test]
fn files_larger_than_any_real_one_are_refused() {
    let big = std::env::temp_dir().join(format!("hapticd-big-{}.yaml", std::process::id()));
    let file = std::fs::File::create(&big).unwrap();
    file.set_len(MAX_FILE_BYTES + 1).unwrap();
    let e = read_text(&big).unwrap_err().to_string();
    std::fs::remove_file(&big).ok();
    assert!(e.contains("more than the 16777216 a file may have"), "{e}");
}

#[test]
fn opening_a_fifo_without_blocking_returns_at_once() {
    use std::os::unix::fs::OpenOptionsExt;
    let fifo = std::env::temp_dir().join(format!("hapticd-nb-{}", std::process::id()));
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        return;
    }
    // Opened blocking, this waits for a writer that never comes: the test would hang.
    let opened = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(O_NONBLOCK)
        .open(&fifo);
    std::fs::remove_file(&fifo).ok();
    assert!(opened.is_ok(), "{opened:?}");
}

#[test]
fn links_out_of_the_confining_directory_are_refused_and_links_within_it_followed() {
    let root = std::env::temp_dir().join(format!("hapticd-within-{}", std::process::id()));
    let dir = root.join("state");
    std::fs::create_dir_all(&dir).unwrap();
    let inside = dir.join("a.json");
    let outside = root.join("b.json");
    for file in [&inside, &outside] {
        std::fs::write(file, "{}").unwrap();
    }
    let rules = FileRules {
        max_bytes: 100,
        within: Some(&dir),
    };
    let near = dir.join("near.json");
    std::os::unix::fs::symlink(&inside, &near).unwrap();
    let far = dir.join("far.json");
    std::os::unix::fs::symlink(&outside, &far).unwrap();
    let (near_read, far_read) = (read_file(&near, rules), read_file(&far, rules));
    // Without confinement the same link is just a file.
    let unconfined = read_file(&far, FileRules::TEXT);
    std::fs::remove_dir_all(&root).ok();
    assert_eq!(near_read.unwrap(), b"{}");
    let e = far_read.unwrap_err();
    assert!(matches!(e.refusal, Refusal::Outside { .. }), "{e}");
    let shown = e.to_string();
    let expected = format!(
        "{}: error: a link to {}, outside ",
        far.display(),
        outside.display()
    );
    assert!(shown.starts_with(&expected), "{shown}");
    assert_eq!(unconfined.unwrap(), b"{}");
}

#[test]
fn missing_files_are_told_apart_from_refused_ones() {
    let e = read_file(Path::new("/nonexistent/hapticd"), FileRules::TEXT).unwrap_err();
    assert!(e.is_missing(), "{e}");
    let e = read_file(Path::new("/dev/zero"), FileRules::TEXT).unwrap_err();
    assert!(
        !e.is_missing() && matches!(e.refusal, Refusal::NotRegular),
        "{e}"
    );
}
