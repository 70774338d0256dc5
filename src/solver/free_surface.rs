//! A free surface y = H(x, t) immersed in the fixed mesh (thesis §6.2–6.3): the height function on
//! its own line mesh, its level set for XFEM, and the kinematic equation that moves it.
//!
//! - [`HeightFunction`]: H on P1 line elements whose nodes are the x-coordinates of the Q2 nodes
//!   downstream of the die exit (two P1 elements per Q2 element, the thesis' choice, §6.3.4 step
//!   5), pinned at the die exit, H(0, t) = H0 (Eq. 6.17).
//! - The kinematic equation ∂H/∂t + u_x ∂H/∂x = u_y (Eq. 6.3) with the velocity of the flow at the
//!   surface, discretized by SUPG (test functions w + τ u_x w′) and Gear's BDF2 (BDF1 on the
//!   first step), as Eqs. (6.45)–(6.50): [`HeightFunction::advance`]. The system is tridiagonal.
//! - [`SurfaceLevelSet`]: ζ = H(x) − y in the extrudate (x > 0), scaled to be 1-Lipschitz as the
//!   cut quadrature requires, and in the die (x ≤ 0) the level H0 + [`DIE_OFFSET`]·h of a wall
//!   that lies on a grid line: the elements above it are then cut by slivers below the discard
//!   ratio (removed) and those below are fluid, so the die wall is a line of mesh nodes where the
//!   caller imposes no-slip.
//! - [`stretch_map`]: the temporary ALE map of the moving surface (§6.3.3): each mesh column
//!   stretched vertically so that the surface of one configuration lands on the next, the
//!   symmetry line and the mesh top fixed.

use crate::fem::element::q2;
use crate::mesh::resolution::elements_between;
use crate::mesh::Mesh;
use crate::solver::ale::{stencil_at, AleMap, Remap, StencilWeights};
use crate::solver::bdf::Bdf2;
use crate::xfem::LevelSet;

/// Offset of the die region's level above the die wall, relative to the element size: places
/// the zero level strictly above the wall's grid line, so that no element below it is cut; the
/// slivers above (area ratio ~1e-9) are below the cut rule's discard ratio (1e-6).
pub const DIE_OFFSET: f64 = 1e-9;

/// The steady test of thesis §6.4: every surface node moves less than this in a step.
pub const STEADY_HEIGHT_TOL: f64 = 1e-7;

/// Ghost-penalty factor of the stress transport in a flow with a free surface, 10× the particles'
/// default ([`GHOST_PENALTY`](crate::solver::constitutive::GHOST_PENALTY)): in the UCM extrudate
/// swell on h = 0.0125 with 1e-3 the extension values of s in the slivers cut near the pinned
/// die-exit corner grew without bound at De ≥ 0.6 (|s| 16 at t = 0.45, blow-up at t ≈ 0.5 with
/// Δt = 0.05 and 0.01 alike); 1e-2 keeps them bounded. It lowers the swell at h = 0.1, De = 0.5
/// by 1.4e-3 (docs/validation.md, "Free surface: UCM extrudate swell").
pub const SURFACE_STRESS_GHOST_PENALTY: f64 = 1e-2;

/// The height of the free surface on its line mesh.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HeightFunction {
    /// Node coordinates x_0 = 0 (die exit) < x_1 < … (extrudate).
    x: Vec<f64>,
    /// Hⁿ at the nodes.
    h: Vec<f64>,
    /// Hⁿ⁻¹ (None before the first step).
    prev: Option<Vec<f64>>,
    /// Die half-height H0 (the pinned value at x_0).
    h0: f64,
}

impl HeightFunction {
    /// The flat surface H = H0 (the initial condition, Eq. 6.16) on nodes `x` (increasing, `x[0]` at
    /// the die exit).
    ///
    /// # Panics
    /// If `x` has fewer than two nodes or is not increasing.
    pub fn flat(x: Vec<f64>, h0: f64) -> Self {
        assert!(x.len() >= 2, "a line mesh needs two nodes");
        assert!(x.windows(2).all(|w| w[1] > w[0]), "nodes must increase");
        let h = vec![h0; x.len()];
        Self {
            x,
            h,
            prev: None,
            h0,
        }
    }

    /// Node coordinates.
    pub fn nodes(&self) -> &[f64] {
        &self.x
    }

    /// Hⁿ at the nodes.
    pub fn heights(&self) -> &[f64] {
        &self.h
    }

    /// The die half-height H0.
    pub fn h0(&self) -> f64 {
        self.h0
    }

    /// (x, H) at the nodes.
    pub fn profile(&self) -> Vec<[f64; 2]> {
        self.x.iter().zip(&self.h).map(|(&x, &h)| [x, h]).collect()
    }

    /// The largest height (the swell is max H / H0).
    pub fn max(&self) -> f64 {
        self.h.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }

    /// The predicted surface Ĥⁿ⁺¹ = (1+ω)Hⁿ − ωHⁿ⁻¹ for a step `dt` after `dt_prev` (Eq. 6.52
    /// with variable steps; Hⁿ on the first step, Eq. 6.54).
    pub fn predicted(&self, dt: f64, dt_prev: f64) -> HeightFunction {
        let h = match &self.prev {
            Some(p) => {
                let (wn, wp) = Bdf2::after(dt, Some(dt_prev)).extrapolation();
                self.h.iter().zip(p).map(|(a, b)| wn * a + wp * b).collect()
            }
            None => self.h.clone(),
        };
        HeightFunction {
            x: self.x.clone(),
            h,
            prev: None,
            h0: self.h0,
        }
    }

    /// H at `x` (P1 interpolation; H0 upstream of the die exit, the last value beyond the end).
    pub fn at(&self, x: f64) -> f64 {
        if x <= self.x[0] {
            return self.h0;
        }
        let i = self.x.partition_point(|&xi| xi <= x);
        if i >= self.x.len() {
            return *self.h.last().expect("two nodes");
        }
        let (x0, x1) = (self.x[i - 1], self.x[i]);
        let s = (x - x0) / (x1 - x0);
        (1.0 - s) * self.h[i - 1] + s * self.h[i]
    }

    /// The level set of the fluid bounded by this surface (see the module); `h` is the element
    /// size across the die wall.
    pub fn level_set(&self, h: f64) -> SurfaceLevelSet<'_> {
        let slope = self
            .x
            .windows(2)
            .zip(self.h.windows(2))
            .map(|(x, y)| ((y[1] - y[0]) / (x[1] - x[0])).abs())
            .fold(0.0, f64::max);
        SurfaceLevelSet {
            surface: self,
            scale: 1.0 / slope.hypot(1.0),
            die_level: self.h0 + DIE_OFFSET * h,
        }
    }

    /// One step of the kinematic equation: Hⁿ⁺¹ from the surface velocity `u[i]` = (u_x, u_y) at
    /// the nodes (of the flow on the predicted surface), by SUPG and BDF2 with steps `dt` (now)
    /// and `dt_prev` (the last; variable-step Gear coefficients), BDF1 on the first step, the
    /// SUPG parameter τ = ((2/Δt_τ)² + (2|a|/h)²)^(−1/2) of a transient advection at `tau_dt`
    /// (the step's Δt, or a fixed one that keeps the spatial discretization from following the
    /// step: without it τ → Δt/2 as Δt → 0, and the surface downstream of a singular corner loses
    /// its damping). Returns max_i |Hⁿ⁺¹ − Hⁿ|.
    ///
    /// # Panics
    /// If `u` does not have one velocity per node.
    pub fn advance(&mut self, u: &[[f64; 2]], dt: f64, dt_prev: f64, tau_dt: f64) -> f64 {
        let n = self.x.len();
        assert_eq!(u.len(), n, "one velocity per surface node");
        // ∂H/∂t ≈ (c₀ Hⁿ⁺¹ − c₁ Hⁿ + c₂ Hⁿ⁻¹)/dt
        let bdf = Bdf2::after(dt, self.prev.as_ref().map(|_| dt_prev));
        let (a0, a1, a2) = (bdf.c0, bdf.c1, bdf.c2);
        let history: Vec<f64> = (0..n)
            .map(|i| a1 * self.h[i] - a2 * self.prev.as_ref().map_or(0.0, |p| p[i]))
            .collect();
        // tridiagonal system: lower[i] H[i-1] + diag[i] H[i] + upper[i] H[i+1] = rhs[i]
        let (mut lower, mut diag, mut upper, mut rhs) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let g = 1.0 / 3f64.sqrt();
        for e in 0..n - 1 {
            let len = self.x[e + 1] - self.x[e];
            let a_mean = 0.5 * (u[e][0] + u[e + 1][0]);
            // SUPG parameter of a transient advection (time and advection scales)
            let tau = ((2.0 / tau_dt).powi(2) + (2.0 * a_mean.abs() / len).powi(2)).powf(-0.5);
            for s in [0.5 * (1.0 - g), 0.5 * (1.0 + g)] {
                let w = 0.5 * len;
                let phi = [1.0 - s, s];
                let dphi = [-1.0 / len, 1.0 / len];
                let a = phi[0] * u[e][0] + phi[1] * u[e + 1][0];
                let f = phi[0] * u[e][1] + phi[1] * u[e + 1][1];
                let hist = phi[0] * history[e] + phi[1] * history[e + 1];
                for i in 0..2 {
                    let test = w * (phi[i] + tau * a * dphi[i]);
                    let row = e + i;
                    rhs[row] += test * (f + hist / dt);
                    for j in 0..2 {
                        let value = test * (a0 / dt * phi[j] + a * dphi[j]);
                        match j as isize - i as isize {
                            0 => diag[row] += value,
                            1 => upper[row] += value,
                            _ => lower[row] += value,
                        }
                    }
                }
            }
        }
        // H(x_0) = H0 (Eq. 6.17)
        (lower[0], diag[0], upper[0], rhs[0]) = (0.0, 1.0, 0.0, self.h0);
        let next = thomas(&lower, &diag, &upper, &rhs);
        let change = next
            .iter()
            .zip(&self.h)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        self.prev = Some(std::mem::replace(&mut self.h, next));
        change
    }
}

/// Solves a tridiagonal system (Thomas algorithm; the SUPG matrix of an advection-dominated
/// kinematic equation with a positive time term is diagonally dominant enough for it).
fn thomas(lower: &[f64], diag: &[f64], upper: &[f64], rhs: &[f64]) -> Vec<f64> {
    let n = diag.len();
    let (mut c, mut d) = (vec![0.0; n], vec![0.0; n]);
    c[0] = upper[0] / diag[0];
    d[0] = rhs[0] / diag[0];
    for i in 1..n {
        let m = diag[i] - lower[i] * c[i - 1];
        c[i] = upper[i] / m;
        d[i] = (rhs[i] - lower[i] * d[i - 1]) / m;
    }
    let mut x = vec![0.0; n];
    x[n - 1] = d[n - 1];
    for i in (0..n - 1).rev() {
        x[i] = d[i] - c[i] * x[i + 1];
    }
    x
}

/// The level set of the fluid under a free surface and a die wall (see the module): positive in
/// the fluid.
#[derive(Debug, Clone, Copy)]
pub struct SurfaceLevelSet<'a> {
    surface: &'a HeightFunction,
    /// 1/√(1 + max|H′|²): makes ζ 1-Lipschitz.
    scale: f64,
    /// The level of the die region, just above the die wall.
    die_level: f64,
}

impl LevelSet for SurfaceLevelSet<'_> {
    fn value(&self, x: [f64; 2]) -> f64 {
        let top = if x[0] <= self.surface.x[0] {
            self.die_level
        } else {
            self.surface.at(x[0])
        };
        self.scale * (top - x[1])
    }
}

/// The vertical stretch of [`stretch_map`] as a mesh displacement at the vertices of `mesh` (in
/// vertex order): the vertex (x, y) of the configuration below `old` moves to where the stretch
/// onto `new` takes it, d = (0, y′ − y). The background of the particles' temporary ALE map when
/// a flow has both (`TemporaryAle::background`).
pub fn stretch_displacement(
    mesh: &Mesh,
    top: f64,
    new: &HeightFunction,
    old: &HeightFunction,
) -> Vec<[f64; 2]> {
    mesh.node_of_vertex
        .iter()
        .map(|&k| {
            let [x, y] = mesh.nodes[k];
            let (to, from) = (new.at(x), old.at(x));
            let moved = if y <= from {
                y * to / from
            } else {
                to + (y - from) * (top - to) / (top - from)
            };
            [0.0, moved - y]
        })
        .collect()
}

/// The flow's `velocity` (at the Q2 nodes of `mesh`) at the nodes of `surface`, for its kinematic
/// step; `Err((x, H))` at the first node that lies outside the mesh or at or above `top`.
pub fn velocity_on(
    mesh: &Mesh,
    velocity: &[[f64; 2]],
    surface: &HeightFunction,
    top: f64,
) -> Result<Vec<[f64; 2]>, (f64, f64)> {
    surface
        .nodes()
        .iter()
        .zip(surface.heights())
        .map(|(&x, &y)| {
            let (e, xi) = mesh.locate([x, y]).filter(|_| y < top).ok_or((x, y))?;
            let (n, _) = q2(xi);
            let mut v = [0.0; 2];
            for (k, &node) in mesh.elements[e].iter().enumerate() {
                v[0] += n[k] * velocity[node][0];
                v[1] += n[k] * velocity[node][1];
            }
            Ok(v)
        })
        .collect()
}

/// The gap between a particle (centre `c`, radius `a`) and the surface: the distance from the
/// centre to the nearest point of the P1 surface or the die wall less the radius
/// ([`nearest_point`]).
pub fn surface_gap(surface: &HeightFunction, c: [f64; 2], a: f64) -> f64 {
    nearest_point(surface, c).1 - a
}

/// The point of the fluid's upper boundary nearest to `c`, and its distance: the die wall y = H0
/// upstream of the die exit, the P1 surface downstream.
pub fn nearest_point(surface: &HeightFunction, c: [f64; 2]) -> ([f64; 2], f64) {
    let (x, h) = (surface.nodes(), surface.heights());
    // the die wall: the segment up to the exit (x[0] = 0), at H0
    let wall = [c[0].min(x[0]), surface.h0()];
    let mut best = (wall, (c[0] - wall[0]).hypot(c[1] - wall[1]));
    for i in 0..x.len() - 1 {
        // a segment whose x-range lies further than the nearest so far cannot be nearer
        if x[i + 1] < c[0] - best.1 || x[i] > c[0] + best.1 {
            continue;
        }
        let (dx, dh) = (x[i + 1] - x[i], h[i + 1] - h[i]);
        let s = (((c[0] - x[i]) * dx + (c[1] - h[i]) * dh) / (dx * dx + dh * dh)).clamp(0.0, 1.0);
        let p = [x[i] + s * dx, h[i] + s * dh];
        let d = (c[0] - p[0]).hypot(c[1] - p[1]);
        if d < best.1 {
            best = (p, d);
        }
    }
    best
}

/// Elements of `mesh` across the film between a particle (centre `c`, radius `a`) and the fluid's
/// upper boundary ([`nearest_point`]), along the line of closest approach
/// ([`elements_between`]); 0 for a particle touching or crossing it.
pub fn film_elements(mesh: &Mesh, surface: &HeightFunction, c: [f64; 2], a: f64) -> f64 {
    let (q, d) = nearest_point(surface, c);
    if d <= a {
        return 0.0;
    }
    // the particle's point nearest to q
    let p = [c[0] + a * (q[0] - c[0]) / d, c[1] + a * (q[1] - c[1]) / d];
    elements_between(mesh, p, q)
}

/// The temporary ALE map of a free surface (thesis §6.3.3) carrying the history from the fluid
/// below `old` (the predicted surface Ĥⁿ of the last step, the domain of sⁿ) to the fluid below
/// `new` (Ĥⁿ⁺¹), and, with `older` (Ĥⁿ⁻¹) and a BDF2 step, the second pre-image of Eq. 5.43. The
/// thesis solves a Laplace problem for the displacement with d = (Ĥⁿ⁺¹ − Ĥⁿ) e_y on the surface;
/// here each mesh column x is stretched piecewise linearly in y: [0, Ĥⁿ] onto [0, Ĥⁿ⁺¹] and
/// [Ĥⁿ, top] onto [Ĥⁿ⁺¹, top]. It moves the surface as the thesis' map does, keeps the symmetry
/// line, the die (Ĥ = H0 for x ≤ 0) and the mesh top fixed, and is the identity once the surface
/// is steady, so the steady state does not depend on it. Pre-images are interpolated with `remap`.
///
/// # Panics
/// If a pre-image falls outside the mesh (it cannot: the stretch maps [0, top] onto itself).
#[allow(clippy::too_many_arguments)]
pub fn stretch_map(
    mesh: &Mesh,
    top: f64,
    new: &HeightFunction,
    old: &HeightFunction,
    older: Option<&HeightFunction>,
    bdf: Bdf2,
    dt: f64,
    remap: Remap,
) -> AleMap {
    let back = |y: f64, to: f64, from: f64| {
        if y <= to {
            y * from / to
        } else {
            from + (y - to) * (top - from) / (top - to)
        }
    };
    let older = older.filter(|_| !bdf.is_euler());
    let at = |x: [f64; 2]| -> StencilWeights {
        let y = x[1].clamp(0.0, top);
        stencil_at(mesh, [x[0], y], remap).expect("a stretch pre-image lies in the mesh")
    };
    let nn = mesh.n_nodes();
    let mut at_n = Vec::with_capacity(mesh.n_vertices());
    let mut at_nm1 = older.map(|_| Vec::with_capacity(mesh.n_vertices()));
    let mut displacement = Vec::with_capacity(mesh.n_vertices());
    let mut mesh_velocity = Vec::with_capacity(nn);
    // vertices come in node order (`vertex_of_node` numbers them so)
    for k in 0..nn {
        let x = mesh.nodes[k];
        let (h_new, h_old) = (new.at(x[0]), old.at(x[0]));
        let yn = back(x[1], h_new, h_old);
        let ynm1 = older.map(|o| back(yn, h_old, o.at(x[0])));
        if mesh.vertex_of_node[k].is_some() {
            at_n.push(at([x[0], yn]));
            displacement.push([0.0, x[1] - yn]);
            if let (Some(v), Some(y2)) = (at_nm1.as_mut(), ynm1) {
                v.push(at([x[0], y2]));
            }
        }
        let um = match ynm1 {
            Some(y2) => (bdf.c0 * x[1] - bdf.c1 * yn + bdf.c2 * y2) / dt,
            None => (x[1] - yn) / dt,
        };
        mesh_velocity.push([0.0, um]);
    }
    AleMap {
        at_n,
        at_n_minus_1: at_nm1,
        mesh_velocity,
        displacement,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Round-off of the tridiagonal solve on O(1) heights.
    const TOL: f64 = 1e-12;

    /// A uniform flow u = (U, V) with V = const lifts the surface at slope V/U in steady state:
    /// H(x) = H0 + (V/U) x, which P1 represents exactly; the transient reaches it.
    #[test]
    fn a_uniform_lift_reaches_the_straight_steady_surface() {
        let x: Vec<f64> = (0..=40).map(|i| 0.05 * i as f64).collect();
        let mut s = HeightFunction::flat(x.clone(), 1.0);
        let u = vec![[1.0, 0.1]; x.len()];
        let mut change = 1.0;
        for _ in 0..400 {
            change = s.advance(&u, 0.05, 0.05, 0.05);
        }
        assert!(change < TOL, "steady: {change}");
        for (xi, h) in x.iter().zip(s.heights()) {
            assert!((h - (1.0 + 0.1 * xi)).abs() < 1e-9, "H({xi}) = {h}");
        }
        assert_eq!(s.heights()[0], 1.0, "pinned at the die exit");
    }

    /// τ held at a fixed Δt (`tau_dt`) keeps the discrete steady surface from following the step;
    /// τ at the step's Δt does not. A surface source that varies along x, so that the SUPG term
    /// matters (a linear H is exact for any τ): steady H after stepping with Δt 0.05 and 0.0125.
    #[test]
    fn a_held_tau_makes_the_steady_surface_independent_of_the_step() {
        /// The steady test of the stepping below (the BDF2 residual at convergence).
        const STEADY: f64 = 1e-13;
        let x: Vec<f64> = (0..=20).map(|i| 0.1 * i as f64).collect();
        let u: Vec<[f64; 2]> = x.iter().map(|&xi| [0.5, 0.2 * (3.0 * xi).sin()]).collect();
        let steady = |dt: f64, tau_dt: f64| {
            let mut s = HeightFunction::flat(x.clone(), 1.0);
            let mut change = 1.0;
            while change > STEADY {
                change = s.advance(&u, dt, dt, tau_dt);
            }
            s.heights().to_vec()
        };
        let diff = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f64::max)
        };
        let held = diff(&steady(0.05, 0.05), &steady(0.0125, 0.05));
        let following = diff(&steady(0.05, 0.05), &steady(0.0125, 0.0125));
        assert!(held < 1e-10, "τ held: the steady surfaces differ by {held}");
        assert!(
            following > 1e-4,
            "τ at the step: they differ by only {following}"
        );
    }

    /// The stretch as a vertex displacement: the old surface's points land on the new surface,
    /// the symmetry line, the mesh top and the die stay; the gap of a particle to a surface.
    #[test]
    fn the_stretch_moves_the_surface_onto_the_new_one_and_the_gap_is_the_distance() {
        let mesh = Mesh::rectangle(
            crate::mesh::Axis::uniform(-1.0, 2.0, 6),
            crate::mesh::Axis::uniform(0.0, 2.0, 8),
            false,
        );
        let xs: Vec<f64> = (2..=12).map(|i| mesh.ax.q2_coord(i)).collect();
        let old = HeightFunction::flat(xs.clone(), 1.0);
        let mut new = old.clone();
        new.h = xs.iter().map(|x| 1.0 + 0.1 * x).collect();
        let d = stretch_displacement(&mesh, 2.0, &new, &old);
        for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
            let [x, y] = mesh.nodes[k];
            assert_eq!(d[v][0], 0.0);
            let want = if (y - 1.0).abs() < 1e-12 {
                new.at(x) - 1.0
            } else if y == 0.0 || y == 2.0 || x <= 0.0 {
                0.0
            } else {
                d[v][1]
            };
            assert!((d[v][1] - want).abs() < TOL, "({x}, {y}): {:?}", d[v]);
        }
        // a flat surface at 1: the gap from below and the corner of a slope
        assert!((surface_gap(&old, [1.0, 0.8], 0.1) - 0.1).abs() < TOL);
        // upstream of the exit the die wall y = H0 bounds the fluid; next to the exit the
        // nearer of the wall and the surface
        let (q, d) = nearest_point(&old, [-0.5, 0.7]);
        assert!(q == [-0.5, 1.0] && (d - 0.3).abs() < TOL, "{q:?} {d}");
        // (this surface starts at x = −0.5, where the wall ends)
        assert_eq!(nearest_point(&new, [-0.7, 0.9]).0, [-0.7, 1.0], "the wall");
        let (q, _) = nearest_point(&new, [-0.45, 0.9]);
        assert!(
            q[0] > -0.5 && (q[1] - new.at(q[0])).abs() < TOL,
            "the surface: {q:?}"
        );
        let g = surface_gap(&new, [1.0, 0.8], 0.1);
        let exact = (1.1 - 0.8) / 0.1f64.hypot(1.0) - 0.1;
        assert!((g - exact).abs() < TOL, "{g} against {exact}");
    }

    /// The level set: the surface's sign, 1-Lipschitz, and the die wall's level just above H0.
    #[test]
    fn the_level_set_follows_the_surface_and_the_die() {
        let mut s = HeightFunction::flat(vec![0.0, 1.0, 2.0], 1.0);
        s.h = vec![1.0, 1.2, 1.2];
        let ls = s.level_set(0.1);
        assert!(ls.value([0.5, 1.05]) > 0.0 && ls.value([0.5, 1.15]) < 0.0);
        assert!(ls.value([-1.0, 1.0]) > 0.0 && ls.value([-1.0, 1.0 + 1e-6]) < 0.0);
        assert!((ls.value([1.5, 1.0]) - 0.2 / 0.2f64.hypot(1.0)).abs() < TOL);
        assert!((s.at(0.5) - 1.1).abs() < TOL && s.at(5.0) == 1.2 && s.at(-1.0) == 1.0);
    }
    /// The surface's ALE map: the new surface's points come from the old surface, the points
    /// above it from between the old surface and the fixed top, the die and the symmetry line stay
    /// (read off by interpolating the field f = y, which the bilinear stencil reproduces), and the
    /// mesh velocity is the Euler one, (y − yⁿ)/Δt; equal surfaces map to themselves.
    #[test]
    fn the_stretch_map_carries_the_old_surface_onto_the_new_one() {
        use crate::mesh::Axis;
        let mesh = Mesh::rectangle(
            Axis::uniform(-1.0, 2.0, 12),
            Axis::uniform(0.0, 2.0, 8),
            false,
        );
        let x: Vec<f64> = (0..=16).map(|i| 0.125 * i as f64).collect();
        let old = HeightFunction::flat(x.clone(), 1.0);
        let mut new = HeightFunction::flat(x, 1.0);
        new.h.iter_mut().skip(1).for_each(|h| *h = 1.5);
        let (dt, top) = (0.1, 2.0);
        let map = stretch_map(
            &mesh,
            top,
            &new,
            &old,
            None,
            Bdf2::EULER,
            dt,
            Remap::Bilinear,
        );
        assert!(map.at_n_minus_1.is_none());
        let y: Vec<f64> = mesh
            .node_of_vertex
            .iter()
            .map(|&n| mesh.nodes[n][1])
            .collect();
        let pre_image = |v: usize| -> f64 {
            (0..16)
                .map(|k| map.at_n[v].1[k] * y[map.at_n[v].0[k]])
                .sum()
        };
        for v in 0..mesh.n_vertices() {
            let node = mesh.node_of_vertex[v];
            let [xv, yv] = mesh.nodes[node];
            let want = if xv <= 0.0 {
                yv
            } else if yv <= 1.5 {
                yv / 1.5
            } else {
                1.0 + (yv - 1.5) * (top - 1.0) / (top - 1.5)
            };
            assert!(
                (pre_image(v) - want).abs() < TOL,
                "({xv}, {yv}): {}",
                pre_image(v)
            );
            assert!((map.mesh_velocity[node][1] - (yv - want) / dt).abs() < TOL / dt);
            assert_eq!(map.mesh_velocity[node][0], 0.0);
        }
        let still = stretch_map(
            &mesh,
            top,
            &new,
            &new,
            Some(&new),
            Bdf2::after(dt, Some(dt)),
            dt,
            Remap::Bilinear,
        );
        assert!(still.mesh_velocity.iter().all(|u| u[1].abs() < TOL));
        assert!(still.at_n_minus_1.is_some());
    }
}
