//! The one clock of the daemon: CLOCK_MONOTONIC in nanoseconds, and absolute sleeps on it.
//! The haptic thread, the physics threads of multi-rate scenes and the plugins' host clock
//! all read it, so their timestamps compare.

/// [any] CLOCK_MONOTONIC in nanoseconds (the vDSO: no system call, no allocation).
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec to a valid pointer.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// [rt] Sleep until CLOCK_MONOTONIC reaches `deadline_ns`, through any signal.
pub fn sleep_until(deadline_ns: u64) {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    loop {
        // SAFETY: ts is a valid timespec; no remainder is needed for an absolute sleep.
        let r = unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                std::ptr::null_mut(),
            )
        };
        if r != libc::EINTR {
            return;
        }
    }
}
