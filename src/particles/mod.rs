//! Rigid-body state of the particles, the predictor–corrector of thesis Eqs. 5.45–5.47 and
//! 5.54–5.56, and overlap / wall-contact detection (reported, never silently continued).

/// Positions, orientations and velocities of all particles at one time level.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RigidState {
    /// Centres X_i (unwrapped: periodic wrapping is left to the geometry).
    pub x: Vec<[f64; 2]>,
    /// Orientation angles Θ_i.
    pub theta: Vec<f64>,
    /// Translational velocities U_i.
    pub u: Vec<[f64; 2]>,
    /// Angular velocities ω_i.
    pub omega: Vec<f64>,
}

impl RigidState {
    /// Particles at rest at the given centres.
    pub fn at_rest(x: Vec<[f64; 2]>) -> Self {
        let n = x.len();
        Self {
            x,
            theta: vec![0.0; n],
            u: vec![[0.0; 2]; n],
            omega: vec![0.0; n],
        }
    }
}

/// Yⁿ + ω(Yⁿ − Yⁿ⁻¹), written 2Yⁿ − Yⁿ⁻¹ for ω = 1 (Eq. 5.45, bit for bit as with fixed steps).
fn extrapolated(c: f64, q: f64, ratio: f64) -> f64 {
    if ratio == 1.0 {
        2.0 * c - q
    } else {
        c + ratio * (c - q)
    }
}

/// The state extrapolated to tⁿ⁺¹, Ŷ = Yⁿ + ω(Yⁿ − Yⁿ⁻¹) for Y = X, Θ, U, ω and the step ratio
/// ω = Δtₙ/Δtₙ₋₁ (`None` at the first step, whose predictor is Xⁿ, Eq. 5.47): its centres are the
/// predictor X̂ⁿ⁺¹ of Eq. 5.45, the whole state what the step controller compares the corrected
/// one with.
pub fn extrapolate(prev: Option<&RigidState>, cur: &RigidState, ratio: f64) -> Option<RigidState> {
    let p = prev?;
    let e = |c: f64, q: f64| extrapolated(c, q, ratio);
    let e2 = |c: &[f64; 2], q: &[f64; 2]| [e(c[0], q[0]), e(c[1], q[1])];
    let scalars = |c: &[f64], q: &[f64]| c.iter().zip(q).map(|(&c, &q)| e(c, q)).collect();
    Some(RigidState {
        x: cur.x.iter().zip(&p.x).map(|(c, q)| e2(c, q)).collect(),
        theta: scalars(&cur.theta, &p.theta),
        u: cur.u.iter().zip(&p.u).map(|(c, q)| e2(c, q)).collect(),
        omega: scalars(&cur.omega, &p.omega),
    })
}

/// How far the particles of a step are from their extrapolation (max over particles; each
/// ≈ ½(1+ω)Δt²|Ÿ| for smooth motion): the step controller's error estimate.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Deviation {
    /// |Xⁿ⁺¹ − X̂| and a|Θⁿ⁺¹ − Θ̂|, in radii a.
    pub position: f64,
    /// |Uⁿ⁺¹ − Û| and a|ωⁿ⁺¹ − ω̂|, in radii a per unit time.
    pub velocity: f64,
}

/// How far `state` is from the `expected` (extrapolated) one, for particles of radius `radius`.
pub fn deviation(state: &RigidState, expected: &RigidState, radius: &[f64]) -> Deviation {
    let mut d = Deviation::default();
    for (i, &a) in radius.iter().enumerate() {
        let dx = (state.x[i][0] - expected.x[i][0]).hypot(state.x[i][1] - expected.x[i][1]);
        let du = (state.u[i][0] - expected.u[i][0]).hypot(state.u[i][1] - expected.u[i][1]);
        d.position = d
            .position
            .max(dx / a)
            .max((state.theta[i] - expected.theta[i]).abs());
        d.velocity = d
            .velocity
            .max(du / a)
            .max((state.omega[i] - expected.omega[i]).abs());
    }
    d
}

/// Corrected state: trapezoidal rule Xⁿ⁺¹ = Xⁿ + ½(Uⁿ⁺¹ + Uⁿ)Δt (Eqs. 5.54–5.55), or explicit
/// Euler with Uⁿ⁺¹ at the first step (Eq. 5.56); `u_new`, `omega_new` solved at the predicted
/// configuration.
pub fn correct(
    cur: &RigidState,
    u_new: &[[f64; 2]],
    omega_new: &[f64],
    dt: f64,
    first: bool,
) -> RigidState {
    let w = if first { (1.0, 0.0) } else { (0.5, 0.5) };
    let x = cur
        .x
        .iter()
        .zip(u_new.iter().zip(&cur.u))
        .map(|(x, (un, uo))| {
            [
                x[0] + dt * (w.0 * un[0] + w.1 * uo[0]),
                x[1] + dt * (w.0 * un[1] + w.1 * uo[1]),
            ]
        })
        .collect();
    let theta = cur
        .theta
        .iter()
        .zip(omega_new.iter().zip(&cur.omega))
        .map(|(t, (on, oo))| t + dt * (w.0 * on + w.1 * oo))
        .collect();
    RigidState {
        x,
        theta,
        u: u_new.to_vec(),
        omega: omega_new.to_vec(),
    }
}

/// Penetration (in radii) of a wall or another particle taken as contact; the method has no contact
/// force, so deeper overlap makes the rest of the trajectory meaningless. Initial touching (δ = 2)
/// is allowed. Used by the solvers to stop and by the outcome rules to classify.
pub const CONTACT_OVERLAP: f64 = 0.01;

/// A contact that stops a case.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Contact {
    /// Two particles overlap or come closer than the minimum gap.
    Overlap {
        /// First particle.
        i: usize,
        /// Second particle.
        j: usize,
        /// Surface gap (negative when overlapping).
        gap: f64,
    },
    /// A particle touches a wall or comes closer than the minimum gap.
    Wall {
        /// Particle.
        i: usize,
        /// Surface gap to the nearest wall.
        gap: f64,
    },
    /// A particle touches a free surface (extrusion, thesis §6.5).
    Surface {
        /// Particle.
        i: usize,
        /// Gap to the surface (from the centre to the nearest surface point, less the radius).
        gap: f64,
    },
    /// A particle reached the outflow of an open domain (extrusion): its run is over.
    Outflow {
        /// Particle.
        i: usize,
    },
}

impl std::fmt::Display for Contact {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Contact::Overlap { i, j, gap } => {
                write!(f, "particles {i} and {j} in contact (gap {gap:.3e})")
            }
            Contact::Wall { i, gap } => {
                write!(f, "particle {i} in contact with a wall (gap {gap:.3e})")
            }
            Contact::Surface { i, gap } => {
                write!(
                    f,
                    "particle {i} in contact with the free surface (gap {gap:.3e})"
                )
            }
            Contact::Outflow { i } => write!(f, "particle {i} reached the outflow"),
        }
    }
}

/// Checks gaps between particles (nearest periodic image when `period_x` is set) and to walls at
/// y = `walls.0` and y = `walls.1`; a gap below `min_gap` is a contact.
pub fn find_contact(
    x: &[[f64; 2]],
    radius: &[f64],
    walls: Option<(f64, f64)>,
    period_x: Option<f64>,
    min_gap: f64,
) -> Option<Contact> {
    for i in 0..x.len() {
        if let Some((lo, hi)) = walls {
            let gap = (x[i][1] - lo).min(hi - x[i][1]) - radius[i];
            if gap < min_gap {
                return Some(Contact::Wall { i, gap });
            }
        }
        for j in i + 1..x.len() {
            let dx = crate::periodic::fold(x[j][0] - x[i][0], period_x);
            let dy = x[j][1] - x[i][1];
            let gap = dx.hypot(dy) - radius[i] - radius[j];
            if gap < min_gap {
                return Some(Contact::Overlap { i, j, gap });
            }
        }
    }
    None
}

/// Checks gaps between particles and to the two cylinders r = `cylinders.0` (inner) and
/// r = `cylinders.1` (outer) of a circular Couette cell centred at the origin; a gap below
/// `min_gap` is a contact ([`Contact::Wall`] for a cylinder, whichever is nearer).
pub fn find_annulus_contact(
    x: &[[f64; 2]],
    radius: &[f64],
    cylinders: (f64, f64),
    min_gap: f64,
) -> Option<Contact> {
    let (r1, r2) = cylinders;
    for (i, (c, a)) in x.iter().zip(radius).enumerate() {
        let r = c[0].hypot(c[1]);
        let gap = (r - r1).min(r2 - r) - a;
        if gap < min_gap {
            return Some(Contact::Wall { i, gap });
        }
    }
    find_contact(x, radius, None, None, min_gap)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn predictor_corrector_is_exact_for_constant_acceleration_in_velocity_linear_motion() {
        // U(t) = a t is integrated exactly by the trapezoidal rule: x = a t²/2
        let (a, dt) = (0.3, 0.1);
        let mut prev: Option<RigidState> = None;
        let mut cur = RigidState::at_rest(vec![[0.0, 0.0]]);
        for n in 0..10 {
            let t1 = (n + 1) as f64 * dt;
            let next = correct(&cur, &[[a * t1, 0.0]], &[0.0], dt, false);
            prev = Some(cur);
            cur = next;
        }
        // exact: a t²/2 at t = 1
        assert!((cur.x[0][0] - 0.5 * a).abs() < 1e-14);
        assert!(prev.is_some());
    }

    #[test]
    fn contacts_are_found_across_the_periodic_seam_and_at_walls() {
        let r = [0.1, 0.1];
        assert!(find_contact(&[[1.95, 0.0], [-1.95, 0.0]], &r, None, Some(4.0), 0.0).is_some());
        assert!(find_contact(&[[1.5, 0.0], [-1.5, 0.0]], &r, None, Some(4.0), 0.0).is_none());
        assert_eq!(
            find_contact(&[[0.0, 0.45]], &r[..1], Some((-0.5, 0.5)), None, 0.0),
            Some(Contact::Wall {
                i: 0,
                gap: 0.5 - 0.45 - 0.1
            })
        );
    }

    #[test]
    fn contacts_with_the_cylinders_are_found() {
        // exact decimal-free geometry: gaps are differences of representable numbers
        const TOL: f64 = 1e-15;
        let r = [0.25, 0.25];
        let cyl = (1.0, 4.0);
        assert!(find_annulus_contact(&[[0.0, 2.5], [2.5, 0.0]], &r, cyl, 0.0).is_none());
        match find_annulus_contact(&[[0.0, 2.5], [0.0, -1.125]], &r, cyl, 0.0) {
            Some(Contact::Wall { i: 1, gap }) => assert!((gap + 0.125).abs() < TOL, "{gap}"),
            c => panic!("inner cylinder contact expected, got {c:?}"),
        }
        match find_annulus_contact(&[[3.0, 0.0], [0.0, 2.5]], &r, cyl, 1.0) {
            Some(Contact::Wall { i: 0, gap }) => assert!((gap - 0.75).abs() < TOL, "{gap}"),
            c => panic!("outer cylinder contact expected, got {c:?}"),
        }
        assert!(matches!(
            find_annulus_contact(&[[2.5, 0.0], [2.5, 0.4]], &r, cyl, 0.0),
            Some(Contact::Overlap { i: 0, j: 1, .. })
        ));
    }
}
