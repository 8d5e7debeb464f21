//! hapticd's renderer: scenes drawn offscreen with Vulkan (`ash`), on any device, the CPU's
//! too (Mesa's lavapipe), and read back as RGBA pixels.
//!
//! - [`mesh`]: triangles of the things drawn (boxes, balls, convex polyhedra, a striped
//!   floor), each vertex with its normal and colour;
//! - [`camera`]: where the picture is taken from;
//! - [`font`]: a small bitmap font, for text written into pictures;
//! - [`vulkan`]: the device, the pipeline, and one frame drawn and read back;
//! - [`picture`]: the frame's pixels and its PNG file;
//! - [`scenery`]: what a scene, a mechanism and the pointers look like, as meshes.
//!
//! Positions are projected on the host (a frame holds a few thousand vertices), so the one
//! pipeline needs neither uniforms nor descriptors; its shaders are WGSL compiled to SPIR-V
//! by naga at build time.

pub mod camera;
pub mod font;
pub mod mesh;
pub mod picture;
pub mod scenery;
pub mod vulkan;
