//! Where each case of a submission stands, from what the tasks left (shards and failure markers)
//! and, when `squeue` answers, from the queue: done, failed, running, queued, interrupted (a
//! shard with a saved state and no task: killed, e.g. by its time limit), or not run (never
//! started, cancelled, or killed before its first saved state).

use std::collections::BTreeMap;

use super::scheduler::QueuedTask;
use super::Submission;
use crate::store::shard::shard_cases;
use crate::sweep::engine::saved_state;
use crate::sweep::task::{shard_path, Marker};

/// Where a case stands.
#[derive(Debug, Clone, PartialEq)]
pub enum CaseState {
    /// Its shard is published with the case done.
    Done,
    /// Its task failed: the error and, if known, the task's log.
    Failed {
        /// The error.
        error: String,
        /// The task's log file.
        log: Option<String>,
    },
    /// SLURM runs its task.
    Running,
    /// Its task waits in the queue.
    Queued,
    /// A shard without a result and no task: resubmit (`--resume`) to continue from the saved
    /// state (`step`, `t`), or from the start without one.
    Interrupted {
        /// The saved state's step and time.
        saved: Option<(u64, f64)>,
    },
    /// No shard, no marker, not queued (or no queue to ask).
    NotRun,
}

impl CaseState {
    /// The state's name in `xpflow status`.
    pub fn name(&self) -> &'static str {
        match self {
            CaseState::Done => "done",
            CaseState::Failed { .. } => "failed",
            CaseState::Running => "running",
            CaseState::Queued => "pending",
            CaseState::Interrupted { .. } => "interrupted",
            CaseState::NotRun => "not run",
        }
    }

    /// Whether `--resume` submits the case again.
    pub fn needs_submission(&self) -> bool {
        matches!(
            self,
            CaseState::Failed { .. } | CaseState::Interrupted { .. } | CaseState::NotRun
        )
    }
}

/// One case of a submission.
#[derive(Debug, Clone, PartialEq)]
pub struct CaseStatus {
    /// Case id.
    pub case: String,
    /// The last round that submitted it.
    pub round: usize,
    /// Its index (manifest line) in that round.
    pub index: usize,
    /// Where it stands.
    pub state: CaseState,
}

/// The state of every case a round of `sub` submitted (the last round's index for a case
/// submitted more than once), in round and index order. `queue`: the submission's tasks as
/// `squeue` lists them, `None` without a reachable scheduler.
pub fn case_states(sub: &Submission, queue: Option<&[QueuedTask]>) -> Vec<CaseStatus> {
    let rounds = sub.rounds();
    let mut latest: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    for r in &rounds {
        for (i, c) in r.manifest.cases.iter().enumerate() {
            latest.insert(c.clone(), (r.number, i));
        }
    }
    // (round, manifest index) → queued task
    let mut queued: BTreeMap<(usize, usize), &QueuedTask> = BTreeMap::new();
    for t in queue.unwrap_or_default() {
        let Some((round, chunk)) = sub.parse_job_name(&t.name) else {
            continue;
        };
        let Some(r) = rounds.iter().find(|r| r.number == round) else {
            continue;
        };
        if let (Some(offset), Some(task)) = (r.chunk_offset(chunk), t.task) {
            queued.insert((round, offset + task), t);
        }
    }
    let shards = sub.shards();
    let mut out: Vec<CaseStatus> = latest
        .into_iter()
        .map(|(case, (round, index))| {
            let shard = shard_path(&shards, &case);
            let recorded = shard_cases(&shard).ok().and_then(|v| v.into_iter().next());
            let state = match (&recorded, queued.get(&(round, index))) {
                (Some(c), _) if c.status == "done" => CaseState::Done,
                (_, Some(t)) if t.is_running() => CaseState::Running,
                (_, Some(_)) => CaseState::Queued,
                _ => match (Marker::read(&shards, &case), recorded) {
                    (Some(m), _) => CaseState::Failed {
                        error: m.error,
                        log: m.log.map(|l| l.display().to_string()),
                    },
                    (None, Some(c)) if c.status == "failed" => CaseState::Failed {
                        error: c.error.unwrap_or_default(),
                        log: None,
                    },
                    (None, Some(_)) => CaseState::Interrupted {
                        saved: saved_state(&shard, &case).map(|s| (s.step, s.t)),
                    },
                    (None, None) => CaseState::NotRun,
                },
            };
            CaseStatus {
                case,
                round,
                index,
                state,
            }
        })
        .collect();
    out.sort_by_key(|c| (c.round, c.index));
    out
}
