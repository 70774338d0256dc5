//! The case specification: serde types of one simulation case (geometry, fluid, particles, numerics,
//! output, stop rules). Construct with [`CaseSpec::from_value`], which resolves shorthands and validates.

use super::method::Method;
use super::time_step::{is_false, TimeStep};
use crate::fem::substructure::Factorization;
use crate::solver::ale::AleExtent;
use crate::solver::multiplier::RigidCondition;
use serde::{Deserialize, Serialize};

use crate::geometry::extrusion::{Extrusion, EXIT_BAND, EXIT_GROWTH};
use crate::mesh::follow::Follow;
use crate::mesh::Axis;

/// One fully specified simulation case. Build it with [`CaseSpec::from_value`] (or via a sweep file) so that
/// it is validated; afterwards treat it as immutable and pass it as `&CaseSpec`.
///
/// Units: lengths and times are in the geometry's units; with H = 1 and U_w = 1 (confined shear) the time is
/// the thesis' t* = t γ̇. The zero-shear viscosity is η0 = η_s + η_p = 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseSpec {
    /// Flow domain and how it is driven.
    pub geometry: Geometry,
    /// Constitutive model and its dimensionless parameters.
    pub fluid: Fluid,
    /// The suspended rigid particles; must be absent for `cylinder_channel` (its cylinder is part of the
    /// geometry).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particles: Option<Particles>,
    /// Mesh and time stepping.
    pub numerics: Numerics,
    /// What is recorded and how often.
    #[serde(default)]
    pub output: Output,
    /// Stopping rules beyond the end time.
    #[serde(default)]
    pub stop: Stop,
}

/// Flow domain. Exactly one variant, written as a sub-table, e.g. `[geometry.confined_shear]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Geometry {
    /// Channel [−L/2, L/2] × [−H/2, H/2], periodic in x, walls at y = ±H/2 moving at ±U_w/2 (thesis 5.6.1).
    /// Shorthand: `delta = δ` instead of `h` gives H = 2aδ (thesis 5.7.3).
    ConfinedShear {
        /// Channel height H.
        h: f64,
        /// Channel length L (period in x).
        l: f64,
        /// Relative wall speed U_w (top wall +U_w/2, bottom wall −U_w/2).
        #[serde(default = "one")]
        wall_speed: f64,
    },
    /// Annulus R1 < r < R2 centred at the origin, inner cylinder rotating counter-clockwise at ω̄, outer
    /// cylinder at rest (thesis 3.5.1). Shorthand: `particles.eps = ε` instead of `particles.radius` gives
    /// a = ε (R2 − R1)/2.
    Couette {
        /// Inner radius R1.
        r1: f64,
        /// Outer radius R2.
        r2: f64,
        /// Angular velocity ω̄ of the inner cylinder.
        #[serde(default = "one")]
        omega_inner: f64,
    },
    /// Extrusion (thesis §6.5, Fig. 6.1): a planar die of half-height H0 over −L_w ≤ x ≤ 0 (wall
    /// y = H0, symmetry line y = 0) fed with the fully developed profile of flow rate Q per
    /// half-width, and an extrudate over 0 ≤ x ≤ L_fs with a free surface, open at x = L_fs.
    /// `numerics.mesh` = [n_x, n_y] uniform elements on [−L_w, L_fs] × [0, height], with grid
    /// lines on x = 0 and y = H0. Wi = λU/H0, U = Q/H0 (for UCM, §6.4's De = 3 Wi).
    Extrusion {
        /// Die half-height H0.
        #[serde(default = "one")]
        h0: f64,
        /// Die length L_w (the thesis' §6.5: 3).
        die_length: f64,
        /// Extrudate length L_fs (the thesis' §6.5: 4).
        extrudate_length: f64,
        /// Flow rate Q per half-width.
        #[serde(default = "one")]
        flow_rate: f64,
        /// Height of the mesh above the symmetry line: room for the swell (default 2 H0).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        height: Option<f64>,
    },
    /// Fixed cylinder of radius R at the centre of a channel with a parabolic inflow of mean velocity U
    /// (thesis Ch. 2 benchmark: H = 4R, L = 30R).
    CylinderChannel {
        /// Cylinder radius R.
        radius: f64,
        /// Channel height H (the benchmark uses 4R).
        h: f64,
        /// Channel length L (the benchmark uses 30R).
        l: f64,
        /// Mean inflow velocity U.
        mean_velocity: f64,
    },
}

/// Constitutive model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Model {
    /// Giesekus model with mobility α (α = 0 is Oldroyd-B).
    Giesekus,
    /// Oldroyd-B model (α must be 0).
    OldroydB,
    /// Newtonian fluid (Wi must be 0).
    Newtonian,
}

/// Fluid rheology in dimensionless form.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fluid {
    /// Constitutive model: `giesekus`, `oldroyd_b` or `newtonian`.
    pub model: Model,
    /// Weissenberg number; see [`CaseSpec::relaxation_time`] for its meaning per geometry. Wi ≥ 0.
    pub wi: f64,
    /// Giesekus mobility α ∈ [0, 1); default 0.
    #[serde(default)]
    pub alpha: f64,
    /// Viscosity ratio β = η_s/(η_s + η_p) ∈ [0, 1); default 0 (UCM); ignored for a Newtonian fluid.
    #[serde(default)]
    pub beta: f64,
}

/// Rigid particles, all of the same radius.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Particles {
    /// Particle radius a (or the shorthand `eps` for Couette, see [`Geometry::Couette`]).
    pub radius: f64,
    /// Initial positions.
    pub layout: Layout,
}

/// Initial particle positions, written as a sub-table, e.g. `[particles.layout.string]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Layout {
    /// Point-symmetric string of n particles, neighbours l_x apart in x and l_y apart in y, first particle
    /// top-left (thesis 5.7, Fig. 5.16; see [`crate::geometry::layout::string_positions`]).
    String {
        /// Number of particles N ≥ 1.
        n: usize,
        /// x-distance between neighbouring centres.
        lx: f64,
        /// y-distance between neighbouring centres.
        ly: f64,
        /// The particle ⌊n/2⌋ (the centre one of an odd string) moved by [dx, dy] off the
        /// point-symmetric layout: a point-symmetric layout on a point-symmetric mesh keeps its
        /// symmetry to round-off, and can keep an unstable symmetric string alive
        /// (`sweeps/beta_robustness.toml`). Default none (not in the case id then).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        perturb: Option<[f64; 2]>,
    },
    /// The two-particle set-up of thesis 5.6.1: centres (−l_x, l_y) and (l_x, −l_y).
    Pair {
        /// Half the x-distance between the centres.
        lx: f64,
        /// Half the y-distance between the centres.
        ly: f64,
    },
    /// Explicit centres [[x, y], ...].
    Explicit {
        /// Particle centres.
        positions: Vec<[f64; 2]>,
    },
    /// One particle in Couette flow at r0* = (r0 − R1)/(R2 − R1) (thesis 3.5.1).
    Couette {
        /// Initial dimensionless radial position r0*.
        r0_star: f64,
        /// Polar angle of the centre in radians, counter-clockwise from +x; default 0.
        #[serde(default)]
        angle: f64,
    },
}

/// Mesh and time stepping.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Numerics {
    /// Number of elements [n1, n2]: along x and y (channels) or radial × azimuthal (Couette).
    /// An extrusion refined at its die exit (`die_exit`) may leave it out: the refinement sets
    /// it (and a given one must be the refinement's).
    #[serde(default)]
    pub mesh: [usize; 2],
    /// Extrusion only: refine the mesh around the die-exit corner (0, H0), where the stress is
    /// singular (thesis §6.4: its meshes M1–M4 are refined there), `{ h, band = 0.2,
    /// growth = 1.05, coarsest }`: elements of size h in the square |x| ≤ band, |y − H0| ≤ band,
    /// growing by `growth` per element away from it, at most to `coarsest` ([`DieExit`]). The mesh of `xpflow validate
    /// extrudate-swell --graded`. Default off: `mesh` uniform elements (not in the case id).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub die_exit: Option<DieExit>,
    /// Ratio (≥ 1) of the largest to the smallest element size across the channel, finest at the
    /// centre line (thesis Fig. 5.25; Couette: at mid-gap); 1 = uniform.
    #[serde(default = "one")]
    pub grading: f64,
    /// Ratio (≥ 1) of the largest to the smallest element size along a confined-shear channel,
    /// finest at x = 0 and coarsest at the periodic seam (symmetric, so the sizes match across
    /// it); 1 = uniform (default; then not part of the case id). Refines where particles end up
    /// in a string started around x = 0 (thesis Fig. 5.25 refines around the particles).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub grading_x: f64,
    /// Confined shear with moving particles (Wi > 0): a computational mesh that follows the
    /// particles. Every step the vertex columns and rows near each particle are moved so that the
    /// elements within `core` radii of its centre are `ratio` times smaller than those of the
    /// mesh set by `mesh`/`grading`/`grading_x`, the count kept by coarser elements out to `reach`
    /// radii and nothing moved beyond (a tensor-product variant of thesis 3.3.4). Default off
    /// (then not part of the case id).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub follow: Option<FollowMesh>,
    /// Refine around particles with the grid deformation method (thesis 3.3.4). Not implemented:
    /// `true` is refused by validation, so that a case never runs silently without it.
    #[serde(default)]
    pub grid_deformation: bool,
    /// Time step: Δt > 0 (a number), or an error-controlled step `{ initial, min, max, tol }`
    /// ([`TimeStep`]; a number keeps the case id it always had).
    pub dt: TimeStep,
    /// End time; the case is undecided (`timeout`) if no outcome is reached by then.
    pub t_end: f64,
    /// Quadtree refinement level of cut-cell integration (thesis Table 2.2); default
    /// [`DEFAULT_QUADTREE_LEVEL`] (docs/validation.md, "The cut rule").
    #[serde(default = "default_quadtree_level")]
    pub quadtree_level: u32,
    /// How the interface is drawn in the finest cut sub-squares: `parabolic` (default) or the
    /// thesis' straight chords, `linear`. Always in the case id (cases run before this field
    /// existed used `linear`).
    #[serde(default)]
    pub interface: InterfaceRule,
    /// How the particles enter the discretization: `xfem` (default) or `fdm`, the fictitious
    /// domain method ([`Method`]). Not in the case id when default.
    #[serde(default, skip_serializing_if = "Method::is_xfem")]
    pub method: Method,
    /// How the rigid-body motion is imposed on the particle boundaries: `weak` (default, thesis
    /// Ch. 5) or `multiplier`, Lagrange multipliers on a ring whose integral is the drag K_L
    /// (thesis Chs. 2–4; [`RigidCondition`]). Not in the case id when default.
    #[serde(default, skip_serializing_if = "RigidCondition::is_weak")]
    pub rigid_condition: RigidCondition,
    /// How the flow matrix is factored when the particles moved: `band` (default: the far field
    /// once per placement of a band around the particles, the band every step) or `whole` (the
    /// whole matrix every step; the same solution to the solver's tolerance, for comparisons).
    /// Not in the case id when default.
    #[serde(default, skip_serializing_if = "Factorization::is_band")]
    pub factorization: Factorization,
    /// Interpolation of the history fields onto the moving mesh (temporary ALE); default
    /// bicubic (earlier defaults: biquadratic, and before that the thesis' bilinear map).
    /// Always written into the canonical case of a viscoelastic case: cases that named their
    /// remap keep their ids when the default changes (Newtonian cases leave it out of their id).
    #[serde(default)]
    pub remap: HistoryRemap,
    /// Where the temporary ALE's mesh displacement is solved: `whole` (default: the whole mesh,
    /// thesis Eq. 5.35) or `ring` (a ring of [`RING_ELEMENTS`](crate::solver::ale::RING_ELEMENTS) elements around the particles,
    /// zero beyond: the far field is neither searched nor interpolated, so the map costs what
    /// the particles' neighbourhood does, not the mesh). Not in the case id when default.
    #[serde(default, skip_serializing_if = "AleExtent::is_whole")]
    pub ale_extent: AleExtent,
    /// How the polymer stress enters the flow solve; default `auto`. Not written into the canonical
    /// case when default (case ids unchanged).
    #[serde(default, skip_serializing_if = "StressCoupling::is_auto")]
    pub coupling: StressCoupling,
    /// Confined shear only: solve in a frame translating along x at this velocity, e.g. that of a
    /// particle near a wall, so that the particle and its stress field move little over the fixed
    /// mesh (inertialless flow in a periodic channel is Galilean invariant: the same physics with
    /// walls at −U_f ± U_w/2). Samples and snapshots are reported in the lab frame. Default 0; not
    /// in the case id when 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub frame_velocity: f64,
    /// Couette only: solve in a frame rotating counter-clockwise at Ω about the axis (walls at
    /// ω̄ − Ω and −Ω), e.g. Ω = u_θ(r0)/r0, the undisturbed orbit of the particle, so that it
    /// stays nearly at rest on the mesh (inertialless flow of an objective fluid is the same in a
    /// rigidly rotating frame). Reported in the lab frame. Default 0; not in the case id when 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub frame_rotation: f64,
    /// `lab` (default) or `particle`: a frame moving with the undisturbed flow at the first
    /// particle's initial position (confined shear: U_f = U_w y0/H; Couette: Ω = u_θ(r0)/r0),
    /// i.e. the `frame_velocity` / `frame_rotation` that keeps that particle nearly at rest on
    /// the mesh, computed per case. Not in the case id when `lab`.
    #[serde(default, skip_serializing_if = "FrameChoice::is_lab")]
    pub frame: FrameChoice,
    /// The squeeze force of the films the mesh does not resolve (fewer than one element across a
    /// gap between two particles, or a particle and a confined-shear channel's wall), added as a
    /// resistance between their rigid-body unknowns with the fluid's zero-shear viscosity
    /// ([`crate::solver::lubrication`]: the fraction the mesh misses, measured by `xpflow validate
    /// near-contact`). Default off; not in the case id when off.
    #[serde(default, skip_serializing_if = "is_false")]
    pub lubrication: bool,
    /// The Δt at which the SUPG parameter of the stress transport switches,
    /// τ = min(h/(2‖u‖), Δt_τ/2) (thesis Eqs. 3.22–3.24 take the step's Δt), and at which an
    /// extrusion's free surface takes its τ (`HeightFunction::advance`). τ is part of the
    /// spatial discretization — it sets how much the stress is damped along the streamlines,
    /// e.g. at a singular corner — so a study of the time step holds it here, and only the time
    /// discretization changes between its runs. Default: the step's Δt (an adaptive step: its
    /// initial Δt). Viscoelastic cases only; not in the case id when left out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supg_dt: Option<f64>,
}

/// A mesh that follows the particles (see [`Numerics::follow`]); lengths in particle radii.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FollowMesh {
    /// Refinement of the core: element size there = the fixed mesh's / ratio (≥ 1).
    pub ratio: f64,
    /// Refinement across the channel (rows), if other than `ratio`; 1 leaves the rows where
    /// they are (e.g. for a string, whose cores would cover much of the height).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ratio_y: Option<f64>,
    /// Half-width of the refined core around a centre, in radii; default 1.5.
    #[serde(default = "default_follow_core")]
    pub core: f64,
    /// Half-width of the zone beyond which no vertex moves, in radii (> core); default 8 (at
    /// ratio 2 neighbouring elements then differ by ≤ 10 % and the coarsest taper element is
    /// 2.3 times the fixed mesh's; `crate::mesh::follow` has the trade-offs).
    #[serde(default = "default_follow_reach")]
    pub reach: f64,
    /// Elements across each film between two particles, or a particle and a wall (e.g. 4): the
    /// columns and rows are also refined at every gap thinner than that many elements, in
    /// proportion to the film's direction ([`crate::mesh::films`]; `xpflow validate film-polymer`: four hold the polymer's
    /// push across the film to 2 % where the fixed mesh's half element is 25–40 % off). Confined
    /// shear only; not in the case id when left out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub films: Option<f64>,
    /// Half-width of a film's zone, in radii (default [`crate::config::FILM_REACH`]): the
    /// count the film's core takes comes from the columns (rows) within it, none of them more
    /// than [`crate::config::FILM_COARSEST`] times coarser. Not in the case id when left out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub film_reach: Option<f64>,
}

impl FollowMesh {
    /// The refinement of the mesh's two axes for particles of radius `a`: along the flow (x, or
    /// θ on an annulus, whose lengths are angles: arcs at the radius `arc_radius`) and across
    /// it (y or r, with `ratio_y`).
    pub fn axes(&self, a: f64, arc_radius: Option<f64>) -> [Follow; 2] {
        let along = arc_radius.map_or(a, |r| a / r);
        let spec = |ratio, unit: f64| Follow {
            ratio,
            core: self.core * unit,
            reach: self.reach * unit,
        };
        [
            spec(self.ratio, along),
            spec(self.ratio_y.unwrap_or(self.ratio), a),
        ]
    }
}

/// An extrusion mesh refined around its die exit (see [`Numerics::die_exit`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DieExit {
    /// Element size in the refined square.
    pub h: f64,
    /// Half-width of the refined square; default [`EXIT_BAND`] (0.2). band/h must be a whole
    /// number, so that the die exit and the die wall are grid lines.
    #[serde(default = "default_exit_band")]
    pub band: f64,
    /// Growth of the element size per element away from the square (≥ 1); default
    /// [`EXIT_GROWTH`] (1.05).
    #[serde(default = "default_exit_growth")]
    pub growth: f64,
    /// The largest element size the growth reaches (≥ h), e.g. the resolution a particle needs
    /// on its way through the die; default none (the growth runs to the mesh's ends). Not in
    /// the case id when none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub coarsest: Option<f64>,
}

impl DieExit {
    /// The axes of the refined mesh of `extrusion` ([`Extrusion::die_exit_axes`]).
    pub fn axes(&self, extrusion: &Extrusion) -> (Axis, Axis) {
        let coarsest = self.coarsest.unwrap_or(f64::INFINITY);
        extrusion.die_exit_axes(self.h, self.band, self.growth, coarsest)
    }
}

fn default_exit_band() -> f64 {
    EXIT_BAND
}

fn default_exit_growth() -> f64 {
    EXIT_GROWTH
}

fn default_follow_core() -> f64 {
    1.5
}

fn default_follow_reach() -> f64 {
    8.0
}

/// The frame a case is solved in (see [`Numerics::frame`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FrameChoice {
    /// The lab frame, or the frame given by `frame_velocity` / `frame_rotation`.
    #[default]
    Lab,
    /// Moving with the undisturbed flow at the first particle's start.
    Particle,
}

impl FrameChoice {
    /// Whether this is the default (`lab`).
    pub fn is_lab(&self) -> bool {
        *self == FrameChoice::Lab
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// How the polymer stress enters the flow solve of a time step (docs/validation.md, "Time order of
/// the explicit coupling").
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StressCoupling {
    /// `explicit` when β > 0, `semi_implicit` when β = 0 (the explicit stress needs a solvent
    /// viscosity in the flow matrix).
    #[default]
    Auto,
    /// τ(cⁿ) and the DEVSS-G term θGⁿ from the last step (thesis §2.3.3): symmetric flow matrix
    /// (LBLᵀ), first order in time in transients.
    Explicit,
    /// τ(cⁿ) explicit, G solved with the flow (coupled DEVSS-G): second order, a larger flow system.
    ExplicitCoupledG,
    /// τ extrapolated from the last two steps, τ(cⁿ + r(cⁿ − c^{n−1})), and G solved with the
    /// flow: no lagged term (the particles' velocities see the stress at t^{n+1} to O(Δt²)); the
    /// cost of `explicit_coupled_g`; β > 0 only.
    ExplicitExtrapolated,
    /// D'Avino & Hulsen's semi-implicit stress (thesis Eqs. 5.26–5.29, 5.51), as in the thesis'
    /// Ch. 5: works at β = 0, non-symmetric flow matrix (LU, ~10× slower); the DEVSS-G term
    /// θGⁿ from the last step, which with η_s = 0 makes transients first order in time (θ = η_p
    /// is then the flow's whole viscosity).
    SemiImplicit,
    /// The semi-implicit stress with G solved with the flow (coupled DEVSS-G): no lagged term,
    /// second order in time — the scheme `xpflow validate translating-cylinder` measures — at
    /// the cost of a larger flow system.
    SemiImplicitCoupledG,
}

impl StressCoupling {
    /// Whether this is the default (`auto`).
    pub fn is_auto(&self) -> bool {
        *self == StressCoupling::Auto
    }
}

/// Quadtree levels of the cut-cell quadrature when a case names none: the quadrature's own
/// validated default (docs/validation.md, "The cut rule": drag K and the §2.4 rates per cost).
pub const DEFAULT_QUADTREE_LEVEL: u32 = crate::xfem::DEFAULT_LEVEL;

/// How the interface is represented inside the finest cut sub-squares of the cut-cell quadrature.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InterfaceRule {
    /// Parabolic chords through the interface point at the chord midpoint (area error O(h_L³)).
    #[default]
    Parabolic,
    /// Straight chords (the thesis' rule; area error O(h_L²)).
    Linear,
}

/// How the temporary ALE interpolates sⁿ, s^{n−1} (and G) at the pre-images. Every step
/// interpolates the history of the vertices near a moving particle at generic points, so the
/// interpolation error accumulates like that of a semi-Lagrangian scheme (∝ h^{p+1}/Δt).
/// Bicubic is the default because it is the most accurate (docs/validation.md): a particle
/// crossing 0.66 elements per step (thesis §5.5, h = a/4) keeps ω* within 8 % of the co-moving
/// frame's (biquadratic: swings of ±0.2, half of ω*), and the Couette particle's migration error
/// at t* = 10 drops from 0.0106 to 0.0038 in r* (a/h = 4) against the rotating frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HistoryRemap {
    /// Bilinear on the element holding the pre-image (thesis §5.3.3; monotone, diffusive).
    Bilinear,
    /// Biquadratic on the 3×3 vertices around it (not monotone; far less numerical diffusion).
    Biquadratic,
    /// Bicubic on the 4×4 vertices around it (not monotone; interpolation error O(h⁴)).
    #[default]
    Bicubic,
}

/// What is recorded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Output {
    /// Store particle states every k time steps (k ≥ 1); default 10.
    #[serde(default = "default_sample_every")]
    pub sample_every: u64,
    /// Write an HDF5 field snapshot every m time steps; 0 (default) writes none.
    #[serde(default)]
    pub snapshot_every: u64,
    /// Extrusion: compute the undisturbed steady surface H̄ first (a prelude without the
    /// particles, up to thousands of steps), from which the separation s = Y + a − H̄(X) and the
    /// undisturbed swell are measured; default true. `false` skips it — for runs whose
    /// separation is not wanted, e.g. a particle's drift in the die — and leaves s empty. (The
    /// particles' run starts from the flat surface either way.)
    #[serde(default = "yes", skip_serializing_if = "is_true")]
    pub undisturbed_surface: bool,
}

impl Default for Output {
    fn default() -> Self {
        Output {
            sample_every: default_sample_every(),
            snapshot_every: 0,
            undisturbed_surface: true,
        }
    }
}

/// Stopping rules.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stop {
    /// Stop the case as soon as its outcome is decided (see docs/sweeps.md); default true.
    #[serde(default = "yes")]
    pub early_stop: bool,
}

impl Default for Stop {
    fn default() -> Self {
        Stop { early_stop: true }
    }
}

fn is_one(v: &f64) -> bool {
    *v == 1.0
}

fn one() -> f64 {
    1.0
}
fn yes() -> bool {
    true
}
fn is_true(v: &bool) -> bool {
    *v
}
fn default_quadtree_level() -> u32 {
    DEFAULT_QUADTREE_LEVEL
}
fn default_sample_every() -> u64 {
    10
}

/// Short name of a geometry variant, as used in messages and the `cases.geometry` column.
impl Geometry {
    /// `confined_shear`, `couette`, `extrusion` or `cylinder_channel`.
    pub fn kind(&self) -> &'static str {
        match self {
            Geometry::ConfinedShear { .. } => "confined_shear",
            Geometry::Couette { .. } => "couette",
            Geometry::Extrusion { .. } => "extrusion",
            Geometry::CylinderChannel { .. } => "cylinder_channel",
        }
    }
}

/// The mesh height of an extrusion above the symmetry line when the case does not give one, in
/// die half-heights: Table 6.3's largest swell is 1.53 (De = 1.7).
pub const DEFAULT_EXTRUSION_HEIGHT: f64 = 2.0;
