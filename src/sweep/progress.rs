//! Progress display: indicatif bars (an overall bar and one per running case: label, simulated time,
//! steps/s, ETA) on a terminal, a plain one-line-per-event log otherwise, or nothing (`--quiet`).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Resolution of a case bar (positions per t_end).
const CASE_BAR_LEN: u64 = 1000;
/// Minimum interval between redraws of a case bar, so that fast steps do not spend time drawing.
const REDRAW_INTERVAL: Duration = Duration::from_millis(100);

/// How progress is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProgressMode {
    /// Bars on the terminal.
    Bars,
    /// One line per event on stdout.
    Plain,
    /// Nothing.
    Quiet,
}

impl ProgressMode {
    /// Bars if stdout is a terminal, else plain; quiet if asked.
    pub fn detect(quiet: bool) -> ProgressMode {
        use std::io::IsTerminal;
        if quiet {
            ProgressMode::Quiet
        } else if std::io::stdout().is_terminal() {
            ProgressMode::Bars
        } else {
            ProgressMode::Plain
        }
    }
}

/// Progress of a whole sweep; shared by the worker threads.
pub struct Progress {
    mode: ProgressMode,
    multi: MultiProgress,
    overall: ProgressBar,
    total: usize,
    /// Cases started so far: the number a case has in the log, from its start to its end.
    started: AtomicUsize,
    finished: AtomicUsize,
}

/// Progress of one running case.
pub struct CaseProgress {
    bar: Option<ProgressBar>,
    /// The case's number in the log ([k/N] on its start and done lines).
    number: usize,
    label: String,
    t_end: f64,
    started: Instant,
    last_draw: Instant,
    /// Time of the last update and the step that led to it (Δt, shown: it varies with an
    /// adaptive step).
    last_t: Option<f64>,
    dt: f64,
}

impl Progress {
    /// Progress over `total` cases to run.
    pub fn new(mode: ProgressMode, total: usize) -> Progress {
        let multi = MultiProgress::with_draw_target(if mode == ProgressMode::Bars {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        });
        let overall = multi.add(ProgressBar::new(total as u64));
        overall.set_style(
            ProgressStyle::with_template(
                "{prefix:>8} [{bar:40}] {pos}/{len} cases, {elapsed} elapsed, ETA {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        overall.set_prefix("sweep");
        Progress {
            mode,
            multi,
            overall,
            total,
            started: AtomicUsize::new(0),
            finished: AtomicUsize::new(0),
        }
    }

    /// A line of the plain log (also printed above the bars).
    pub fn log(&self, line: &str) {
        match self.mode {
            ProgressMode::Bars => self.multi.println(line).unwrap_or(()),
            ProgressMode::Plain => println!("{line}"),
            ProgressMode::Quiet => {}
        }
    }

    /// A case starts.
    pub fn start_case(&self, label: &str, id: &str, t_end: f64) -> CaseProgress {
        let bar = (self.mode == ProgressMode::Bars).then(|| {
            let b = self.multi.add(ProgressBar::new(CASE_BAR_LEN));
            b.set_style(
                ProgressStyle::with_template("{prefix:>8} [{bar:40}] {msg} ETA {eta}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            b.set_prefix(id[..8.min(id.len())].to_string());
            b.set_message(label.to_string());
            b
        });
        let number = self.started.fetch_add(1, Ordering::Relaxed) + 1;
        if self.mode == ProgressMode::Plain {
            println!("[{number}/{}] start  {label} ({id})", self.total);
        }
        let now = Instant::now();
        CaseProgress {
            bar,
            number,
            label: label.to_string(),
            t_end,
            started: now,
            last_draw: now,
            last_t: None,
            dt: 0.0,
        }
    }

    /// A case ended with `summary` (outcome or error).
    pub fn finish_case(&self, case: CaseProgress, summary: &str) {
        let n = self.finished.fetch_add(1, Ordering::Relaxed) + 1;
        if let Some(b) = &case.bar {
            b.finish_and_clear();
            self.multi.remove(b);
        }
        self.overall.inc(1);
        let line = self.done_line(&case, n, summary);
        self.log(&line);
    }

    /// The log line of a case that ended as the `finished`-th: numbered as it started.
    fn done_line(&self, case: &CaseProgress, finished: usize, summary: &str) -> String {
        format!(
            "[{}/{}] done   {}: {summary} ({:.1} s; {finished} of {} finished)",
            case.number,
            self.total,
            case.label,
            case.started.elapsed().as_secs_f64(),
            self.total
        )
    }

    /// The sweep ended.
    pub fn finish(&self) {
        self.overall.finish_and_clear();
    }
}

impl CaseProgress {
    /// The case's label.
    pub fn label(&self) -> &str {
        &self.label
    }

    /// Simulated time `t` reached after `step` steps.
    pub fn update(&mut self, t: f64, step: u64) {
        if let Some(last) = self.last_t.replace(t) {
            self.dt = t - last;
        }
        let Some(bar) = &self.bar else { return };
        if self.last_draw.elapsed() < REDRAW_INTERVAL {
            return;
        }
        self.last_draw = Instant::now();
        let rate = step as f64 / self.started.elapsed().as_secs_f64().max(1e-9);
        bar.set_position(((t / self.t_end).clamp(0.0, 1.0) * CASE_BAR_LEN as f64) as u64);
        bar.set_message(format!(
            "{} t={t:.3}/{} Δt={:.4} {rate:.1} steps/s",
            self.label, self.t_end, self.dt
        ));
    }

    /// The case's prelude (an extrusion's undisturbed flow to its steady surface, before the
    /// case's time starts) reached time `t` after `steps` steps: said as such, the bar at 0.
    pub fn prelude(&mut self, t: f64, steps: usize) {
        let Some(bar) = &self.bar else { return };
        if self.last_draw.elapsed() < REDRAW_INTERVAL {
            return;
        }
        self.last_draw = Instant::now();
        bar.set_message(format!(
            "{} prelude (undisturbed flow to the steady surface): t={t:.3} after {steps} steps",
            self.label
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two cases started before either ends have two numbers, and each keeps its number when it
    /// ends, whatever the order (issue 28: the log numbered two different cases "[1/4] start").
    #[test]
    fn each_case_keeps_its_number_from_start_to_end() {
        let p = Progress::new(ProgressMode::Quiet, 4);
        let a = p.start_case("wi=1", "aaaaaaaaaaaaaaaa", 1.0);
        let b = p.start_case("wi=2", "bbbbbbbbbbbbbbbb", 1.0);
        assert_eq!((a.number, b.number), (1, 2));
        let line = p.done_line(&b, 1, "string");
        assert!(line.starts_with("[2/4] done   wi=2: string"), "{line}");
        assert!(line.ends_with("1 of 4 finished)"), "{line}");
    }
}
