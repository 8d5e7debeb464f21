//! hapticd's renderer: scenes drawn offscreen with Vulkan (`ash`), on any device, the CPU's
//! too (Mesa's lavapipe), and read back as RGBA pixels.
//!
//! - [`mesh`]: triangles of the things drawn (boxes, balls, convex polyhedra, a striped
//!   floor), each vertex with its normal and colour;
//! - [`camera`]: where the picture is taken from;
//! - [`light`]: the light, and its view of the scene for shadows;
//! - [`font`]: a small bitmap font, for text written into pictures;
//! - [`caption`]: a line of that text on a picture;
//! - [`vulkan`]: the device, the pipeline, and one frame drawn and read back;
//! - [`picture`]: the frame's pixels and its PNG file;
//! - [`scenery`]: what a scene, a mechanism and the pointers look like, as meshes;
//! - [`shading`]: a mesh's curved surfaces drawn smooth, its edges sharp;
//! - [`smoothing`]: edges smoothed as a picture is read back.
//!
//! Positions are projected on the host, for the camera and for the light (a frame holds a
//! few thousand vertices), so the pipelines need no uniforms: their one resource is the
//! shadow map. The shaders are WGSL compiled to
//! SPIR-V by naga at build time.

pub mod camera;
pub mod caption;
pub mod font;
pub mod light;
pub mod mesh;
pub mod picture;
pub mod scenery;
pub mod shading;
pub mod smoothing;
pub mod vulkan;
