//! The tests' own load kept off the CPU hapticd gives its haptic thread (the last one it may
//! use, `hapticd_service::cpus::Plan`), as the daemon keeps its helpers and the renderer and
//! bridge keep themselves: on a kernel without full preemption a thread inside a system call
//! on that CPU delays the haptic thread's wake-up, so a test's clients there would count
//! against the daemon what is the test's doing.

use std::os::unix::process::CommandExt;
use std::process::Command;

/// The CPUs other than the haptic one; empty on a single CPU (then nothing moves).
fn others() -> Vec<usize> {
    let allowed = hapticd_service::cpus::allowed().unwrap_or_default();
    match allowed.split_last() {
        Some((_, rest)) if !rest.is_empty() => rest.to_vec(),
        _ => Vec::new(),
    }
}

/// The calling thread kept off the haptic CPU until dropped, and with it every thread and
/// process it starts meanwhile (they inherit where it may run): start hapticd before.
pub struct KeptOff {
    allowed: Vec<usize>,
}

impl KeptOff {
    /// Move the calling thread off the haptic CPU.
    pub fn new() -> Self {
        let allowed = hapticd_service::cpus::allowed().expect("the test's CPUs");
        let others = others();
        if !others.is_empty() {
            hapticd_service::cpus::pin(0, &others).expect("the test's own CPUs");
        }
        Self { allowed }
    }
}

impl Drop for KeptOff {
    fn drop(&mut self) {
        let _ = hapticd_service::cpus::pin(0, &self.allowed);
    }
}

/// Start `command`'s process off the haptic CPU (for one started before hapticd).
pub fn keep_off(command: &mut Command) -> &mut Command {
    let others = others();
    if others.is_empty() {
        return command;
    }
    // SAFETY: between fork and exec only sched_setaffinity runs, on a set built beforehand
    // on the stack: no allocation, no lock.
    unsafe { command.pre_exec(move || hapticd_service::cpus::pin(0, &others)) }
}

/// A test's turn on the machine, held while its daemons run: shared with the other tests,
/// or alone for a test that measures a haptic loop's timing or runs loops on every CPU (a
/// second `SCHED_FIFO` loop on the measured loop's CPU would be counted against it).
pub enum Turn {
    /// Beside any number of other shared turns.
    Shared(std::sync::RwLockReadGuard<'static, ()>),
    /// With no other turn.
    Alone(std::sync::RwLockWriteGuard<'static, ()>),
}

static TURNS: std::sync::RwLock<()> = std::sync::RwLock::new(());

impl Turn {
    /// A turn beside the others.
    pub fn shared() -> Self {
        Turn::Shared(TURNS.read().unwrap_or_else(|p| p.into_inner()))
    }

    /// A turn alone, once every other has ended.
    pub fn alone() -> Self {
        Turn::Alone(TURNS.write().unwrap_or_else(|p| p.into_inner()))
    }
}
