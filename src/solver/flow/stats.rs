//! What the flow solves cost: the phases of the last solve ([`Timings`]) and the counts over a
//! run ([`FlowSolverStats`]).

/// Wall-clock seconds spent in the phases of the last solve.
#[derive(Debug, Clone, Copy, Default)]
pub struct Timings {
    /// Element loop and scatter.
    pub assembly: f64,
    /// Symbolic analysis (only on the first solve).
    pub symbolic: f64,
    /// New placement of the band ([`FlowFactorization::Band`](super::FlowFactorization::Band)): far-field factorization and
    /// condensation, band analysis.
    pub placement: f64,
    /// Numeric factorization.
    pub numeric: f64,
    /// Triangular solves and residual check.
    pub solve: f64,
}

/// What the flow solves of a run cost beyond their factorizations: the iterations of GMRES
/// (the symmetric-part preconditioner of a semi-implicit stress, or a polish of an inaccurate
/// direct solve) and the switches to faer's LU (`fem::linsolve`).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct FlowSolverStats {
    /// Flow solves.
    pub solves: usize,
    /// GMRES iterations over all solves.
    pub krylov_iterations: usize,
    /// Switches of the symmetric-part solver to a whole LU (each lasts for its pattern).
    pub lu_fallbacks: usize,
    /// Numeric factorizations of the flow matrix (the whole matrix's, or the band's).
    pub factorizations: usize,
    /// Pattern (and symbolic analysis) rebuilds: a particle left the reach of its pattern.
    pub pattern_rebuilds: usize,
    /// Placements of the band solver ([`FlowFactorization::Band`](super::FlowFactorization::Band): far-field factorizations,
    /// each about a whole factorization and a condensation onto the band's interface).
    pub placements: usize,
    /// Factorizations without pivots (the whole matrix's, the band's M and K) whose solve missed
    /// the residual tolerance, redone with pivoting (`fem::linsolve::unpivoted`; left out of the
    /// serialized form when none).
    #[serde(skip_serializing_if = "is_zero")]
    pub pivoted_refactors: usize,
    /// Solves with at least one film corrected by [`StokesParams::lubrication`](super::StokesParams::lubrication) (left out of
    /// the serialized form when none).
    #[serde(skip_serializing_if = "is_zero")]
    pub lubricated_solves: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}
