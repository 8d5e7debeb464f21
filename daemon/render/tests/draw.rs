//! Frames drawn on the machine's Vulkan device (Mesa's lavapipe in CI), checked by what
//! their pixels must show.

use glam::{DQuat, DVec3};
use hapticd_render::camera::Camera;
use hapticd_render::mesh::Mesh;
use hapticd_render::picture::Picture;
use hapticd_render::vulkan::Renderer;

const RED: [f32; 4] = [0.8, 0.1, 0.1, 1.0];
const GREY: [[f32; 4]; 2] = [[0.6, 0.6, 0.6, 1.0], [0.45, 0.45, 0.45, 1.0]];
const SKY: [f32; 4] = [1.0, 1.0, 1.0, 1.0];

fn renderer() -> Renderer {
    Renderer::new().expect("a Vulkan device (install mesa-vulkan-drivers for lavapipe)")
}

fn pixel(p: &Picture, x: u32, y: u32) -> [u8; 4] {
    let i = 4 * (y * p.width + x) as usize;
    [p.rgba[i], p.rgba[i + 1], p.rgba[i + 2], p.rgba[i + 3]]
}

/// How many pixels of the left and right halves are reddish.
fn red_halves(p: &Picture) -> (usize, usize) {
    let mut halves = (0, 0);
    for y in 0..p.height {
        for x in 0..p.width {
            let [r, g, b, _] = pixel(p, x, y);
            if r > 60 && u16::from(r) > 2 * u16::from(g.max(b)) {
                if x < p.width / 2 {
                    halves.0 += 1;
                } else {
                    halves.1 += 1;
                }
            }
        }
    }
    halves
}

/// Keep a picture where a failing test can be looked at: target/tmp/render-NAME.png.
fn save(p: &Picture, name: &str) {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let file = std::fs::File::create(dir.join(format!("render-{name}.png"))).unwrap();
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), p.width, p.height);
    encoder.set_color(png::ColorType::Rgba);
    encoder
        .write_header()
        .unwrap()
        .write_image_data(&p.rgba)
        .unwrap();
}

fn scene(block_x: f64) -> (Mesh, Mesh) {
    let mut floor = Mesh::default();
    floor.floor(DVec3::ZERO, 0.0, 0.4, 0.05, GREY);
    let mut block = Mesh::default();
    block.cuboid(
        DVec3::new(block_x, 0.02, 0.0),
        DVec3::splat(0.02),
        DQuat::IDENTITY,
        RED,
    );
    (floor, block)
}

#[test]
fn a_block_moved_to_the_left_is_drawn_on_the_left() {
    let mut r = renderer();
    let camera = Camera::orbit(DVec3::ZERO, 0.5, 0.0, 0.5);
    let mut draw = |x: f64| {
        let (floor, block) = scene(x);
        r.draw(&[&floor, &block], &camera, (320, 240), SKY).unwrap()
    };
    let (left, right) = (draw(-0.08), draw(0.08));
    assert_eq!(
        (left.width, left.height, left.rgba.len()),
        (320, 240, 320 * 240 * 4)
    );
    let (l, r_) = red_halves(&left);
    assert!(l > 200 && r_ == 0, "left block: {l} left, {r_} right");
    let (l, r_) = red_halves(&right);
    assert!(r_ > 200 && l == 0, "right block: {l} left, {r_} right");
    // The corners show the sky: nothing is drawn there.
    assert_eq!(pixel(&left, 0, 0), [255, 255, 255, 255]);
    save(&left, "left");
}

#[test]
fn a_frame_is_drawn_the_same_twice() {
    let mut r = renderer();
    let camera = Camera::orbit(DVec3::ZERO, 0.5, 0.3, 0.4);
    let (floor, block) = scene(0.0);
    let a = r.draw(&[&floor, &block], &camera, (160, 120), SKY).unwrap();
    let b = r.draw(&[&floor, &block], &camera, (160, 120), SKY).unwrap();
    assert_eq!(a, b);
    // Another size in between (the renderer keeps one frame's images), then the first again.
    let large = r.draw(&[&floor, &block], &camera, (320, 240), SKY).unwrap();
    assert_eq!(large.rgba.len(), 320 * 240 * 4);
    assert_eq!(
        r.draw(&[&floor, &block], &camera, (160, 120), SKY).unwrap(),
        a
    );
}

#[test]
fn bad_sizes_and_cameras_are_refused() {
    let mut r = renderer();
    let camera = Camera::orbit(DVec3::ZERO, 0.5, 0.0, 0.5);
    for size in [(0, 240), (320, 0), (100_000, 10)] {
        assert!(r.draw(&[], &camera, size, SKY).is_err(), "{size:?}");
    }
    let mut bad = camera;
    bad.eye.x = f64::NAN;
    assert!(r.draw(&[], &bad, (32, 32), SKY).is_err());
    let straight_down = Camera {
        eye: DVec3::new(0.0, 1.0, 0.0),
        target: DVec3::ZERO,
        fov: 0.7,
    };
    assert!(r.draw(&[], &straight_down, (32, 32), SKY).is_err());
}
