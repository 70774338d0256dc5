//! Field snapshots of a running case on the Q2 nodes, moved into the lab frame.

use super::frame::Frame;
use crate::fem::element::{q1, Q2_NODES};
use crate::mesh::Mesh;
use crate::observe::{FieldSnapshot, NodalField};
use crate::rheology::Sym2;
use crate::solver::cutcells::level_set;
use crate::solver::rigid::Particle;
use crate::xfem::LevelSet;

/// The flow fields of the last solve, for snapshots.
#[derive(Debug, Clone)]
pub struct FlowFields {
    /// Velocity at the Q2 nodes.
    pub u: Vec<[f64; 2]>,
    /// Pressure at the Q1 vertices.
    pub p: Vec<f64>,
    /// Particles (centres wrapped into the period) of that solve.
    pub particles: Vec<Particle>,
    /// Polymer stress τ at the Q1 vertices (empty for a fluid without polymer).
    pub tau: Vec<Sym2>,
}

/// The polymer-stress fields of a snapshot: tr τ and the components (xx, xy, yy).
pub const STRESS_FIELDS: [&str; 4] = ["tr_tau", "tau_xx", "tau_xy", "tau_yy"];

/// Field snapshot on the Q2 nodes (each element drawn as 4 sub-quadrilaterals; the periodic seam
/// gets its own column of nodes so that no quad spans the domain): velocity, pressure and, for a
/// viscoelastic fluid, the polymer stress ([`STRESS_FIELDS`]; both interpolated bilinearly from
/// the Q1 vertices), and the particles' level set.
pub fn snapshot(
    step: u64,
    t: f64,
    mesh: &Mesh,
    f: &FlowFields,
    period: Option<f64>,
) -> FieldSnapshot {
    let (nx, ny) = mesh.dims();
    let cols = 2 * nx + 1;
    let n = cols * (2 * ny + 1);
    let mut coords = vec![[0.0; 2]; n];
    let mut u = vec![0.0; 2 * n];
    let mut p = vec![0.0; n];
    let with_stress = !f.tau.is_empty();
    let mut stress = vec![vec![0.0; if with_stress { n } else { 0 }]; STRESS_FIELDS.len()];
    let mut quads = Vec::with_capacity(4 * nx * ny);
    for e in 0..mesh.n_elements() {
        let (ex, ey) = (e % nx, e / nx);
        let vs = mesh.element_vertices[e];
        for b in 0..3 {
            for a in 0..3 {
                let id = (2 * ex + a) + cols * (2 * ey + b);
                let k = a + 3 * b;
                coords[id] = mesh.element_coords[e][k];
                let node = mesh.elements[e][k];
                u[2 * id] = f.u[node][0];
                u[2 * id + 1] = f.u[node][1];
                let psi = q1(Q2_NODES[k]).0;
                p[id] = (0..4).map(|m| psi[m] * f.p[vs[m]]).sum();
                if with_stress {
                    let tau = (0..4).fold(Sym2::new(0.0, 0.0, 0.0), |acc, m| {
                        acc + psi[m] * f.tau[vs[m]]
                    });
                    let values = [tau.xx + tau.yy, tau.xx, tau.xy, tau.yy];
                    for (field, v) in stress.iter_mut().zip(values) {
                        field[id] = v;
                    }
                }
            }
        }
        for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let id = |da: usize, db: usize| (2 * ex + a + da) + cols * (2 * ey + b + db);
            quads.push([id(0, 0), id(1, 0), id(1, 1), id(0, 1)]);
        }
    }
    let mut fields = vec![
        NodalField {
            name: "u".into(),
            components: 2,
            values: u,
        },
        NodalField {
            name: "p".into(),
            components: 1,
            values: p,
        },
    ];
    if with_stress {
        for (name, values) in STRESS_FIELDS.iter().zip(stress) {
            fields.push(NodalField {
                name: (*name).into(),
                components: 1,
                values,
            });
        }
    }
    if let Ok(ls) = level_set(&f.particles, period) {
        fields.push(NodalField {
            name: "level_set".into(),
            components: 1,
            values: coords.iter().map(|&x| ls.value(x)).collect(),
        });
    }
    FieldSnapshot {
        step,
        t,
        coords,
        quads,
        fields,
    }
}

/// A snapshot of the solver's frame moved into the lab frame (node positions, velocity and the
/// polymer stress's components).
pub fn in_lab(mut snap: FieldSnapshot, frame: Frame) -> FieldSnapshot {
    if frame == Frame::LAB {
        return snap;
    }
    let t = snap.t;
    if let Frame::Rotating(w) = frame {
        // τ_lab = R τ Rᵀ with R the rotation by ωt (tr τ is invariant)
        let (s, c) = (w * t).sin_cos();
        let at: Vec<Option<usize>> = STRESS_FIELDS[1..]
            .iter()
            .map(|name| snap.fields.iter().position(|f| f.name == *name))
            .collect();
        if let [Some(ixx), Some(ixy), Some(iyy)] = at[..] {
            for k in 0..snap.coords.len() {
                let (xx, xy, yy) = (
                    snap.fields[ixx].values[k],
                    snap.fields[ixy].values[k],
                    snap.fields[iyy].values[k],
                );
                snap.fields[ixx].values[k] = c * c * xx - 2.0 * s * c * xy + s * s * yy;
                snap.fields[ixy].values[k] = s * c * (xx - yy) + (c * c - s * s) * xy;
                snap.fields[iyy].values[k] = s * s * xx + 2.0 * s * c * xy + c * c * yy;
            }
        }
    }
    let u = snap.fields.iter_mut().find(|f| f.name == "u");
    let mut u = u.map(|f| &mut f.values);
    for (k, c) in snap.coords.iter_mut().enumerate() {
        let uk = u.as_ref().map_or([0.0; 2], |u| [u[2 * k], u[2 * k + 1]]);
        let (x, ul) = frame.to_lab(t, *c, uk);
        *c = x;
        if let Some(u) = u.as_mut() {
            u[2 * k] = ul[0];
            u[2 * k + 1] = ul[1];
        }
    }
    snap
}

#[cfg(test)]
mod tests {
    use super::*;

    /// τ = e_x ⊗ e_x in a frame rotated by ωt = π/4 is ((1, 1), (1, 1))/2 in the lab (R τ Rᵀ
    /// with the rotation `to_lab` applies to positions); tr τ is unchanged.
    #[test]
    fn the_stress_of_a_rotating_frame_is_rotated_into_the_lab() {
        let scalar = |name: &str, v: f64| NodalField {
            name: name.into(),
            components: 1,
            values: vec![v],
        };
        let snap = FieldSnapshot {
            step: 1,
            t: 1.0,
            coords: vec![[1.0, 0.0]],
            quads: Vec::new(),
            fields: vec![
                scalar("tr_tau", 1.0),
                scalar("tau_xx", 1.0),
                scalar("tau_xy", 0.0),
                scalar("tau_yy", 0.0),
            ],
        };
        let lab = in_lab(snap, Frame::Rotating(std::f64::consts::FRAC_PI_4));
        let value = |name: &str| lab.fields.iter().find(|f| f.name == name).unwrap().values[0];
        for (name, expected) in [
            ("tr_tau", 1.0),
            ("tau_xx", 0.5),
            ("tau_xy", 0.5),
            ("tau_yy", 0.5),
        ] {
            assert!(
                (value(name) - expected).abs() < 1e-15,
                "{name} = {}",
                value(name)
            );
        }
        // the node itself went the same way: (1, 0) → (1, 1)/√2
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!((lab.coords[0][0] - s).abs() < 1e-15 && (lab.coords[0][1] - s).abs() < 1e-15);
    }
}
