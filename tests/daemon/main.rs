//! hapticd as a running service: its D-Bus interfaces on a private `dbus-daemon`, the process
//! as its unit starts it, hostile input on every path, the bus fuzzed, and USB through
//! umockdev.

#[path = "../support/mod.rs"]
mod support;

mod bad_input;
mod dbus_service;
mod fuzz_bus;
mod hapticd_process;
mod usb_umockdev;
