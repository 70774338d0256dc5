//! The resources a task asks for, unless given: memory from the case's estimate
//! ([`crate::config::CaseSpec::memory_estimate`], measured peak memory per element), time from a
//! measured cost per element and step — the slowest of the sweep database's finished cases
//! (their core seconds / (steps × elements × step cost); core seconds are the CPU time a case
//! records, `final_json.cpu_s`, or its `wall_s` where it has none) when it has any, else the benchmark of
//! docs/performance.md — times the case's steps, elements and [`CaseSpec::step_cost`].

use crate::config::{CaseSpec, PlannedCase};
use crate::store::Store;

/// Seconds per element and step of an explicit viscoelastic step without a band: `xpflow bench
/// moving --mesh 440x110 --particles 3` took 2.457 s per step on 48 400 elements
/// (docs/performance.md, "Where issue 8 stands"; 200×50 gives 44 µs). The band factorization,
/// the default, is faster: an upper bound.
pub const BENCHMARK_SECONDS_PER_ELEMENT_STEP: f64 = 51e-6;
/// Margin on the estimated run time (machines and meshes differ from the benchmark's).
const TIME_MARGIN: f64 = 1.5;
/// Seconds added to every task: start-up, the mesh and the first factorization, the last
/// publication of the shard.
const TIME_OVERHEAD_S: f64 = 300.0;

/// Where the time estimate's cost per element and step comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum Rate {
    /// The slowest finished case of the sweep database (core seconds / (steps · elements · cost)).
    Measured {
        /// Seconds per element and step.
        seconds: f64,
        /// How many finished cases were measured.
        cases: usize,
    },
    /// [`BENCHMARK_SECONDS_PER_ELEMENT_STEP`].
    Benchmark,
}

impl Rate {
    /// The rate from finished cases `(case, core seconds, steps)`, or the benchmark's without any.
    pub fn from_finished(finished: &[(CaseSpec, f64, u64)]) -> Rate {
        let rates: Vec<f64> = finished
            .iter()
            .filter(|(_, core, steps)| *steps > 0 && *core > 0.0)
            .map(|(c, core, steps)| core / (*steps as f64 * c.mesh_elements() * c.step_cost()))
            .collect();
        match rates.iter().copied().reduce(f64::max) {
            Some(seconds) => Rate::Measured {
                seconds,
                cases: rates.len(),
            },
            None => Rate::Benchmark,
        }
    }

    /// Seconds per element and step.
    pub fn seconds(&self) -> f64 {
        match self {
            Rate::Measured { seconds, .. } => *seconds,
            Rate::Benchmark => BENCHMARK_SECONDS_PER_ELEMENT_STEP,
        }
    }

    /// Where the number comes from, for the script's comment and the log.
    pub fn source(&self) -> String {
        match self {
            Rate::Measured { seconds, cases } => format!(
                "{:.1} µs per element and step, the slowest of {cases} finished case(s) in the database",
                seconds * 1e6
            ),
            Rate::Benchmark => format!(
                "{:.0} µs per element and step, `xpflow bench moving` at 440x110 (docs/performance.md)",
                BENCHMARK_SECONDS_PER_ELEMENT_STEP * 1e6
            ),
        }
    }
}

/// What finished cases made of their bound, for an expected cost beside [`Rate`]'s upper one:
/// their core seconds in all over the work of their step bounds in all ([`case_steps_bound`] ×
/// elements × step cost), seconds per element and bound step. It folds in everything the bound
/// leaves out or overstates (early stops, adaptive steps above the initial Δt, rejected steps,
/// resumptions, the machine's load), and it gives the finished cases' own total back exactly;
/// a sum rather than a median, because a study's cost is its long cases'.
///
/// A case that cannot stop early (`stop.early_stop = false`) runs to t_end whatever it does, so
/// the finished cases' early stops say nothing of it: it is expected to take t_end over its
/// largest Δt steps (the fixed step, or the adaptive step's `max`, which the controller never
/// exceeds: a lower bound on its steps) at the finished cases' cost per element and step taken.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Expectation {
    /// Seconds per element and bound step.
    pub seconds: f64,
    /// Seconds per element and step taken (the finished cases' core seconds over their steps'
    /// work): the cost of a case that runs to its end.
    pub per_step: f64,
    /// The finished cases' core seconds in all.
    pub core: f64,
    /// How many finished cases were measured.
    pub cases: usize,
}

impl Expectation {
    /// The expectation from finished cases `(case, core seconds, steps)`; `None` without any.
    pub fn from_finished(finished: &[(CaseSpec, f64, u64)]) -> Option<Expectation> {
        let (mut core, mut work, mut taken, mut cases) = (0.0, 0.0, 0.0, 0);
        for (c, w, steps) in finished {
            let per_step = c.mesh_elements() * c.step_cost();
            let bound = case_steps_bound(c) * per_step;
            if *steps > 0 && *w > 0.0 && bound > 0.0 {
                core += w;
                work += bound;
                taken += *steps as f64 * per_step;
                cases += 1;
            }
        }
        (cases > 0).then(|| Expectation {
            seconds: core / work,
            per_step: core / taken,
            core,
            cases,
        })
    }

    /// Expected core-seconds of a case whose step bound is `steps` (its steps at the initial Δt
    /// and an extrusion's prelude): by the finished cases' share of their bounds, or, for a case
    /// without early stop, its steps at the largest Δt (and the prelude's bound) at the cost per
    /// step taken.
    pub fn seconds_of(&self, spec: &CaseSpec, steps: f64) -> f64 {
        let work = spec.mesh_elements() * spec.step_cost();
        if spec.stop.early_stop {
            return steps * work * self.seconds;
        }
        let to_end = steps - spec.steps() + spec.steps_at_largest_dt();
        to_end * work * self.per_step
    }

    /// Where the number comes from.
    pub fn source(&self) -> String {
        format!(
            "{:.1} µs per element and bound step: the {} finished case(s) of the database, \
             {:.1} core-hours, over their step bounds; a case without early stop at its largest \
             Δt, {:.1} µs per element and step taken",
            self.seconds * 1e6,
            self.cases,
            self.core / 3600.0,
            self.per_step * 1e6
        )
    }
}

/// A case's step bound: its steps at the initial Δt to t_end and an extrusion's undisturbed
/// prelude ([`prelude_steps`]).
pub fn case_steps_bound(spec: &CaseSpec) -> f64 {
    spec.steps() + prelude_steps(spec)
}

/// The finished cases of `store` that took steps, as (case, core seconds, steps): what
/// [`Rate::from_finished`] measures (a case whose stored JSON no longer parses is left out).
///
/// # Errors
/// A failed read of the database.
pub fn finished_cases(store: &Store) -> crate::store::Result<Vec<(CaseSpec, f64, u64)>> {
    Ok(store
        .finished_timings()?
        .into_iter()
        .filter_map(|(json, core, steps)| {
            let spec = CaseSpec::from_value(serde_json::from_str(&json).ok()?).ok()?;
            Some((spec, core, steps))
        })
        .collect())
}

/// Memory of the largest case, in MB (rounded up).
pub fn memory_mb(cases: &[&PlannedCase]) -> u64 {
    let bytes = cases
        .iter()
        .map(|c| c.spec.memory_estimate())
        .fold(0.0, f64::max);
    (bytes / 1e6).ceil() as u64
}

/// Core-seconds a case needs at most: its steps (at the initial Δt of an adaptive step, all of
/// them even with an early stop, and an extrusion's undisturbed prelude: [`prelude_steps`]) ×
/// elements × step cost × `rate`.
pub fn case_seconds(spec: &CaseSpec, rate: &Rate) -> f64 {
    steps_seconds(spec, case_steps_bound(spec), rate)
}

/// Core-seconds of `steps` steps of case `spec` at `rate`.
pub fn steps_seconds(spec: &CaseSpec, steps: f64, rate: &Rate) -> f64 {
    steps * spec.mesh_elements() * spec.step_cost() * rate.seconds()
}

/// The steps of an extrusion's undisturbed prelude at most (to
/// [`UNDISTURBED_T_MAX`](crate::simulate::undisturbed::UNDISTURBED_T_MAX) at the case's initial
/// Δt; the steady test usually ends it sooner); 0 for other cases and for those that skip it
/// (`output.undisturbed_surface = false`).
pub fn prelude_steps(spec: &CaseSpec) -> f64 {
    if spec.extrusion().is_none() || !spec.output.undisturbed_surface {
        return 0.0;
    }
    (crate::simulate::undisturbed::UNDISTURBED_T_MAX / spec.numerics.dt.initial()).ceil()
}

/// Wall-clock seconds the longest case may need: [`case_seconds`] with a margin and a fixed
/// overhead.
pub fn time_seconds(cases: &[&PlannedCase], rate: &Rate) -> f64 {
    let longest = cases
        .iter()
        .map(|c| case_seconds(&c.spec, rate))
        .fold(0.0, f64::max);
    longest * TIME_MARGIN + TIME_OVERHEAD_S
}

/// Seconds as SLURM's `D-HH:MM:SS`, rounded up to the minute.
pub fn slurm_time(seconds: f64) -> String {
    let minutes = (seconds / 60.0).ceil().max(1.0) as u64;
    let (days, rest) = (minutes / 1440, minutes % 1440);
    format!("{days}-{:02}:{:02}:00", rest / 60, rest % 60)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{AdaptiveStep, TimeStep};

    fn case(mesh: [usize; 2], t_end: f64, beta: f64) -> CaseSpec {
        CaseSpec::from_value(serde_json::json!({
            "geometry": {"confined_shear": {"h": 1.0, "l": 4.0}},
            "fluid": {"model": "giesekus", "wi": 1.0, "alpha": 0.01, "beta": beta},
            "particles": {"radius": 0.1, "layout": {"string": {"n": 2, "lx": 0.5, "ly": 0.1}}},
            "numerics": {"mesh": mesh, "dt": 0.02, "t_end": t_end}
        }))
        .unwrap()
    }

    /// 200×50 for 1000 steps at the benchmark rate: 510 s × 1.5 + 300 s = 17.75 min → 18 min;
    /// semi-implicit (β = 0) ten times the step; a measured rate replaces the benchmark's.
    #[test]
    fn time_and_memory_follow_the_cases() {
        let planned = |spec: CaseSpec| PlannedCase {
            index: 0,
            id: "x".into(),
            label: "x".into(),
            spec,
            params: Vec::new(),
        };
        let c = planned(case([200, 50], 20.0, 0.1));
        assert_eq!(c.spec.steps(), 1000.0);
        let t = time_seconds(&[&c], &Rate::Benchmark);
        assert!(
            (t - (1000.0 * 1e4 * 51e-6 * 1.5 + 300.0)).abs() < 1e-6,
            "{t}"
        );
        assert_eq!(slurm_time(t), "0-00:18:00");
        assert_eq!(slurm_time(90_000.0), "1-01:00:00");
        let semi = planned(case([200, 50], 20.0, 0.0));
        assert!(time_seconds(&[&semi], &Rate::Benchmark) > 9.0 * (t - 300.0));
        assert_eq!(
            memory_mb(&[&c]),
            (c.spec.memory_estimate() / 1e6).ceil() as u64
        );
        let measured = Rate::from_finished(&[(c.spec.clone(), 20.0, 1000)]);
        assert_eq!(
            measured,
            Rate::Measured {
                seconds: 2e-6,
                cases: 1
            }
        );
        assert!(measured.source().contains("1 finished case"));
        assert_eq!(Rate::from_finished(&[]), Rate::Benchmark);
    }

    /// The expectation is the finished cases' core seconds in all over their bounds' work: three
    /// cases of 1000 bound steps on 10⁴ elements that took 8, 2 and 20 s expect 10 s per such
    /// case; none without finished cases.
    #[test]
    fn the_expectation_is_the_finished_cases_total_over_their_bounds() {
        let c = case([200, 50], 20.0, 0.1);
        let finished = [
            (c.clone(), 8.0, 400),
            (c.clone(), 2.0, 100),
            (c.clone(), 20.0, 250),
        ];
        let e = Expectation::from_finished(&finished).unwrap();
        assert!((e.seconds - 1e-6).abs() < 1e-18, "{e:?}");
        assert_eq!((e.core, e.cases), (30.0, 3));
        assert!((e.seconds_of(&c, 1000.0) - 10.0).abs() < 1e-9);
        assert!(e.source().contains("3 finished case(s)"), "{}", e.source());
        // 30 s over 750 steps of 10⁴ elements: 4 µs per element and step taken; a case that
        // cannot stop early runs t_end / Δt_max = 20 / 0.2 = 100 steps (its bound is 200 at
        // the initial 0.1) and is expected at 100 × 10⁴ × 4e-6 = 4 s
        assert!((e.per_step - 4e-6).abs() < 1e-18, "{e:?}");
        let mut to_end = c.clone();
        to_end.stop.early_stop = false;
        to_end.numerics.dt = TimeStep::Adaptive(AdaptiveStep {
            initial: 0.1,
            min: 0.01,
            max: 0.2,
            tol: 1e-3,
            coupling_lag: false,
        });
        assert_eq!(case_steps_bound(&to_end), 200.0);
        assert!((e.seconds_of(&to_end, 200.0) - 4.0).abs() < 1e-9);
        assert!(
            e.source().contains("4.0 µs per element and step taken"),
            "{}",
            e.source()
        );
        // the bound takes the slowest rate per step taken: 20 s / (250 × 10⁴)
        assert_eq!(Rate::from_finished(&finished).seconds(), 8e-6);
        assert_eq!(Expectation::from_finished(&[]), None);
    }
}
