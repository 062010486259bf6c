//! The CPU time of one render's own threads, readable from any thread.
//!
//! Renders side by side in one process share the cores as the scheduler
//! decides, and it does not decide evenly: with three one-thread renders on
//! two cores, the same render's thread waited 18–24 s of 60 s in the run
//! queue depending on where it was placed, not on what it did (session 35,
//! `/proc/PID/task/TID/schedstat`; it blocked 4 times in that minute). The
//! process's CPU clock counts every render of the process. Each pool thread
//! has its own CPU clock (`pthread_getcpuclockid`), which any thread can
//! read while the pool lives, so a render can measure exactly its own CPU
//! time, and can even run on it ([`crate::pacing::TimeBase::Cpu`]).

/// The CPU clocks of a rayon pool's threads. Valid while the pool lives: a
/// render owns its pool for the whole run.
#[derive(Clone, Debug)]
pub struct PoolCpuClock {
    clocks: Vec<libc::clockid_t>,
}

impl PoolCpuClock {
    /// The clocks of every thread of `pool`, or why they cannot be read.
    pub fn of(pool: &rayon::ThreadPool) -> Result<Self, String> {
        let clocks = pool
            .broadcast(|_| {
                let mut id: libc::clockid_t = 0;
                // SAFETY: `pthread_self` is this live thread, and `id` is a
                // valid clockid_t for the call to fill in.
                let rc = unsafe { libc::pthread_getcpuclockid(libc::pthread_self(), &mut id) };
                (rc == 0).then_some(id).ok_or(rc)
            })
            .into_iter()
            .collect::<Result<Vec<_>, _>>()
            .map_err(|rc| format!("cannot find a render thread's CPU clock (error {rc})"))?;
        let clock = PoolCpuClock { clocks };
        match clock.total_seconds() {
            Some(_) => Ok(clock),
            None => Err("cannot read a render thread's CPU clock".into()),
        }
    }

    pub fn threads(&self) -> usize {
        self.clocks.len()
    }

    /// CPU seconds the pool's threads have consumed so far, summed, or
    /// `None` when any clock cannot be read.
    pub fn total_seconds(&self) -> Option<f64> {
        self.thread_seconds().map(|t| t.iter().sum())
    }

    /// Each thread's CPU seconds so far, in the pool's thread order, or
    /// `None` when any clock cannot be read.
    pub fn thread_seconds(&self) -> Option<Vec<f64>> {
        self.clocks.iter().map(|&id| read_clock(id)).collect()
    }
}

/// Works until the calling thread has used `seconds` of CPU (on a loaded
/// machine that takes longer in wall time): a known amount of CPU for tests.
#[cfg(test)]
pub(crate) fn spin_cpu(seconds: f64) -> f64 {
    let own = || read_clock(libc::CLOCK_THREAD_CPUTIME_ID).unwrap();
    let t0 = own();
    let mut x = 1.0f64;
    while own() - t0 < seconds {
        for _ in 0..1000 {
            x = std::hint::black_box((x * 1.000001).sqrt() + 1e-9);
        }
    }
    x
}

fn read_clock(id: libc::clockid_t) -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec for the call to fill in; an invalid
    // or stale id makes the call fail, which is reported.
    if unsafe { libc::clock_gettime(id, &mut ts) } != 0 {
        return None;
    }
    Some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The clock counts the work of the pool's threads, read from outside
    /// the pool, and not the work of a thread outside it.
    #[test]
    fn counts_its_pool_threads_and_nothing_else() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let clock = PoolCpuClock::of(&pool).unwrap();
        assert_eq!(clock.threads(), 2);
        let before = clock.total_seconds().unwrap();
        // The calling thread works hard: none of it may show.
        std::hint::black_box(spin_cpu(0.2));
        let idle = clock.total_seconds().unwrap() - before;
        assert!(idle < 0.1, "the pool idled but its clock moved {idle} s");
        // Both pool threads use 0.15 s of CPU each.
        pool.broadcast(|_| spin_cpu(0.15));
        let busy = clock.total_seconds().unwrap() - before;
        assert!(
            (0.3..0.45).contains(&busy),
            "two threads used 0.15 s each, clock moved {busy} s"
        );
    }
}
