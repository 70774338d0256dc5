//! `numerics.dt`: a fixed time step (a number, as every case before adaptive stepping, with the
//! same case id) or an error-controlled one (a table `{ initial, min, max, tol }`, run by
//! `simulate::adaptive`).

use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};

use super::error::SpecError;
use super::validate::positive;

/// The time step of a case.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(untagged)]
pub enum TimeStep {
    /// Every step Δt (the thesis' way).
    Fixed(f64),
    /// Steps chosen by an error estimate (`simulate::adaptive`).
    Adaptive(AdaptiveStep),
}

/// An error-controlled time step: the controller keeps the deviation of each step's particles
/// from their prediction (positions, and angles times the radius, in radii) below `tol`, with
/// `min ≤ Δt ≤ max`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdaptiveStep {
    /// Δt of the first step.
    pub initial: f64,
    /// Smallest Δt: a step that misses the tolerance at `min` is taken all the same.
    pub min: f64,
    /// Largest Δt (at most `MAX_DT_OVER_LAMBDA` λ).
    pub max: f64,
    /// Tolerance on the deviation of a step from its prediction.
    pub tol: f64,
    /// Whether the explicit stress coupling's lag is part of a step's error (default `false`,
    /// not in the case id then): the particles' velocities solved again with the stress at the
    /// end of the step, against those the step used (`simulate::adaptive`). For transients at
    /// β ≳ 0.3, which depend on the steps of the stress build-up (terminal steady states did
    /// not, docs/validation.md); at β = 0.1 it costs several times the steps for < 1 %.
    #[serde(default, skip_serializing_if = "is_false")]
    pub coupling_lag: bool,
}

/// Serde's `skip_serializing_if` for flags that are off by default (not in the case id).
pub(super) fn is_false(b: &bool) -> bool {
    !*b
}

impl TimeStep {
    /// Δt of the first step (the step of a fixed case).
    pub fn initial(&self) -> f64 {
        match self {
            TimeStep::Fixed(dt) => *dt,
            TimeStep::Adaptive(a) => a.initial,
        }
    }

    /// The largest Δt a step takes: the fixed step, or the adaptive step's `max`.
    pub fn largest(&self) -> f64 {
        match self {
            TimeStep::Fixed(dt) => *dt,
            TimeStep::Adaptive(a) => a.max,
        }
    }

    /// The controller's settings, for an adaptive step.
    pub fn adaptive(&self) -> Option<AdaptiveStep> {
        match self {
            TimeStep::Fixed(_) => None,
            TimeStep::Adaptive(a) => Some(*a),
        }
    }
}

impl TimeStep {
    /// A fixed step > 0, or an adaptive one with 0 < min ≤ initial ≤ max and 0 < tol < 1.
    pub(super) fn validate(&self) -> Result<(), SpecError> {
        let a = match self {
            TimeStep::Fixed(dt) => return positive("numerics.dt", *dt),
            TimeStep::Adaptive(a) => a,
        };
        positive("numerics.dt.initial", a.initial)?;
        positive("numerics.dt.min", a.min)?;
        positive("numerics.dt.max", a.max)?;
        positive("numerics.dt.tol", a.tol)?;
        if a.min > a.max {
            return Err(SpecError::new(
                "numerics.dt.min",
                format!("min = {} is more than max = {}", a.min, a.max),
            ));
        }
        if !(a.min..=a.max).contains(&a.initial) {
            return Err(SpecError::new(
                "numerics.dt.initial",
                format!(
                    "initial = {} is outside [min, max] = [{}, {}]",
                    a.initial, a.min, a.max
                ),
            ));
        }
        if a.tol >= 1.0 {
            return Err(SpecError::new(
                "numerics.dt.tol",
                format!(
                    "tol = {} allows a step to miss its prediction by a radius or more; use a \
                     tolerance well below 1, e.g. 1e-3",
                    a.tol
                ),
            ));
        }
        Ok(())
    }
}

/// A number or a table, with serde's own messages for the table's fields (unknown, missing).
impl<'de> Deserialize<'de> for TimeStep {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct StepVisitor;
        impl<'de> Visitor<'de> for StepVisitor {
            type Value = TimeStep;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a time step (a number) or an adaptive step { initial, min, max, tol }")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<TimeStep, E> {
                Ok(TimeStep::Fixed(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<TimeStep, E> {
                Ok(TimeStep::Fixed(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<TimeStep, E> {
                Ok(TimeStep::Fixed(v as f64))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<TimeStep, A::Error> {
                AdaptiveStep::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(TimeStep::Adaptive)
            }
        }
        deserializer.deserialize_any(StepVisitor)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_number_is_a_fixed_step_and_serializes_back_to_the_number() {
        let s: TimeStep = serde_json::from_str("0.02").unwrap();
        assert_eq!(s, TimeStep::Fixed(0.02));
        assert_eq!(serde_json::to_string(&s).unwrap(), "0.02");
        let one: TimeStep = serde_json::from_str("1").unwrap();
        assert_eq!(one, TimeStep::Fixed(1.0));
    }

    #[test]
    fn a_table_is_an_adaptive_step_and_its_fields_are_checked_by_name() {
        let text = r#"{"initial": 0.01, "min": 0.001, "max": 0.2, "tol": 0.001}"#;
        let s: TimeStep = serde_json::from_str(text).unwrap();
        assert_eq!(s.adaptive().map(|a| a.max), Some(0.2));
        assert_eq!(s.initial(), 0.01);
        let back: TimeStep = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(back, s);
        let typo = r#"{"initial": 0.01, "min": 0.001, "max": 0.2, "tolerance": 0.001}"#;
        let e = serde_json::from_str::<TimeStep>(typo)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `tolerance`"), "{e}");
        let missing = r#"{"initial": 0.01, "min": 0.001, "max": 0.2}"#;
        let e = serde_json::from_str::<TimeStep>(missing)
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing field `tol`"), "{e}");
        let e = serde_json::from_str::<TimeStep>(r#""fast""#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("adaptive step"), "{e}");
    }
}
