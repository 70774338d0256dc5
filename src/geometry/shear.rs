//! Confined shear flow (thesis §5.6.1): a channel with walls at y = ±H/2 sliding at ±U_w/2,
//! periodic in x with period L centred on x = 0.

use super::Confinement;
use crate::mesh::Side;
use crate::particles::{find_contact, Contact};

/// Confined shear flow, optionally seen from a frame translating along x (`drift`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConfinedShear {
    /// Channel height H.
    pub h: f64,
    /// Period L.
    pub l: f64,
    /// Relative wall speed U_w (γ̇ = U_w/H).
    pub wall_speed: f64,
    /// Velocity in x common to both walls (0 for the thesis' set-ups; −U puts a body moving at U
    /// through fluid at rest into its own frame, −U_f the lab walls into a frame moving at U_f).
    pub drift: f64,
}

impl Confinement for ConfinedShear {
    fn period(&self) -> Option<f64> {
        Some(self.l)
    }

    /// drift ∓ U_w/2 on the bottom and top walls.
    ///
    /// # Panics
    /// For [`Side::Left`] / [`Side::Right`]: the channel is periodic there.
    fn wall_velocity(&self, side: Side, _x: [f64; 2]) -> [f64; 2] {
        let uw = 0.5 * self.wall_speed;
        match side {
            Side::Bottom => [self.drift - uw, 0.0],
            Side::Top => [self.drift + uw, 0.0],
            Side::Left | Side::Right => panic!("a periodic channel has no {side:?} wall"),
        }
    }

    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact> {
        let walls = Some((-0.5 * self.h, 0.5 * self.h));
        find_contact(x, radius, walls, Some(self.l), min_gap)
    }

    fn shear_rate(&self) -> f64 {
        self.wall_speed / self.h
    }
}
