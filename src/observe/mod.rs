//! Observables and outcome classification from trajectories.
