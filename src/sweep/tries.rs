//! Sweeps with a `[tries]` section ([`crate::config::TriesSpec`]): the values of one axis (or the
//! rows of one `[[zip]]`) are tried in order on every combination of the other axes (a *line*),
//! and a line stops at the first case whose outcome meets `until` — a Table 5.2 cell is '+' once a
//! string forms from one initial position, so its other positions need not run. A line none of
//! whose cases meets it runs them all.
//!
//! The cases are the grid's (the same expansion, indices, labels and ids as without the section,
//! so a database that ran the grid counts its cases), run in rounds: round k holds the first
//! unfinished try of every line not yet met. Like a search (`sweep::search`), the state is
//! rebuilt from the store before every round ([`replay`]), never kept in memory: a killed sweep
//! continues with the round it was in, and no finished case runs again.

use std::collections::HashMap;

use serde_json::Value;

use super::engine::{run_sweep, SweepError, SweepOptions};
use super::expand::{canonical_json, swept_axes, Labels};
use super::runner::CaseRunner;
use super::search::replay::Outcomes;
use super::search::stored_outcomes;
use crate::config::{ConfigError, PlannedCase, SweepSpec, TriesSpec, Until};
use crate::observe::OutcomeKind;
use crate::store::Store;

/// One combination of the other axes and its tries.
#[derive(Debug, Clone, PartialEq)]
pub struct TryLine {
    /// Label of the combination (`base` without other axes).
    pub label: String,
    /// Indices (into the grid's cases) of its tries, in the order they are tried.
    pub tries: Vec<usize>,
    /// The try whose outcome met `until`, if one has.
    pub met: Option<usize>,
    /// The first try not finished yet (the one to run now), unless met or exhausted.
    pub current: Option<usize>,
    /// Whether this invocation tries the line: every line, unless `xpflow sweep --where`
    /// selected some ([`select_lines`]); the others are registered as they stand, not run.
    pub run: bool,
}

impl TryLine {
    /// Its tries up to and including `last` (all of them for `None`).
    fn through(&self, last: Option<usize>) -> &[usize] {
        let n = last
            .and_then(|c| self.tries.iter().position(|&t| t == c))
            .map_or(self.tries.len(), |p| p + 1);
        &self.tries[..n]
    }
}

/// Where a sweep with tries stands.
#[derive(Debug, Clone, PartialEq)]
pub struct TriesState {
    /// The lines, in the grid's order.
    pub lines: Vec<TryLine>,
}

impl TriesState {
    /// The cases of the current round: each line's current try, in grid order (the lines run
    /// by this invocation).
    pub fn round(&self) -> Vec<usize> {
        let mut r: Vec<usize> = self
            .lines
            .iter()
            .filter(|l| l.run)
            .filter_map(|l| l.current)
            .collect();
        r.sort_unstable();
        r
    }

    /// The cases tried so far, the current round's included: on each line run by this
    /// invocation its tries up to the one that met `until` or the current one, all of them when
    /// none met it; in grid order.
    pub fn tried(&self) -> Vec<usize> {
        self.collect(|l| {
            if l.run {
                l.through(l.met.or(l.current))
            } else {
                &[]
            }
        })
    }

    /// The sweep's cases as the database lists them: on a line that met `until` its tries up to
    /// that one, on every other line all its tries (those not run yet pending), so that a line
    /// reads as without `until` only once every try has run; in grid order.
    pub fn registered(&self) -> Vec<usize> {
        self.collect(|l| l.through(l.met))
    }

    fn collect(&self, per_line: impl Fn(&TryLine) -> &[usize]) -> Vec<usize> {
        let mut v: Vec<usize> = self.lines.iter().flat_map(per_line).copied().collect();
        v.sort_unstable();
        v
    }

    /// Whether no line run by this invocation has a try left.
    pub fn finished(&self) -> bool {
        self.lines
            .iter()
            .filter(|l| l.run)
            .all(|l| l.current.is_none())
    }
}

/// Runs only the lines whose tries are all among `ids` (cases `xpflow sweep --where` selected):
/// a selection is of whole lines, so a line with only some of its tries among them is an error
/// naming it.
pub fn select_lines(
    lines: &mut [TryLine],
    cases: &[PlannedCase],
    ids: &std::collections::BTreeSet<String>,
) -> Result<(), String> {
    for line in lines.iter_mut() {
        let among = line
            .tries
            .iter()
            .filter(|&&i| ids.contains(&cases[i].id))
            .count();
        if among > 0 && among < line.tries.len() {
            return Err(format!(
                "the selection takes {among} of the {} tries of `{}`: select whole combinations \
                 of the other axes, not values of the tried one",
                line.tries.len(),
                line.label
            ));
        }
        line.run = among > 0;
    }
    Ok(())
}

/// The tries of the grid `cases` of `sweep` grouped into lines: cases that agree in every swept
/// field but the tried axis (or its zip group), each line in the tried values' order.
///
/// # Errors
/// A `[tries]` whose `until` names no outcome kind (file, `tries.until`).
pub fn lines(sweep: &SweepSpec, cases: &[PlannedCase]) -> Result<Vec<TryLine>, ConfigError> {
    let Some(spec) = &sweep.tries else {
        return Err(ConfigError::Sweep {
            file: sweep.file.clone(),
            field: "tries".into(),
            message: "this sweep has no [tries] section".into(),
        });
    };
    check_kind(sweep, spec)?;
    let tried = tried_paths(sweep, spec);
    let labels = Labels::new(&swept_axes(sweep));
    let mut by_rest: HashMap<String, usize> = HashMap::new();
    let mut lines: Vec<TryLine> = Vec::new();
    for (index, case) in cases.iter().enumerate() {
        let rest: Vec<(String, Value)> = case
            .params
            .iter()
            .filter(|(path, _)| !tried.contains(path))
            .cloned()
            .collect();
        let key = canonical_json(&Value::Array(
            rest.iter()
                .map(|(p, v)| Value::Array(vec![Value::String(p.clone()), v.clone()]))
                .collect(),
        ));
        let line = *by_rest.entry(key).or_insert_with(|| {
            lines.push(TryLine {
                label: labels.of(&rest),
                tries: Vec::new(),
                met: None,
                current: None,
                run: true,
            });
            lines.len() - 1
        });
        lines[line].tries.push(index);
    }
    Ok(lines)
}

/// The state of the tries from the stored outcomes `lookup` returns for given case ids: on each
/// line, a finished try that meets `until` ends it; a finished one that does not (or a failed
/// one, unless `retry_failed`) passes to the next; the first unfinished one is the line's current.
///
/// # Errors
/// Whatever `lookup` returns.
pub fn replay<E>(
    sweep: &SweepSpec,
    cases: &[PlannedCase],
    mut lines: Vec<TryLine>,
    retry_failed: bool,
    lookup: &mut dyn FnMut(&[&str]) -> Result<Outcomes, E>,
) -> Result<TriesState, E> {
    let ids: Vec<&str> = cases.iter().map(|c| c.id.as_str()).collect();
    let stored = lookup(&ids)?;
    let until = sweep.tries.as_ref().map(|t| &t.until);
    for line in &mut lines {
        line.met = None;
        line.current = None;
        for &i in &line.tries {
            match stored.get(&cases[i].id) {
                Some(o) if o.status == "done" => {
                    let kind = o.kind.as_deref().unwrap_or_default();
                    if until.is_some_and(|u| u.met_by(kind, o.string_length)) {
                        line.met = Some(i);
                        break;
                    }
                }
                Some(o) if o.status == "failed" && !retry_failed => {}
                _ => {
                    line.current = Some(i);
                    break;
                }
            }
        }
    }
    Ok(TriesState { lines })
}

/// What a sweep with tries did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriesSummary {
    /// Lines (combinations of the other axes) this invocation tries.
    pub lines: usize,
    /// Of those, the lines whose tries met `until`.
    pub met: usize,
    /// Rounds this invocation ran.
    pub rounds: usize,
    /// Cases of the grid (of the lines this invocation tries).
    pub grid: usize,
    /// Cases tried so far (finished, or running elsewhere).
    pub tried: usize,
    /// Cases run by this invocation.
    pub ran: usize,
    /// Of those, the ones that failed.
    pub failed: usize,
    /// Whether no line has a try left.
    pub finished: bool,
    /// Cases of the current round another process is running (the sweep stopped to wait).
    pub elsewhere: usize,
}

/// Runs (or resumes) the tries of `sweep` over its grid `cases` grouped into `template` (from
/// [`lines`]), round by round, until no line has a try left; `log` gets one line per round.
///
/// # Errors
/// A round that cannot run (the runner refuses a case, one needs too much memory, the store
/// fails).
pub fn run_tries(
    sweep: &SweepSpec,
    cases: &[PlannedCase],
    template: &[TryLine],
    runner: &dyn CaseRunner,
    opts: &SweepOptions,
    log: &mut dyn FnMut(&str),
) -> Result<TriesSummary, SweepError> {
    let mut summary = TriesSummary {
        lines: template.iter().filter(|l| l.run).count(),
        grid: template
            .iter()
            .filter(|l| l.run)
            .map(|l| l.tries.len())
            .sum(),
        ..TriesSummary::default()
    };
    // a failed case is retried once, in the first round
    let mut retry_failed = opts.retry_failed;
    let state = loop {
        let lookup = &mut |ids: &[&str]| stored_outcomes(&opts.db, ids);
        let state = replay(sweep, cases, template.to_vec(), retry_failed, lookup)?;
        // the sweep's cases in the store: every try of a line still trying (the later ones
        // pending), up to the one that met `until` on the others (also when nothing is left to
        // run: a grid run of the same file registered every case); the round runs the current
        register(&opts.db, sweep, cases, &state)?;
        if state.finished() {
            break state;
        }
        let round: Vec<PlannedCase> = state.round().iter().map(|&i| cases[i].clone()).collect();
        summary.rounds += 1;
        log(&format!(
            "tries {}: round {}, {} line(s) still trying, {} met",
            sweep.name,
            summary.rounds,
            round.len(),
            state
                .lines
                .iter()
                .filter(|l| l.run && l.met.is_some())
                .count()
        ));
        let round_opts = SweepOptions {
            retry_failed,
            keep_links: true,
            ..opts.clone()
        };
        retry_failed = false;
        let s = run_sweep(sweep, &round, runner, &round_opts)?;
        summary.ran += s.ran;
        summary.failed += s.failed;
        if s.ran == 0 {
            // nothing could run: the round's open cases are another process's
            summary.elsewhere = s.elsewhere;
            break state;
        }
    };
    summary.met = state
        .lines
        .iter()
        .filter(|l| l.run && l.met.is_some())
        .count();
    summary.finished = state.finished();
    summary.tried = state.tried().len();
    Ok(summary)
}

/// Makes the sweep's cases in the database at `db` those of [`TriesState::registered`].
fn register(
    db: &std::path::Path,
    sweep: &SweepSpec,
    cases: &[PlannedCase],
    state: &TriesState,
) -> Result<(), SweepError> {
    let listed: Vec<PlannedCase> = state
        .registered()
        .iter()
        .map(|&i| cases[i].clone())
        .collect();
    let mut store = Store::open(db)?;
    let id = store.register_sweep(sweep)?;
    store.add_cases(id, &listed)?;
    Ok(())
}

/// The swept paths the tries run over: `over`, with its zip partners.
fn tried_paths(sweep: &SweepSpec, spec: &TriesSpec) -> Vec<String> {
    sweep
        .zips
        .iter()
        .find(|g| g.iter().any(|a| a.path == spec.over))
        .map_or_else(
            || vec![spec.over.clone()],
            |g| g.iter().map(|a| a.path.clone()).collect(),
        )
}

/// `until` names an outcome kind the classifier can give.
fn check_kind(sweep: &SweepSpec, spec: &TriesSpec) -> Result<(), ConfigError> {
    if let Until::Kind(k) = &spec.until {
        if !OutcomeKind::ALL.iter().any(|o| o.as_str() == k) {
            let kinds: Vec<&str> = OutcomeKind::ALL.iter().map(|o| o.as_str()).collect();
            return Err(ConfigError::Sweep {
                file: sweep.file.clone(),
                field: "tries.until".into(),
                message: format!("`{k}` is not an outcome kind ({})", kinds.join(", ")),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::sweep::expand;

    const SWEEP: &str = r#"
        name = "t"
        [base]
        fluid = { model = "giesekus", alpha = 0.01, beta = 0.1, wi = 1.0 }
        geometry.confined_shear = { h = 1.0, l = 4.0 }
        particles = { radius = 0.1, layout.string = { n = 2, lx = 0.5, ly = 0.1 } }
        numerics = { mesh = [40, 10], dt = 0.01, t_end = 1.0 }
        [axes]
        particles.layout.string.ly = [0.1, 0.05]
        fluid.wi = [1, 2, 3]
        [tries]
        over = "particles.layout.string.ly"
        until = "string"
    "#;

    #[test]
    fn a_plain_axis_tried_in_its_order_on_each_combination_of_the_others() {
        let sweep = SweepSpec::from_str(SWEEP, false, Path::new("t.toml")).unwrap();
        let cases = expand(&sweep).unwrap();
        let lines = lines(&sweep, &cases).unwrap();
        // the axes expand sorted by path (wi slowest): each line is two neighbours, in the
        // written order of ly
        let got: Vec<(&str, &[usize])> = lines
            .iter()
            .map(|l| (l.label.as_str(), l.tries.as_slice()))
            .collect();
        assert_eq!(
            got,
            [
                ("wi=1", &[0, 1][..]),
                ("wi=2", &[2, 3][..]),
                ("wi=3", &[4, 5][..])
            ]
        );
        // with nothing stored every line's first try is the round, and the tries so far
        let state = replay(&sweep, &cases, lines, false, &mut |_: &[&str]| {
            Ok::<_, ConfigError>(Outcomes::new())
        })
        .unwrap();
        assert!(cases[0].label.contains("ly=0.1") && cases[1].label.contains("ly=0.05"));
        assert_eq!(
            (state.round(), state.tried()),
            (vec![0, 2, 4], vec![0, 2, 4])
        );
        // no line has met `until`: the database lists every try
        assert_eq!(state.registered(), (0..6).collect::<Vec<_>>());
        assert!(!state.finished());
    }
}
