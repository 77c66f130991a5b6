//! The worker threads of one training run (`train --threads N`).
//!
//! Parallel work never changes a number: each task computes whole rows or whole networks with
//! exactly the instructions one thread would run, and no sum is ever split between threads, so
//! the blobs are the same bytes for any thread count (`tests/training.rs` pins 1, 2 and 3).
//!
//! Why a rayon pool of the run's own, and not `std::thread::scope`: an update has a handful of
//! parallel regions of 10–400 µs each, 587,000 times per run. Spawning a scoped thread per region
//! cost 60–75 µs on the project's 2-core machine (a throwaway program: 20,000 two-way splits of a
//! tiny task), a `ThreadPool::join` 16–22 µs under the same load (both measured with other builds
//! running; a pool's warm, spinning workers answer in a few µs on a quiet machine). The pool is
//! per run, not rayon's global one, so two trainers in one process (the tests) can use different
//! counts; with one thread there is no pool and every task runs inline on the caller.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

use rayon::prelude::*;

/// The most worker threads a run may ask for (`train --threads`). A fixed number rather than a
/// multiple of the cores, so a command line valid on one machine is valid on every machine a
/// sweep or a Slurm array sends it to; well above today's largest single machines, and far above
/// the pieces an update splits into (DCP's 64 × 17 proposal rows make 182 tiles of six), so no
/// run is slowed by it. Without it `--threads 100000` started threads one by one for over a
/// minute before failing or training.
pub const MAX_THREADS: u32 = 1024;

/// A run's worker threads: one means no pool, everything inline.
#[derive(Clone, Debug, Default)]
pub struct Workers {
    pool: Option<Arc<rayon::ThreadPool>>,
    /// The crash test's injected fault: the task that makes the count reach this panics.
    fault: Option<Arc<Fault>>,
}

#[derive(Debug)]
struct Fault {
    at: usize,
    tasks: AtomicUsize,
}

impl Workers {
    /// `threads` worker threads (at least one; 1 is the same as [`Workers::default`]).
    ///
    /// # Errors
    /// If the operating system refuses to start the threads.
    ///
    /// ```
    /// use host_trainer::nn::workers::Workers;
    /// let workers = Workers::new(3).expect("threads");
    /// assert_eq!(workers.threads(), 3);
    /// assert_eq!(Workers::new(0).expect("one thread").threads(), 1);
    /// ```
    pub fn new(threads: usize) -> Result<Workers, rayon::ThreadPoolBuildError> {
        if threads <= 1 {
            return Ok(Workers::default());
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("host-trainer-worker-{i}"))
            .build()?;
        Ok(Workers {
            pool: Some(Arc::new(pool)),
            fault: None,
        })
    }

    /// These workers, with the crash test's fault armed: the `at`-th task run through them
    /// (counted from 1, over every [`Workers::join`] half and [`Workers::for_each`] item)
    /// panics on the thread that runs it.
    ///
    /// ```
    /// use host_trainer::nn::workers::Workers;
    /// use std::panic::{catch_unwind, AssertUnwindSafe};
    /// let workers = Workers::new(2).expect("threads").with_fault_at(3);
    /// assert_eq!(workers.join(|| 1, || 2), (1, 2)); // tasks 1 and 2
    /// let caught = catch_unwind(AssertUnwindSafe(|| workers.join(|| 1, || 2)));
    /// assert!(caught.is_err());
    /// ```
    pub fn with_fault_at(mut self, at: usize) -> Workers {
        self.fault = Some(Arc::new(Fault {
            at,
            tasks: AtomicUsize::new(0),
        }));
        self
    }

    /// How many threads work (1 without a pool).
    ///
    /// ```
    /// use host_trainer::nn::workers::Workers;
    /// assert_eq!(Workers::default().threads(), 1);
    /// ```
    pub fn threads(&self) -> usize {
        self.pool
            .as_ref()
            .map_or(1, |pool| pool.current_num_threads())
    }

    /// Runs `a` and `b`, on two threads when there is a pool, and returns both results.
    ///
    /// ```
    /// use host_trainer::nn::workers::Workers;
    /// let workers = Workers::new(2).expect("threads");
    /// assert_eq!(workers.join(|| 1 + 1, || "two"), (2, "two"));
    /// ```
    pub fn join<A, B, RA, RB>(&self, a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA + Send,
        B: FnOnce() -> RB + Send,
        RA: Send,
        RB: Send,
    {
        let a = || {
            self.task_started();
            a()
        };
        let b = || {
            self.task_started();
            b()
        };
        match &self.pool {
            Some(pool) => pool.join(a, b),
            None => (a(), b()),
        }
    }

    /// Calls `f` on every item, spread over the threads when there is a pool and more than one
    /// item.
    ///
    /// ```
    /// use host_trainer::nn::workers::Workers;
    /// let mut items = vec![1, 2, 3];
    /// Workers::new(2).expect("threads").for_each(&mut items, |x| *x *= 10);
    /// assert_eq!(items, vec![10, 20, 30]);
    /// ```
    pub fn for_each<T, F>(&self, items: &mut [T], f: F)
    where
        T: Send,
        F: Fn(&mut T) + Sync + Send,
    {
        let f = |item: &mut T| {
            self.task_started();
            f(item)
        };
        match &self.pool {
            // One item runs here: `install` would hand it to a pool thread and wait, a round
            // trip that cost DDPG's update about 15 % on 2 threads (`update_threads` bench).
            Some(pool) if items.len() > 1 => pool.install(|| items.par_iter_mut().for_each(f)),
            _ => items.iter_mut().for_each(f),
        }
    }

    fn task_started(&self) {
        if let Some(fault) = &self.fault {
            if fault.tasks.fetch_add(1, Ordering::Relaxed) + 1 == fault.at {
                panic!("injected worker panic (crash test, task {})", fault.at);
            }
        }
    }
}
