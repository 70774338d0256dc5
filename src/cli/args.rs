//! The command line: commands, their arguments and value types (clap).

use clap::{Parser, Subcommand, ValueEnum};

use super::{query_cmds, status_cmds, sweep_cmds};
use crate::fem::linsolve::SolverKind;

/// xpflow: rigid particles in viscoelastic fluids (XFEM), with parameter sweeps.
#[derive(Debug, Parser)]
#[command(name = "xpflow", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run one case (a case file: the `[base]` table of a sweep file) and write its trajectories.
    Run {
        /// Case file.
        case: std::path::PathBuf,
        /// Print every resolved numerical setting of the case (all defaults filled in) and
        /// run nothing.
        #[arg(long)]
        resolved: bool,
    },
    /// Expand a sweep file into cases and run them (resumable).
    Sweep(sweep_cmds::SweepArgs),
    /// Print results tables from a results database.
    Query(query_cmds::QueryArgs),
    /// Per-sweep counts of done / running / failed / pending cases (and, with --submission,
    /// where each case of a cluster submission stands).
    Status(status_cmds::StatusArgs),
    /// One task of a cluster submission: the case on line --index of a manifest, run into its
    /// own shard (resuming an earlier task's).
    RunCase(super::cluster::RunCaseArgs),
    /// Fold the shards of a cluster submission into the sweep's database (one transaction per
    /// shard; merging again is a no-op).
    Merge(super::cluster::MergeArgs),
    /// Copy the finished cases of a results database into a new compact one (a dataset to ship:
    /// `--thin` keeps at most `--samples` sampled steps per case; no snapshots).
    Export(super::export::ExportArgs),
    /// Run a validation study and print its numbers and verdict.
    Validate {
        /// Which study.
        study: Study,
        /// Number of mesh levels for convergence studies.
        #[arg(long, default_value_t = 4)]
        levels: usize,
        /// Linear solver.
        #[arg(long, value_enum, default_value_t = SolverArg::Lblt)]
        solver: SolverArg,
        /// Weissenberg number (cylinder study; couette-wall-mode: 0 means its default, 1).
        #[arg(long, default_value_t = 0.0)]
        wi: f64,
        /// Element sizes near the cylinder, in units of R (cylinder study; comma-separated,
        /// coarse to fine; the verdict is the finest one's). Default: 0.1,0.05,0.03 for Wi = 0;
        /// for Wi > 0 one mesh that runs in a minute or two (0.1 up to Wi = 0.45, 0.07 above).
        #[arg(long, alias = "mesh", value_delimiter = ',')]
        h: Option<Vec<f64>>,
        /// Deborah numbers De = λγ̇_w of the extrudate-swell study (comma-separated; 0: Newtonian,
        /// above 0 the UCM fluid of thesis §6.4).
        #[arg(long, value_delimiter = ',', default_values_t = vec![0.0])]
        de: Vec<f64>,
        /// Extrudate swell: refine around the die exit (`--h` there, elements growing away from
        /// it) instead of a uniform mesh.
        #[arg(long)]
        graded: bool,
        /// Directory for CSV output (trajectories).
        #[arg(long, default_value = "results/validate")]
        out: std::path::PathBuf,
        /// Time step (viscoelastic cylinder study: default 0.01; extrudate swell: 0.05, below
        /// λ/2 at low De: 0.04 at De = 0.25).
        #[arg(long)]
        dt: Option<f64>,
        /// Longest simulated time before giving up on the steady state (viscoelastic cylinder:
        /// default 20; extrudate swell: 40).
        #[arg(long)]
        t_max: Option<f64>,
        /// Quadtree levels of the cut-cell quadrature (default: the cases' default).
        #[arg(long, default_value_t = crate::config::DEFAULT_QUADTREE_LEVEL)]
        cut_level: u32,
        /// Interface in the finest cut sub-squares (default: the cases' default).
        #[arg(long, value_enum, default_value_t = InterfaceArg::Parabolic)]
        interface: InterfaceArg,
        /// How the cylinder enters the discretization (cylinder study): `xfem`, or `fdm`, the
        /// fictitious domain method (`numerics.method`).
        #[arg(long, value_enum, default_value_t = MethodArg::Xfem)]
        method: MethodArg,
        /// How the cylinder's rigid-body motion is imposed (cylinder study): `weak`, or
        /// `multiplier`, Lagrange multipliers on a ring (`numerics.rigid_condition`).
        #[arg(long, value_enum, default_value_t = RigidConditionArg::Weak)]
        rigid_condition: RigidConditionArg,
        /// x of the cylinder's centre (cylinder study; comma-separated, one table row per centre
        /// and mesh): the channel is periodic, so the flow is the same and only the way the grid
        /// cuts the cylinder changes. Default: the benchmark's 0.0123R, off the grid lines.
        #[arg(long, value_delimiter = ',')]
        center_x: Option<Vec<f64>>,
        /// Mesh of the couette-wall-mode study, NθxNr elements (default 240x45, the Couette
        /// family's; 480x90 is family (iv)'s ε = 2/15).
        #[arg(long)]
        elements: Option<String>,
    },
    /// Run a performance benchmark.
    Bench {
        /// Which benchmark.
        name: BenchName,
        /// Mesh as NXxNY (elements), e.g. 200x50 (moving benchmark: comma-separated list).
        #[arg(long, default_value = "200x50")]
        mesh: String,
        /// Linear solver.
        #[arg(long, value_enum, default_value_t = SolverArg::Lblt)]
        solver: SolverArg,
        /// Include the DEVSS-G unknowns (stokes benchmark; moving benchmark: coupled DEVSS-G
        /// instead of the lagged Gⁿ).
        #[arg(long)]
        with_g: bool,
        /// Repeated solves after the first (median reported).
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Number of particles (moving benchmark; comma-separated for several runs).
        #[arg(long, value_delimiter = ',', default_values_t = vec![3])]
        particles: Vec<usize>,
        /// Element sizes near the cylinder in units of R (drag benchmark; comma-separated).
        #[arg(long, value_delimiter = ',', default_values_t = vec![0.2, 0.1, 0.05, 0.03])]
        h: Vec<f64>,
        /// Quadtree levels of the cut-cell quadrature (drag and moving benchmarks; default: the
        /// cases').
        #[arg(long, default_value_t = crate::config::DEFAULT_QUADTREE_LEVEL)]
        cut_level: u32,
        /// Interface in the finest cut sub-squares (drag and moving benchmarks; default: the
        /// cases').
        #[arg(long, value_enum, default_value_t = InterfaceArg::Parabolic)]
        interface: InterfaceArg,
        /// Moving benchmark: a mesh that follows the particles along x, columns this many times
        /// finer around each (`numerics.follow.ratio`).
        #[arg(long)]
        follow: Option<f64>,
        /// Moving benchmark: how the flow matrix is factored; `both` runs the band path and the
        /// refactor-every-step path one after the other and compares them phase by phase.
        #[arg(long, value_enum, default_value_t = FactorizationArg::Both)]
        factorization: FactorizationArg,
        /// Moving benchmark: where the ALE's mesh displacement is solved (`numerics.ale_extent`)
        /// on the paths of `--factorization`; with `--factorization both` on the band path only
        /// (the refactor path is the whole mesh's, as before the ring); `both` runs the ring and
        /// then the whole mesh (with `--factorization band` or `whole`). Default: the whole
        /// mesh, or with `--sweep` the case's own `numerics.ale_extent`.
        #[arg(long, value_enum)]
        ale: Option<AleArg>,
        /// Moving benchmark: a study's case instead of the benchmark's own (the §5.7 set-up on
        /// `--mesh` with `--particles`): the case `--case` of this sweep file, on each path.
        #[arg(long, requires = "case")]
        sweep: Option<std::path::PathBuf>,
        /// Moving benchmark with `--sweep`: the case's id, or a unique prefix of it (as `xpflow
        /// sweep --dry-run` lists them).
        #[arg(long = "case", requires = "sweep")]
        case: Option<String>,
        /// Moving benchmark with `--sweep`: every path continues the case from its saved state in
        /// this results database (a running or interrupted sweep's; nothing is written), instead
        /// of from rest.
        #[arg(long, requires = "sweep")]
        db: Option<std::path::PathBuf>,
    },
}

/// Flow factorizations the moving benchmark runs (`numerics.factorization`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FactorizationArg {
    /// The band path, then the whole matrix every step, with the ratio of each phase.
    Both,
    /// The far field once per placement of a band around the particles (the cases' default).
    Band,
    /// The whole matrix every step.
    Whole,
}

/// Extents of the ALE map the moving benchmark runs (`numerics.ale_extent`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AleArg {
    /// A ring of elements around the particles, then the whole mesh.
    Both,
    /// A ring of elements around the particles.
    Ring,
    /// The whole mesh (the cases' default).
    Whole,
}

/// Validation studies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Study {
    /// Manufactured solution, periodic channel and annulus, with and without DEVSS-G.
    StokesMms,
    /// Plane and circular Couette flow.
    Couette,
    /// Newtonian / Oldroyd-B drag on the confined cylinder (Ch. 2), XFEM or `--method fdm`:
    /// prints `K = <traction integral>` and `K_L = <force of the rigid-body condition>`.
    Cylinder,
    /// XFEM Stokes around a cylinder with the exact solution of thesis §2.4 (rates).
    XfemStokes,
    /// Free particle at the centre of plane Couette flow: ω/γ̇ against confinement 2a/H.
    FreeParticle,
    /// Two particles in confined Stokes shear flow (thesis §5.6.2): reverse / pass.
    TwoParticles,
    /// Translating cylinder in a Giesekus fluid (thesis §5.4): order in Δt of K(t), 0 ≤ t ≤ λ,
    /// over Δt = 0.04 … 0.005 against Δt = 0.0025, on the first `--h` (units of a).
    TranslatingCylinder,
    /// The translating cylinder (channel frame, default remap) with random steps whose
    /// consecutive ratios lie in [½, 2], mean Δt 0.04 … 0.005, against fixed Δt = 0.0025: the
    /// fitted order must reach 1.8 (issue 27: adaptive steps stay second order).
    VariableSteps,
    /// The translating cylinder held at rest with η_s = 0.1 and the explicit coupling: order in
    /// Δt (0.02 … 0.005 against 0.0025) with the lagged Gⁿ and with G as flow unknowns, on the
    /// first `--h`; the verdict asks second order of the latter.
    ExplicitCoupling,
    /// The translating cylinder held at rest with η_s = 0 and the semi-implicit coupling: order
    /// in Δt (0.02 … 0.005 against 0.0025) with the lagged Gⁿ (`semi_implicit`, what `auto`
    /// runs at β = 0) and with G as flow unknowns (`semi_implicit_coupled_g`), on the first
    /// `--h`; the verdict asks second order of the latter.
    SemiImplicitCoupling,
    /// A particle crossing the fixed mesh (thesis §5.5, Y0/H = 0.1, 160×80, 0.66 elements per
    /// step) in the lab frame against a frame moving with it: ω*, V* per history remap up to
    /// t* = 2.5 (≈ 4 min); the verdict is the default (bicubic) remap's.
    LabFrame,
    /// The Couette particle (thesis §3.5.2, 30×160) up to t* = 10 in the rotating frame, in the
    /// lab frame on the fixed mesh and on a mesh that follows it (≈ 6 min); the verdict asks
    /// the following mesh's r*(10) to be within 1e-3 of the rotating frame's.
    CouetteFrame,
    /// Near-contact forces in Stokes flow (issue 25): two cylinders squeezing their film and a
    /// cylinder approaching a wall, gaps 0.5a … 0.01a, against the lubrication asymptote, on the
    /// element sizes `--h` (units of a; default 0.2,0.1,0.05).
    NearContact,
    /// The polymer's forces across a sheared film (issue 25): two cylinders co-rotating in a
    /// Giesekus fluid (λω = 0.13, α = 0.01, β = 0.1) at gaps 0.2a and 0.05a, steady, on the
    /// element sizes `--h` (default 0.2,0.1,0.05,0.025,0.0125; films of more than 8 elements
    /// skipped): the normal force a film pushes them apart with, against the elements across it
    /// (≈ 10 min).
    FilmPolymer,
    /// The explicit coupling's wall mode in the Couette cell (issue 26): the undisturbed flow
    /// (45×240, R2/R1 = 4, β = 0.1, α = 0.01) at `--wi` (default 1), seeded with an m = 9
    /// perturbation at the inner cylinder, to t* = 36 with the explicit coupling at `--dt`
    /// (default 0.08) and `--dt`/4 and with the semi-implicit stress at `--dt`: the growth rate of
    /// the mode per t* (≈ 10 min; a Couette set-up's check before a long sweep). The verdict asks
    /// growth of the first and decay of the other two.
    CouetteWallMode,
    /// Newtonian extrudate swell (thesis §6.4, Table 6.3, De = 0): the free surface immersed in
    /// the fixed mesh moved by the kinematic equation to steady state; `swell = <H_max/H0>` per
    /// element size `--h` (default 0.1,0.05,0.025; Δt = 0.05 up to t = 40), the extrapolation
    /// and the verdict against the published 1.188; the profiles and each run's approach (per
    /// step: swell, max|ΔH| and where) as CSV in `--out`.
    ExtrudateSwell,
}

/// Benchmarks.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum BenchName {
    /// One Stokes (Q2/Q1) solve: assembly, symbolic, numeric, refactor, solve.
    Stokes,
    /// The unfitted Stokes drag problem (confined cylinder, Wi = 0): K, its error and the time of
    /// each phase, for element sizes `--h`.
    Drag,
    /// One viscoelastic time step with moving particles in confined shear flow (thesis §5.7
    /// set-up) on `--mesh` with `--particles`: every phase, medians over `--repeats` steps.
    Moving,
    /// Sweep expansion of 100² and 200² grids (best of `--repeats`) and their ratio: linear in
    /// the cases is ×4.
    Expand,
}

/// Linear solver choice.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum SolverArg {
    /// Symmetric indefinite LBLᵀ.
    Lblt,
    /// General LU.
    Lu,
}

impl From<SolverArg> for SolverKind {
    fn from(s: SolverArg) -> Self {
        match s {
            SolverArg::Lblt => SolverKind::Lblt,
            SolverArg::Lu => SolverKind::Lu,
        }
    }
}

/// Parses `NXxNY` (a mesh as element counts: `bench --mesh`, `validate --elements`).
pub(super) fn parse_mesh(s: &str) -> anyhow::Result<(usize, usize)> {
    let (a, b) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| anyhow::anyhow!("a mesh must look like 200x50, got '{s}'"))?;
    let (nx, ny) = (a.trim().parse()?, b.trim().parse()?);
    anyhow::ensure!(
        nx > 0 && ny > 0,
        "a mesh needs positive element counts, got '{s}'"
    );
    Ok((nx, ny))
}

/// How particles enter the discretization (`numerics.method`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// XFEM (the cases' default).
    Xfem,
    /// The fictitious domain method (thesis §2.3.4).
    Fdm,
}

/// How the rigid-body motion is imposed (`numerics.rigid_condition`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RigidConditionArg {
    /// The weak condition (the cases' default, thesis Ch. 5).
    Weak,
    /// Lagrange multipliers on a ring (thesis Chs. 2–4).
    Multiplier,
}

impl From<RigidConditionArg> for crate::solver::multiplier::RigidCondition {
    fn from(r: RigidConditionArg) -> Self {
        match r {
            RigidConditionArg::Weak => Self::Weak,
            RigidConditionArg::Multiplier => Self::Multiplier,
        }
    }
}

/// The discretization of `--method` with the cut rule of `--cut-level` / `--interface`, as a case
/// with those `numerics` would use; the fictitious domain method has no cut rule, so a cut rule
/// other than the default is refused with it.
///
/// # Errors
/// `--method fdm` with `--cut-level` or `--interface` other than the default.
pub(super) fn discretization(
    method: MethodArg,
    level: u32,
    interface: InterfaceArg,
) -> anyhow::Result<crate::solver::cutcells::Discretization> {
    use crate::solver::cutcells::Discretization;
    match method {
        MethodArg::Xfem => Ok(Discretization::Xfem(cut_options(level, interface))),
        MethodArg::Fdm => {
            anyhow::ensure!(
                level == crate::config::DEFAULT_QUADTREE_LEVEL
                    && matches!(interface, InterfaceArg::Parabolic),
                "--method fdm integrates every element whole and has no cut-cell quadrature: \
                 drop --cut-level and --interface"
            );
            Ok(Discretization::FictitiousDomain)
        }
    }
}

/// Interface representation of the cut-cell quadrature (`numerics.interface`).
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum InterfaceArg {
    /// Parabolic chords (the default of cases).
    Parabolic,
    /// Straight chords (the thesis').
    Linear,
}

impl From<InterfaceArg> for crate::config::InterfaceRule {
    fn from(i: InterfaceArg) -> Self {
        match i {
            InterfaceArg::Parabolic => crate::config::InterfaceRule::Parabolic,
            InterfaceArg::Linear => crate::config::InterfaceRule::Linear,
        }
    }
}

/// Cut-cell quadrature with `level` quadtree levels and the `interface` rule, as a case with
/// those `numerics` would use.
pub(super) fn cut_options(level: u32, interface: InterfaceArg) -> crate::xfem::CutOptions {
    crate::xfem::CutOptions {
        level,
        interface: crate::simulate::settings::interface_approx(interface.into()),
    }
}
