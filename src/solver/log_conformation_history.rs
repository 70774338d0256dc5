//! The time levels of the log-conformation `s` that the BDF2 transport
//! ([`LogConformationTransport`](super::constitutive::LogConformationTransport)) steps from,
//! with the size of the last step for the variable-step coefficients ([`Bdf2`]).

use crate::rheology::Sym2;
use crate::solver::bdf::Bdf2;

/// The time levels of `s` the BDF2 scheme needs, per Q1 vertex. Public so that a temporary ALE
/// map can move both levels onto the current mesh before a step.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LogConformationHistory {
    /// `sⁿ`.
    pub current: Vec<Sym2>,
    /// `s^{n−1}` (`None` before the first step: that one is Euler).
    pub previous: Option<Vec<Sym2>>,
    steps: usize,
    /// Δt of the last step (from s^{n−1} to sⁿ), for the variable-step coefficients of the next;
    /// `None` before the first step (and in states saved before steps could vary: then the
    /// next step is taken as of the same size).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    last_dt: Option<f64>,
}

impl LogConformationHistory {
    /// The stress-free state `s = 0` (`c = I`) on `n_vertices` vertices.
    pub fn at_rest(n_vertices: usize) -> Self {
        Self::from_field(vec![Sym2::ZERO; n_vertices])
    }

    /// Starts from a given field `s⁰` (no earlier level: the first step is Euler).
    pub fn from_field(s0: Vec<Sym2>) -> Self {
        Self {
            current: s0,
            previous: None,
            steps: 0,
            last_dt: None,
        }
    }

    /// Number of steps taken.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Ends a step of size `dt` with its solution: s^{n−1} ← sⁿ, sⁿ ← `next`.
    pub fn push(&mut self, next: Vec<Sym2>, dt: f64) {
        self.previous = Some(std::mem::replace(&mut self.current, next));
        self.steps += 1;
        self.last_dt = Some(dt);
    }

    /// Ends a step of size `dt` in which `s` did not change (a fluid without polymer: s = 0
    /// throughout), without copying the fields.
    pub fn push_unchanged(&mut self, dt: f64) {
        self.steps += 1;
        self.last_dt = Some(dt);
    }

    /// Δt of the last step (`None` before the first, or unknown in an old saved state).
    pub fn last_dt(&self) -> Option<f64> {
        self.last_dt
    }

    /// The BDF2 coefficients of a step `dt` from these levels: Euler without s^{n−1}, else
    /// variable-step BDF2 after the last step (taken as `dt` when unknown).
    pub fn bdf2(&self, dt: f64) -> Bdf2 {
        match self.previous {
            None => Bdf2::EULER,
            Some(_) => Bdf2::after(dt, Some(self.last_dt.unwrap_or(dt))),
        }
    }
}
