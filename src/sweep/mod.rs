//! Sweep expansion, case ids, scheduling, resume and progress.
//!
//! [`expand()`] turns a [`crate::config::SweepSpec`] into validated [`PlannedCase`]s with stable ids;
//! [`engine`] runs them through a [`CaseRunner`] on a rayon pool, records them in the
//! [`crate::store::Store`] (one transaction per finished case) and resumes interrupted sweeps;
//! [`progress`] shows bars or a plain log; [`search`] runs a sweep with a `[search]` section round by
//! round through the same engine, refining one axis where the outcome changes. On a cluster,
//! [`slurm`] writes and submits job arrays over a [`manifest`] whose tasks each run one case into a
//! shard of their own ([`task`]).

pub mod clock;
pub mod engine;
pub mod expand;
pub mod manifest;
pub mod memory;
pub mod progress;
mod recorder;
pub mod runner;
pub mod search;
pub mod slurm;
pub mod solver_runner;
pub mod task;
pub mod tries;

pub use crate::config::PlannedCase;
pub use engine::{run_sweep, SweepOptions, SweepSummary};
pub use expand::{case_id, expand};
pub use runner::{default_runner, CaseResult, CaseRunner, FakeBehaviour, FakeRunner, RunStatus};
