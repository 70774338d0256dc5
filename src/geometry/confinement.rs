//! What a solver needs to know of a problem set-up in which particles move: its walls and their
//! velocities, its period, when particles touch each other or a wall, and its characteristic
//! shear rate ([`Confinement`]); how the flow is bounded ([`Boundary`]); and the set-ups a case can
//! name ([`SetUp`]).

use super::{ConfinedShear, Extrusion, RotatingCouette};
use crate::mesh::Side;
use crate::particles::Contact;

/// How the flow is bounded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Boundary {
    /// Walls on the mesh's bottom and top sides (the channel's walls, the annulus' inner and
    /// outer cylinders) with the velocities of [`Confinement::wall_velocity`]; the flow is
    /// enclosed, so the pressure is pinned.
    Walls,
    /// An extrusion die and its extrudate: the inflow profile on the left side, the die wall and
    /// the symmetry line inside the mesh, a free surface downstream and an open outflow.
    Extrusion(Extrusion),
}

/// Where particles move: the walls (see [`Boundary`]), the period, contact and the rate that
/// makes times dimensionless.
pub trait Confinement: Send + Sync {
    /// Period in x of a periodic rectangle (`None` otherwise; the annulus needs none).
    fn period(&self) -> Option<f64>;
    /// Velocity of the wall on `side` ([`Side::Bottom`] or [`Side::Top`]) at `x`.
    fn wall_velocity(&self, side: Side, x: [f64; 2]) -> [f64; 2];
    /// A particle–particle or particle–wall gap below `min_gap`.
    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact>;
    /// Characteristic shear rate γ̇ (t* = tγ̇, ω* = ω/γ̇).
    fn shear_rate(&self) -> f64;
    /// How the flow is bounded (walls on the bottom and top sides unless said otherwise).
    fn boundary(&self) -> Boundary {
        Boundary::Walls
    }
    /// The point moved into the period (identity without one).
    fn wrap(&self, x: [f64; 2]) -> [f64; 2] {
        crate::periodic::nearest_image(x, 0.0, self.period())
    }
}

/// The set-ups a sweep case runs in (in the frame the case is solved in).
#[derive(Debug, Clone, Copy)]
pub enum SetUp {
    /// Confined shear flow (thesis §5.6.1).
    ConfinedShear(ConfinedShear),
    /// The circular Couette cell (thesis §3.5.1), possibly from a rotating frame.
    Couette(RotatingCouette),
    /// Extrusion through a die into a free-surface extrudate (thesis §6.5).
    Extrusion(Extrusion),
}

impl SetUp {
    fn inner(&self) -> &dyn Confinement {
        match self {
            SetUp::ConfinedShear(s) => s,
            SetUp::Couette(c) => c,
            SetUp::Extrusion(e) => e,
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

    fn boundary(&self) -> Boundary {
        self.inner().boundary()
    }
}
