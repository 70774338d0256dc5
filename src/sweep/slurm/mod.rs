//! A sweep on a SLURM cluster (`xpflow sweep FILE --slurm`): a submission directory, one job
//! array per round whose tasks each run one case into a shard of their own ([`crate::sweep::task`],
//! the engine's path), merged afterwards by `xpflow merge`.
//!
//! ```text
//! <submission>/                      default <db dir>/<db stem>.slurm/
//!   round-1/ sweep.toml              a copy of the sweep file the tasks expand
//!            manifest.txt            one case id per line = per array index
//!            array-0.sbatch …        one job array per MaxArraySize cases
//!            jobs.txt                chunk, first manifest line, tasks, job id (- if not submitted)
//!   round-2/ …                       `--resume`: what was not done, failed or interrupted
//!   shards/<case>.db                 published shards; <case>/ their saved states;
//!          <case>.failed.json        the marker of a failed task; <sweep name>/ HDF5 snapshots
//!   logs/                            one log per task
//! ```
//! [`plan`] decides what a round submits, [`write_round`] writes it, [`submit`] hands it to
//! sbatch; [`status`] says where each case stands.

pub mod estimate;
pub mod scheduler;
pub mod script;
pub mod status;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use self::estimate::Rate;
use self::script::{Chunk, Resources, ScriptPaths};
use super::manifest::Manifest;
use crate::config::PlannedCase;

/// A submission that cannot be written or submitted.
#[derive(Debug, thiserror::Error)]
pub enum SlurmError {
    /// A file of the submission directory.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// sbatch refused an array (the arrays before it stay submitted, in `jobs.txt`).
    #[error(transparent)]
    Scheduler(#[from] scheduler::SchedulerError),
}

/// `map_err` for an I/O error on `path`.
fn io(path: &Path) -> impl Fn(std::io::Error) -> SlurmError + '_ {
    move |source| SlurmError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// A submission directory.
#[derive(Debug, Clone, PartialEq)]
pub struct Submission {
    /// The directory (absolute: the tasks run elsewhere).
    pub dir: PathBuf,
}

/// One round of a submission: its manifest and job arrays.
#[derive(Debug, Clone, PartialEq)]
pub struct Round {
    /// 1, 2, …
    pub number: usize,
    /// `round-<number>/`.
    pub dir: PathBuf,
    /// The round's cases.
    pub manifest: Manifest,
    /// Its job arrays with their job ids, if submitted.
    pub jobs: Vec<(Chunk, Option<String>)>,
}

impl Round {
    /// The first manifest line of array `chunk`.
    pub fn chunk_offset(&self, chunk: usize) -> Option<usize> {
        self.jobs
            .iter()
            .find(|(c, _)| c.number == chunk)
            .map(|(c, _)| c.offset)
    }

    /// The sbatch script of `chunk`.
    pub fn script(&self, chunk: &Chunk) -> PathBuf {
        self.dir.join(format!("array-{}.sbatch", chunk.number))
    }

    fn write_jobs(&self) -> std::io::Result<()> {
        let mut text = String::from("# chunk, first manifest line, tasks, job id\n");
        for (c, id) in &self.jobs {
            text += &format!(
                "{} {} {} {}\n",
                c.number,
                c.offset,
                c.count,
                id.as_deref().unwrap_or("-")
            );
        }
        std::fs::write(self.dir.join("jobs.txt"), text)
    }

    fn read_jobs(dir: &Path) -> Vec<(Chunk, Option<String>)> {
        let text = std::fs::read_to_string(dir.join("jobs.txt")).unwrap_or_default();
        text.lines()
            .filter(|l| !l.starts_with('#'))
            .filter_map(|l| {
                let f: Vec<&str> = l.split_whitespace().collect();
                let [n, o, c, id] = f.as_slice() else {
                    return None;
                };
                let chunk = Chunk {
                    number: n.parse().ok()?,
                    offset: o.parse().ok()?,
                    count: c.parse().ok()?,
                };
                Some((chunk, (*id != "-").then(|| id.to_string())))
            })
            .collect()
    }
}

impl Submission {
    /// The submission in `dir` (made absolute).
    pub fn new(dir: &Path) -> Submission {
        Submission {
            dir: std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf()),
        }
    }

    /// The default directory of the submissions of database `db`: `<db dir>/<db stem>.slurm`.
    pub fn default_dir(db: &Path) -> PathBuf {
        let stem = db
            .file_stem()
            .map_or_else(|| "results".into(), |s| s.to_string_lossy().into_owned());
        db.parent()
            .unwrap_or_else(|| Path::new("."))
            .join(format!("{stem}.slurm"))
    }

    /// The shard directory.
    pub fn shards(&self) -> PathBuf {
        self.dir.join("shards")
    }

    /// The log directory.
    pub fn logs(&self) -> PathBuf {
        self.dir.join("logs")
    }

    /// The rounds written so far, in order (a round whose manifest cannot be read is left out).
    pub fn rounds(&self) -> Vec<Round> {
        let mut rounds: Vec<Round> = std::fs::read_dir(&self.dir)
            .map(|d| {
                d.filter_map(|e| {
                    let e = e.ok()?;
                    let name = e.file_name().to_string_lossy().into_owned();
                    let number = name.strip_prefix("round-")?.parse().ok()?;
                    let manifest = Manifest::read(&e.path().join("manifest.txt")).ok()?;
                    Some(Round {
                        number,
                        jobs: Round::read_jobs(&e.path()),
                        dir: e.path(),
                        manifest,
                    })
                })
                .collect()
            })
            .unwrap_or_default();
        rounds.sort_by_key(|r| r.number);
        rounds
    }

    /// What every job name of this submission starts with: `xpflow-<8 hex digits of the
    /// directory's path>-`, so that two submissions of one sweep are told apart in the queue.
    pub fn job_prefix(&self) -> String {
        let tag = crate::sweep::expand::fnv1a64(self.dir.to_string_lossy().as_bytes());
        format!("xpflow-{:08x}-", tag >> 32)
    }

    /// The job name of array `chunk` of round `round` of sweep `sweep`.
    pub fn job_name(&self, round: usize, chunk: usize, sweep: &str) -> String {
        format!("{}r{round}c{chunk}-{sweep}", self.job_prefix())
    }

    /// Round and chunk of one of this submission's job names.
    pub fn parse_job_name(&self, name: &str) -> Option<(usize, usize)> {
        let rest = name.strip_prefix(&self.job_prefix())?.strip_prefix('r')?;
        let (round, rest) = rest.split_once('c')?;
        let chunk = rest.split('-').next()?;
        Some((round.parse().ok()?, chunk.parse().ok()?))
    }

    /// This submission's tasks in the queue (`None`: `squeue` does not answer).
    pub fn queue(&self) -> Option<Vec<scheduler::QueuedTask>> {
        scheduler::squeue(&self.job_prefix())
    }
}

/// What a new round is to submit.
#[derive(Debug, Clone)]
pub struct Plan<'a> {
    /// The cases to submit, in sweep order.
    pub cases: Vec<&'a PlannedCase>,
    /// Cases done (in the database or a shard).
    pub done: usize,
    /// Cases whose tasks are queued or running.
    pub active: usize,
}

/// The cases of `cases` to submit: those not `done` (ids done in the database or a shard) and
/// not queued or running in `sub` (per `queue`).
pub fn plan<'a>(
    sub: &Submission,
    cases: &'a [PlannedCase],
    done_in_db: &BTreeSet<String>,
    queue: Option<&[scheduler::QueuedTask]>,
) -> Plan<'a> {
    let states = status::case_states(sub, queue);
    let done = |id: &str| {
        done_in_db.contains(id)
            || states
                .iter()
                .any(|s| s.case == id && s.state == status::CaseState::Done)
    };
    let active = |id: &str| {
        states.iter().any(|s| {
            s.case == id
                && matches!(
                    s.state,
                    status::CaseState::Running | status::CaseState::Queued
                )
        })
    };
    let mut plan = Plan {
        cases: Vec::new(),
        done: 0,
        active: 0,
    };
    for c in cases {
        if done(&c.id) {
            plan.done += 1;
        } else if active(&c.id) {
            plan.active += 1;
        } else {
            plan.cases.push(c);
        }
    }
    plan
}

/// The file beside a round's manifest with the swept fields of its cases ([`RoundCase`]).
pub const ROUND_CASES: &str = "cases.json";

/// A case of a round as written beside its manifest: enough to plan it again from the sweep
/// file without expanding it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RoundCase {
    /// The case id.
    pub id: String,
    /// Its index in the sweep (or the search).
    pub index: usize,
    /// Its label.
    pub label: String,
    /// The swept fields and their values.
    pub params: Vec<(String, serde_json::Value)>,
}

/// Writes round `sub.rounds().len() + 1` for `cases`: the sweep file's copy, the manifest, its
/// cases' swept fields ([`ROUND_CASES`]), the scripts (arrays of at most `max_array_size`), `jobs.txt` without job ids.
///
/// # Errors
/// [`SlurmError::Io`] with the path.
pub fn write_round(
    sub: &Submission,
    sweep_file: &Path,
    sweep_name: &str,
    cases: &[&PlannedCase],
    res: &Resources,
    max_array_size: usize,
) -> Result<Round, SlurmError> {
    let number = sub.rounds().last().map_or(1, |r| r.number + 1);
    let dir = sub.dir.join(format!("round-{number}"));
    for d in [&dir, &sub.shards(), &sub.logs()] {
        std::fs::create_dir_all(d).map_err(io(d))?;
    }
    let ext = sweep_file
        .extension()
        .map_or("toml".into(), |e| e.to_string_lossy());
    let copy = PathBuf::from(format!("sweep.{ext}"));
    std::fs::copy(sweep_file, dir.join(&copy)).map_err(io(sweep_file))?;
    let ids: Vec<String> = cases.iter().map(|c| c.id.clone()).collect();
    let manifest_path = dir.join("manifest.txt");
    let manifest = Manifest::write(&manifest_path, &copy, &ids).map_err(io(&manifest_path))?;
    // the swept fields of each case: a search's cases are planned from its results, so its
    // tasks cannot find them by expanding the sweep file (`task::run_task` reads this instead)
    let planned: Vec<RoundCase> = cases
        .iter()
        .map(|c| RoundCase {
            id: c.id.clone(),
            index: c.index,
            label: c.label.clone(),
            params: c.params.clone(),
        })
        .collect();
    let cases_path = dir.join(ROUND_CASES);
    let json = serde_json::to_string_pretty(&planned).unwrap_or_default();
    std::fs::write(&cases_path, json).map_err(io(&cases_path))?;
    let exe = std::env::current_exe().map_err(io(Path::new("the xpflow binary")))?;
    let (shards, logs) = (sub.shards(), sub.logs());
    let paths = ScriptPaths {
        exe: &exe,
        manifest: &manifest_path,
        shards: &shards,
        logs: &logs,
    };
    let round = Round {
        number,
        jobs: script::split(ids.len(), max_array_size)
            .into_iter()
            .map(|c| (c, None))
            .collect(),
        dir,
        manifest,
    };
    for (chunk, _) in &round.jobs {
        let name = sub.job_name(number, chunk.number, sweep_name);
        let path = round.script(chunk);
        std::fs::write(&path, script::script(*chunk, &name, res, paths)).map_err(io(&path))?;
    }
    round.write_jobs().map_err(io(&round.dir))?;
    Ok(round)
}

/// Submits the arrays of `round` with sbatch, each after the previous one has ended (so that the
/// throttle holds across arrays), recording the job ids in `jobs.txt`; returns them.
///
/// # Errors
/// The first sbatch that fails (the arrays submitted before it stay submitted and recorded).
pub fn submit(round: &mut Round) -> Result<Vec<String>, SlurmError> {
    let mut ids = Vec::new();
    let mut result = Ok(());
    for k in 0..round.jobs.len() {
        let script = round.script(&round.jobs[k].0);
        match scheduler::sbatch(&script, ids.last().map(String::as_str)) {
            Ok(id) => {
                round.jobs[k].1 = Some(id.clone());
                ids.push(id);
            }
            Err(e) => {
                result = Err(e);
                break;
            }
        }
    }
    round.write_jobs().map_err(io(&round.dir))?;
    result?;
    Ok(ids)
}

/// The resources of a round: those given, else the estimates (with notes saying whence).
pub fn resources(
    cases: &[&PlannedCase],
    rate: &Rate,
    given_time: Option<&str>,
    given_mem: Option<&str>,
) -> Resources {
    let mut notes = Vec::new();
    let mem = match given_mem {
        Some(m) => m.to_string(),
        None => {
            let mb = estimate::memory_mb(cases);
            notes.push(format!(
                "--mem: {mb} MB, the memory estimate of the largest case (CaseSpec::memory_estimate)"
            ));
            format!("{mb}M")
        }
    };
    let time = match given_time {
        Some(t) => t.to_string(),
        None => {
            let t = estimate::slurm_time(estimate::time_seconds(cases, rate));
            notes.push(format!(
                "--time: {t}, the longest case's steps x elements x step cost at {}, x1.5 + 5 min",
                rate.source()
            ));
            t
        }
    };
    Resources {
        time,
        mem,
        notes,
        ..Resources::default()
    }
}
