//! The signals hapticd answers: SIGTERM and SIGINT stop it (motors zeroed first), SIGHUP
//! reloads the configuration and plugins, SIGXCPU (past `LimitRTTIME=`) stops it for a
//! restart. The handlers only set flags, which the main thread reads.

use std::sync::atomic::{AtomicBool, Ordering};

/// Set by SIGTERM, SIGINT or SIGXCPU: stop.
pub static STOP: AtomicBool = AtomicBool::new(false);

/// Set by SIGXCPU: the haptic thread ran past LimitRTTIME= without sleeping.
pub static OVERTIME: AtomicBool = AtomicBool::new(false);
/// Set by SIGHUP: re-read the configuration and rescan plugins.
pub static RELOAD: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(signal: libc::c_int) {
    match signal {
        libc::SIGHUP => RELOAD.store(true, Ordering::Release),
        libc::SIGXCPU => {
            OVERTIME.store(true, Ordering::Release);
            STOP.store(true, Ordering::Release);
        }
        _ => STOP.store(true, Ordering::Release),
    }
}

/// Install the handlers of SIGTERM, SIGINT, SIGHUP and SIGXCPU.
pub fn install() -> Result<(), String> {
    use nix::sys::signal::{SaFlags, SigAction, SigHandler, SigSet, Signal, sigaction};
    let action = SigAction::new(
        SigHandler::Handler(on_signal),
        SaFlags::SA_RESTART,
        SigSet::empty(),
    );
    for signal in [
        Signal::SIGTERM,
        Signal::SIGINT,
        Signal::SIGHUP,
        Signal::SIGXCPU,
    ] {
        // SAFETY: the handler only stores to atomics, which is async-signal-safe.
        unsafe { sigaction(signal, &action) }
            .map_err(|e| format!("cannot handle {signal}: {e}"))?;
    }
    Ok(())
}
