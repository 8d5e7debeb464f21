//! hapticd as a running service: its D-Bus interfaces on a private `dbus-daemon`, the process
//! as its unit starts it, hostile input on every path, the bus fuzzed, and USB through
//! umockdev.

#[path = "../support/mod.rs"]
mod support;

mod dbus_service;
mod hapticd_process;
mod bad_input;
mod fuzz_bus;
mod usb_umockdev;
