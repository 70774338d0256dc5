//! Every numerical setting of a case, resolved from its [`CaseSpec`] with all defaults filled in:
//! what [`Simulation::new`](super::Simulation::new) builds, and what `xpflow run CASE --resolved`
//! and `xpflow sweep --dry-run --resolved` print. Numerical defaults are decided here once (the
//! stress coupling, the flow solver, the cut rule) or in `config` (the serde defaults of the case
//! fields); no caller chooses them again.

use crate::fem::substructure::Factorization;
use serde::Serialize;

use crate::config::{
    film_refinement, CaseSpec, DieExit, Geometry, HistoryRemap, InterfaceRule, Method,
    StressCoupling, TimeStep,
};
use crate::observe::outcome::STEADY_OMEGA_RATE;
use crate::particles::CONTACT_OVERLAP;
use crate::solver::ale::{AleExtent, Remap};
use crate::solver::constitutive::SupgVelocity;
use crate::solver::constitutive_projection::PROJECTION_GHOST_PENALTY;
use crate::solver::constitutive_stress::Coupling;
use crate::solver::cutcells::Discretization;
use crate::solver::flow::FLOW_GHOST_PENALTY;
use crate::solver::free_surface::SURFACE_STRESS_GHOST_PENALTY;
use crate::solver::lubrication::{Lubrication, PAIR_FILM_FIT, RESOLVED_ELEMENTS, WALL_FILM_FIT};
use crate::solver::moving::step_count;
use crate::solver::multiplier::{RigidCondition, MIN_RING_NODES, RING_SPACING};
use crate::solver::rigid::FICTITIOUS_DOMAIN_PENALTY;
use crate::solver::viscoelastic::ViscoelasticParams;
use crate::xfem::{CutOptions, InterfaceApprox};

/// The resolved numerical settings of a case.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Settings {
    /// `confined_shear` or `couette`.
    pub geometry: &'static str,
    /// The mesh.
    pub mesh: MeshSettings,
    /// The fluid as the solver sees it.
    pub fluid: FluidSettings,
    /// Time stepping.
    pub time: TimeSettings,
    /// How the particles enter the discretization: `xfem`, or `fdm` (the fictitious domain
    /// method: particle interior fluid, elements integrated whole, no cut cells).
    pub method: &'static str,
    /// The flow solve.
    pub flow: FlowSettings,
    /// The cut-cell quadrature (XFEM only; absent with the fictitious domain method).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cut: Option<CutSettings>,
    /// How the history is carried onto the moving configuration (temporary ALE).
    pub history_remap: &'static str,
    /// Where the temporary ALE's mesh displacement is solved.
    pub ale_extent: &'static str,
    /// The frame the case is solved in (samples and snapshots are reported in the lab frame).
    pub frame: FrameSettings,
    /// Contact: particles closer than −overlap × a (a small overlap) touch.
    pub contact_overlap: f64,
    /// Steady rotation (thesis §5.7.2, decided by `observe::outcome`): |dω*/dt*| below this for
    /// every particle (the thesis' 1e-6 per step of Δt* = 0.02).
    pub steady_rotation_rate: f64,
}

/// The computational mesh.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MeshSettings {
    /// Elements [along, across] (Couette: [radial, azimuthal]).
    pub elements: [usize; 2],
    /// Largest / smallest element across (finest at the centre line or mid-gap).
    pub grading: f64,
    /// Largest / smallest element along a channel (finest at x = 0).
    pub grading_x: f64,
    /// A mesh that follows the particles: refinement along and across, core and reach in radii.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub follow: Option<FollowSettings>,
    /// An extrusion mesh refined around its die exit: element size, band and growth.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub die_exit: Option<DieExit>,
}

/// The refinement of a mesh that follows the particles, all defaults filled in.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FollowSettings {
    /// Refinement along the flow.
    pub ratio: f64,
    /// Refinement across the flow.
    pub ratio_y: f64,
    /// Half-width of the refined core, in radii.
    pub core: f64,
    /// Half-width of the zone beyond which nothing moves, in radii.
    pub reach: f64,
    /// The films' refinement: elements across each, its zone's half-width in radii and the
    /// largest refinement (`None`: films not refined).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub films: Option<FilmSettings>,
}

/// The refinement of the films between near particles (`numerics.follow.films`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FilmSettings {
    /// Elements asked across each film.
    pub elements: f64,
    /// Half-width of a film's zone, in radii.
    pub reach: f64,
    /// Largest refinement at a film.
    pub max_ratio: f64,
    /// Largest element in a film's zone relative to the mesh's own.
    pub coarsest: f64,
}

/// The fluid.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FluidSettings {
    /// Solvent viscosity η_s (the whole viscosity without polymer).
    pub eta_s: f64,
    /// Polymer viscosity η_p (0: Stokes flow, no stress transport).
    pub eta_p: f64,
    /// Relaxation time λ (0 without polymer).
    pub lambda: f64,
    /// Giesekus mobility α.
    pub alpha: f64,
}

/// Time stepping.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TimeSettings {
    /// Δt: fixed, or the adaptive step's settings.
    pub dt: TimeStep,
    /// End time.
    pub t_end: f64,
    /// Steps to the end time (a fixed step; an adaptive one ends at `t_end`).
    pub steps: Option<usize>,
    /// The step controller of an adaptive step (`simulate::adaptive`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub controller: Option<String>,
    /// The scheme.
    pub scheme: &'static str,
}

/// The flow solve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlowSettings {
    /// How the polymer stress enters (`none` without polymer).
    pub stress_coupling: &'static str,
    /// DEVSS-G parameter θ (= η_p), and whether G is a flow unknown.
    pub devss_theta: f64,
    /// G as flow unknowns (coupled DEVSS-G).
    pub coupled_g: bool,
    /// Sparse direct solver of the flow system.
    pub solver: &'static str,
    /// How a changed flow matrix is factored: `band` (the far field once per placement of a
    /// band around the particles) or `whole`.
    pub factorization: Factorization,
    /// Weak rigid-body condition (thesis Eqs. 5.21–5.24) on the particle boundary inside each
    /// element it crosses: κ = η0 with XFEM; with the fictitious domain method its stabilization
    /// alone, κ = [`FICTITIOUS_DOMAIN_PENALTY`] η0 (`solver::rigid`).
    pub rigid_condition: String,
    /// Ghost penalty of the flow (γ of velocity and pressure on cut-element faces; 0 with the
    /// fictitious domain method, which has no cut cells).
    pub ghost_penalty: f64,
    /// Ghost penalty of the log-conformation transport.
    pub stress_ghost_penalty: f64,
    /// The SUPG parameter of the stress transport (none without polymer).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub supg: Option<String>,
    /// Ghost penalty of the Q1 projections.
    pub projection_ghost_penalty: f64,
    /// The lubrication correction of unresolved films (`numerics.lubrication`), if on.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lubrication: Option<String>,
}

/// The cut-cell quadrature.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CutSettings {
    /// Interface in the finest sub-squares: `parabolic` or `linear` chords.
    pub interface: &'static str,
    /// Quadtree levels.
    pub quadtree_level: u32,
}

/// The frame of the solve.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrameSettings {
    /// Translation velocity along x relative to the lab.
    pub velocity: f64,
    /// Rotation rate about the origin relative to the lab (counter-clockwise).
    pub rotation: f64,
}

/// The cut-cell quadrature options of a case's `numerics.quadtree_level` and `interface`.
pub fn cut_options(case: &CaseSpec) -> CutOptions {
    CutOptions {
        level: case.numerics.quadtree_level,
        interface: interface_approx(case.numerics.interface),
    }
}

/// How a case's particles enter the discretization (`numerics.method`): XFEM with the cut rule
/// of [`cut_options`], or the fictitious domain method.
pub fn discretization(case: &CaseSpec) -> Discretization {
    match case.numerics.method {
        Method::Xfem => Discretization::Xfem(cut_options(case)),
        Method::Fdm => Discretization::FictitiousDomain,
    }
}

/// The quadrature's representation of an interface rule.
pub fn interface_approx(rule: InterfaceRule) -> InterfaceApprox {
    match rule {
        InterfaceRule::Parabolic => InterfaceApprox::Quadratic,
        InterfaceRule::Linear => InterfaceApprox::Linear,
    }
}

/// The ALE interpolation of a case's `numerics.remap`.
pub fn ale_remap(remap: HistoryRemap) -> Remap {
    match remap {
        HistoryRemap::Bilinear => Remap::Bilinear,
        HistoryRemap::Biquadratic => Remap::Quadratic,
        HistoryRemap::Bicubic => Remap::Cubic,
    }
}

/// The fluid and stepping parameters of a case: with a polymer (λ > 0) the viscoelastic fluid
/// with the stress coupling of `numerics.coupling` (`auto`: explicit with LBLᵀ when β > 0, the
/// semi-implicit stress of thesis Eq. 5.51 when η_s = 0); without one, Stokes flow of viscosity
/// η_s + η_p.
pub fn fluid_params(case: &CaseSpec) -> ViscoelasticParams {
    let (eta_s, eta_p) = (case.solvent_viscosity(), case.polymer_viscosity());
    let lambda = case.relaxation_time();
    let (dt, t_end) = (case.numerics.dt.initial(), case.numerics.t_end);
    if lambda == 0.0 {
        let mut params = ViscoelasticParams::newtonian(eta_s + eta_p, dt, t_end);
        params.factorization = factorization(case);
        params.rigid_condition = case.numerics.rigid_condition;
        params.lubrication = lubrication(case);
        return params;
    }
    let mut params = ViscoelasticParams::new(eta_s, eta_p, lambda, case.fluid.alpha, dt, t_end);
    params.factorization = factorization(case);
    params.rigid_condition = case.numerics.rigid_condition;
    params.lubrication = lubrication(case);
    if case.extrusion().is_some() {
        params.stress_ghost_penalty = SURFACE_STRESS_GHOST_PENALTY;
    }
    params.supg = supg(case);
    match case.numerics.coupling {
        // without solvent viscosity the explicit stress has no viscous term (thesis §5.3.2)
        StressCoupling::Auto if eta_s == 0.0 => params.coupling = Coupling::SemiImplicit,
        StressCoupling::Auto | StressCoupling::Explicit => params.coupling = Coupling::Explicit,
        StressCoupling::ExplicitCoupledG => {
            params.coupling = Coupling::Explicit;
            params.coupled_g = true;
        }
        StressCoupling::ExplicitExtrapolated => {
            params.coupling = Coupling::Explicit;
            params.coupled_g = true;
            params.extrapolate_stress = true;
        }
        StressCoupling::SemiImplicit => params.coupling = Coupling::SemiImplicit,
        StressCoupling::SemiImplicitCoupledG => {
            params.coupling = Coupling::SemiImplicit;
            params.coupled_g = true;
        }
    }
    params
}

/// The SUPG parameter of a case's stress transport: the Courant switch at `numerics.supg_dt`
/// if given, else at the initial step of an adaptive Δt (the spatial discretization stays put
/// while the step changes), else at the step's Δt (thesis Eqs. 3.22–3.24).
pub fn supg(case: &CaseSpec) -> SupgVelocity {
    match (case.numerics.supg_dt, case.numerics.dt.adaptive()) {
        (Some(dt), _) => SupgVelocity::LocalAt(dt),
        (None, Some(_)) => SupgVelocity::LocalAt(case.numerics.dt.initial()),
        (None, None) => SupgVelocity::Local,
    }
}

/// The lubrication correction of a case with `numerics.lubrication`: the zero-shear viscosity
/// η_s + η_p, and the walls of a confined-shear channel (the other geometries' walls are curved
/// or not walls: none).
pub fn lubrication(case: &CaseSpec) -> Option<Lubrication> {
    case.numerics.lubrication.then(|| Lubrication {
        viscosity: case.solvent_viscosity() + case.polymer_viscosity(),
        walls: matches!(case.geometry, Geometry::ConfinedShear { .. }),
    })
}

/// How a case's changed flow matrix is factored: `numerics.factorization`, except with a free
/// surface, whose cut rows change every step outside any band around the particles (the whole
/// matrix then).
fn factorization(case: &CaseSpec) -> Factorization {
    if case.extrusion().is_some() {
        Factorization::Whole
    } else {
        case.numerics.factorization
    }
}

impl Settings {
    /// The settings a case runs with.
    pub fn of(case: &CaseSpec) -> Settings {
        let n = &case.numerics;
        let params = fluid_params(case);
        let polymer = params.has_polymer();
        let (velocity, rotation) = case.solver_frame();
        let follow = n.follow.map(|f| FollowSettings {
            ratio: f.ratio,
            ratio_y: f.ratio_y.unwrap_or(f.ratio),
            core: f.core,
            reach: f.reach,
            // in radii: the refinement for a = 1
            films: f.films.map(|elements| {
                let films = film_refinement(1.0, elements, f.film_reach);
                FilmSettings {
                    elements,
                    reach: films.reach,
                    max_ratio: films.max_ratio,
                    coarsest: films.coarsest,
                }
            }),
        });
        let coupling = match (polymer, params.coupling, params.coupled_g) {
            (false, _, _) => "none (Stokes flow)",
            (true, Coupling::Explicit, false) => "explicit (lagged G)",
            (true, Coupling::Explicit, true) if params.extrapolate_stress => {
                "explicit (extrapolated stress, coupled G)"
            }
            (true, Coupling::Explicit, true) => "explicit (coupled G)",
            (true, Coupling::SemiImplicit, false) => "semi_implicit (lagged G)",
            (true, Coupling::SemiImplicit, true) => "semi_implicit (coupled G)",
        };
        let lu = params.coupling == Coupling::SemiImplicit && polymer;
        let cut = cut_options(case);
        let xfem = n.method == Method::Xfem;
        let multiplier = n.rigid_condition == RigidCondition::Multiplier;
        // the ghost penalties act on the faces of XFEM's cut cells only: none exist otherwise
        let ghost = |gamma: f64| if xfem { gamma } else { 0.0 };
        Settings {
            geometry: case.geometry.kind(),
            mesh: MeshSettings {
                elements: n.mesh,
                grading: n.grading,
                grading_x: match case.geometry {
                    Geometry::ConfinedShear { .. } => n.grading_x,
                    _ => 1.0,
                },
                follow,
                die_exit: n.die_exit,
            },
            method: n.method.name(),
            fluid: FluidSettings {
                eta_s: params.eta_s,
                eta_p: params.eta_p,
                lambda: if polymer { params.lambda } else { 0.0 },
                alpha: params.alpha,
            },
            time: TimeSettings {
                dt: n.dt,
                t_end: n.t_end,
                steps: match n.dt {
                    TimeStep::Fixed(dt) => Some(step_count(n.t_end, dt)),
                    TimeStep::Adaptive(_) => None,
                },
                controller: n.dt.adaptive().map(|a| {
                    let lag = a.coupling_lag && polymer && params.coupling == Coupling::Explicit;
                    let mut text = super::adaptive::DESCRIPTION.to_string();
                    if !lag {
                        text += " (no coupling-lag term: coupling_lag = false, or no explicit coupling)";
                    }
                    text
                }),
                scheme: if polymer {
                    "BDF2 (Euler first step; variable-step coefficients with an adaptive Δt), \
                     predictor-corrector particles"
                } else {
                    "quasi-static Stokes, predictor-corrector particles"
                },
            },
            flow: FlowSettings {
                stress_coupling: coupling,
                devss_theta: if polymer { params.theta } else { 0.0 },
                coupled_g: polymer && params.coupled_g,
                solver: if lu { "LU" } else { "LBLT" },
                // the band is condensed onto velocity dofs: multipliers factor the whole matrix
                factorization: if lu || multiplier {
                    Factorization::Whole
                } else {
                    factorization(case)
                },
                rigid_condition: match (multiplier, xfem) {
                    (true, _) => format!(
                        "Lagrange multipliers on a P1 ring per particle, element size \
                         {RING_SPACING} x that of the elements it crosses (at least \
                         {MIN_RING_NODES} nodes); force and torque from the multipliers"
                    ),
                    (false, true) => "symmetric weak condition, kappa = eta0".into(),
                    (false, false) => format!(
                        "weak condition on a two-sided boundary: penalty only, kappa = \
                         {FICTITIOUS_DOMAIN_PENALTY} eta0"
                    ),
                },
                ghost_penalty: ghost(FLOW_GHOST_PENALTY),
                stress_ghost_penalty: ghost(params.stress_ghost_penalty),
                supg: polymer.then(|| match params.supg {
                    SupgVelocity::Local => "tau = min(h/(2|u|), dt/2), dt the step's".to_string(),
                    SupgVelocity::LocalAt(dt) => format!("tau = min(h/(2|u|), {dt}/2)"),
                    SupgVelocity::Global(u) => format!("tau = h/(2 x {u})"),
                }),
                projection_ghost_penalty: ghost(PROJECTION_GHOST_PENALTY),
                lubrication: lubrication(case).map(|l| {
                    format!(
                        "squeeze resistance of films under {RESOLVED_ELEMENTS} element across, \
                         fraction missed c/(x^2 + c) - c/(1 + c), c = {PAIR_FILM_FIT} between \
                         particles and {WALL_FILM_FIT} at walls, viscosity {}, \
                         {}",
                        l.viscosity,
                        if l.walls {
                            "between particles and with the channel walls"
                        } else {
                            "between particles"
                        }
                    )
                }),
            },
            cut: xfem.then_some(CutSettings {
                interface: match cut.interface {
                    InterfaceApprox::Quadratic => "parabolic",
                    InterfaceApprox::Linear => "linear",
                },
                quadtree_level: cut.level,
            }),
            history_remap: match (polymer, n.remap) {
                (false, _) => "none (no history)",
                (true, HistoryRemap::Bilinear) => "bilinear",
                (true, HistoryRemap::Biquadratic) => "biquadratic",
                (true, HistoryRemap::Bicubic) => "bicubic",
            },
            ale_extent: match (polymer, n.ale_extent) {
                (false, _) => "none (no history)",
                (true, AleExtent::Whole) => "whole mesh (thesis Eq. 5.35)",
                (true, AleExtent::Ring) => "a ring of elements around the particles",
            },
            frame: FrameSettings { velocity, rotation },
            contact_overlap: CONTACT_OVERLAP,
            steady_rotation_rate: STEADY_OMEGA_RATE,
        }
    }

    /// The settings as TOML, one table per group (what `--resolved` prints).
    pub fn to_toml(&self) -> String {
        // serializing plain numbers, strings and tables cannot fail
        toml::to_string(self).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn case(numerics: serde_json::Value) -> CaseSpec {
        CaseSpec::from_value(serde_json::json!({
            "geometry": { "confined_shear": { "h": 1.0, "l": 4.0, "wall_speed": 1.0 } },
            "fluid": { "model": "giesekus", "wi": 1.0, "alpha": 0.01, "beta": 0.1 },
            "particles": { "radius": 0.1, "layout": { "pair": { "lx": 0.5, "ly": 0.02 } } },
            "numerics": numerics,
        }))
        .unwrap()
    }

    /// One default of the cut rule: a case that names none runs the quadrature's default, the
    /// one the validations and tests use.
    #[test]
    fn a_case_without_a_cut_rule_runs_the_quadrature_default() {
        let c = case(serde_json::json!({ "mesh": [40, 10], "dt": 0.04, "t_end": 1.0 }));
        assert_eq!(cut_options(&c), CutOptions::default());
        let s = Settings::of(&c);
        let cut = s.cut.expect("an XFEM case has a cut rule");
        assert_eq!(
            (cut.interface, cut.quadtree_level),
            ("parabolic", crate::xfem::DEFAULT_LEVEL)
        );
        let thesis = case(serde_json::json!({
            "mesh": [40, 10], "dt": 0.04, "t_end": 1.0,
            "quadtree_level": 5, "interface": "linear"
        }));
        assert_eq!(
            cut_options(&thesis),
            CutOptions {
                level: 5,
                interface: InterfaceApprox::Linear
            }
        );
    }

    /// The fictitious domain method: no cut rule and no ghost penalty to show, its own condition.
    #[test]
    fn the_fictitious_domain_has_no_cut_rule() {
        let c = case(serde_json::json!({
            "mesh": [40, 10], "dt": 0.04, "t_end": 1.0, "method": "fdm"
        }));
        assert_eq!(discretization(&c), Discretization::FictitiousDomain);
        let s = Settings::of(&c);
        assert_eq!((s.method, s.cut.is_none()), ("fdm", true));
        assert_eq!(
            (s.flow.ghost_penalty, s.flow.stress_ghost_penalty),
            (0.0, 0.0)
        );
        assert!(s.flow.rigid_condition.contains("penalty only"));
        assert!(!s.to_toml().contains("[cut]"));
    }

    /// `numerics.rigid_condition = "multiplier"` reaches the solver's parameters and the resolved
    /// settings (whole-matrix factorization: the band is condensed onto velocity dofs); `weak`
    /// is the default and leaves the case id as it was.
    #[test]
    fn the_multiplier_condition_reaches_the_solver() {
        use crate::sweep::expand::case_id;
        let base = serde_json::json!({ "mesh": [40, 10], "dt": 0.04, "t_end": 1.0 });
        let weak = case(base.clone());
        let mut with = base.clone();
        with["rigid_condition"] = "multiplier".into();
        let multiplier = case(with);
        assert_eq!(fluid_params(&weak).rigid_condition, RigidCondition::Weak);
        assert_eq!(
            fluid_params(&multiplier).rigid_condition,
            RigidCondition::Multiplier
        );
        let s = Settings::of(&multiplier);
        assert!(s.flow.rigid_condition.contains("Lagrange multipliers"));
        assert_eq!(s.flow.factorization, Factorization::Whole);
        let mut named = base;
        named["rigid_condition"] = "weak".into();
        assert_eq!(case_id(&case(named)), case_id(&weak));
        assert_ne!(case_id(&multiplier), case_id(&weak));
    }

    /// The stress coupling resolved from `auto`: explicit (LBLᵀ) with a solvent, semi-implicit
    /// (LU) without; no stress and no history for a Newtonian fluid.
    #[test]
    fn the_coupling_and_solver_follow_the_fluid() {
        let c = case(serde_json::json!({ "mesh": [40, 10], "dt": 0.04, "t_end": 1.0 }));
        let s = Settings::of(&c);
        assert_eq!(
            (s.flow.stress_coupling, s.flow.solver),
            ("explicit (lagged G)", "LBLT")
        );
        assert_eq!(s.history_remap, "bicubic");
        let mut ucm = c.clone();
        ucm.fluid.beta = 0.0;
        let s = Settings::of(&ucm);
        assert_eq!(
            (s.flow.stress_coupling, s.flow.solver),
            ("semi_implicit (lagged G)", "LU")
        );
        ucm.numerics.coupling = crate::config::StressCoupling::SemiImplicitCoupledG;
        let s = Settings::of(&ucm);
        assert!(fluid_params(&ucm).coupled_g);
        assert_eq!(
            (s.flow.stress_coupling, s.flow.solver),
            ("semi_implicit (coupled G)", "LU")
        );
        let mut newtonian = c;
        newtonian.fluid.model = crate::config::Model::Newtonian;
        newtonian.fluid.wi = 0.0;
        let s = Settings::of(&newtonian);
        assert_eq!(s.flow.stress_coupling, "none (Stokes flow)");
        assert_eq!(s.history_remap, "none (no history)");
        assert_eq!((s.fluid.eta_s, s.fluid.eta_p), (1.0, 0.0));
        assert!(s.to_toml().contains("[cut]"));
    }
}
