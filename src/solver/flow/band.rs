//! The flow solve by substructuring ([`FlowFactorization::Band`]): the matrix changes from step
//! to step only near the particles (their reach, where elements may be cut, and the elements
//! whose coordinates may move), so a band around them is factored every step and the far field
//! once per placement of the band ([`Substructured`]). The band is the elements that change
//! widened by [`BAND_MARGIN`] ring, so that every entry that changes (a changing element's, or a
//! ghost-penalty face's) couples band dofs only — those on the band's boundary Γ included, whose
//! changes enter M's Γ block directly; a new placement is made whenever the far field's entries
//! differ (bitwise) from those it was factored with — after a pattern rebuild or a moved mesh
//! outside the band.

use std::time::Instant;

use super::cache::assembled_each_step;
use super::dofs::{element_dofs, MAX_EL_DOFS};
use super::{FlowFactorization, Stokes, RESIDUAL_TOL};
use crate::fem::linsolve::SolveError;
use crate::fem::substructure::Substructured;
use crate::mesh::dilate;
use crate::solver::rigid::ElementCut;

/// Rings of elements added around the elements that may change: one, for the ghost-penalty
/// faces next to them (which couple the neighbouring element's dofs). The band's boundary dofs
/// Γ may belong to changing entries ([`Substructured`] takes A_ΓΓ's changes into M's Γ block);
/// a second ring, which kept them off changing entries, made the band's factorization 1.25×
/// dearer (200×50, three particles).
const BAND_MARGIN: usize = 1;

/// How deep inside a particle, in rings of elements, an element lies whose dofs M takes as
/// inert: their couplings, zeros that the pattern stores so that a moving particle does not
/// change it, are left out of M's pattern ([`Substructured::with_interface`]; it checks at every
/// step that they are still zero, and a new placement follows when one is not). Depth is taken
/// in the particle at its centre and at the end of its reach's stretch
/// ([`Reach::stays_inside`](super::reach::Reach::stays_inside)), so that a fast particle's inert
/// elements stay inside while its stretched pattern lasts; a slow one travels about two
/// elements (the pattern's rigid reach) before its pattern is rebuilt, so at two rings a
/// placement comes at most a little before the rebuild's own. a/12, three particles (300×78
/// graded, t* ≤ 0.6, 18 steps, before the stretch): M's factorization median 0.189 s with no
/// inert dofs, 0.146 s at three rings, 0.123 s at two, 0.107 s at one — but at one ring 6
/// placements instead of 4. With the stretch (2026-12-07, `xpflow bench moving --sweep
/// sweeps/beta_near_contact.toml`, 60 steps): two rings against three, M 0.220 → 0.198 s from
/// rest at a/12 and 0.230 → 0.206 s on the β = 0.3 a/16 string forming, the same placements
/// (5 and 2), and the Couette case's (one particle) unchanged.
const INERT_DEPTH: usize = 2;

/// Largest fraction of the elements in the band for which substructuring pays (beyond it the
/// band's own factorization costs about what the whole one does, and the far field's is extra):
/// a larger band falls back to [`FlowFactorization::Whole`].
pub const BAND_FRACTION_LIMIT: f64 = 0.5;

/// Largest interface |Γ| for which the band pays, in units of √(number of dofs). M's dense Γ
/// block costs ∝ |Γ|³ per step, the whole matrix's factorization (nested dissection, 2D)
/// ∝ n^1.5, so they meet at |Γ| ∝ √n. Measured on 200×50 (`xpflow bench moving --particles
/// 3,5,6,7,8`, n = 91 000, √n = 302), both factored without pivots, the flow's factorization and
/// solve of the band against the whole matrix's (2026-12-07, session 26): |Γ| ≈ 1050 = 3.5 √n
/// (three particles) 0.074 against 0.194 s, 2040 = 6.8 √n (six) 0.197 against 0.316 s at 661
/// against 300 MB, 2400 = 8.0 √n (seven) 0.245 against 0.272 s; eight (2600 = 8.6 √n, and
/// 2856 = 9.5 √n in session 25's layout) break even. The limit takes six particles and leaves
/// the marginal gain of seven for the memory. At 440×110 three particles have |Γ| = 1920 =
/// 2.9 √n.
pub const INTERFACE_LIMIT: f64 = 7.5;

/// Seconds of one factor-and-solve, by phase.
pub(super) struct SolveTimes {
    /// New placement: split, far-field factorization and condensation, band analysis.
    pub placement: f64,
    /// Numeric factorization (the band's, or the whole matrix's).
    pub numeric: f64,
    /// Triangular solves, residual check, polishing.
    pub solve: f64,
}

impl Stokes {
    /// Factors (when the values changed) and solves the assembled system with the band solver;
    /// `None` when there is no band to speak of (no particles, nothing moves, or the band holds
    /// more than [`BAND_FRACTION_LIMIT`] of the elements), when its interface is too large to pay
    /// ([`INTERFACE_LIMIT`], counted in `band_declines`) or the band solver failed (counted in
    /// `band_fallbacks`): the caller factors the whole matrix.
    pub(super) fn solve_by_band(&mut self) -> Result<Option<(f64, SolveTimes)>, SolveError> {
        debug_assert_eq!(self.params.factorization, FlowFactorization::Band);
        let t0 = Instant::now();
        // a new placement's K check counts with the solve's (its solver starts from zero)
        let mut pivoted_before = self
            .band_solver
            .as_ref()
            .map_or(0, |s| s.pivoted_refactors());
        if self
            .band_solver
            .as_ref()
            .is_none_or(|s| !s.fits(&self.matrix))
        {
            self.band_solver = None;
            pivoted_before = 0;
            let placement = (self.pattern_rebuilds, self.base_rebuilds);
            if self.band_declined == Some(placement) {
                return Ok(None);
            }
            let Some(band) = self.band_dofs() else {
                return Ok(None);
            };
            let interface = Substructured::interface(&self.matrix, &band);
            let n_gamma = interface.iter().filter(|&&g| g).count();
            if n_gamma as f64 > INTERFACE_LIMIT * (self.matrix.n() as f64).sqrt() {
                // the dense Γ block would cost more than the whole matrix: the whole matrix
                // then, until the band is placed anew
                self.band_declined = Some(placement);
                self.band_declines += 1;
                return Ok(None);
            }
            // the whole matrix's factorization is stale once the band solver takes over
            self.factored_values = None;
            let placed = Substructured::with_interface(
                &self.matrix,
                &band,
                &interface,
                &self.inert_dofs(),
                &self.dof_blocks(),
                RESIDUAL_TOL,
            );
            match placed {
                Ok(solver) => self.band_solver = Some(solver),
                Err(_) => {
                    // the whole matrix then, until the band moves
                    self.band_fallbacks += 1;
                    return Ok(None);
                }
            }
            self.placements += 1;
        }
        let t1 = Instant::now();
        let solver = self.band_solver.as_mut().expect("placed above");
        // (M keeps the values it was factored with: the whole matrix's are not copied)
        let solved = solver.factor(&self.matrix).and_then(|refactored| {
            let t2 = Instant::now();
            solver
                .solve_checked(&self.matrix, &self.rhs, &mut self.sol, RESIDUAL_TOL)
                .map(|res| (refactored, t2, res))
        });
        let Ok((refactored, t2, residual)) = solved else {
            // a band the factorization cannot take (the whole matrix pivots across it)
            self.band_solver = None;
            self.band_fallbacks += 1;
            return Ok(None);
        };
        self.refactorizations += usize::from(refactored);
        self.stats.pivoted_refactors += solver.pivoted_refactors() - pivoted_before;

        let times = SolveTimes {
            placement: (t1 - t0).as_secs_f64(),
            numeric: (t2 - t1).as_secs_f64(),
            solve: t2.elapsed().as_secs_f64(),
        };
        Ok(Some((residual, times)))
    }

    /// The inert dofs (per dof): those whose every element lies inside a particle (or beyond a
    /// free surface), also where the particle's stretched reach takes it
    /// ([`Reach::stays_inside`](super::reach::Reach::stays_inside)), [`INERT_DEPTH`] rings of
    /// elements or more from any element that is not.
    fn inert_dofs(&self) -> Vec<bool> {
        // inside a particle now and wherever its reach's stretch takes it
        let outside: Vec<bool> = self
            .cuts
            .iter()
            .enumerate()
            .map(|(e, c)| {
                !matches!(c, ElementCut::Inside)
                    || !self.reach.stays_inside(&self.mesh, &self.particles, e)
            })
            .collect();
        let near = dilate(&outside, self.mesh.dims(), self.mesh.periodic, INERT_DEPTH);
        let lay = self.layout;
        let mut inert = vec![false; lay.n_dofs()];
        let mut el = Vec::with_capacity(MAX_EL_DOFS);
        // the deep elements' dofs, then those shared with an element that is not deep
        for deep in [true, false] {
            for e in (0..near.len()).filter(|&e| near[e] != deep) {
                element_dofs(&self.mesh, &lay, e, &mut el);
                el.iter().for_each(|&d| inert[d] = deep);
            }
        }
        inert
    }

    /// The dofs of the band (per dof), or `None` if it is empty or too large.
    fn band_dofs(&self) -> Option<Vec<bool>> {
        let n_el = self.mesh.n_elements();
        let changing: Vec<bool> = (0..n_el)
            .map(|e| assembled_each_step(&self.reach, &self.moving, e))
            .collect();
        let band = dilate(&changing, self.mesh.dims(), self.mesh.periodic, BAND_MARGIN);
        let count = band.iter().filter(|&&b| b).count();
        if count == 0 || count as f64 > BAND_FRACTION_LIMIT * n_el as f64 {
            return None;
        }
        let lay = self.layout;
        let mut dofs = vec![false; lay.n_dofs()];
        let mut el = Vec::with_capacity(MAX_EL_DOFS);
        for e in (0..n_el).filter(|&e| band[e]) {
            element_dofs(&self.mesh, &lay, e, &mut el);
            el.iter().for_each(|&d| dofs[d] = true);
        }
        for i in 0..lay.n_particles {
            for c in 0..3 {
                dofs[lay.rigid(i, c)] = true;
            }
        }
        Some(dofs)
    }
}
