//! The CPU time of the calling thread: what a case cost, without the time its thread waited —
//! for the other jobs of a loaded machine, or paused by a signal (`kill -STOP`, as benchmarks
//! and `scripts/` do to running sweeps). A case runs on one thread from start to finish (the
//! sweep parallelizes across cases, each case's solvers run sequentially), so the thread's CPU
//! time is the case's. Read from Linux's `/proc/thread-self/schedstat` (its first field: the
//! nanoseconds the thread has run on a CPU); `None` where there is no such file, and the
//! estimates fall back to wall time.

/// Seconds the calling thread has run on a CPU since it started, if the system says.
pub fn thread_cpu_seconds() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns as f64 * 1e-9)
}

/// CPU seconds from a starting reading, plus those of earlier attempts: `None` once any part
/// is unknown (an attempt on a system without the clock, or a saved state written before cases
/// recorded it), so that a case never reports a part of its cost as the whole.
#[derive(Debug, Clone, Copy)]
pub struct CpuClock {
    before: Option<f64>,
    started: Option<f64>,
}

impl CpuClock {
    /// Starts counting on the calling thread.
    pub fn start() -> CpuClock {
        CpuClock {
            before: Some(0.0),
            started: thread_cpu_seconds(),
        }
    }

    /// Adds what earlier attempts took (`None`: unknown).
    pub fn continue_after(&mut self, earlier: Option<f64>) {
        self.before = earlier;
    }

    /// CPU seconds so far, over all attempts; read on the thread that started the clock.
    pub fn seconds(&self) -> Option<f64> {
        Some(self.before? + (thread_cpu_seconds()? - self.started?).max(0.0))
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
        let clock = CpuClock::start();
        let wall = std::time::Instant::now();
        let mut x = 1.0f64;
        while clock.seconds().unwrap() < WORK {
            for _ in 0..100_000 {
                x = std::hint::black_box(x * 1.000_000_1 + 1e-9);
            }
            assert!(
                wall.elapsed().as_secs() < 120,
                "no CPU time counted in 2 minutes"
            );
        }
        let worked = clock.seconds().unwrap();
        // a tick of slack: the clock and the wall clock are read at different instants
        assert!(
            worked <= wall.elapsed().as_secs_f64() + 0.01,
            "{worked} s of CPU in {:?}",
            wall.elapsed()
        );
        std::thread::sleep(std::time::Duration::from_millis(300));
        let slept = clock.seconds().unwrap() - worked;
        assert!(slept < 0.05, "asleep 0.3 s: {slept} s of CPU");
        let mut resumed = CpuClock::start();
        resumed.continue_after(Some(10.0));
        assert!(resumed.seconds().unwrap() >= 10.0);
        resumed.continue_after(None);
        assert_eq!(resumed.seconds(), None, "an unknown earlier attempt");
    }
}
