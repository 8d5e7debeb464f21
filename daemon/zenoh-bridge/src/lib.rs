//! What hapticd's network programs share: the configuration file (`network.yaml`), the Zenoh
//! session built from it, and the keys a world stepped on one machine and touched from others
//! is exchanged under. The bridge (`hapticd-zenoh`) and the world host (`hapticd-world`) are
//! built on it.

pub mod config;
pub mod session;
pub mod world_keys;
