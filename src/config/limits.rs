//! What a case must respect to be runnable at all, beyond its physics: the size of its mesh (an
//! absolute cap, and the memory estimate a sweep checks against the machine), and how far one time
//! step may carry a particle over the mesh.

use super::case::{CaseSpec, Geometry, StressCoupling};
use super::error::SpecError;

/// Most elements a case's mesh may have, whatever the machine: 10⁷ elements would take ~500 GB with
/// the cheapest coupling (below), and validation itself builds the mesh of a following-mesh case.
pub const MAX_MESH_ELEMENTS: f64 = 1e7;

/// Furthest a particle may move over the mesh in one step, in elements along the flow (the mean
/// element length: L/n1 in a channel, the arc 2πr0/n_θ at the particle's radius in a Couette
/// cell). A step that carries a particle across several elements skips the cut cells between and
/// gave impossible states (a particle at y = −0.94 in a channel of half-height 0.5 after one step
/// at Wi = 50, Δt = 20); the lab-frame study of docs/validation.md runs at 0.66 elements per step.
/// The speed is the particle's at its start in the undisturbed flow, over the mesh (a frame moving
/// with the flow counts), plus γ̇a for its rim: the walls themselves may cross more (simple shear
/// is the same after any shift along the walls). For viscoelastic cases, whose history is
/// interpolated on the mesh every step; see [`MAX_RADII_PER_STEP`] for the others.
pub const MAX_ELEMENTS_PER_STEP: f64 = 1.0;

/// Furthest a particle may move in one step of a case without polymer, in particle radii: the
/// quasi-static Stokes stepper carries no history on the mesh (the two-particle validation runs at
/// 1.2 elements per step, reverse/pass as in thesis §5.6.2), but a step must not carry a particle
/// past a neighbour or into a wall before the contact test sees it.
pub const MAX_RADII_PER_STEP: f64 = 0.5;

/// Memory of a case beyond its mesh (code, quadrature tables, buffers), bytes.
const BASE_BYTES: f64 = 64e6;
/// Bytes per element with the explicit stress coupling, and without polymer. Measured peak
/// resident memory (`xpflow run`, three particles, 2 steps) with the flow factored whole: 124 MB
/// at 100×25, 440 MB at 200×50, 1.79 GB at 400×100 (45 kB per element); Newtonian 1.57 GB at
/// 400×100; Couette 416 MB at 50×200. With the band factorization (the default: far-field factor
/// with its dense interface block, the band's, and the condensation's dense temporaries):
/// 706 MB at 200×50, 2.41 GB at 400×100 (70 and 60 kB per element). With ~10 % margin.
const EXPLICIT_BYTES_PER_ELEMENT: f64 = 75e3;
/// Bytes per element with G solved with the flow (`explicit_coupled_g`): 779 MB at 200×50 whole,
/// 1.35 GB with the band factorization.
const COUPLED_G_BYTES_PER_ELEMENT: f64 = 145e3;
/// The semi-implicit coupling's LU factors grow faster than the element count E: measured
/// 461 MB at 100×25, 2.16 GB at 200×50, 12.1 GB at 400×100, i.e. ≈ 21.5 kB × E^1.25; with margin.
const SEMI_IMPLICIT_BYTES: f64 = 25e3;
/// Exponent of E in the semi-implicit estimate (fitted to the three measurements above).
const SEMI_IMPLICIT_EXPONENT: f64 = 1.25;

/// Relative cost of a step with G solved with the flow (docs/sweeps.md, `numerics.coupling`:
/// ≈ 2.4× the explicit step).
pub const COUPLED_G_STEP_COST: f64 = 2.4;
/// Relative cost of a semi-implicit step (docs/sweeps.md: ≈ 10× the explicit step).
pub const SEMI_IMPLICIT_STEP_COST: f64 = 10.0;
/// Peak memory of the semi-implicit coupling with G solved with the flow relative to the lagged
/// G's: `xpflow run`, 200×50, three particles, β = 0, 25 steps: 1.07 GB against 625 MB (1.72;
/// four more unknowns per Q1 vertex), with margin.
const SEMI_IMPLICIT_COUPLED_G_MEMORY: f64 = 1.9;
/// Cost of a semi-implicit step with G solved with the flow relative to the lagged G's: the same
/// runs, 1.56 s against 0.645 s per step (set-up subtracted).
pub const SEMI_IMPLICIT_COUPLED_G_STEP_COST: f64 = 2.4;
/// t_end/Δt within this of a whole number is that number of steps (0.3/0.1 = 2.9999999999999996).
const STEP_ROUND_OFF: f64 = 1e-9;

impl CaseSpec {
    /// Elements of the mesh, n1·n2 (as a float: no overflow).
    pub fn mesh_elements(&self) -> f64 {
        self.numerics.mesh[0] as f64 * self.numerics.mesh[1] as f64
    }

    /// Estimated peak memory of the case in bytes, from its element count and stress coupling
    /// (measured on this code; the flow matrix factors dominate).
    pub fn memory_estimate(&self) -> f64 {
        let e = self.mesh_elements();
        let polymer = self.relaxation_time() > 0.0;
        let coupling = self.resolved_coupling();
        BASE_BYTES
            + match coupling {
                _ if !polymer => EXPLICIT_BYTES_PER_ELEMENT * e,
                StressCoupling::SemiImplicit => {
                    SEMI_IMPLICIT_BYTES * e.powf(SEMI_IMPLICIT_EXPONENT)
                }
                StressCoupling::SemiImplicitCoupledG => {
                    SEMI_IMPLICIT_COUPLED_G_MEMORY
                        * SEMI_IMPLICIT_BYTES
                        * e.powf(SEMI_IMPLICIT_EXPONENT)
                }
                StressCoupling::ExplicitCoupledG | StressCoupling::ExplicitExtrapolated => {
                    COUPLED_G_BYTES_PER_ELEMENT * e
                }
                _ => EXPLICIT_BYTES_PER_ELEMENT * e,
            }
    }

    /// The stress coupling `auto` stands for (semi-implicit without solvent viscosity).
    fn resolved_coupling(&self) -> StressCoupling {
        match self.numerics.coupling {
            StressCoupling::Auto if self.fluid.beta == 0.0 => StressCoupling::SemiImplicit,
            StressCoupling::Auto => StressCoupling::Explicit,
            c => c,
        }
    }

    /// Time steps to the end time, ⌈t_end/Δt⌉ (fewer when the outcome is decided early); for
    /// an adaptive step at its initial Δt (an upper estimate: the controller grows the step
    /// where little happens).
    pub fn steps(&self) -> f64 {
        (self.numerics.t_end / self.numerics.dt.initial() - STEP_ROUND_OFF).ceil()
    }

    /// Time steps to the end time at the largest Δt, ⌈t_end/Δt_max⌉ ([`TimeStep::largest`]):
    /// all of a fixed step's, the fewest an adaptive step can take.
    ///
    /// [`TimeStep::largest`]: crate::config::TimeStep::largest
    pub fn steps_at_largest_dt(&self) -> f64 {
        (self.numerics.t_end / self.numerics.dt.largest() - STEP_ROUND_OFF).ceil()
    }

    /// Cost of one time step per element relative to the explicit coupling's: 1 explicit (and
    /// without polymer), [`COUPLED_G_STEP_COST`] with G solved with the flow,
    /// [`SEMI_IMPLICIT_STEP_COST`] semi-implicit. Times a measured seconds per element and step,
    /// an estimate of a case's run time.
    pub fn step_cost(&self) -> f64 {
        if self.relaxation_time() == 0.0 {
            return 1.0;
        }
        match self.resolved_coupling() {
            StressCoupling::SemiImplicit => SEMI_IMPLICIT_STEP_COST,
            StressCoupling::SemiImplicitCoupledG => {
                SEMI_IMPLICIT_COUPLED_G_STEP_COST * SEMI_IMPLICIT_STEP_COST
            }
            StressCoupling::ExplicitCoupledG | StressCoupling::ExplicitExtrapolated => {
                COUPLED_G_STEP_COST
            }
            _ => 1.0,
        }
    }

    /// Refuses a mesh above [`MAX_MESH_ELEMENTS`].
    pub(super) fn validate_mesh_size(&self) -> Result<(), SpecError> {
        let e = self.mesh_elements();
        if e > MAX_MESH_ELEMENTS {
            let [n1, n2] = self.numerics.mesh;
            return Err(SpecError::new(
                "numerics.mesh",
                format!(
                    "{n1}×{n2} = {e:.3e} elements is more than {MAX_MESH_ELEMENTS:.0e}: such a case \
                     would need about {:.0} GB of memory; use a coarser mesh",
                    self.memory_estimate() / 1e9
                ),
            ));
        }
        Ok(())
    }

    /// Refuses a time step that moves a particle over more than [`MAX_ELEMENTS_PER_STEP`]
    /// elements, in the frame the case is solved in.
    pub(super) fn validate_distance_per_step(&self) -> Result<(), SpecError> {
        let (Some(a), dt) = (self.radius(), self.numerics.dt.initial()) else {
            return Ok(());
        };
        let (frame_velocity, frame_rotation) = self.solver_frame();
        let rim = self.characteristic_rate() * a;
        // (particle, speed over the mesh, element length along the flow there)
        let moves: Vec<(usize, f64, f64)> = match self.geometry {
            Geometry::ConfinedShear { h, l, wall_speed } => {
                let length = l / self.numerics.mesh[0] as f64;
                self.initial_positions()
                    .iter()
                    .enumerate()
                    .map(|(i, x)| {
                        let u = wall_speed * x[1] / h - frame_velocity;
                        (i, u.abs() + rim, length)
                    })
                    .collect()
            }
            Geometry::Couette {
                r1,
                r2,
                omega_inner,
            } => {
                // u_θ = A r + B/r (thesis 3.5.1)
                let d = r2 * r2 - r1 * r1;
                let (big_a, big_b) = (
                    -omega_inner * r1 * r1 / d,
                    omega_inner * r1 * r1 * r2 * r2 / d,
                );
                self.initial_positions()
                    .iter()
                    .enumerate()
                    .map(|(i, x)| {
                        let r = x[0].hypot(x[1]);
                        let u = big_a * r + big_b / r - frame_rotation * r;
                        let arc = std::f64::consts::TAU * r / self.numerics.mesh[1] as f64;
                        (i, u.abs() + rim, arc)
                    })
                    .collect()
            }
            // the die's profile at the particle's height (the fastest the fluid moves there)
            Geometry::Extrusion { .. } => {
                let (Some(e), Some((ax, _))) = (self.extrusion(), self.extrusion_axes()) else {
                    return Ok(());
                };
                // (the column the particle starts in: a mesh refined at the die exit is
                // coarser upstream)
                self.initial_positions()
                    .iter()
                    .enumerate()
                    .map(|(i, x)| {
                        let k = ax.locate(x[0]);
                        let length = ax.vertices[k + 1] - ax.vertices[k];
                        (i, e.inflow_velocity(x[1].abs()) + rim, length)
                    })
                    .collect()
            }
            Geometry::CylinderChannel { .. } => Vec::new(),
        };
        let Some((i, speed, length)) = moves
            .into_iter()
            .max_by(|a, b| (a.1 / a.2).total_cmp(&(b.1 / b.2)))
        else {
            return Ok(());
        };
        let moved = speed * dt;
        if self.relaxation_time() > 0.0 {
            let crossed = moved / length;
            if crossed > MAX_ELEMENTS_PER_STEP {
                return Err(SpecError::new(
                    "numerics.dt",
                    format!(
                        "Δt = {dt} moves particle {i} (speed {speed:.4} over the mesh, its rim \
                         included) across {crossed:.3} elements of length {length:.4} per step; \
                         more than {MAX_ELEMENTS_PER_STEP} element per step gives impossible \
                         states (particles through walls); use dt ≤ {:.4}, or a coarser mesh \
                         along the flow",
                        MAX_ELEMENTS_PER_STEP * length / speed
                    ),
                ));
            }
        } else if moved > MAX_RADII_PER_STEP * a {
            return Err(SpecError::new(
                "numerics.dt",
                format!(
                    "Δt = {dt} moves particle {i} (speed {speed:.4}, its rim included) by \
                     {:.3} radii per step; more than {MAX_RADII_PER_STEP} radius per step can \
                     carry it past a neighbour or into a wall; use dt ≤ {:.4}",
                    moved / a,
                    MAX_RADII_PER_STEP * a / speed
                ),
            ));
        }
        Ok(())
    }
}
