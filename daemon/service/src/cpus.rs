//! CPUs of their own for the haptic threads.
//!
//! On a kernel without full preemption (most distribution kernels), a thread that is inside a
//! system call on the haptic thread's CPU when its deadline comes delays the wake-up until the
//! call returns; the daemon's own helpers (the supervisor, loggers, the bus) wake at 10–100 Hz
//! and would do that a few times a second. So each haptic thread gets the last free CPU the
//! daemon may use, and every other thread of the daemon keeps off those CPUs, a multi-rate
//! scene's physics thread too (stepping a large world it would otherwise take the haptic
//! CPU for milliseconds at a time). With one CPU for each of several devices and none to
//! spare, each loop keeps a CPU of its own and the helpers share them; with a single CPU,
//! or more devices than CPUs, threads stay where the scheduler puts them.

use std::io;

/// The CPUs the calling thread may run on, in order.
pub fn allowed() -> io::Result<Vec<usize>> {
    // SAFETY: cpu_set_t is plain data, all-zero is the empty set.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    // SAFETY: the size and pointer describe `set`.
    if unsafe { libc::sched_getaffinity(0, std::mem::size_of_val(&set), &mut set) } != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok((0..libc::CPU_SETSIZE as usize)
        // SAFETY: cpu is below CPU_SETSIZE.
        .filter(|&cpu| unsafe { libc::CPU_ISSET(cpu, &set) })
        .collect())
}

/// Restrict thread `tid` (0: the calling thread) to `cpus`.
pub fn pin(tid: libc::pid_t, cpus: &[usize]) -> io::Result<()> {
    // SAFETY: as in `allowed`.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    for &cpu in cpus {
        // SAFETY: CPU_SET checks nothing but writes within `set` for cpu < CPU_SETSIZE,
        // which `allowed` guarantees for every CPU it lists.
        unsafe { libc::CPU_SET(cpu, &mut set) };
    }
    // SAFETY: the size and pointer describe `set`.
    if unsafe { libc::sched_setaffinity(tid, std::mem::size_of_val(&set), &set) } != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok(())
}

/// How the daemon's threads share the CPUs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Plan {
    /// The CPU of each device's haptic thread, in device order.
    pub haptic: Vec<usize>,
    /// The CPUs left to every other thread.
    pub others: Vec<usize>,
}

impl Plan {
    /// A CPU for each of `devices` haptic threads from the end of `allowed`: with at least
    /// one CPU left, the rest keep to those; with exactly one CPU for each of several
    /// devices, the rest share them (two loops on one CPU would delay each other by a
    /// whole tick, a helper only by a system call). None otherwise.
    pub fn new(allowed: &[usize], devices: usize) -> Option<Plan> {
        let split = allowed.len().checked_sub(devices)?;
        if devices == 0 || (split == 0 && devices == 1) {
            return None;
        }
        Some(Plan {
            haptic: allowed[split..].iter().rev().copied().collect(),
            others: match split {
                0 => allowed.to_vec(),
                _ => allowed[..split].to_vec(),
            },
        })
    }

    /// Whether the daemon's other threads run on the haptic threads' CPUs too.
    pub fn shared_with_others(&self) -> bool {
        self.haptic.iter().any(|cpu| self.others.contains(cpu))
    }

    /// Move every thread of this process (those started so far, and through the calling
    /// thread those started later) onto the other CPUs.
    pub fn keep_daemon_off(&self) -> io::Result<()> {
        for task in std::fs::read_dir("/proc/self/task")? {
            let tid = task?.file_name().to_string_lossy().parse().unwrap_or(0);
            if tid > 0 {
                // A thread may end between listing and pinning; that is no failure.
                match pin(tid, &self.others) {
                    Err(e) if e.raw_os_error() != Some(libc::ESRCH) => return Err(e),
                    _ => {}
                }
            }
        }
        Ok(())
    }
}

/// Move this whole process (its threads so far and, through the calling thread, those it
/// starts later) off the CPU hapticd's first haptic thread takes: for the programs that run
/// beside hapticd (the renderer, the network bridge). Nothing to do with a single CPU.
pub fn keep_off_the_haptic_cpu() -> io::Result<()> {
    match Plan::new(&allowed()?, 1) {
        Some(plan) => plan.keep_daemon_off(),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn haptic_threads_take_cpus_from_the_end_and_leave_at_least_one() {
        assert_eq!(
            Plan::new(&[0, 1], 1),
            Some(Plan {
                haptic: vec![1],
                others: vec![0]
            })
        );
        assert_eq!(
            Plan::new(&[0, 2, 3, 5], 2),
            Some(Plan {
                haptic: vec![5, 3],
                others: vec![0, 2]
            })
        );
        assert_eq!(Plan::new(&[0], 1), None);
        assert_eq!(Plan::new(&[0, 1], 0), None);
        assert_eq!(Plan::new(&[0, 1], 3), None);
        // Two loops on two CPUs: one each, the helpers beside them.
        let two = Plan::new(&[0, 1], 2).unwrap();
        assert_eq!(two.haptic, [1, 0]);
        assert!(two.shared_with_others());
        assert!(!Plan::new(&[0, 1, 2], 2).unwrap().shared_with_others());
    }

    #[test]
    fn a_thread_pinned_to_one_allowed_cpu_runs_there_only() {
        let cpus = allowed().unwrap();
        let last = *cpus.last().unwrap();
        std::thread::spawn(move || {
            pin(0, &[last]).unwrap();
            assert_eq!(allowed().unwrap(), [last]);
            // SAFETY: a pure query.
            assert_eq!(unsafe { libc::sched_getcpu() }, last as i32);
        })
        .join()
        .unwrap();
    }
}
