//! The symmetric-part path timed against a whole LU, once per flow.
//!
//! GMRES on the symmetric part (see [`super::symmetric_part`]) needs 2–3 iterations on the
//! semi-implicit flow of confined shear, but 9–13 on a stretched extrudate (UCM, De = 1.25) and
//! ≈ 12 with G solved with the flow; on small systems a whole LU can then be the cheaper solve.
//! So after a slow solve the next factorization is a whole LU, timed against the symmetric
//! part's factorization and solve, and the cheaper stays ([`Probe`]).
//!
//! The probe is not free: faer's LU reserves the structure of the Cholesky factor of AᵀA, and on
//! large systems that costs more than all the steps it could save. On the a/3 die of an
//! extrusion with G solved with the flow (133 000 unknowns) one probe took ≈ 60 s, most of it
//! the kernel zeroing the pages of the LU's factor, against ≈ 2.5 s per symmetric-part solve
//! (`perf` of `xpflow run`, 2026-12-06) — and a flow whose pattern is rebuilt (the free surface
//! or the particles crossing element rows) used to probe again after every rebuild. Hence:
//! - systems above [`PROBE_MAX_UNKNOWNS`] never probe;
//! - the verdict outlives the solver: a flow hands it to the solver of its rebuilt pattern
//!   ([`DirectSolver::probe_verdict`], [`DirectSolver::settle`]).

use super::symmetric_part::SymmetricPart;
use super::{lu_backend, Backend, DirectSolver, SolveError};
use crate::fem::sparse::SparseMatrix;
use dyn_stack::MemBuffer;

/// GMRES iterations on the symmetric part above which a whole LU is timed once against it (a
/// few iterations always win; on small or strongly non-symmetric systems the LU may).
pub(super) const PROBE_ITERATIONS: usize = 5;

/// Unknowns above which the symmetric part is never timed against a whole LU. Measured: at
/// 16 000 unknowns (the swell at h = 0.05, 9–13 iterations) the symmetric part took 0.29–0.37 s
/// per solve against the LU's 0.68–0.82 s; at 23 000 the LU's factorization alone is 10× the
/// LBLᵀ's (1.32 s against 0.13 s), at 112 000 25× (13.4 s against 0.55 s; docs/performance.md
/// "The semi-implicit flow"), so beyond this size even [`super::MAX_POLISH_ITERATIONS`]
/// iterations (each a pair of triangular solves, a fraction of a factorization) cost less.
pub const PROBE_MAX_UNKNOWNS: usize = 20_000;

/// Whether the symmetric-part path has been timed against a whole LU.
pub(super) enum Probe {
    /// Few iterations so far: nothing to compare.
    Watching,
    /// The last solve took many iterations at `symmetric_cost` seconds (factor + solve): the
    /// next factorization is a whole LU, timed.
    Pending { symmetric_cost: f64 },
    /// The LU is being timed; the symmetric part waits.
    Probing {
        symmetric_cost: f64,
        parked: Box<SymmetricPart>,
    },
    /// Compared (or no comparison applies): the backend stays.
    Decided,
}

impl Probe {
    /// The state of a new solver of `n` unknowns: watching, or decided above
    /// [`PROBE_MAX_UNKNOWNS`].
    pub(super) fn initial(n: usize) -> Probe {
        if n > PROBE_MAX_UNKNOWNS {
            Probe::Decided
        } else {
            Probe::Watching
        }
    }
}

/// What the comparison decided, for the solver of a rebuilt pattern of the same flow.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProbeVerdict {
    /// GMRES on the symmetric part.
    SymmetricPart,
    /// A whole LU (it was cheaper, or the symmetric part failed).
    Lu,
}

impl DirectSolver {
    /// The symmetric-part path's verdict once it has one (`None` while it watches, and for
    /// solvers analysed as LBLᵀ or LU).
    pub fn probe_verdict(&self) -> Option<ProbeVerdict> {
        match (&self.probe, &self.backend) {
            (Probe::Decided, Backend::SymmetricPart(_)) => Some(ProbeVerdict::SymmetricPart),
            (Probe::Decided, Backend::Lu { .. }) if self.lu_fallbacks > 0 => Some(ProbeVerdict::Lu),
            _ => None,
        }
    }

    /// Takes the `verdict` of an earlier solver of the same flow on `a`'s (new) pattern: no
    /// probe again; for [`ProbeVerdict::Lu`] the LU from the start. A solver that is not on the
    /// symmetric-part path is left as it is.
    ///
    /// # Errors
    /// [`SolveError::Symbolic`] if the LU's symbolic analysis fails.
    pub fn settle(&mut self, verdict: ProbeVerdict, a: &SparseMatrix) -> Result<(), SolveError> {
        if !matches!(self.backend, Backend::SymmetricPart(_)) {
            return Ok(());
        }
        if verdict == ProbeVerdict::Lu {
            let (backend, req) = lu_backend(a)?;
            self.backend = backend;
            self.buffer = MemBuffer::new(req);
            self.factored = false;
        }
        self.probe = Probe::Decided;
        Ok(())
    }

    /// After a solve on the symmetric-part path with `polish` GMRES iterations at `cost`
    /// seconds (factor + solve): start, finish or skip the comparison with a whole LU.
    pub(super) fn record_probe(&mut self, polish: usize, cost: f64) {
        match std::mem::replace(&mut self.probe, Probe::Decided) {
            Probe::Watching
                if polish > PROBE_ITERATIONS
                    && matches!(self.backend, Backend::SymmetricPart(_)) =>
            {
                self.probe = Probe::Pending {
                    symmetric_cost: cost,
                }
            }
            Probe::Probing {
                symmetric_cost,
                parked,
            } if symmetric_cost < cost => {
                // the symmetric part was cheaper: back to it
                self.backend = Backend::SymmetricPart(parked);
            }
            Probe::Probing { .. } => self.lu_fallbacks += 1,
            other => self.probe = other,
        }
    }
}
