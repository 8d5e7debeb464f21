//! Plugins loaded as the daemon loads them, and every parser fuzzed.

#[path = "../support/mod.rs"]
mod support;

mod plugin_loading;
mod fuzz_parsers;
