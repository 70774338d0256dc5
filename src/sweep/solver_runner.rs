//! The case runner backed by the solver: every case goes through [`crate::simulate`], the one
//! path from a case to a running simulation.

use crate::config::CaseSpec;
use crate::observe::CaseObserver;
use crate::simulate::{run::run_case, Settings, Simulation};
use crate::sweep::runner::{CaseResult, CaseRunner};

/// Runs cases with the XFEM solver.
#[derive(Debug, Clone, Copy, Default)]
pub struct SolverRunner;

impl CaseRunner for SolverRunner {
    fn supports(&self, case: &CaseSpec) -> Result<(), String> {
        Simulation::supports(case)
    }

    fn run(&self, case: &CaseSpec, obs: &mut dyn CaseObserver) -> CaseResult {
        run_case(case, obs)
    }

    fn settings(&self, case: &CaseSpec) -> Option<serde_json::Value> {
        serde_json::to_value(Settings::of(case)).ok()
    }
}
