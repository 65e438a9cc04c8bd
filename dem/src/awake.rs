//! Keeping a thread pool's workers awake between a step's parallel passes.
//!
//! A step makes three short parallel passes over the particles (kick and drift, pair
//! forces, gather and kick), each of some tens of microseconds on a few thousand
//! particles, with a little sequential work between them. A rayon worker that finds no
//! work yields about thirty times and then sleeps on a condition variable; waking it for
//! the next pass costs tens of microseconds on a virtual machine, as much as the pass's
//! share of work. On the 3000-sphere settled bed on two threads this guard made the
//! kernel 1.29× as fast (median of three; 1.03× on 30 000 spheres, whose passes are
//! longer; `docs/performance.md`).
//!
//! [`AwakeWorkers`] keeps every other worker of the current pool looking for work (one
//! stolen piece at a time, [`rayon::yield_now`]) until it is dropped, as an OpenMP
//! runtime spins before it sleeps. The workers then hold their cores for the run even
//! when idle, which a job that asked for that many threads holds anyway. Results do not
//! depend on it: which thread runs a piece never changes what the piece computes.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

use rayon::Yield;

/// While alive, the other workers of the pool it was started in poll for work instead
/// of sleeping. Start it inside `ThreadPool::install`, around a loop of steps; drop it
/// when the loop ends (the workers then go back to rayon's own idling).
#[derive(Debug)]
pub struct AwakeWorkers {
    shared: Arc<Shared>,
}

/// What the caller and the polling workers share.
#[derive(Debug, Default)]
struct Shared {
    /// Set when the guard is dropped.
    stop: AtomicBool,
    /// Workers in their polling loop now.
    polling: AtomicUsize,
}

impl AwakeWorkers {
    /// Sets the other workers of the current rayon pool polling. Outside a pool, or in
    /// a pool of one thread, there is no other worker and nothing happens.
    pub fn start() -> Self {
        let shared = Arc::new(Shared::default());
        let caller = rayon::current_thread_index();
        if let Some(caller) = caller.filter(|_| rayon::current_num_threads() > 1) {
            let shared = Arc::clone(&shared);
            rayon::spawn_broadcast(move |worker| {
                // The caller runs the loop of steps itself; its copy has nothing to do.
                if worker.index() == caller {
                    return;
                }
                shared.polling.fetch_add(1, Ordering::Relaxed);
                while !shared.stop.load(Ordering::Relaxed) {
                    if rayon::yield_now() == Some(Yield::Idle) {
                        std::thread::yield_now();
                    }
                }
                shared.polling.fetch_sub(1, Ordering::Relaxed);
            });
        }
        Self { shared }
    }
}

impl Drop for AwakeWorkers {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;
    use std::time::{Duration, Instant};

    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    }

    #[test]
    fn the_other_workers_take_part_and_the_sums_do_not_change() {
        let values: Vec<f64> = (0..100_000).map(|i| (i as f64).sqrt()).collect();
        let alone: Vec<f64> = values.chunks(512).map(|c| c.iter().sum()).collect();
        let pool = pool(3);
        let (sums, threads_seen) = pool.install(|| {
            let _awake = AwakeWorkers::start();
            let mut seen = std::collections::BTreeSet::new();
            let mut sums = Vec::new();
            for _ in 0..200 {
                let pass: Vec<(f64, usize)> = values
                    .par_chunks(512)
                    .map(|c| (c.iter().sum(), rayon::current_thread_index().unwrap()))
                    .collect();
                seen.extend(pass.iter().map(|&(_, t)| t));
                sums = pass.into_iter().map(|(s, _)| s).collect();
            }
            (sums, seen.len())
        });
        assert_eq!(sums, alone);
        assert!(threads_seen > 1, "only one worker ran the passes");
    }

    /// Waits up to 10 s for `polling` workers to be in their loop.
    fn wait_for(shared: &Shared, polling: usize) -> usize {
        let started = Instant::now();
        while shared.polling.load(Ordering::Relaxed) != polling
            && started.elapsed() < Duration::from_secs(10)
        {
            std::thread::sleep(Duration::from_millis(1));
        }
        shared.polling.load(Ordering::Relaxed)
    }

    #[test]
    fn the_other_workers_poll_until_it_is_dropped() {
        let pool = pool(3);
        let awake = pool.install(AwakeWorkers::start);
        let shared = Arc::clone(&awake.shared);
        assert_eq!(
            wait_for(&shared, 2),
            2,
            "the other two workers never polled"
        );
        drop(awake);
        assert_eq!(wait_for(&shared, 0), 0, "a worker is still polling");
        // The pool is free for other work.
        assert_eq!(
            pool.install(|| (0..1000).into_par_iter().sum::<i32>()),
            499_500
        );
    }

    #[test]
    fn outside_a_pool_or_on_one_thread_no_worker_is_asked_to_poll() {
        // Nothing but the guard holds the shared state: no worker was given a share.
        assert_eq!(Arc::strong_count(&AwakeWorkers::start().shared), 1);
        let one = pool(1).install(AwakeWorkers::start);
        assert_eq!(Arc::strong_count(&one.shared), 1);
    }
}
