//! Assembly of the flow system: the element loop (cached fluid base, rectangles by their sides,
//! fluid and cut elements with the weak rigid-body condition, body force and polymer stress),
//! the multiplier rigid-body condition where it replaces the weak one,
//! the patch ghost penalty of velocity γ (η + θ)/h² and pressure −γ/(η + θ) (and θγ on G), and
//! the elimination of the constraints.

use std::collections::HashMap;

use super::cache::{assembled_each_step, canonical_rectangle, GhostPatch, RECTANGLE_CACHE_LEN};
use super::dofs::{element_dofs, MAX_EL_DOFS};
use super::kernels::{fluid_element_matrix, shape_table, stokes_kernel};
use super::Stokes;
use crate::fem::element::{physical_gradients, q1, q2, q2_map};
use crate::mesh::Shape;
use crate::solver::ghost::{ghost_faces, FaceSide, GhostFace};
use crate::solver::lubrication::films;
use crate::solver::multiplier::RigidCondition;
use crate::solver::polymer_terms::{boundary_terms, volume_terms, PolymerStress};
use crate::solver::rigid::{jump_vectors, weak_rigid_kernel, CutElement, ElementCut};

impl Stokes {
    pub(super) fn assemble(
        &mut self,
        f: &dyn Fn([f64; 2]) -> [f64; 2],
        stress: Option<&dyn PolymerStress>,
    ) {
        let lay = self.layout;
        let (eta, theta) = (self.params.eta, self.params.theta);
        let nd = 22 + if lay.with_g { 16 } else { 0 };
        // the Stokes part of the fluid elements is the same every step; a semi-implicit stress
        // adds its matrix on top of it
        let implicit = stress.is_some_and(|ps| ps.is_implicit());
        if self
            .fluid_base
            .as_ref()
            .is_none_or(|b| (b.eta, b.theta) != (eta, theta))
        {
            self.fluid_base = Some(self.fluid_base());
        }
        let base = self.fluid_base.take().expect("built above");
        self.matrix.values.copy_from_slice(&base.values);
        self.rhs.iter_mut().for_each(|v| *v = 0.0);
        let rectangles = self.mesh.shape == Shape::Rectangle;
        if rectangles
            && ((self.rectangles.0, self.rectangles.1) != (eta, theta)
                || self.rectangles.2.len() > RECTANGLE_CACHE_LEN)
        {
            self.rectangles = (eta, theta, HashMap::new());
        }
        let mut dofs = Vec::with_capacity(MAX_EL_DOFS);
        let mut ke = [0.0; MAX_EL_DOFS * MAX_EL_DOFS];
        let mut fe = [0.0; MAX_EL_DOFS];
        let tab = shape_table(&self.rule);
        let mut dn = [[0.0; 2]; 9];
        // the weak condition's terms on the boundary pieces (the multipliers are added below)
        let weak = self.params.rigid_condition == RigidCondition::Weak;
        for e in 0..self.mesh.n_elements() {
            element_dofs(&self.mesh, &lay, e, &mut dofs);
            let xe = &self.mesh.element_coords[e];
            // outside every particle's reach an element is fluid while the pattern lasts and,
            // unless it may move, its Stokes matrix is in the base (built without the reach and
            // the moving elements: no cancellation on cut rows)
            let in_base = !assembled_each_step(&self.reach, &self.moving, e);
            let cut = match &self.cuts[e] {
                ElementCut::Inside => continue,
                ElementCut::Fluid => None,
                ElementCut::Cut(c) => Some(c),
            };
            let pieces = if weak {
                cut.map_or(&[][..], |c| &c.particles[..])
            } else {
                &[]
            };
            let ndc = nd + 3 * pieces.len();
            assert!(
                ndc <= MAX_EL_DOFS,
                "element {e} is cut by more than 4 particle pieces"
            );
            let ke = &mut ke[..ndc * ndc];
            let fe = &mut fe[..ndc];
            ke.iter_mut().for_each(|v| *v = 0.0);
            fe.iter_mut().for_each(|v| *v = 0.0);
            // a fluid rectangle outside the base: its matrix from the sides, the loads below
            let by_sides = rectangles && cut.is_none() && !in_base;
            match cut {
                None if in_base || by_sides => {
                    // the Stokes matrix is in the base or known from the sides: the loads and
                    // the semi-implicit stress's matrix only (a base element's map from the
                    // base's table)
                    for (q, ((n2, dref), _)) in tab.iter().enumerate() {
                        let (x, jac, det) = if in_base {
                            base.maps.at(e)[q]
                        } else {
                            q2_map(xe, self.rule.points[q])
                        };
                        let w = self.rule.weights[q] * det;
                        let force = f(x);
                        for a in 0..9 {
                            fe[2 * a] += w * n2[a] * force[0];
                            fe[2 * a + 1] += w * n2[a] * force[1];
                        }
                        if let Some(ps) = stress {
                            physical_gradients(&jac, det, dref, &mut dn);
                            let lin = ps.at(e, self.rule.points[q], x, false);
                            volume_terms(ke, fe, ndc, w, n2, &dn, &lin);
                        }
                    }
                    if in_base && !implicit {
                        for (a, &i) in dofs.iter().enumerate() {
                            self.rhs[i] += fe[a];
                        }
                        continue;
                    }
                    if by_sides {
                        let (key, canonical) = canonical_rectangle(xe);
                        let m = self.rectangles.2.entry(key).or_insert_with(|| {
                            let mut m = vec![0.0; nd * nd];
                            let rule = &self.rule;
                            fluid_element_matrix(
                                &canonical, rule, &tab, eta, theta, lay.with_g, &mut m,
                            );
                            m.into_boxed_slice()
                        });
                        ke.iter_mut().zip(m.iter()).for_each(|(k, m)| *k += m);
                    }
                }
                None => {
                    for (q, ((n2, dref), psi)) in tab.iter().enumerate() {
                        let (x, jac, det) = q2_map(xe, self.rule.points[q]);
                        let w = self.rule.weights[q] * det;
                        physical_gradients(&jac, det, dref, &mut dn);
                        stokes_kernel(ke, fe, ndc, w, eta, theta, n2, &dn, psi, f(x), lay.with_g);
                        if let Some(ps) = stress {
                            let lin = ps.at(e, self.rule.points[q], x, false);
                            volume_terms(ke, fe, ndc, w, n2, &dn, &lin);
                        }
                    }
                }
                Some(cut) => {
                    for &(xi, wref) in &cut.vol {
                        let (x, jac, det) = q2_map(xe, xi);
                        let (n2, dref) = q2(xi);
                        physical_gradients(&jac, det, &dref, &mut dn);
                        let psi = q1(xi).0;
                        stokes_kernel(
                            ke,
                            fe,
                            ndc,
                            wref * det,
                            eta,
                            theta,
                            &n2,
                            &dn,
                            &psi,
                            f(x),
                            lay.with_g,
                        );
                        if let Some(ps) = stress {
                            let lin = ps.at(e, xi, x, false);
                            volume_terms(ke, fe, ndc, wref * det, &n2, &dn, &lin);
                        }
                    }
                    for (slot, pc) in pieces.iter().enumerate() {
                        dofs.extend((0..3).map(|c| lay.rigid(pc.particle, c)));
                        let ce = CutElement::of(xe, cut, pc);
                        let off = nd + 3 * slot;
                        weak_rigid_kernel(
                            ke,
                            ndc,
                            off,
                            &ce,
                            pc.center,
                            eta,
                            self.params.kappa,
                            self.params.rigid_form,
                        );
                        // the polymer consistency term: none on a two-sided boundary (FDM)
                        if let Some(ps) = stress.filter(|_| !cut.whole) {
                            for bp in &pc.points {
                                let (_, jac, det) = q2_map(xe, bp.xi);
                                let (n2, dref) = q2(bp.xi);
                                physical_gradients(&jac, det, &dref, &mut dn);
                                let r = [bp.x[0] - pc.center[0], bp.x[1] - pc.center[1]];
                                let jv = jump_vectors(&n2, r);
                                let lin = ps.at(e, bp.xi, bp.x, true);
                                boundary_terms(ke, fe, ndc, off, bp.w, &jv, &n2, &dn, bp.n, &lin);
                            }
                        }
                    }
                }
            }
            // the element's own block at its positions; a cut element's rigid rows and columns
            // by search
            let positions = self.positions.of(e, &dofs[..nd], &self.matrix);
            self.matrix.add_block_at(positions, ke, ndc, nd);
            if ndc > nd {
                self.matrix.add_border(&dofs, ke, nd);
            }
            for (a, &i) in dofs.iter().enumerate() {
                self.rhs[i] += fe[a];
            }
        }
        self.fluid_base = Some(base);
        if !weak {
            self.assemble_multipliers();
        }
        if self.params.ghost_penalty > 0.0 {
            self.assemble_ghost_penalty();
        }
        self.assemble_lubrication();
        if self.transpose.is_empty() {
            self.transpose = self.matrix.transpose_positions();
        }
        self.matrix
            .eliminate_constraints(&mut self.rhs, &self.fixed, &self.transpose);
        self.matrix.apply_constraints(&mut self.rhs, &self.fixed);
    }

    /// Adds the resistance R n nᵀ of each film the mesh does not resolve to the translational
    /// rows of its particles (−R n nᵀ between them; [`crate::solver::lubrication`]).
    fn assemble_lubrication(&mut self) {
        let Some(lubrication) = self.params.lubrication else {
            return;
        };
        let lay = self.layout;
        self.films = films(&self.mesh, &self.particles, &lubrication);
        if !self.films.is_empty() {
            self.stats.lubricated_solves += 1;
        }
        for film in &self.films {
            let [nx, ny] = film.normal;
            let r = film.resistance;
            let block = [r * nx * nx, r * nx * ny, r * ny * nx, r * ny * ny];
            let first = [lay.rigid(film.first, 0), lay.rigid(film.first, 1)];
            match film.second {
                None => self.matrix.scatter(
                    &first,
                    &block,
                    &[0.0; 2],
                    &mut self.rhs,
                    &self.unconstrained,
                ),
                Some(j) => {
                    let dofs = [first[0], first[1], lay.rigid(j, 0), lay.rigid(j, 1)];
                    let mut k = [0.0; 16];
                    for a in 0..4 {
                        for b in 0..4 {
                            let sign = if (a < 2) == (b < 2) { 1.0 } else { -1.0 };
                            k[4 * a + b] = sign * block[2 * (a % 2) + b % 2];
                        }
                    }
                    self.matrix
                        .scatter(&dofs, &k, &[0.0; 4], &mut self.rhs, &self.unconstrained);
                }
            }
        }
    }

    /// Adds the patch ghost penalty of velocity and pressure on the faces of cut elements.
    fn assemble_ghost_penalty(&mut self) {
        let lay = self.layout;
        let visc = self.params.eta + self.params.theta;
        const N: usize = 44;
        let mut ke = [0.0; N * N];
        let zero = [0.0; N];
        let mut dofs = [0usize; N];
        // the last step's patches, for the faces that are ghost faces still
        let mut last = std::mem::take(&mut self.ghost_patches);
        for face in ghost_faces(&self.mesh, &self.cuts) {
            let key = face_key(&face);
            let patch = last
                .remove(&key)
                .unwrap_or_else(|| GhostPatch::of(&self.mesh, &face, &self.rule));
            let (k2, k1, h) = (&patch.k2, &patch.k1, patch.h);
            let (gu, gp) = (
                self.params.ghost_penalty * visc / (h * h),
                -self.params.ghost_penalty / visc,
            );
            let (e1, e2) = (face.first, face.second);
            let nodes = [self.mesh.elements[e1], self.mesh.elements[e2]];
            let verts = [
                self.mesh.element_vertices[e1],
                self.mesh.element_vertices[e2],
            ];
            for a in 0..18 {
                let k = nodes[a / 9][a % 9];
                dofs[2 * a] = lay.u(k, 0);
                dofs[2 * a + 1] = lay.u(k, 1);
            }
            for a in 0..8 {
                dofs[36 + a] = lay.p(verts[a / 4][a % 4]);
            }
            ke.fill(0.0);
            for a in 0..18 {
                for b in 0..18 {
                    let v = gu * k2[18 * a + b];
                    ke[(2 * a) * N + 2 * b] = v;
                    ke[(2 * a + 1) * N + 2 * b + 1] = v;
                }
            }
            for a in 0..8 {
                for b in 0..8 {
                    ke[(36 + a) * N + 36 + b] = gp * k1[8 * a + b];
                }
            }
            // (by columns, as `scatter` adds: the faces' shared nodes repeat in `dofs`)
            let positions = self.face_positions.of(face_key(&face), &dofs, &self.matrix);
            self.matrix.add_at_by_columns(positions, &ke, N);
            if lay.with_g {
                // G's rows are an L² projection (θ(G, H)): the same patch term, unscaled by h
                let kg = k1.map(|v| self.params.ghost_penalty * self.params.theta * v);
                for ij in 0..4 {
                    let g_dofs: [usize; 8] =
                        std::array::from_fn(|a| lay.g(verts[a / 4][a % 4], ij));
                    self.matrix.scatter(
                        &g_dofs,
                        &kg,
                        &zero[..8],
                        &mut self.rhs,
                        &self.unconstrained,
                    );
                }
            }
            self.ghost_patches.insert(key, patch);
        }
    }
}

/// A ghost-penalty face's key among the faces of a mesh: its first element and its side.
pub(super) fn face_key(face: &GhostFace) -> usize {
    2 * face.first + usize::from(face.side == FaceSide::Top)
}
