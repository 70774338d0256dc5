//! The frame a case is solved in, relative to the lab (`numerics.frame`, `frame_velocity`,
//! `frame_rotation`), and the observer's samples moved into the lab frame.

use crate::config::CaseSpec;
use crate::observe::{ParticleState, Sample};
use crate::particles::RigidState;

/// The frame the solver works in, relative to the lab ([`CaseSpec::solver_frame`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Frame {
    /// Translating along x at this velocity.
    Translating(f64),
    /// Rotating counter-clockwise about the origin at this angular velocity.
    Rotating(f64),
}

impl Frame {
    /// The lab frame.
    pub const LAB: Frame = Frame::Translating(0.0);

    /// The frame of a case ([`CaseSpec::solver_frame`]).
    pub fn of(case: &CaseSpec) -> Frame {
        match case.solver_frame() {
            (_, rotation) if rotation != 0.0 => Frame::Rotating(rotation),
            (velocity, _) => Frame::Translating(velocity),
        }
    }

    /// A position and a velocity of the solver's frame at time t in the lab frame.
    pub fn to_lab(self, t: f64, x: [f64; 2], u: [f64; 2]) -> ([f64; 2], [f64; 2]) {
        match self {
            Frame::Translating(v) => ([x[0] + v * t, x[1]], [u[0] + v, u[1]]),
            Frame::Rotating(w) => {
                let (s, c) = (w * t).sin_cos();
                let rot = |p: [f64; 2]| [c * p[0] - s * p[1], s * p[0] + c * p[1]];
                let (xl, ul) = (rot(x), rot(u));
                // plus the frame's rigid rotation Ω × x
                (xl, [ul[0] - w * xl[1], ul[1] + w * xl[0]])
            }
        }
    }

    /// The frame's velocity along x.
    pub fn velocity(self) -> f64 {
        match self {
            Frame::Translating(v) => v,
            Frame::Rotating(_) => 0.0,
        }
    }

    /// The frame's angular velocity (counter-clockwise).
    pub fn spin(self) -> f64 {
        match self {
            Frame::Translating(_) => 0.0,
            Frame::Rotating(w) => w,
        }
    }
}

/// Observer sample from the solver state in the lab frame (ω and θ clockwise positive, as the
/// store expects), with the elements across the narrowest gap (frame-independent).
pub fn sample(
    step: u64,
    t: f64,
    s: &RigidState,
    frame: Frame,
    gap_elements: Option<f64>,
) -> Sample {
    Sample {
        step,
        t,
        gap_elements,
        surface: None,
        particles: (0..s.x.len())
            .map(|i| {
                let (x, u) = frame.to_lab(t, s.x[i], s.u[i]);
                ParticleState {
                    x: x[0],
                    y: x[1],
                    u: u[0],
                    v: u[1],
                    omega: -(s.omega[i] + frame.spin()),
                    theta: -(s.theta[i] + frame.spin() * t),
                    separation: None,
                }
            })
            .collect(),
    }
}
