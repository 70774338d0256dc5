//! Tests of the log-conformation transport.

use super::*;
use crate::mesh::Axis;

/// Closed-form values through a few flops: round-off only.
const ROUND_OFF: f64 = 1e-13;

/// The nodal velocity `u` everywhere and G = 0: a flow that only translates the stress.
fn uniform_translation(mesh: &Mesh, u: [f64; 2]) -> (Vec<[f64; 2]>, Vec<[f64; 4]>) {
    (vec![u; mesh.n_nodes()], vec![[0.0; 4]; mesh.n_vertices()])
}

#[test]
fn supg_tau_follows_the_courant_switch() {
    // C = 2 ≥ 1: τ = h/(2U); C = 0.5 < 1: τ = Δt/2; U = 0: Δt/2
    assert!((supg_tau(2.0, 0.1, 0.1) - 0.025).abs() < ROUND_OFF);
    assert!((supg_tau(0.5, 0.1, 0.1) - 0.05).abs() < ROUND_OFF);
    assert_eq!(supg_tau(0.0, 0.0, 0.1), 0.05);
    // continuous at C = 1
    assert!((supg_tau(1.0, 0.1, 0.1) - 0.05).abs() < ROUND_OFF);
}

#[test]
fn element_length_along_the_flow_direction() {
    // 0.4 × 0.1 rectangle: J = diag(0.2, 0.05)
    let jac = [[0.2, 0.0], [0.0, 0.05]];
    let det = 0.01;
    assert!((length_along(&jac, det, [3.0, 0.0]) - 0.4).abs() < ROUND_OFF);
    assert!((length_along(&jac, det, [0.0, -2.0]) - 0.1).abs() < ROUND_OFF);
    // diagonal direction (1,1)/√2: the line through the centre leaves through y = ±0.05,
    // length 0.1·√2
    let h = length_along(&jac, det, [1.0, 1.0]);
    assert!((h - 0.1 * 2f64.sqrt()).abs() < ROUND_OFF, "{h}");
    assert_eq!(length_along(&jac, det, [0.0, 0.0]), 0.0);
}

#[test]
fn uniform_field_in_uniform_flow_follows_the_point_scheme() {
    // s uniform, w uniform (SUPG active), G = 0: every vertex must take exactly the 0-D step
    let mesh = Mesh::rectangle(Axis::uniform(0.0, 2.0, 6), Axis::uniform(0.0, 1.0, 3), true);
    let model = Giesekus::new(0.7, 1.0, 0.3).unwrap();
    let dt = 0.05;
    let s0 = Sym2::new(0.4, -0.2, 0.1);
    let (u, g) = uniform_translation(&mesh, [1.3, 0.0]);
    let flow = TransportFlow {
        velocity: &u,
        mesh_velocity: None,
        gradient: &g,
    };
    let mut tr = LogConformationTransport::new(&mesh);
    let mut hist = LogConformationHistory::from_field(vec![s0; mesh.n_vertices()]);
    let mut point = crate::rheology::HomogeneousLogConformation::new(
        model,
        VelocityGradient::default(),
        s0,
        dt,
    )
    .unwrap();
    for _ in 0..5 {
        tr.step(&mesh, &model, dt, &flow, &mut hist).unwrap();
        let want = point.step();
        for s in &hist.current {
            assert!((*s - want).norm() < ROUND_OFF, "{s:?} vs {want:?}");
        }
    }
    assert_eq!(hist.steps(), 5);
}

#[test]
fn inactive_vertices_are_identity_rows_at_rest() {
    let mesh = Mesh::rectangle(Axis::uniform(0.0, 3.0, 3), Axis::uniform(0.0, 1.0, 1), true);
    let mut cuts = vec![ElementCut::Fluid; 3];
    cuts[1] = ElementCut::Inside;
    // element 1 has vertices 1, 2 (bottom) and 4, 5 (top); all are shared with fluid elements
    assert!(inactive_vertices(&mesh, &cuts).iter().all(|f| f.is_none()));
    let mut cuts = vec![ElementCut::Inside; 3];
    cuts[0] = ElementCut::Fluid;
    let fixed = inactive_vertices(&mesh, &cuts);
    assert_eq!(fixed.iter().filter(|f| f.is_some()).count(), 2);
    let model = Giesekus::oldroyd_b(1.0, 1.0).unwrap();
    let u = vec![[0.5, 0.0]; mesh.n_nodes()];
    let g = vec![[0.0, 1.0, 0.0, 0.0]; mesh.n_vertices()];
    let mut tr = LogConformationTransport::new(&mesh);
    tr.set_cuts(&mesh, cuts);
    let mut hist = LogConformationHistory::at_rest(mesh.n_vertices());
    let flow = TransportFlow {
        velocity: &u,
        mesh_velocity: None,
        gradient: &g,
    };
    tr.step(&mesh, &model, 0.1, &flow, &mut hist).unwrap();
    for (v, f) in fixed.iter().enumerate() {
        if f.is_some() {
            assert_eq!(hist.current[v], Sym2::ZERO);
        } else {
            // Euler step in shear from rest: s = Δt g(L, 0) = Δt (L + Lᵀ) → s_xy = 0.1
            assert!((hist.current[v].xy - 0.1).abs() < ROUND_OFF);
        }
    }
}

/// An inflow boundary (the extrudate's die): a stretched state s_in = log diag(3, 1) enters a
/// channel with u = (1, 0), G = 0 and relaxes while convected. The steady state is exact:
/// c_xx(x) = 1 + (c_in − 1) e^{−x/λ} (from ∂ₓs = −(1 − e^{−s})/λ). Q1 with h = 0.1 and the
/// SUPG/BDF2 steady state: measured 1.6e-4 at most; the inflow holds s_in to round-off.
#[test]
fn an_inflow_state_relaxes_downstream_as_the_exact_steady_solution() {
    const DISCRETIZATION: f64 = 1e-3;
    let mesh = Mesh::rectangle(
        Axis::uniform(0.0, 2.0, 20),
        Axis::uniform(0.0, 0.5, 2),
        false,
    );
    let lambda = 1.0;
    let model = Giesekus::oldroyd_b(lambda, 1.0).unwrap();
    let s_in = Sym2::new(3f64.ln(), 0.0, 0.0);
    let inflow: Vec<(usize, Sym2)> = (0..mesh.n_vertices())
        .filter(|&v| mesh.nodes[mesh.node_of_vertex[v]][0] == 0.0)
        .map(|v| (v, s_in))
        .collect();
    assert_eq!(inflow.len(), 3);
    let (u, g) = uniform_translation(&mesh, [1.0, 0.0]);
    let flow = TransportFlow {
        velocity: &u,
        mesh_velocity: None,
        gradient: &g,
    };
    let mut tr = LogConformationTransport::new(&mesh);
    tr.set_inflow(inflow.clone());
    let mut hist = LogConformationHistory::at_rest(mesh.n_vertices());
    for _ in 0..300 {
        tr.step(&mesh, &model, 0.05, &flow, &mut hist).unwrap();
    }
    for &(v, s) in &inflow {
        assert!((hist.current[v] - s).norm() < ROUND_OFF);
    }
    for v in 0..mesh.n_vertices() {
        let x = mesh.nodes[mesh.node_of_vertex[v]][0];
        let c = hist.current[v].exp();
        let want = 1.0 + 2.0 * (-x / lambda).exp();
        assert!(
            (c.xx - want).abs() < DISCRETIZATION,
            "x = {x}: {} vs {want}",
            c.xx
        );
        assert!(c.xy.abs() < ROUND_OFF && (c.yy - 1.0).abs() < ROUND_OFF);
    }
}

/// The iterative solve (GMRES with ILU(0)) against the LU it replaced: a non-uniform field in a
/// rotating shear flow with an inactive hole, at a Courant number of 2, ten BDF2 steps. The
/// iterative solve stops at a relative residual of [`ITERATIVE_TOL`] = 1e-12; the fields agree to
/// a small multiple of it, and no step falls back to LU.
#[test]
fn the_iterative_transport_solve_agrees_with_lu() {
    const AGREEMENT: f64 = 1e-10;
    let mesh = Mesh::rectangle(
        Axis::uniform(-1.0, 1.0, 24),
        Axis::uniform(-1.0, 1.0, 24),
        true,
    );
    let model = Giesekus::new(0.8, 1.0, 0.2).unwrap();
    let node = |k: usize| mesh.nodes[k];
    let u: Vec<[f64; 2]> = (0..mesh.n_nodes())
        .map(|k| {
            let [x, y] = node(k);
            [2.0 * y + 0.5, -0.5 * x]
        })
        .collect();
    let g = vec![[0.0, 2.0, -0.5, 0.0]; mesh.n_vertices()];
    let flow = TransportFlow {
        velocity: &u,
        mesh_velocity: None,
        gradient: &g,
    };
    // a hole: the elements whose centre lies within 0.25 of the origin
    let cuts: Vec<ElementCut> = (0..mesh.n_elements())
        .map(|e| {
            let c = mesh.element_coords[e][8];
            if c[0].hypot(c[1]) < 0.25 {
                ElementCut::Inside
            } else {
                ElementCut::Fluid
            }
        })
        .collect();
    let start: Vec<Sym2> = (0..mesh.n_vertices())
        .map(|v| {
            let [x, y] = node(mesh.node_of_vertex[v]);
            Sym2::new(0.3 * (2.0 * x).sin(), 0.2 * x * y, 0.1 * (3.0 * y).cos())
        })
        .collect();
    let dt = 0.1; // |u| h/Δt ≈ 2.5 elements per step at the top and bottom
    let run = |direct: bool| {
        let mut tr = LogConformationTransport::new(&mesh);
        tr.set_cuts(&mesh, cuts.clone());
        tr.direct = direct;
        let mut hist = LogConformationHistory::from_field(start.clone());
        for _ in 0..10 {
            tr.step(&mesh, &model, dt, &flow, &mut hist).unwrap();
        }
        (hist.current, tr.stats)
    };
    let (iterative, stats) = run(false);
    let (direct, direct_stats) = run(true);
    assert_eq!((stats.iterative_steps, stats.lu_steps), (10, 0));
    assert_eq!(
        (direct_stats.iterative_steps, direct_stats.lu_steps),
        (0, 10)
    );
    let diff = iterative
        .iter()
        .zip(&direct)
        .map(|(a, b)| (*a - *b).norm())
        .fold(0.0, f64::max);
    let size = direct.iter().map(|s| s.norm()).fold(0.0, f64::max);
    assert!(size > 0.1, "the field is not trivial: {size}");
    assert!(diff < AGREEMENT * size, "max difference {diff:e}");
}
