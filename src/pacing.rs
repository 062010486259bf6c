//! The clock, the snapshots and the size of render calls of one run: what
//! makes runs of different methods comparable at equal time.

use crate::cpu_clock::PoolCpuClock;
use crate::film::image::Image;
use std::cell::{Cell, RefCell};
use std::time::Instant;

/// What a run's budget, snapshot times and training schedule are measured in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TimeBase {
    /// Wall-clock seconds: what a user waits for.
    #[default]
    Wall,
    /// The render's own CPU seconds, as the wall time it would take with
    /// its cores to itself: work spread over the pool's threads at its
    /// per-thread mean, work between them at its busiest thread's time.
    /// Side by side with other renders it does not depend on how the
    /// scheduler shares the cores among them (see [`crate::cpu_clock`]).
    Cpu,
}

/// The run's clock, in its time base, which can leave out time spent on
/// bookkeeping (snapshots), so taking snapshots does not change what a
/// run's timings mean. It also keeps wall time, which every run reports.
#[derive(Clone, Debug)]
pub struct RenderClock {
    wall_start: Instant,
    wall_excluded: f64,
    cpu: Option<CpuSeconds>,
    excluded: f64,
}

/// A pool's CPU time since the run started, counted as the wall time the
/// run would have taken with its cores to itself, and not as the scheduler
/// happened to share them.
///
/// Work spread over the pool's threads (a render call, marked by
/// [`RenderClock::parallel`]) is charged at its per-thread mean: a thread
/// that waits in the run queue lets the others take its share, and the
/// mean is the same however the work was shared. Everything else (tree
/// refinement, the combination of iterations, the trial's decisions) runs
/// on one thread while the others idle, or in short parallel steps, so each
/// interval between reads is charged at its busiest thread's CPU time,
/// which is the per-thread mean for evenly shared work. With one thread
/// both are the same; with N, a per-thread mean alone charged
/// single-threaded work at 1/N, a discount that methods with more of it
/// (the guided ones) got and path tracing did not.
///
/// Inside render calls the busiest thread would measure how the work
/// happened to be shared, not how much there was: a thread descheduled
/// for another process's sake hands its share to the others.
///
/// A clock that stops reading (it cannot while the pool lives) advances
/// with wall time from its last reading instead, so a deadline is still
/// reached, and the failed reads are counted.
#[derive(Clone, Debug)]
struct CpuSeconds {
    clock: PoolCpuClock,
    /// Each thread's CPU seconds at the last successful read.
    threads_last: RefCell<Vec<f64>>,
    /// Seconds charged by successful reads.
    charged: Cell<f64>,
    /// Of those, seconds charged beyond the per-thread mean.
    serial: Cell<f64>,
    /// Inside [`RenderClock::parallel`].
    parallel: Cell<bool>,
    /// The clock's last value (monotone across failed reads) and when.
    last: Cell<(f64, Instant)>,
    failed_reads: Cell<u64>,
}

impl CpuSeconds {
    fn new(clock: PoolCpuClock) -> Result<Self, String> {
        let start = clock
            .thread_seconds()
            .ok_or("cannot read a render thread's CPU clock")?;
        Ok(CpuSeconds {
            clock,
            threads_last: RefCell::new(start),
            charged: Cell::new(0.0),
            serial: Cell::new(0.0),
            parallel: Cell::new(false),
            last: Cell::new((0.0, Instant::now())),
            failed_reads: Cell::new(0),
        })
    }

    fn read(&self) -> f64 {
        let (last, at) = self.last.get();
        let now = match self.clock.thread_seconds() {
            Some(threads) => {
                let mut before = self.threads_last.borrow_mut();
                let delta = |i: usize| (threads[i] - before[i]).max(0.0);
                let mean = (0..threads.len()).map(delta).sum::<f64>() / threads.len() as f64;
                let charge = match self.parallel.get() {
                    true => mean,
                    false => (0..threads.len()).map(delta).fold(mean, f64::max),
                };
                self.charged.set(self.charged.get() + charge);
                self.serial.set(self.serial.get() + (charge - mean));
                *before = threads;
                self.charged.get()
            }
            None => {
                self.failed_reads.set(self.failed_reads.get() + 1);
                last + at.elapsed().as_secs_f64()
            }
        };
        // Monotone even across a failed read.
        let now = now.max(last);
        self.last.set((now, Instant::now()));
        now
    }
}

impl RenderClock {
    /// A wall clock, started now.
    pub fn start() -> Self {
        RenderClock {
            wall_start: Instant::now(),
            wall_excluded: 0.0,
            cpu: None,
            excluded: 0.0,
        }
    }

    /// A clock on the CPU time of the pool whose threads `cpu` reads (per
    /// thread), started now. The pool must run the whole render.
    pub fn on_cpu(cpu: PoolCpuClock) -> Result<Self, String> {
        Ok(RenderClock {
            cpu: Some(CpuSeconds::new(cpu)?),
            ..RenderClock::start()
        })
    }

    pub fn base(&self) -> TimeBase {
        match self.cpu {
            Some(_) => TimeBase::Cpu,
            None => TimeBase::Wall,
        }
    }

    /// Seconds of rendering so far, in the clock's time base.
    pub fn seconds(&self) -> f64 {
        match &self.cpu {
            Some(cpu) => cpu.read() - self.excluded,
            None => self.wall_seconds(),
        }
    }

    /// Wall-clock seconds of rendering so far, whatever the time base.
    pub fn wall_seconds(&self) -> f64 {
        self.wall_start.elapsed().as_secs_f64() - self.wall_excluded
    }

    /// Reads of a CPU clock that failed (each advanced it by wall time).
    pub fn failed_reads(&self) -> u64 {
        self.cpu.as_ref().map_or(0, |c| c.failed_reads.get())
    }

    /// Runs `f`, work spread over every thread of the pool, charging it at
    /// its per-thread mean (see [`CpuSeconds`]). Outside such sections the
    /// CPU clock charges each interval at its busiest thread's time.
    pub fn parallel<T>(&self, f: impl FnOnce() -> T) -> T {
        let Some(cpu) = &self.cpu else { return f() };
        cpu.read();
        cpu.parallel.set(true);
        let out = f();
        cpu.read();
        cpu.parallel.set(false);
        out
    }

    /// CPU seconds the clock charged beyond its pool's per-thread mean:
    /// single-threaded work outside render calls, charged in full (0 on
    /// the wall clock and with one thread).
    pub fn serial_seconds(&self) -> f64 {
        self.cpu.as_ref().map_or(0.0, |c| c.serial.get())
    }

    /// Runs `f` without charging its time to the render.
    pub fn excluding<T>(&mut self, f: impl FnOnce() -> T) -> T {
        let (t0, wall0) = (self.seconds(), Instant::now());
        let serial0 = self.serial_seconds();
        let out = f();
        self.wall_excluded += wall0.elapsed().as_secs_f64();
        if let Some(cpu) = &self.cpu {
            let spent = self.seconds() - t0;
            cpu.serial.set(serial0);
            self.excluded += spent;
        }
        out
    }
}

/// The estimate a method would return if stopped at `seconds`.
#[derive(Clone, Debug)]
pub struct Snapshot {
    pub seconds: f64,
    pub spp: u32,
    pub image: Image,
}

/// Takes snapshots at the given render times (seconds, ascending).
#[derive(Clone, Debug, Default)]
pub struct SnapshotPlan {
    pub times: Vec<f64>,
    next: usize,
    pub taken: Vec<Snapshot>,
}

impl SnapshotPlan {
    /// Snapshots at `times` (seconds, ascending).
    pub fn at(times: Vec<f64>) -> Self {
        SnapshotPlan {
            times,
            next: 0,
            taken: Vec::new(),
        }
    }

    /// Refuses times the plan cannot take in order: it waits for each
    /// time before the next, so a NaN or a time below its predecessor would
    /// hold back every snapshot after it, and their points would be lost
    /// from the error-versus-time curve.
    pub fn check_times(times: &[f64]) -> Result<(), String> {
        if let Some(t) = times.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
            return Err(format!(
                "snapshot times must be finite and non-negative, got {t}"
            ));
        }
        if let Some(w) = times.windows(2).find(|w| w[1] < w[0]) {
            return Err(format!(
                "snapshot times must be ascending, got {} after {}",
                w[1], w[0]
            ));
        }
        Ok(())
    }

    /// Roughly geometric time points from `first` to `last`, `per_doubling` per doubling.
    pub fn geometric(first: f64, last: f64, per_doubling: u32) -> Self {
        let mut times = Vec::new();
        let ratio = 2f64.powf(1.0 / per_doubling.max(1) as f64);
        let mut t = first.max(1e-3);
        while t < last {
            times.push(t);
            t *= ratio;
        }
        SnapshotPlan::at(times)
    }

    /// The next snapshot's time, if any is left.
    pub fn next_time(&self) -> Option<f64> {
        self.times.get(self.next).copied()
    }

    /// True when the clock has passed the next snapshot time.
    pub fn due(&self, seconds: f64) -> bool {
        self.next < self.times.len() && seconds >= self.times[self.next]
    }

    /// Records an estimate (taken outside the render clock by the caller).
    pub fn take(&mut self, seconds: f64, spp: u32, image: Image) {
        while self.due(seconds) {
            self.next += 1;
        }
        self.taken.push(Snapshot {
            seconds,
            spp,
            image,
        });
    }
}

/// Most passes one pixel-major call renders (so the progress bar moves).
const MAX_PASSES_PER_CALL: u64 = 16;

/// Chooses how many passes each call of `render_passes_into` renders.
///
/// A call traces each pixel's paths one after the other: their first hits
/// stay in cache, and product guiding reuses a first product lobe across a
/// pixel's paths and its neighbours' (`guiding::pixel_reuse`). But the
/// clock is read only between calls, so:
/// - a sample budget renders what is left of it;
/// - a deadline some seconds away takes about half of that time, judged by
///   the last call's seconds per pass, so the calls shrink towards it;
///   before any call has been timed, one pass;
/// - a snapshot is reached in one call: the passes that take the clock to
///   it, rounded up, so the snapshot is taken less than a pass late, at
///   its real time (the curves interpolate each run at common times).
///   Halving towards every snapshot, as towards the deadline, had cut each
///   of a comparison's 18 snapshot intervals into calls of 8, 4, 2 and 1
///   passes, and a pixel's product lobe is reused only within a call:
///   `compare` on staircase at 120 CPU s, 2 runs side by side, imaged 145
///   and 141 spp of the product before, 149 and 149 after, and 189 and
///   181 of radiance guiding before, 186 and 188 after (session 49);
/// - a timed run ends when less than half a pass is left before its
///   deadline ([`deadline_reached`](Self::deadline_reached)), so it ends
///   within half a pass of it on either side. Ending at the first pass past
///   the deadline gave a slow method up to a whole pass (9 % of a 30 s
///   living-room run) more than its budget in an equal-time comparison.
#[derive(Default)]
pub struct PassPacer {
    seconds_per_pass: Option<f64>,
}

impl PassPacer {
    /// Whether a timed run should end at `now`: its deadline has passed,
    /// or less than half a pass (at the last call's pace) is left before it.
    pub fn deadline_reached(&self, now: f64, deadline: f64) -> bool {
        now >= deadline
            || self
                .seconds_per_pass
                .is_some_and(|s| deadline - now < 0.5 * s)
    }

    /// At most `n` passes, fewer where the deadline comes within `n` passes
    /// at the known pace: about half the time left, at least one pass.
    /// Unlike [`next_call`](Self::next_call) it ignores snapshots (a late
    /// snapshot is taken at its real time) and keeps `n` while no pace is
    /// known, for calls whose size matters (the strategy trial).
    pub fn bound_by_deadline(&self, n: u64, now: f64, deadline: Option<f64>) -> u64 {
        match (deadline, self.seconds_per_pass) {
            (Some(end), Some(s)) if s > 0.0 => half_of(n, end - now, s),
            _ => n,
        }
    }

    /// Passes for a call starting at `now`, with `passes_left` of a sample
    /// budget or a `deadline`, and the snapshots still to take.
    pub fn next_call(
        &self,
        now: f64,
        passes_left: Option<u64>,
        deadline: Option<f64>,
        snapshots: &SnapshotPlan,
    ) -> u64 {
        let mut n = MAX_PASSES_PER_CALL;
        if let Some(p) = passes_left {
            n = n.min(p);
        }
        let pace = self.seconds_per_pass.filter(|&s| s > 0.0);
        if let Some(end) = deadline {
            n = match pace {
                Some(s) if end.is_finite() => half_of(n, end - now, s),
                _ => 1,
            };
        }
        if let Some(t) = snapshots.next_time() {
            n = match pace {
                Some(s) if t.is_finite() => n.min(((t - now) / s).ceil().max(1.0) as u64),
                _ => 1,
            };
        }
        n.max(1)
    }

    /// Records that a call rendered `passes` in `seconds`.
    pub fn called(&mut self, passes: u64, seconds: f64) {
        self.seconds_per_pass = Some(seconds / passes as f64);
    }
}

/// At most `n` passes, and no more than fit in half of `seconds_left` at
/// `seconds_per_pass` (at least one).
fn half_of(n: u64, seconds_left: f64, seconds_per_pass: f64) -> u64 {
    n.min((0.5 * seconds_left / seconds_per_pass).max(0.0) as u64)
        .max(1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu_clock::spin_cpu;

    /// A pool of 2 threads and a CPU clock on it.
    fn two_thread_clock() -> (rayon::ThreadPool, RenderClock) {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let clock = RenderClock::on_cpu(PoolCpuClock::of(&pool).unwrap()).unwrap();
        (pool, clock)
    }

    /// The CPU clock advances with its pool's work alone, per thread, and
    /// leaves out what runs inside `excluding`; the wall clock it keeps
    /// advances regardless.
    #[test]
    fn the_cpu_clock_counts_its_pools_work_per_thread() {
        let (pool, mut clock) = two_thread_clock();
        assert_eq!(clock.base(), TimeBase::Cpu);
        std::thread::sleep(std::time::Duration::from_millis(150));
        let idle = clock.seconds();
        assert!(idle < 0.05, "the pool idled, its clock read {idle} s");
        assert!(clock.wall_seconds() >= 0.15);
        // 0.2 s of CPU on each of 2 threads: 0.2 s per thread.
        pool.broadcast(|_| spin_cpu(0.2));
        let busy = clock.seconds();
        assert!(
            (0.2..0.27).contains(&busy),
            "{busy} s after 0.2 s per thread"
        );
        clock.excluding(|| pool.broadcast(|_| spin_cpu(0.1)));
        let after = clock.seconds();
        assert!(
            (after - busy).abs() < 0.03,
            "excluded work moved the clock from {busy} to {after} s"
        );
        assert_eq!(clock.failed_reads(), 0);
        let wall = RenderClock::start();
        assert_eq!(wall.base(), TimeBase::Wall);
        std::thread::sleep(std::time::Duration::from_millis(20));
        assert!(wall.seconds() >= 0.02);
    }

    /// Work between render calls that runs on one thread while the others
    /// idle is charged in full, not at 1/N: with two threads a per-thread
    /// mean alone charged it at half. Render calls and evenly shared work
    /// stay at their per-thread mean, and `excluding` leaves out both
    /// kinds.
    #[test]
    fn the_cpu_clock_charges_single_threaded_work_in_full() {
        let (pool, mut clock) = two_thread_clock();
        let clock = &mut clock;
        let pool = &pool;
        let moved = |clock: &RenderClock, f: &dyn Fn()| {
            let t0 = clock.seconds();
            f();
            clock.seconds() - t0
        };
        pool.install(|| {
            let call = moved(clock, &|| {
                clock.parallel(|| pool.broadcast(|_| spin_cpu(0.2)));
            });
            assert!((0.19..0.27).contains(&call), "render call: {call} s");
            assert!(clock.serial_seconds() < 0.01);
            let alone = moved(clock, &|| {
                std::hint::black_box(spin_cpu(0.2));
            });
            assert!(
                (0.19..0.27).contains(&alone),
                "0.2 s on one of 2 threads moved the clock {alone} s"
            );
            let serial = clock.serial_seconds();
            assert!((0.09..0.14).contains(&serial), "serial {serial} s");
            let shared = moved(clock, &|| {
                pool.broadcast(|_| spin_cpu(0.2));
            });
            assert!((0.19..0.3).contains(&shared), "shared work: {shared} s");
            let before = clock.seconds();
            let serial = clock.serial_seconds();
            clock.excluding(|| std::hint::black_box(spin_cpu(0.2)));
            assert!((clock.seconds() - before).abs() < 0.03);
            assert!((clock.serial_seconds() - serial).abs() < 0.03);
        });
    }

    /// Calls take what is left of a sample budget (at most 16 passes), one
    /// pass until a timed budget has a pace, then about half the time left
    /// before the deadline, and at most the passes that reach the next
    /// snapshot.
    #[test]
    fn the_pacer_takes_half_the_time_left() {
        let none = SnapshotPlan::default();
        let mut pacer = PassPacer::default();
        assert_eq!(pacer.next_call(0.0, Some(40), None, &none), 16);
        assert_eq!(pacer.next_call(0.0, Some(3), None, &none), 3);
        assert_eq!(pacer.next_call(0.0, None, Some(10.0), &none), 1);
        pacer.called(2, 0.25);
        assert_eq!(pacer.next_call(0.0, None, Some(1.0), &none), 4);
        assert_eq!(pacer.next_call(0.0, None, Some(100.0), &none), 16);
        assert_eq!(pacer.next_call(2.0, None, Some(1.0), &none), 1, "past it");
        let snapshots = SnapshotPlan {
            times: vec![0.6],
            ..Default::default()
        };
        // A snapshot 0.6 s away at 0.125 s per pass: 5 passes reach it
        // (4.8 rounded up), where halving took 2 and then 1, 1.
        assert_eq!(pacer.next_call(0.0, None, Some(10.0), &snapshots), 5);
        assert_eq!(pacer.next_call(0.0, Some(40), None, &snapshots), 5);
        assert_eq!(pacer.next_call(0.5, Some(40), None, &snapshots), 1);
        assert_eq!(pacer.next_call(0.7, Some(40), None, &snapshots), 1, "late");
        assert_eq!(
            pacer.next_call(0.0, None, Some(0.5), &snapshots),
            2,
            "the nearer deadline still halves"
        );
    }

    /// A timed run stops when less than half a pass is left (so it ends
    /// within half a pass of its deadline), and a deadline bounds a call of
    /// fixed size only once a pace is known.
    #[test]
    fn the_pacer_ends_within_half_a_pass_of_the_deadline() {
        let mut pacer = PassPacer::default();
        assert!(!pacer.deadline_reached(9.9, 10.0), "no pace yet");
        assert!(pacer.deadline_reached(10.0, 10.0));
        assert_eq!(
            pacer.bound_by_deadline(4, 9.0, Some(10.0)),
            4,
            "no pace yet"
        );
        pacer.called(1, 0.5);
        assert!(
            !pacer.deadline_reached(9.7, 10.0),
            "0.3 s left of a 0.5 s pass"
        );
        assert!(pacer.deadline_reached(9.8, 10.0), "0.2 s left");
        assert_eq!(pacer.bound_by_deadline(4, 0.0, Some(10.0)), 4);
        assert_eq!(pacer.bound_by_deadline(4, 8.0, Some(10.0)), 2);
        assert_eq!(pacer.bound_by_deadline(4, 9.7, Some(10.0)), 1);
        assert_eq!(pacer.bound_by_deadline(4, 12.0, Some(10.0)), 1, "past it");
        assert_eq!(pacer.bound_by_deadline(4, 8.0, None), 4, "sample budget");
    }
}
