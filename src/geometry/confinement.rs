//! What a solver needs to know of a problem set-up in which particles move: its walls and their
//! velocities, its period, when particles touch each other or a wall, and its characteristic
//! shear rate ([`Confinement`]); and the set-ups a case can name ([`SetUp`]).

use super::{ConfinedShear, RotatingCouette};
use crate::mesh::Side;
use crate::particles::Contact;

/// Where particles move. The walls are the mesh's bottom and top sides (the channel's walls, the
/// annulus' inner and outer cylinders), where the velocity is prescribed and the pressure is
/// pinned (the flow is enclosed).
pub trait Confinement: Send + Sync {
    /// Period in x of a periodic rectangle (`None` otherwise; the annulus needs none).
    fn period(&self) -> Option<f64>;
    /// Velocity of the wall on `side` ([`Side::Bottom`] or [`Side::Top`]) at `x`.
    fn wall_velocity(&self, side: Side, x: [f64; 2]) -> [f64; 2];
    /// A particle–particle or particle–wall gap below `min_gap`.
    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact>;
    /// Characteristic shear rate γ̇ (t* = tγ̇, ω* = ω/γ̇).
    fn shear_rate(&self) -> f64;
    /// The point moved into the period (identity without one).
    fn wrap(&self, x: [f64; 2]) -> [f64; 2] {
        match self.period() {
            Some(l) => [x[0] - l * (x[0] / l).round(), x[1]],
            None => x,
        }
    }
}

/// The set-ups a sweep case runs in (in the frame the case is solved in).
#[derive(Debug, Clone, Copy)]
pub enum SetUp {
    /// Confined shear flow (thesis §5.6.1).
    ConfinedShear(ConfinedShear),
    /// The circular Couette cell (thesis §3.5.1), possibly from a rotating frame.
    Couette(RotatingCouette),
}

impl SetUp {
    fn inner(&self) -> &dyn Confinement {
        match self {
            SetUp::ConfinedShear(s) => s,
            SetUp::Couette(c) => c,
        }
    }
}

impl Confinement for SetUp {
    fn period(&self) -> Option<f64> {
        self.inner().period()
    }

    fn wall_velocity(&self, side: Side, x: [f64; 2]) -> [f64; 2] {
        self.inner().wall_velocity(side, x)
    }

    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact> {
        self.inner().contact(x, radius, min_gap)
    }

    fn shear_rate(&self) -> f64 {
        self.inner().shear_rate()
    }
}
