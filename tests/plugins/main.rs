//! Plugins loaded as the daemon loads them, and every parser fuzzed.

#[path = "../support/mod.rs"]
mod support;

mod fuzz_parsers;
mod plugin_loading;
