//! Stokes validation: manufactured solution on the periodic channel and the annulus (with and
//! without DEVSS-G), plane Couette flow, circular Couette flow.

use super::{ConvRow, ConvStudy};
use crate::fem::linsolve::{SolveError, SolverKind};
use crate::mesh::{Axis, Mesh, Side};
use crate::solver::flow::{Stokes, StokesParams};
use crate::solver::norms::{flow_errors, ExactFlow};

/// Plane Couette flow lies in Q2 (a linear profile): only round-off remains in its nodal error.
pub const PLANE_COUETTE_ROUND_OFF: f64 = 1e-11;

/// Minimum fitted rates for Taylor–Hood Q2/Q1 (expected 3, 2, 2; STYLE: within 0.15).
pub const MIN_RATE_U_L2: f64 = 2.85;
/// Minimum fitted rate of the velocity H1 seminorm and the pressure L2 error.
pub const MIN_RATE_H1_P: f64 = 1.85;

/// Manufactured smooth solution, divergence-free, periodic in x with period 2π:
/// u = (sin x cos y, −cos x sin y), p = sin x sin y, so that for −∇·(2ηD(u)) + ∇p = f
/// (−∇·(2ηD(u)) = −ηΔu for ∇·u = 0):
/// f = (2η sin x cos y + cos x sin y, −2η cos x sin y + sin x cos y).
#[derive(Debug, Clone, Copy)]
pub struct TrigFlow {
    /// Viscosity η.
    pub eta: f64,
}

impl TrigFlow {
    /// Body force f(x).
    pub fn force(&self, x: [f64; 2]) -> [f64; 2] {
        let (sx, cx, sy, cy) = (x[0].sin(), x[0].cos(), x[1].sin(), x[1].cos());
        [
            2.0 * self.eta * sx * cy + cx * sy,
            -2.0 * self.eta * cx * sy + sx * cy,
        ]
    }
}

impl ExactFlow for TrigFlow {
    fn u(&self, x: [f64; 2]) -> [f64; 2] {
        [x[0].sin() * x[1].cos(), -x[0].cos() * x[1].sin()]
    }
    fn grad_u(&self, x: [f64; 2]) -> [[f64; 2]; 2] {
        let (sx, cx, sy, cy) = (x[0].sin(), x[0].cos(), x[1].sin(), x[1].cos());
        [[cx * cy, -sx * sy], [sx * sy, -cx * cy]]
    }
    fn p(&self, x: [f64; 2]) -> f64 {
        x[0].sin() * x[1].sin()
    }
}

/// Circular Couette flow between R1 (rotating with ω) and R2 (at rest):
/// u_θ(r) = A r + B/r, A = −ω R1²/(R2² − R1²), B = ω R1² R2²/(R2² − R1²), constant pressure.
/// In Cartesian form u = f(r) (−y, x) with f = A + B/r².
#[derive(Debug, Clone, Copy)]
pub struct CircularCouette {
    /// Inner radius.
    pub r1: f64,
    /// Outer radius.
    pub r2: f64,
    /// Angular velocity of the inner cylinder (counter-clockwise positive).
    pub omega: f64,
}

impl CircularCouette {
    fn ab(&self) -> (f64, f64) {
        let d = self.r2 * self.r2 - self.r1 * self.r1;
        (
            -self.omega * self.r1 * self.r1 / d,
            self.omega * self.r1 * self.r1 * self.r2 * self.r2 / d,
        )
    }
}

impl ExactFlow for CircularCouette {
    fn u(&self, x: [f64; 2]) -> [f64; 2] {
        let (a, b) = self.ab();
        let f = a + b / (x[0] * x[0] + x[1] * x[1]);
        [-x[1] * f, x[0] * f]
    }
    fn grad_u(&self, x: [f64; 2]) -> [[f64; 2]; 2] {
        let (a, b) = self.ab();
        let r2 = x[0] * x[0] + x[1] * x[1];
        let f = a + b / r2;
        let (fx, fy) = (-2.0 * b * x[0] / (r2 * r2), -2.0 * b * x[1] / (r2 * r2));
        [[-x[1] * fx, -f - x[1] * fy], [f + x[0] * fx, x[0] * fy]]
    }
    fn p(&self, _x: [f64; 2]) -> f64 {
        0.0
    }
}

/// Which domain a Stokes study runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Domain {
    /// [0, 2π] × [−1, 1], periodic in x, graded in y (k = 1) toward the lower wall.
    Channel,
    /// Annulus 1 ≤ r ≤ 2, periodic in θ, graded radially (k = 1) toward the inner circle.
    Annulus,
}

/// Meshes of refinement level `l` (0-based): channel (8·2^l) × (4·2^l), annulus (16·2^l) × (2·2^l).
pub fn mms_mesh(domain: Domain, level: usize) -> (Mesh, String, f64) {
    let m = 1usize << level;
    match domain {
        Domain::Channel => {
            let (nx, ny) = (8 * m, 4 * m);
            let mesh = Mesh::rectangle(
                Axis::uniform(0.0, 2.0 * std::f64::consts::PI, nx),
                Axis::graded(-1.0, 1.0, ny, -1.0, 1.0),
                true,
            );
            (mesh, format!("{nx}x{ny}"), 1.0 / ny as f64)
        }
        Domain::Annulus => {
            let (nt, nr) = (16 * m, 2 * m);
            let mesh = Mesh::annulus(nt, Axis::graded(1.0, 2.0, nr, 1.0, 1.0));
            (mesh, format!("{nt}x{nr}"), 1.0 / nr as f64)
        }
    }
}

/// Manufactured-solution convergence study (η = 1; θ = 1 with DEVSS-G, else 0) on `levels` meshes.
pub fn stokes_mms(
    domain: Domain,
    with_g: bool,
    levels: usize,
    solver: SolverKind,
) -> Result<ConvStudy, SolveError> {
    let exact = TrigFlow { eta: 1.0 };
    let params = StokesParams::new(1.0, if with_g { 1.0 } else { 0.0 }, solver);
    let mut rows = Vec::new();
    for l in 0..levels {
        let (mesh, label, h) = mms_mesh(domain, l);
        let mut st = Stokes::new(mesh, params);
        for side in [Side::Bottom, Side::Top] {
            st.set_velocity(side, move |x| exact.u(x));
        }
        st.pin_pressure();
        let sol = st.solve(&|x| exact.force(x))?;
        let e = flow_errors(&st.mesh, &sol.u, &sol.p, sol.g.as_deref(), &exact);
        let mut errors = vec![e.u_l2, e.u_h1, e.p_l2];
        if let Some(g) = e.g_l2 {
            errors.push(g);
        }
        rows.push(ConvRow {
            mesh: label,
            h,
            dofs: st.size().0,
            errors,
        });
    }
    let mut columns = vec![
        "‖u−u_h‖_L2".to_string(),
        "|u−u_h|_H1".into(),
        "‖p−p_h‖_L2".into(),
    ];
    let mut min_rates = vec![MIN_RATE_U_L2, MIN_RATE_H1_P, MIN_RATE_H1_P];
    if with_g {
        // G is the Q1 L2-projection of a Q2 gradient: rate 2
        columns.push("‖L(u)−G_h‖_L2".into());
        min_rates.push(MIN_RATE_H1_P);
    }
    Ok(ConvStudy {
        title: format!(
            "Stokes MMS on the {} ({}), {:?}",
            match domain {
                Domain::Channel => "periodic channel",
                Domain::Annulus => "annulus",
            },
            if with_g {
                "DEVSS-G, θ = η"
            } else {
                "plain Stokes"
            },
            solver
        ),
        columns,
        rows,
        min_rates,
    })
}

/// Plane Couette flow between walls y = ±H/2 moving at ±U/2 on a periodic graded mesh:
/// returns the largest nodal velocity error (Q2 reproduces the linear profile exactly).
pub fn plane_couette_max_error(with_g: bool) -> Result<f64, SolveError> {
    let (h, u) = (1.0, 2.0);
    let mesh = Mesh::rectangle(
        Axis::uniform(-2.0, 2.0, 16),
        Axis::graded(-0.5, 0.5, 8, 0.1, 2.0),
        true,
    );
    let mut st = Stokes::new(
        mesh,
        StokesParams::new(0.7, if with_g { 0.3 } else { 0.0 }, SolverKind::Lblt),
    );
    st.set_velocity(Side::Bottom, move |_| [-u / 2.0, 0.0]);
    st.set_velocity(Side::Top, move |_| [u / 2.0, 0.0]);
    st.pin_pressure();
    let sol = st.solve(&|_| [0.0, 0.0])?;
    let mut worst: f64 = 0.0;
    for (k, x) in st.mesh.nodes.iter().enumerate() {
        worst = worst
            .max((sol.u[k][0] - u * x[1] / h).abs())
            .max(sol.u[k][1].abs());
    }
    for p in &sol.p {
        worst = worst.max(p.abs());
    }
    if let Some(g) = &sol.g {
        for gv in g {
            worst = worst
                .max((gv[1] - u / h).abs())
                .max(gv[0].abs())
                .max(gv[2].abs())
                .max(gv[3].abs());
        }
    }
    Ok(worst)
}

/// Circular Couette flow, R2/R1 = 4, inner cylinder rotating: convergence of u to the exact u_θ(r).
pub fn circular_couette(levels: usize) -> Result<ConvStudy, SolveError> {
    let exact = CircularCouette {
        r1: 1.0,
        r2: 4.0,
        omega: 1.0,
    };
    let mut rows = Vec::new();
    for l in 0..levels {
        let m = 1usize << l;
        let (nt, nr) = (16 * m, 4 * m);
        let mesh = Mesh::annulus(nt, Axis::graded(1.0, 4.0, nr, 1.0, 1.0));
        let mut st = Stokes::new(mesh, StokesParams::new(1.0, 0.0, SolverKind::Lblt));
        st.set_velocity(Side::Bottom, move |x| exact.u(x));
        st.set_velocity(Side::Top, |_| [0.0, 0.0]);
        st.pin_pressure();
        let sol = st.solve(&|_| [0.0, 0.0])?;
        let e = flow_errors(&st.mesh, &sol.u, &sol.p, None, &exact);
        rows.push(ConvRow {
            mesh: format!("{nt}x{nr}"),
            h: 1.0 / nr as f64,
            dofs: st.size().0,
            errors: vec![e.u_l2, e.u_h1],
        });
    }
    Ok(ConvStudy {
        title: "Circular Couette flow, R2/R1 = 4, inner cylinder rotating".into(),
        columns: vec!["‖u−u_h‖_L2".into(), "|u−u_h|_H1".into()],
        rows,
        min_rates: vec![MIN_RATE_U_L2, MIN_RATE_H1_P],
    })
}
