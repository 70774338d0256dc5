//! The SUPG parameter τ of the log-conformation transport (thesis Eqs. 3.22–3.24 and the "Note
//! on the SUPG parameter", §2.3.2): its characteristic velocity, the Courant switch and the
//! element length along the flow.

/// SUPG parameter of Eqs. 3.22–3.24: `τ = β̄ h/(2 U_c)`, `β̄ = min(1, C)`, `C = U_c Δt/h`,
/// which is `min(h/(2 U_c), Δt/2)` (and `Δt/2` for `U_c = 0`, where the SUPG term vanishes anyway).
#[inline]
pub fn supg_tau(speed: f64, h: f64, dt: f64) -> f64 {
    if speed > 0.0 && speed * dt >= h {
        h / (2.0 * speed)
    } else {
        0.5 * dt
    }
}

/// Element length in the direction of `w` at a point with Jacobian `jac` (`J_ij = ∂x_i/∂ξ_j`): the
/// chord through the point of the (locally affine) element, `h = 2‖w‖/‖J⁻¹w‖_∞` (the reference
/// square [−1, 1]² has the chord `2/‖r‖_∞` in the unit direction r); 0 for `w = 0`.
#[inline]
pub fn length_along(jac: &[[f64; 2]; 2], det: f64, w: [f64; 2]) -> f64 {
    let speed = (w[0] * w[0] + w[1] * w[1]).sqrt();
    if speed == 0.0 {
        return 0.0;
    }
    let r = [
        (jac[1][1] * w[0] - jac[0][1] * w[1]) / det,
        (-jac[1][0] * w[0] + jac[0][0] * w[1]) / det,
    ];
    2.0 * speed / r[0].abs().max(r[1].abs())
}

/// Characteristic velocity of the SUPG parameter ("Note on the SUPG parameter", §2.3.2).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum SupgVelocity {
    /// Case 1 (Eqs. 2.37, 3.22–3.24): `U_c = ‖w‖` at each quadrature point with the Courant
    /// switch, `τ = min(h/(2‖w‖), Δt/2)` — the thesis' choice for particle flows.
    #[default]
    Local,
    /// Case 3 (Eq. 2.42): a global velocity scale, `τ = h/(2 U_glob)` (β̄ = 1), independent of Δt.
    Global(f64),
    /// Case 1 with the Courant switch at this fixed Δt instead of the step's, for variable steps:
    /// τ is part of the spatial discretization (it sets the discrete steady state), so a step that
    /// grows or shrinks must not change it. With the case's initial Δt it is the fixed-step
    /// scheme's τ.
    LocalAt(f64),
}

impl SupgVelocity {
    /// τ at a point with convective speed `speed`, element length `h` along the flow, step `dt`.
    #[inline]
    pub fn tau(self, speed: f64, h: f64, dt: f64) -> f64 {
        match self {
            SupgVelocity::Global(u) => h / (2.0 * u),
            SupgVelocity::Local | SupgVelocity::LocalAt(_) => supg_tau(speed, h, self.step(dt)),
        }
    }

    /// The Δt a τ of this kind is taken at during a step `dt`: the fixed one of
    /// [`LocalAt`](Self::LocalAt), else the step's. (Also the Δt of the free surface's τ, so
    /// that one setting holds both.)
    #[inline]
    pub fn step(self, dt: f64) -> f64 {
        match self {
            SupgVelocity::LocalAt(fixed) => fixed,
            SupgVelocity::Local | SupgVelocity::Global(_) => dt,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With variable steps τ stays that of the fixed Δt on both sides of the Courant switch, so
    /// the discrete steady state does not follow the step.
    #[test]
    fn tau_at_a_fixed_step_ignores_the_step_taken() {
        let at = SupgVelocity::LocalAt(0.02);
        for (speed, h) in [(0.1, 0.05), (5.0, 0.05), (0.0, 0.05)] {
            let fixed = supg_tau(speed, h, 0.02);
            for dt in [0.005, 0.02, 0.08] {
                assert_eq!(at.tau(speed, h, dt), fixed, "speed {speed}, Δt {dt}");
            }
        }
        // Case 1 follows the step below the switch: 0.1 · 0.08 < 0.05
        assert_eq!(SupgVelocity::Local.tau(0.1, 0.05, 0.08), 0.04);
    }
}
