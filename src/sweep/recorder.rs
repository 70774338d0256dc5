//! The observer the engine gives a runner ([`Recorder`]): classifies every step, keeps every k-th
//! sample, checkpoints samples, writes snapshots and saved solver states (the resume files of
//! [`resume_path`]) and drives the case's progress bar. A snapshot or state that cannot be written
//! stops the case: it is recorded as failed with the error (docs/sweeps.md).

use std::path::PathBuf;
use std::time::{Duration, Instant};

use super::clock::CaseClock;
use super::engine::CaseContext;
use super::progress::{CaseProgress, Progress};
use crate::config::CaseSpec;
use crate::observe::{CaseObserver, Classifier, Control, FieldSnapshot, OutcomeKind, Sample};
use crate::store::snapshot::SnapshotWriter;
use crate::store::Store;

/// Sample rows buffered before a checkpoint writes them, bounding memory of long cases.
const CHECKPOINT_ROWS: usize = 50_000;

/// The observer the engine gives a runner: classifies every step, keeps every k-th sample, checkpoints,
/// writes snapshots and drives the case's progress bar.
pub(super) struct Recorder<'a> {
    store: &'a mut Store,
    case_id: i64,
    hash: &'a str,
    spec: &'a CaseSpec,
    pub(super) classifier: Classifier,
    pub(super) buffer: Vec<Sample>,
    pub(super) last: Option<Sample>,
    pub(super) stored_step: Option<u64>,
    last_flush: Instant,
    checkpoint_every: Duration,
    snapshot_dir: &'a PathBuf,
    snapshots: Option<SnapshotWriter>,
    /// The first snapshot that could not be written: the case stops and fails.
    pub(super) snapshot_error: Option<String>,
    pub(super) bar: Option<CaseProgress>,
    progress: &'a Progress,
    /// Where the solver state goes ([`resume_path`]).
    pub(super) resume_path: PathBuf,
    /// Where the case's prelude state goes ([`prelude_path`]).
    prelude_path: PathBuf,
    state_every: Duration,
    last_state: Instant,
    /// The database (for the directory of its saved states).
    db: &'a std::path::Path,
    /// Where a shard is published after each saved state ([`super::SweepOptions::publish`]).
    publish: Option<&'a std::path::Path>,
    /// The first saved state that could not be written: the case stops and fails (a case
    /// without its saved states would lose all its work to a kill).
    pub(super) state_error: Option<String>,
    /// The state a resumed case continues from, until the runner takes it.
    resume_state: Option<String>,
    /// The step a resumed case continues after (its snapshots up to there are kept).
    resumed_at: Option<u64>,
    /// What the case has cost so far, earlier attempts' included.
    clock: CaseClock,
}

impl<'a> Recorder<'a> {
    pub(super) fn new(
        store: &'a mut Store,
        case_id: i64,
        spec: &'a CaseSpec,
        hash: &'a str,
        ctx: &CaseContext<'a>,
        bar: CaseProgress,
    ) -> Self {
        Recorder {
            store,
            case_id,
            hash,
            spec,
            classifier: Classifier::new(spec),
            buffer: Vec::new(),
            last: None,
            stored_step: None,
            last_flush: Instant::now(),
            checkpoint_every: ctx.opts.checkpoint_every,
            snapshot_dir: ctx.snapshot_dir,
            snapshots: None,
            snapshot_error: None,
            bar: Some(bar),
            progress: ctx.progress,
            resume_path: resume_path(&ctx.opts.db, hash),
            prelude_path: prelude_path(&ctx.opts.db, hash),
            state_every: ctx.opts.state_every,
            last_state: Instant::now(),
            db: &ctx.opts.db,
            publish: ctx.opts.publish.as_deref(),
            state_error: None,
            resume_state: None,
            resumed_at: None,
            clock: CaseClock::start(),
        }
    }

    /// Wall-clock seconds spent on the case so far, over all attempts.
    pub(super) fn wall_s(&self) -> f64 {
        self.clock.wall_seconds()
    }

    /// CPU seconds spent on the case so far, over all attempts, if known for all of them
    /// ([`CaseClock`]): its cost without the time it waited.
    pub(super) fn cpu_s(&self) -> Option<f64> {
        self.clock.cpu_seconds()
    }

    /// Continues an interrupted attempt: the classifier, the last sample and the solver state as
    /// they were saved.
    pub(super) fn resume_from(&mut self, r: ResumeFile) {
        self.classifier = r.classifier;
        self.stored_step = r.stored_step;
        self.last = Some(r.last);
        self.clock.continue_after(r.wall_s, r.cpu_s);
        self.resumed_at = Some(r.step);
        self.resume_state = Some(r.solver.get().to_string());
    }

    /// Writes the resume file for `step` (samples flushed first, so that the database holds every
    /// sample up to `step` whenever the file says so).
    fn write_state(&mut self, step: u64, state: &str) -> Result<(), String> {
        let Some(last) = self.last.clone().filter(|s| s.step == step) else {
            return Err(format!("step {step} was not reported before its state"));
        };
        self.flush();
        if !self.buffer.is_empty() {
            return Err("samples could not be written".into());
        }
        let rows = self
            .store
            .count_samples(self.case_id, step)
            .map_err(|e| e.to_string())?;
        let file = ResumeFile {
            format: RESUME_FORMAT,
            case_hash: self.hash.to_string(),
            code_version: crate::store::code_version(),
            step,
            t: last.t,
            rows,
            stored_step: self.stored_step,
            last,
            classifier: self.classifier.clone(),
            wall_s: self.wall_s(),
            cpu_s: self.cpu_s(),
            solver: serde_json::value::RawValue::from_string(state.to_string())
                .map_err(|e| format!("solver state is not JSON: {e}"))?,
        };
        let json = serde_json::to_string(&file).map_err(|e| e.to_string())?;
        write_atomically(&self.resume_path, &json)
    }

    /// Keeps the first snapshot (`what` = "snapshot") or saved-state error and says so at once.
    fn io_failed(&mut self, what: &str, error: String) {
        let label = self.spec_label();
        let slot = if what == "snapshot" {
            &mut self.snapshot_error
        } else {
            &mut self.state_error
        };
        if slot.is_none() {
            self.progress.log(&format!(
                "error: case {} ({label}): {what}: {error}; the case stops and is recorded as failed",
                self.hash,
            ));
            *slot = Some(error);
        }
    }

    /// The case's label as its progress bar shows it.
    fn spec_label(&self) -> String {
        self.bar
            .as_ref()
            .map_or_else(String::new, |b| b.label().to_string())
    }

    fn flush(&mut self) {
        if self.buffer.is_empty() {
            return;
        }
        // A failed checkpoint is not fatal: the samples stay buffered for the final transaction.
        if self.store.write_samples(self.case_id, &self.buffer).is_ok() {
            self.stored_step = self.buffer.last().map(|s| s.step);
            self.buffer.clear();
        }
        self.last_flush = Instant::now();
    }
}

impl CaseObserver for Recorder<'_> {
    fn on_undisturbed_surface(&mut self, surface: &crate::observe::UndisturbedSurface) {
        self.classifier.set_undisturbed_surface(surface);
    }

    fn on_contact(&mut self, contact: &crate::particles::Contact, t: f64) {
        self.classifier.contact(contact, t);
    }

    fn on_contact_at_failure(&mut self, contact: &crate::particles::Contact, t: f64, error: &str) {
        self.classifier.contact_at_failure(contact, t, error);
    }

    fn on_step(&mut self, sample: &Sample) -> Control {
        self.classifier.push(sample);
        if sample.step.is_multiple_of(self.spec.output.sample_every) {
            self.buffer.push(sample.clone());
        }
        self.last = Some(sample.clone());
        if let Some(bar) = &mut self.bar {
            bar.update(sample.t, sample.step);
        }
        let rows = self.buffer.len() * sample.particles.len().max(1);
        if rows >= CHECKPOINT_ROWS || self.last_flush.elapsed() >= self.checkpoint_every {
            self.flush();
        }
        if self.snapshot_error.is_some() || self.state_error.is_some() {
            // the case cannot give what was asked (its snapshots, or its protection against a
            // kill): stop now rather than after hours, it fails with the error
            return Control::Stop;
        }
        match self.classifier.decided() {
            Some(o) if o.kind == OutcomeKind::Diverged || self.spec.stop.early_stop => {
                Control::Stop
            }
            _ => Control::Continue,
        }
    }

    fn snapshot_due(&self, step: u64) -> bool {
        let every = self.spec.output.snapshot_every;
        every > 0 && step.is_multiple_of(every)
    }

    fn on_snapshot(&mut self, snapshot: &FieldSnapshot) {
        if self.snapshots.is_none() && self.snapshot_error.is_none() {
            let opened = match self.resumed_at {
                Some(step) => SnapshotWriter::reopen(self.snapshot_dir, self.hash, step),
                None => SnapshotWriter::create(self.snapshot_dir, self.hash),
            };
            match opened {
                Ok(w) => self.snapshots = Some(w),
                Err(e) => self.io_failed("snapshot", e.to_string()),
            }
        }
        let Some(w) = &mut self.snapshots else { return };
        let file = w.h5_path().display().to_string();
        let written = w.write(snapshot).and_then(|_| {
            self.store
                .record_snapshot(self.case_id, snapshot.step, snapshot.t, &file)
        });
        if let Err(e) = written {
            self.io_failed("snapshot", e.to_string());
        }
    }

    fn checkpoint(&mut self) {
        self.flush();
    }

    fn state_due(&self, _step: u64) -> bool {
        self.last_state.elapsed() >= self.state_every
    }

    fn save_state(&mut self, step: u64, state: &str) {
        let written = self.write_state(step, state);
        self.saved(written);
    }

    fn resume_state(&mut self) -> Option<String> {
        self.resume_state.take()
    }

    fn on_prelude_step(&mut self, t: f64, steps: usize) {
        if let Some(bar) = &mut self.bar {
            bar.prelude(t, steps);
        }
    }

    fn prelude_due(&self) -> bool {
        self.last_state.elapsed() >= self.state_every
    }

    fn save_prelude(&mut self, state: &str) {
        let written = self.write_prelude(state);
        self.saved(written);
    }

    fn resume_prelude(&mut self) -> Option<String> {
        let saved = PreludeFile::load(&self.prelude_path, self.hash)?;
        self.progress.log(&format!(
            "resume {} ({}): its prelude (the undisturbed flow) from its saved state, saved by {}",
            self.spec_label(),
            self.hash,
            saved.code_version
        ));
        Some(saved.state.get().to_string())
    }

    fn shared_prelude(&mut self, key: &str) -> Option<String> {
        let path = shared_prelude_path(self.db, key);
        let text = std::fs::read_to_string(&path).ok()?;
        self.progress.log(&format!(
            "{} ({}): the undisturbed surface of an earlier case with the same flow ({})",
            self.spec_label(),
            self.hash,
            path.display()
        ));
        Some(text)
    }

    fn share_prelude(&mut self, key: &str, finished: &str) {
        if let Err(e) = write_atomically(&shared_prelude_path(self.db, key), finished) {
            // (the case goes on: the next case of this flow computes its own)
            self.progress
                .log(&format!("cannot share the undisturbed surface: {e}"));
        }
    }
}

impl Recorder<'_> {
    /// After a saved state (`written`: the resume or the prelude file): a shard publishes its
    /// database and states at once (a task killed by its time limit loses its local disk); the
    /// first failure stops the case; the clock of [`CaseObserver::state_due`] restarts.
    fn saved(&mut self, written: Result<(), String>) {
        let published = written.and_then(|()| match self.publish {
            Some(dir) => crate::store::shard::publish(self.store, &states_dir(self.db), dir)
                .map_err(|e| e.to_string()),
            None => Ok(()),
        });
        if let Err(e) = published {
            self.io_failed("saved state", e);
        }
        self.last_state = Instant::now();
    }

    /// Writes the prelude file.
    fn write_prelude(&self, state: &str) -> Result<(), String> {
        let file = PreludeFile {
            format: RESUME_FORMAT,
            case_hash: self.hash.to_string(),
            code_version: crate::store::code_version(),
            state: serde_json::value::RawValue::from_string(state.to_string())
                .map_err(|e| format!("prelude state is not JSON: {e}"))?,
        };
        let json = serde_json::to_string(&file).map_err(|e| e.to_string())?;
        write_atomically(&self.prelude_path, &json)
    }
}

/// Writes `json` to `path` (its directory made if needed) by write-then-rename: a kill leaves the
/// previous file or this one, never half of one.
fn write_atomically(path: &std::path::Path, json: &str) -> Result<(), String> {
    let io = |e: std::io::Error| format!("{}: {e}", path.display());
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    let tmp = path.with_extension("json.tmp");
    std::fs::write(&tmp, json).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(io)
}

/// A case's prelude state (an extrusion's undisturbed flow on its way to the steady surface,
/// before the case's first sample): the runner's own, opaque, after one of the prelude's steps.
#[derive(serde::Serialize, serde::Deserialize)]
struct PreludeFile {
    format: u32,
    case_hash: String,
    /// The build that wrote it.
    code_version: String,
    state: Box<serde_json::value::RawValue>,
}

impl PreludeFile {
    /// The saved prelude of case `hash`, if there is a readable one of this layout.
    fn load(path: &std::path::Path, hash: &str) -> Option<PreludeFile> {
        let text = std::fs::read_to_string(path).ok()?;
        serde_json::from_str::<PreludeFile>(&text)
            .ok()
            .filter(|p| p.format == RESUME_FORMAT && p.case_hash == hash)
    }
}

/// Where the saved prelude of case `hash` of database `db` lives: beside its resume file,
/// `<db dir>/<db stem>/<hash>.prelude.resume.json` (published with the saved states of a shard).
pub fn prelude_path(db: &std::path::Path, hash: &str) -> PathBuf {
    resume_path(db, hash).with_file_name(format!("{hash}.prelude.resume.json"))
}

/// Where the finished prelude of the cases of `key` (an extrusion's undisturbed surface, see
/// [`crate::simulate::undisturbed::prelude_key`]) is shared: `<db dir>/<db stem>/<key>.json`.
pub fn shared_prelude_path(db: &std::path::Path, key: &str) -> PathBuf {
    states_dir(db).join(format!("{key}.json"))
}

/// Where a case that failed or diverged keeps its last saved state, for a diagnosis or a resume
/// after a fix: beside its resume file, `<db dir>/<db stem>/<hash>.failed.resume.json` (renamed
/// to `<hash>.resume.json`, the next run of a `failed` case with `--retry-failed` continues from it).
pub fn failed_state_path(db: &std::path::Path, hash: &str) -> PathBuf {
    resume_path(db, hash).with_file_name(format!("{hash}.failed.resume.json"))
}

/// Where the saved state of case `hash` of database `db` lives: `<db dir>/<db stem>/<hash>.resume.json`
/// (beside the snapshots when the sweep is named like its database, the default), whichever sweep
/// invocation runs the case.
pub fn resume_path(db: &std::path::Path, hash: &str) -> PathBuf {
    let stem = db
        .file_stem()
        .map_or_else(|| "results".into(), |s| s.to_string_lossy().into_owned());
    db.parent()
        .unwrap_or_else(|| std::path::Path::new("."))
        .join(stem)
        .join(format!("{hash}.resume.json"))
}

/// The directory of the saved states of database `db`: `<db dir>/<db stem>/`.
pub fn states_dir(db: &std::path::Path) -> PathBuf {
    resume_path(db, "x")
        .parent()
        .map_or_else(|| PathBuf::from("."), std::path::Path::to_path_buf)
}

/// What the header of a saved state says: where the case stands and what it took to get there.
#[derive(Debug, Clone, PartialEq)]
pub struct SavedState {
    /// Steps taken.
    pub step: u64,
    /// Time reached.
    pub t: f64,
    /// The build that wrote it.
    pub code_version: String,
    /// Wall-clock seconds the case has run, over its attempts (absent in states written before
    /// 2026-12-07).
    pub wall_s: Option<f64>,
}

impl SavedState {
    /// Wall-clock seconds until the case reaches `t_end` at its mean rate so far (simulated time
    /// per wall-clock second over its attempts): an upper bound where early stop ends it sooner,
    /// and a rough one with adaptive steps, which start small. `None` without a clock or a
    /// time reached.
    pub fn wall_left(&self, t_end: f64) -> Option<f64> {
        let wall = self.wall_s.filter(|w| *w > 0.0)?;
        (self.t > 0.0).then(|| (t_end - self.t).max(0.0) * wall / self.t)
    }
}

impl std::fmt::Display for SavedState {
    /// Where it stands, as `xpflow status` lists it: `step 836, t = 33.40`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "step {}, t = {:.2}", self.step, self.t)
    }
}

/// The header of the saved state of a case, if it has a readable one.
pub fn saved_state(db: &std::path::Path, hash: &str) -> Option<SavedState> {
    state_header(&resume_path(db, hash))
}

/// The step, time and runner state (a [`crate::simulate::Simulation::checkpoint`]) of the saved
/// state of case `hash`, if it has a readable one: what a benchmark continues the case from.
pub fn saved_runner_state(db: &std::path::Path, hash: &str) -> Option<(u64, f64, String)> {
    ResumeFile::load(&resume_path(db, hash), hash).map(|r| (r.step, r.t, r.solver.get().into()))
}

/// The header of the state a failed case kept ([`failed_state_path`]), from which
/// `--retry-failed` continues it.
pub fn saved_failed_state(db: &std::path::Path, hash: &str) -> Option<SavedState> {
    state_header(&failed_state_path(db, hash))
}

/// The header of the saved state at `path`, if it is readable.
fn state_header(path: &std::path::Path) -> Option<SavedState> {
    #[derive(serde::Deserialize)]
    struct Header {
        format: u32,
        code_version: String,
        step: u64,
        t: f64,
        #[serde(default)]
        wall_s: Option<f64>,
    }
    let text = std::fs::read_to_string(path).ok()?;
    serde_json::from_str::<Header>(&text)
        .ok()
        .filter(|h| h.format == RESUME_FORMAT)
        .map(|h| SavedState {
            step: h.step,
            t: h.t,
            code_version: h.code_version,
            wall_s: h.wall_s,
        })
}

/// The prelude steps in the saved prelude state of a case (an extrusion's undisturbed flow), if
/// it has a readable one.
pub fn saved_prelude(db: &std::path::Path, hash: &str) -> Option<usize> {
    #[derive(serde::Deserialize)]
    struct Steps {
        steps: usize,
    }
    let file = PreludeFile::load(&prelude_path(db, hash), hash)?;
    serde_json::from_str::<Steps>(file.state.get())
        .ok()
        .map(|s| s.steps)
}

/// Layout version of the resume file.
const RESUME_FORMAT: u32 = 1;

/// A running case's saved state: what the observer had seen (classifier, last sample, how many
/// sample rows the database held) and the runner's own state, after one step.
#[derive(serde::Serialize, serde::Deserialize)]
pub(super) struct ResumeFile {
    format: u32,
    case_hash: String,
    /// The build that wrote it (a resumed case may finish with another; the log says so).
    pub(super) code_version: String,
    pub(super) step: u64,
    pub(super) t: f64,
    /// Sample rows of the case with step ≤ `step` when it was written.
    pub(super) rows: u64,
    stored_step: Option<u64>,
    last: Sample,
    classifier: Classifier,
    wall_s: f64,
    /// CPU seconds so far (absent from files written before cases recorded it: unknown).
    #[serde(default)]
    cpu_s: Option<f64>,
    solver: Box<serde_json::value::RawValue>,
}

impl ResumeFile {
    /// The saved state of case `hash`, if there is a readable one of this layout.
    pub(super) fn load(path: &std::path::Path, hash: &str) -> Option<ResumeFile> {
        let text = std::fs::read_to_string(path).ok()?;
        serde_json::from_str::<ResumeFile>(&text)
            .ok()
            .filter(|r| r.format == RESUME_FORMAT && r.case_hash == hash)
    }
}
