//! The state of a search, rebuilt from what the store holds: round 1 is the coarse values of every
//! line (combination of the other axes); round k + 1 is [`next_values`] of what rounds 1 … k gave.
//! The replay stops at the first round with a case not finished yet (the round to run now) or when
//! no line has a value left to try (the search is over). A killed search therefore continues with
//! the same cases it would have run, and cases already done are never run again.

use std::collections::HashMap;

use serde_json::Value;

use super::bracket::{coarse_values, next_values, Point};
use crate::config::{Axis, ConfigError, PlannedCase, SearchSpec, SpecError, SweepSpec};
use crate::store::StoredOutcome;
use crate::sweep::expand::{combinations, plan_case, swept_axes, Labels};

/// One value of a line as the store has it.
#[derive(Debug, Clone, PartialEq)]
pub struct LinePoint {
    /// Value of the searched axis.
    pub value: f64,
    /// Index of its case in [`SearchState::cases`].
    pub case: usize,
    /// The stored outcome kind and string length; `None` while unfinished, or for a failed case.
    pub outcome: Option<(String, Option<i64>)>,
    /// Whether its case is finished (done or failed).
    pub finished: bool,
}

/// One combination of the other axes and the values searched on it.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// Label of the combination (`base` without other axes).
    pub label: String,
    /// Its assignments of the other axes.
    pub params: Vec<(String, Value)>,
    /// Its values in the order they were planned (coarse first).
    pub points: Vec<LinePoint>,
}

impl Line {
    /// Its points sorted by value, with the class of each finished outcome under `spec.change`.
    pub fn sorted_points(&self, spec: &SearchSpec) -> Vec<(Point, &LinePoint)> {
        let mut v: Vec<(Point, &LinePoint)> = self
            .points
            .iter()
            .map(|p| {
                let class = p
                    .outcome
                    .as_ref()
                    .map(|(kind, len)| spec.change.class_of(kind, *len));
                (
                    Point {
                        value: p.value,
                        class,
                    },
                    p,
                )
            })
            .collect();
        v.sort_by(|a, b| a.0.value.total_cmp(&b.0.value));
        v
    }
}

/// Where a search stands.
#[derive(Debug, Clone)]
pub struct SearchState {
    /// Every case planned so far, round after round (index = position).
    pub cases: Vec<PlannedCase>,
    /// The lines, in expansion order of the other axes.
    pub lines: Vec<Line>,
    /// Rounds planned (the last one is the current one unless the search is over).
    pub rounds: usize,
    /// Whether every planned case is finished and no line has a value left to try.
    pub finished: bool,
}

impl SearchState {
    /// Cases of the current round that are not finished.
    pub fn open_cases(&self) -> usize {
        self.lines
            .iter()
            .flat_map(|l| &l.points)
            .filter(|p| !p.finished)
            .count()
    }
}

/// The stored status and outcome of given case ids (absent: not in the database).
pub type Outcomes = HashMap<String, StoredOutcome>;

/// Rebuilds the state of the search of `sweep` (which must have a `[search]` section) from the
/// stored outcomes that `lookup` returns for given case ids. With a `lookup` that knows nothing,
/// this is the coarse round: what `--dry-run` lists, and the validation before anything runs.
///
/// # Errors
/// A case that is invalid (file, case index and label, field), two lines giving the same case,
/// or more than `max_cases` cases in the worst case (lines × budget); and whatever `lookup`
/// returns, as `E`.
pub fn replay<E: From<ConfigError>>(
    sweep: &SweepSpec,
    max_cases: usize,
    lookup: &mut dyn FnMut(&[&str]) -> Result<Outcomes, E>,
) -> Result<SearchState, E> {
    let Some(spec) = &sweep.search else {
        return Err(ConfigError::Sweep {
            file: sweep.file.clone(),
            field: "search".into(),
            message: "this sweep has no [search] section".into(),
        }
        .into());
    };
    let combos = combinations(sweep, max_cases, spec.budget)?;
    let search_axis = label_axis(spec);
    let mut axes = swept_axes(sweep);
    axes.push(&search_axis);
    let labels = Labels::new(&axes);
    let mut lines: Vec<Line> = combos
        .into_iter()
        .map(|params| Line {
            label: labels.of(&params),
            params,
            points: Vec::new(),
        })
        .collect();
    let mut cases: Vec<PlannedCase> = Vec::new();
    let mut proposals: Vec<Vec<f64>> = vec![coarse_values(spec); lines.len()];
    let mut rounds = 0;
    loop {
        let start = cases.len();
        for (line, values) in lines.iter_mut().zip(&proposals) {
            for &v in values {
                let mut params = line.params.clone();
                params.push((spec.axis.clone(), Value::from(v)));
                let case = plan_case(sweep, &labels, cases.len(), params)?;
                line.points.push(LinePoint {
                    value: v,
                    case: cases.len(),
                    outcome: None,
                    finished: false,
                });
                cases.push(case);
            }
        }
        if cases.len() == start {
            return Ok(SearchState {
                cases,
                lines,
                rounds,
                finished: true,
            });
        }
        rounds += 1;
        if rounds == 1 {
            refuse_twins(sweep, &cases)?;
        }
        let ids: Vec<&str> = cases[start..].iter().map(|c| c.id.as_str()).collect();
        let stored = lookup(&ids)?;
        let mut open = false;
        for p in lines.iter_mut().flat_map(|l| &mut l.points) {
            if p.case < start {
                continue;
            }
            match stored.get(&cases[p.case].id) {
                Some(o) if o.status == "done" || o.status == "failed" => {
                    p.finished = true;
                    p.outcome = o.kind.clone().map(|k| (k, o.string_length));
                }
                _ => open = true,
            }
        }
        if open {
            return Ok(SearchState {
                cases,
                lines,
                rounds,
                finished: false,
            });
        }
        proposals = lines
            .iter()
            .map(|line| {
                let points: Vec<Point> = line
                    .sorted_points(spec)
                    .into_iter()
                    .map(|(p, _)| p)
                    .collect();
                next_values(&points, spec, spec.budget.saturating_sub(line.points.len()))
            })
            .collect();
    }
}

/// A stand-in axis for the labels: the searched values are not known in advance, so the label
/// digits are those that tell apart the finest values a search can choose near either end.
fn label_axis(spec: &SearchSpec) -> Axis {
    let step = spec.tol / (2.0 * (spec.per_bracket + 1) as f64);
    Axis {
        path: spec.axis.clone(),
        values: [spec.lo, spec.lo + step, spec.hi - step, spec.hi]
            .into_iter()
            .map(Value::from)
            .collect(),
    }
}

/// Two combinations of the other axes that give the same case would search one line twice.
fn refuse_twins(sweep: &SweepSpec, cases: &[PlannedCase]) -> Result<(), ConfigError> {
    let mut seen: HashMap<&str, usize> = HashMap::new();
    for c in cases {
        if let Some(&twin) = seen.get(c.id.as_str()) {
            let first = swept_axes(sweep)
                .first()
                .map_or(String::new(), |a| a.path.clone());
            return Err(ConfigError::Case {
                file: sweep.file.clone(),
                index: c.index,
                label: c.label.clone(),
                error: SpecError::new(
                    first,
                    format!(
                        "identical to case {} ({}); remove the duplicate axis value",
                        twin, cases[twin].label
                    ),
                ),
            });
        }
        seen.insert(&c.id, c.index);
    }
    Ok(())
}
