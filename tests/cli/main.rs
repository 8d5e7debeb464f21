//! hapticctl's offline commands and the renderer: mechanisms, scenes, pictures against their
//! goldens, and the renderer's limits.

#[path = "../support/mod.rs"]
mod support;

mod mechanism_cli;
mod mesh_cli;
mod render_cli;
mod render_limits;
mod scene_cli;
