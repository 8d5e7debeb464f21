//! A few threads of its own for the service's blocking work (waiting for the haptic loop,
//! writing state files), awaited without blocking the bus.
//!
//! A general pool would start a thread for each request waiting at once; under
//! `mlockall(MCL_FUTURE)` every new thread's stack is locked and zeroed on the spot, and a
//! burst of a hundred clients doing that was enough to make the haptic thread overrun.

use std::sync::mpsc;
use std::sync::{Arc, Mutex, PoisonError};

use zruntime::Event;

/// Threads that run the work.
const THREADS: usize = 4;
/// Stack of each: the work is shallow (checks, JSON, file system calls), but building a
/// multi-rate scene moves its renderer (tens of kilobytes of plane sets and local bodies)
/// through several frames, more of them in a debug build.
const STACK: usize = 2 * 1024 * 1024;

type Job = Box<dyn FnOnce() + Send>;

/// The worker threads; they end when this is dropped.
pub struct Workers {
    jobs: Mutex<mpsc::Sender<Job>>,
}

impl Workers {
    /// Start the threads.
    pub fn start() -> std::io::Result<Self> {
        let (jobs, queue) = mpsc::channel::<Job>();
        let queue = Arc::new(Mutex::new(queue));
        for k in 0..THREADS {
            let queue = queue.clone();
            std::thread::Builder::new()
                .name(format!("hapticd-work-{k}"))
                .stack_size(STACK)
                .spawn(move || {
                    loop {
                        // Hold the queue only to take a job, not while running it.
                        let job = queue.lock().unwrap_or_else(PoisonError::into_inner).recv();
                        match job {
                            Ok(job) => job(),
                            Err(_) => return,
                        }
                    }
                })?;
        }
        Ok(Self {
            jobs: Mutex::new(jobs),
        })
    }

    /// Run `work` on a worker thread and wait for its result without blocking the caller's
    /// thread.
    pub async fn run<T: Send + 'static>(&self, work: impl FnOnce() -> T + Send + 'static) -> T {
        let done = Arc::new((Mutex::new(None), Event::new()));
        let slot = done.clone();
        let job: Job = Box::new(move || {
            *slot.0.lock().unwrap_or_else(PoisonError::into_inner) = Some(work());
            slot.1.notify(usize::MAX);
        });
        self.jobs
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .send(job)
            .expect("the worker threads live as long as the service");
        loop {
            let listener = done.1.listen();
            if let Some(result) = done.0.lock().unwrap_or_else(PoisonError::into_inner).take() {
                return result;
            }
            listener.await;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_runs_on_the_workers_and_its_results_come_back() {
        let workers = Workers::start().unwrap();
        let caller = std::thread::current().id();
        let results = zbus::block_on(async {
            let mut results = Vec::new();
            for k in 0..10u64 {
                let ran_on = workers
                    .run(move || (k * k, std::thread::current().id()))
                    .await;
                assert_ne!(ran_on.1, caller);
                results.push(ran_on.0);
            }
            results
        });
        assert_eq!(results, (0..10u64).map(|k| k * k).collect::<Vec<_>>());
    }
}
