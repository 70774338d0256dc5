//! The outcome record of a decision: the final state (positions, ω*, gaps, r*, the free
//! surface, the resolution it rests on, a chain that held on the way) around its kind.

use serde_json::json;

use super::{
    chain_gaps, layout, Classifier, Geometry, Outcome, OutcomeKind, ParticleState, MIN_GAP_ELEMENTS,
};

impl Classifier {
    /// The outcome `kind` decided at time `t` (with a `reason` for `diverged`), with the final
    /// state of the last sample.
    pub(super) fn outcome(&self, kind: OutcomeKind, t: f64, reason: Option<&str>) -> Outcome {
        let ps: &[ParticleState] = self.last.as_ref().map_or(&[], |s| &s.particles);
        let (mut final_state, gaps) = self.particles_at(t);
        let centres: Vec<[f64; 2]> = ps.iter().map(|p| [p.x, p.y]).collect();
        let mean_gap = (!gaps.is_empty() && gaps.iter().all(|g| g.is_finite()))
            .then(|| gaps.iter().sum::<f64>() / gaps.len() as f64 / self.radius);
        if let Geometry::Couette { r1, r2, .. } = self.geometry {
            final_state["r_star"] = json!(centres
                .iter()
                .map(|c| layout::r_star(r1, r2, *c))
                .collect::<Vec<_>>());
        }
        if let Some(f) = self.last.as_ref().and_then(|s| s.surface.as_ref()) {
            final_state["surface"] = json!({
                "x": f.profile.iter().map(|p| p[0]).collect::<Vec<_>>(),
                "h": f.profile.iter().map(|p| p[1]).collect::<Vec<_>>(),
                "swell": f.swell(),
                "change": f.change,
            });
        }
        if let Some(u) = &self.undisturbed {
            final_state["undisturbed_surface"] = json!({
                "x": u.profile.iter().map(|p| p[0]).collect::<Vec<_>>(),
                "h": u.profile.iter().map(|p| p[1]).collect::<Vec<_>>(),
                "swell": u.swell,
                "steps": u.steps,
                "steady": u.steady,
                "shared": u.shared,
            });
        }
        if ps.iter().any(|p| p.separation.is_some()) {
            final_state["separation"] = json!(ps.iter().map(|p| p.separation).collect::<Vec<_>>());
        }
        if let Some(e) = self.last.as_ref().and_then(|s| s.gap_elements) {
            final_state["gap_elements"] = json!(e);
        }
        if let (Some([from, to]), false) = (self.longest_chain(), kind == OutcomeKind::String) {
            // a string formed before this outcome (and came apart, or met a contact)
            final_state["chain_held"] = json!({ "from": from, "to": to });
        }
        if let Some(m) = self.min_gap_elements {
            final_state["gap_elements_min"] = json!(m);
            // (a contact has no gap to resolve; diverged and timeout decide nothing)
            let decided = matches!(
                kind,
                OutcomeKind::String
                    | OutcomeKind::Repel
                    | OutcomeKind::Pass
                    | OutcomeKind::Steady
                    | OutcomeKind::Migrated
            );
            if decided && m < MIN_GAP_ELEMENTS {
                final_state["warning"] = json!(format!(
                    "the narrowest gap had {m:.2} elements across it (< {MIN_GAP_ELEMENTS}): the \
                     outcome may depend on the mesh"
                ));
            }
        }
        if let Some(r) = reason {
            final_state["reason"] = json!(r);
        } else if kind == OutcomeKind::Diverged {
            final_state["reason"] = json!("non-finite particle state");
        }
        Outcome {
            kind,
            string_length: (kind == OutcomeKind::String).then_some(ps.len()),
            t_decided: t,
            mean_gap: if kind == OutcomeKind::Diverged {
                None
            } else {
                mean_gap
            },
            final_state,
        }
    }

    /// The particles of the last sample, labelled time `t`: `{t, positions, omega_star,
    /// gaps_over_a}` (the core of every final state, and a run's `at_end`), and the chain's
    /// surface gaps.
    pub(super) fn particles_at(&self, t: f64) -> (serde_json::Value, Vec<f64>) {
        let ps: &[ParticleState] = self.last.as_ref().map_or(&[], |s| &s.particles);
        let centres: Vec<[f64; 2]> = ps.iter().map(|p| [p.x, p.y]).collect();
        let gaps = if centres.len() >= 2 && self.radius > 0.0 {
            chain_gaps(&centres, self.radius, self.period)
        } else {
            Vec::new()
        };
        let state = json!({
            "t": t,
            "positions": centres,
            "omega_star": ps.iter().map(|p| p.omega / self.omega_scale()).collect::<Vec<_>>(),
            "gaps_over_a": gaps.iter().map(|g| g / self.radius).collect::<Vec<_>>(),
        });
        (state, gaps)
    }
}
