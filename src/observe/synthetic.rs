//! Synthetic, deterministic trajectories that produce each outcome kind under the rules of
//! [`super::outcome`]. They stand in for the solver in tests of the classifier, the sweep engine and the
//! store (STYLE.md item 7); they are not physics.

use super::{OutcomeKind, ParticleState, Sample};
use crate::config::{CaseSpec, Geometry};
use crate::geometry::layout;

/// Relaxation time of the synthetic approach to a final state, in units of t* (the steady-state test
/// fires near t* ≈ 10 with Δt = 0.01).
const RELAX: f64 = 1.0;
/// Duration of the approach-and-turn of a synthetic `repel`, in t*.
const TURN: f64 = 4.0;

/// Particle states at time `t` (step `step`) of a trajectory of `spec` that ends in `kind`.
///
/// `Diverged` returns NaN states from t = 1 on; kinds that do not fit the geometry (e.g. `Pass` in Couette
/// flow) give particles at rest with a never-steady ω (a `timeout`).
pub fn sample(kind: OutcomeKind, spec: &CaseSpec, step: u64, t: f64) -> Sample {
    let rate = spec.characteristic_rate();
    let ts = t * rate;
    let a = spec.radius().unwrap_or(0.0);
    let init = spec.initial_positions();
    let n = init.len();
    let centre = (n as f64 - 1.0) / 2.0;
    let decay = (-ts / RELAX).exp();
    let wobble = 0.5 + 0.1 * (2.0 * std::f64::consts::PI * ts).sin();
    let shear = matches!(spec.geometry, Geometry::ConfinedShear { .. });
    let particles = (0..n)
        .map(|k| {
            let s = k as f64 - centre;
            let p0 = init[k];
            let (pos, omega_star) = match kind {
                OutcomeKind::String | OutcomeKind::Steady if shear => {
                    // Chain along the initial string direction with gaps of 0.1a (String) or 4a (Steady).
                    let gap = if kind == OutcomeKind::String {
                        0.1
                    } else {
                        4.0
                    };
                    let dir = string_direction(&init);
                    let target = [s * (2.0 + gap) * a * dir[0], s * (2.0 + gap) * a * dir[1]];
                    (lerp(target, p0, decay), 0.3 * (1.0 - decay))
                }
                OutcomeKind::Repel if shear => {
                    let c = 0.5 * a;
                    let x = p0[0]
                        - sgn(s)
                            * (c * (std::f64::consts::PI * ts / TURN).sin() - 0.1 * c * ts / TURN);
                    let y = p0[1] * (1.0 - 2.0 * (ts / TURN).min(1.0));
                    ([x, y], wobble)
                }
                OutcomeKind::Pass if shear => {
                    let ramp = (ts / RELAX).min(1.0);
                    let y = p0[1] + (-s * 2.5 * a - p0[1]) * ramp;
                    ([p0[0] - s * 2.0 * ts * a, y], wobble)
                }
                OutcomeKind::Jammed => (lerp([0.0, 0.0], p0, (1.0 - ts / TURN).max(0.0)), wobble),
                OutcomeKind::WallContact if k == 0 => {
                    let up = if p0[1] < 0.0 { -1.0 } else { 1.0 };
                    ([p0[0], p0[1] + up * 0.5 * ts], wobble)
                }
                OutcomeKind::Migrated | OutcomeKind::Steady => match spec.geometry {
                    Geometry::Couette { r1, r2, .. } => {
                        let r0 = layout::r_star(r1, r2, p0);
                        let goal = if kind == OutcomeKind::Migrated {
                            r0 + 0.1 * (0.5 - r0).signum()
                        } else {
                            r0
                        };
                        let r = r0 + (goal - r0) * (1.0 - decay);
                        let phi = p0[1].atan2(p0[0]) + 0.1 * ts;
                        // a particle that stays rotates steadily; a migrating one need not
                        let omega_star = if kind == OutcomeKind::Steady {
                            0.5
                        } else {
                            wobble
                        };
                        (layout::couette_position(r1, r2, r, phi), omega_star)
                    }
                    _ => (p0, wobble),
                },
                OutcomeKind::Diverged if ts >= 1.0 => ([f64::NAN, f64::NAN], f64::NAN),
                _ => (p0, wobble),
            };
            ParticleState {
                x: pos[0],
                y: pos[1],
                u: 0.0,
                v: 0.0,
                omega: omega_star * rate,
                theta: omega_star * ts,
                separation: None,
            }
        })
        .map(|mut p| {
            if let Geometry::ConfinedShear { l, .. } = spec.geometry {
                // Positions are reported folded into the periodic channel, as a solver would.
                p.x = crate::periodic::fold(p.x, Some(l));
            }
            p
        })
        .collect();
    Sample {
        step,
        t,
        particles,
        gap_elements: None,
        surface: None,
    }
}

fn lerp(target: [f64; 2], start: [f64; 2], weight_of_start: f64) -> [f64; 2] {
    [
        target[0] + (start[0] - target[0]) * weight_of_start,
        target[1] + (start[1] - target[1]) * weight_of_start,
    ]
}

/// Sign that is 0 at 0 (`f64::signum` gives 1 there).
fn sgn(s: f64) -> f64 {
    if s == 0.0 {
        0.0
    } else {
        s.signum()
    }
}

fn unit(p: [f64; 2]) -> [f64; 2] {
    let r = p[0].hypot(p[1]);
    [p[0] / r, p[1] / r]
}

/// Unit vector from the first to the last particle (x-axis for one particle).
fn string_direction(init: &[[f64; 2]]) -> [f64; 2] {
    match (init.first(), init.last()) {
        (Some(f), Some(l)) if init.len() >= 2 && (l[0] - f[0]).hypot(l[1] - f[1]) > 0.0 => {
            unit([l[0] - f[0], l[1] - f[1]])
        }
        _ => [1.0, 0.0],
    }
}
