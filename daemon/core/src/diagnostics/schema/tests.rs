use super::*;
use serde::Deserialize;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
struct Body {
    name: String,
    position: [f64; 3],
    radius: Option<f64>,
    #[serde(default)]
    fixed: bool,
    kind: Shape,
}

#[derive(Debug, Deserialize, PartialEq)]
#[serde(rename_all = "lowercase")]
enum Shape {
    Box,
    Ball,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
struct File {
    title: String,
    bodies: Vec<Body>,
}

fn mistakes(text: &str) -> Vec<String> {
    let (_, found) = parse::<File>(text, Path::new("f.yaml")).expect("recovers");
    found.iter().map(|d| d.to_string()).collect()
}

#[test]
fn every_mistake_is_reported_at_its_place_in_one_pass() {
    let text = "\
title: t
colour: red
bodies:
  - name: a
    position: [1, 2]
    kind: box
  - name: b
    position: [1, 2, x]
    fixed: maybe
    kind: cone
    radius: [1]
";
    assert_eq!(
        mistakes(text),
        [
            "f.yaml:2:1: error: colour: unknown key; the keys here are `title`, `bodies`",
            "f.yaml:5:15: error: bodies[0].position: expected a list of 3 items, found 2",
            "f.yaml:8:22: error: bodies[1].position[2]: expected a number, found `x`",
            "f.yaml:9:12: error: bodies[1].fixed: expected true or false, found `maybe`",
            "f.yaml:10:11: error: bodies[1].kind: `cone` is not one of `box`, `ball`",
            "f.yaml:11:13: error: bodies[1].radius: expected a number, found a list",
        ]
    );
}

#[test]
fn missing_keys_are_each_named_and_the_rest_still_checked() {
    let text = "\
bodies:
  - position: [0, 0, 0]
    kind: ball
  - name: b
    kind: box
    extra: 1
";
    assert_eq!(
        mistakes(text),
        [
            "f.yaml:1:1: error: title: required, but not given",
            "f.yaml:2:5: error: bodies[0].name: required, but not given",
            "f.yaml:4:5: error: bodies[1].position: required, but not given",
            "f.yaml:6:5: error: bodies[1].extra: unknown key; the keys here are `name`, \
                 `position`, `radius`, `fixed`, `kind`",
        ]
    );
}

#[test]
fn a_valid_text_reads_as_the_yaml_library_reads_it() {
    let text = "title: t\nbodies:\n  - {name: a, position: [1, .5, -2e-3], radius: .inf, \
                    kind: ball, fixed: true}\n";
    let (file, found) = parse::<File>(text, Path::new("f.yaml")).unwrap();
    assert!(found.is_empty(), "{found:?}");
    let b = &file.bodies[0];
    assert_eq!(b.position, [1.0, 0.5, -2e-3]);
    assert_eq!(b.radius, Some(f64::INFINITY));
    assert!(b.fixed);
    assert_eq!(b.kind, Shape::Ball);
}

#[test]
fn duplicate_keys_and_alias_bombs_are_caught() {
    assert_eq!(
        mistakes("title: t\ntitle: u\nbodies: []\n"),
        ["f.yaml:2:1: error: `title` is given twice; give it once"]
    );
    let mut bomb = String::from("a: &a [x, x, x, x, x, x, x, x, x, x]\n");
    for i in 0..8 {
        bomb.push_str(&format!(
            "b{i}: &b{i} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n",
            p = if i == 0 {
                "a".to_string()
            } else {
                format!("b{}", i - 1)
            }
        ));
    }
    assert!(parse::<File>(&bomb, Path::new("f.yaml")).is_none());
}
