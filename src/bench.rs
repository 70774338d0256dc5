//! Performance benchmarks behind `xpflow bench` (results recorded in docs/performance.md).

use std::time::Instant;

use crate::fem::linsolve::{SolveError, SolverKind};
use crate::mesh::{Axis, Mesh, Side};
use crate::solver::stokes::{Stokes, StokesParams, Timings};

/// Result of the Stokes benchmark.
#[derive(Debug, Clone)]
pub struct StokesBench {
    /// Mesh label.
    pub mesh: String,
    /// Solver used.
    pub solver: SolverKind,
    /// Whether DEVSS-G unknowns were included.
    pub with_g: bool,
    /// Unknowns.
    pub unknowns: usize,
    /// Stored non-zeros (both triangles).
    pub nnz: usize,
    /// Pattern construction (seconds).
    pub pattern: f64,
    /// Timings of the first solve (includes the symbolic analysis).
    pub first: Timings,
    /// Median timings of the repeated solves (numeric refactorization reusing the symbolic analysis).
    pub repeat: Timings,
    /// Peak resident memory of the process after the runs (MB), if readable.
    pub peak_rss_mb: Option<f64>,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Stokes solve on the periodic channel [−15, 15] × [−2, 2] (the Ch. 2 benchmark box) with
/// `nx × ny` elements, graded toward the centre, sliding walls and a body force; the first solve
/// does the symbolic analysis, the `repeats` further solves only assemble, refactor and solve.
pub fn stokes(
    nx: usize,
    ny: usize,
    solver: SolverKind,
    with_g: bool,
    repeats: usize,
) -> Result<StokesBench, SolveError> {
    let t = Instant::now();
    let mesh = Mesh::rectangle(
        Axis::graded(-15.0, 15.0, nx, 0.0, 2.0),
        Axis::graded(-2.0, 2.0, ny, 0.0, 1.0),
        true,
    );
    let mut st = Stokes::new(
        mesh,
        StokesParams::new(0.59, if with_g { 0.41 } else { 0.0 }, solver),
    );
    let pattern = t.elapsed().as_secs_f64();
    st.set_velocity(Side::Bottom, |_| [-0.5, 0.0]);
    st.set_velocity(Side::Top, |_| [0.5, 0.0]);
    st.pin_pressure();
    let force = |x: [f64; 2]| [1.0 + 0.1 * x[1], 0.05 * (x[0] * 0.2).sin()];
    st.solve(&force)?;
    let first = st.timings;
    let mut runs = Vec::new();
    for _ in 0..repeats {
        // a slightly different viscosity each time, so that the matrix changes and the numeric
        // refactorization is measured (an unchanged matrix reuses the factorization)
        st.params.eta *= 1.0 + 1e-3;
        st.solve(&force)?;
        runs.push(st.timings);
    }
    let repeat = Timings {
        assembly: median(runs.iter().map(|r| r.assembly).collect()),
        symbolic: 0.0,
        numeric: median(runs.iter().map(|r| r.numeric).collect()),
        solve: median(runs.iter().map(|r| r.solve).collect()),
    };
    let (unknowns, nnz) = st.size();
    Ok(StokesBench {
        mesh: format!("{nx}x{ny}"),
        solver,
        with_g,
        unknowns,
        nnz,
        pattern,
        first,
        repeat,
        peak_rss_mb: peak_rss_mb(),
    })
}

/// Peak resident set size of this process in MB (Linux `VmHWM`).
pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

impl std::fmt::Display for StokesBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "stokes {} {:?}{}: unknowns {}, nnz {}",
            self.mesh,
            self.solver,
            if self.with_g { " +G" } else { "" },
            self.unknowns,
            self.nnz
        )?;
        writeln!(f, "  pattern            {:9.4} s", self.pattern)?;
        writeln!(f, "  assembly           {:9.4} s", self.repeat.assembly)?;
        writeln!(f, "  symbolic           {:9.4} s", self.first.symbolic)?;
        writeln!(f, "  numeric (first)    {:9.4} s", self.first.numeric)?;
        writeln!(f, "  numeric (refactor) {:9.4} s", self.repeat.numeric)?;
        writeln!(f, "  solve              {:9.4} s", self.repeat.solve)?;
        writeln!(
            f,
            "  step (asm+refactor+solve) {:9.4} s",
            self.repeat.assembly + self.repeat.numeric + self.repeat.solve
        )?;
        match self.peak_rss_mb {
            Some(m) => write!(f, "  peak RSS           {m:9.0} MB"),
            None => write!(f, "  peak RSS           n/a"),
        }
    }
}
