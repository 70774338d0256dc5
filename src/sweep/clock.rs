//! What a case has cost so far, over all its attempts ([`CaseClock`]): its wall-clock time, and
//! its CPU time — the cost without the time its thread waited, for the other jobs of a loaded
//! machine or paused by a signal (`kill -STOP`, as benchmarks and `scripts/` do to running
//! sweeps). A case runs on one thread from start to finish (the sweep parallelizes across cases,
//! each case's solvers run sequentially), so the thread's CPU time is the case's. It is read
//! from Linux's `/proc/thread-self/schedstat` (its first field: the nanoseconds the thread has
//! run on a CPU); `None` where there is no such file, and the estimates fall back to wall time.

use std::time::Instant;

/// Seconds the calling thread has run on a CPU since it started, if the system says.
pub fn thread_cpu_seconds() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns as f64 * 1e-9)
}

/// A case's wall-clock and CPU seconds since this attempt started, plus those of earlier
/// attempts (from its saved state). The CPU time is `None` once any part of it is unknown (an
/// attempt on a system without the clock, or a saved state written before cases recorded it), so
/// that a case never reports a part of its cost as the whole.
#[derive(Debug, Clone, Copy)]
pub struct CaseClock {
    started: Instant,
    wall_before: f64,
    cpu_started: Option<f64>,
    cpu_before: Option<f64>,
}

impl CaseClock {
    /// Starts counting on the calling thread.
    pub fn start() -> CaseClock {
        CaseClock {
            started: Instant::now(),
            wall_before: 0.0,
            cpu_started: thread_cpu_seconds(),
            cpu_before: Some(0.0),
        }
    }

    /// Adds what earlier attempts took: `wall` seconds, `cpu` CPU seconds (`None`: unknown).
    pub fn continue_after(&mut self, wall: f64, cpu: Option<f64>) {
        self.wall_before = wall;
        self.cpu_before = cpu;
    }

    /// Wall-clock seconds so far, over all attempts.
    pub fn wall_seconds(&self) -> f64 {
        self.wall_before + self.started.elapsed().as_secs_f64()
    }

    /// CPU seconds so far, over all attempts; read on the thread that started the clock.
    pub fn cpu_seconds(&self) -> Option<f64> {
        Some(self.cpu_before? + (thread_cpu_seconds()? - self.cpu_started?).max(0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Work counts, a sleep does not, and one thread's CPU time never exceeds its wall time.
    /// Linux only (elsewhere the clock is `None`). Written for a loaded machine: the loop runs
    /// until the clock has counted its work (however long the other jobs make that take), and
    /// the sleep's bound holds whatever the load.
    #[test]
    fn the_clock_counts_work_and_not_waiting() {
        /// CPU seconds of work to count; the clock advances at scheduling events (a few ms).
        const WORK: f64 = 0.05;
        let Some(_) = thread_cpu_seconds() else {
            return;
        };
        let clock = CaseClock::start();
        let wall = std::time::Instant::now();
        let mut x = 1.0f64;
        while clock.cpu_seconds().unwrap() < WORK {
            for _ in 0..100_000 {
                x = std::hint::black_box(x * 1.000_000_1 + 1e-9);
            }
            assert!(
                wall.elapsed().as_secs() < 120,
                "no CPU time counted in 2 minutes"
            );
        }
        let worked = clock.cpu_seconds().unwrap();
        // a tick of slack: the clock and the wall clock are read at different instants
        assert!(
            worked <= wall.elapsed().as_secs_f64() + 0.01,
            "{worked} s of CPU in {:?}",
            wall.elapsed()
        );
        std::thread::sleep(std::time::Duration::from_millis(300));
        let slept = clock.cpu_seconds().unwrap() - worked;
        assert!(slept < 0.05, "asleep 0.3 s: {slept} s of CPU");
        assert!(
            clock.wall_seconds() >= 0.3,
            "the wall clock counts the sleep"
        );
        let mut resumed = CaseClock::start();
        resumed.continue_after(100.0, Some(10.0));
        assert!(resumed.cpu_seconds().unwrap() >= 10.0 && resumed.wall_seconds() >= 100.0);
        resumed.continue_after(100.0, None);
        assert_eq!(resumed.cpu_seconds(), None, "an unknown earlier attempt");
    }
}
