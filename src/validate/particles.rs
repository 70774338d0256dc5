//! Particle-motion validation through the same runner the sweeps use: two particles in confined
//! Stokes shear flow (thesis §5.6.2), classified by the outcome rules of `observe`.

use std::io::Write;
use std::path::Path;

use crate::config::CaseSpec;
use crate::observe::outcome::{Classifier, OutcomeKind};
use crate::observe::{CaseObserver, Control, FieldSnapshot, Sample};
use crate::sweep::solver_runner::SolverRunner;
use crate::sweep::{CaseRunner, RunStatus};

/// Thesis §5.6.2 (validation.md §2): in Stokes flow l_y = 0.02, 0.04, 0.06 reverse (repel) and
/// l_y = 0.08, 0.10 pass.
pub const TWO_PARTICLE_STOKES: [(f64, OutcomeKind); 5] = [
    (0.02, OutcomeKind::Repel),
    (0.04, OutcomeKind::Repel),
    (0.06, OutcomeKind::Repel),
    (0.08, OutcomeKind::Pass),
    (0.10, OutcomeKind::Pass),
];

/// One classified two-particle run.
#[derive(Debug, Clone)]
pub struct TwoParticleRun {
    /// Initial offset l_y.
    pub ly: f64,
    /// Outcome decided by the rules of `observe::outcome`.
    pub kind: OutcomeKind,
    /// Expected outcome.
    pub expected: OutcomeKind,
    /// Time at which it was decided.
    pub t_decided: f64,
    /// Steps run.
    pub steps: u64,
    /// Wall-clock seconds.
    pub seconds: f64,
}

struct Collect<'a> {
    classifier: Classifier,
    csv: Option<&'a mut dyn Write>,
}

impl CaseObserver for Collect<'_> {
    fn on_step(&mut self, s: &Sample) -> Control {
        if let Some(w) = self.csv.as_mut() {
            for (i, p) in s.particles.iter().enumerate() {
                // a failed CSV write must not stop the physics; the file is a by-product
                let _ = writeln!(
                    w,
                    "{},{},{},{},{},{},{},{}",
                    s.step, s.t, i, p.x, p.y, p.u, p.v, p.omega
                );
            }
        }
        match self.classifier.push(s) {
            Some(_) => Control::Stop,
            None => Control::Continue,
        }
    }
    fn snapshot_due(&self, _step: u64) -> bool {
        false
    }
    fn on_snapshot(&mut self, _s: &FieldSnapshot) {}
    fn checkpoint(&mut self) {}
}

/// The case spec of one two-particle Stokes run (H = 1, L = 4, a = 0.1, l_x = 0.5).
pub fn two_particle_case(ly: f64, mesh: [usize; 2], dt: f64) -> CaseSpec {
    let v = serde_json::json!({
        "geometry": { "confined_shear": { "h": 1.0, "l": 4.0, "wall_speed": 1.0 } },
        "fluid": { "model": "newtonian", "wi": 0.0 },
        "particles": { "radius": 0.1, "layout": { "pair": { "lx": 0.5, "ly": ly } } },
        "numerics": { "mesh": mesh, "dt": dt, "t_end": 60.0, "quadtree_level": 5 },
        "output": { "sample_every": 1, "snapshot_every": 0 },
        "stop": { "early_stop": true }
    });
    CaseSpec::from_value(v).expect("the two-particle case spec is valid by construction")
}

/// Runs the five l_y of thesis §5.6.2; trajectories go to `csv_dir/two_particles_ly<l_y>.csv`.
pub fn two_particles_stokes(
    mesh: [usize; 2],
    dt: f64,
    csv_dir: Option<&Path>,
) -> std::io::Result<Vec<TwoParticleRun>> {
    let mut out = Vec::new();
    for (ly, expected) in TWO_PARTICLE_STOKES {
        let spec = two_particle_case(ly, mesh, dt);
        let mut file = match csv_dir {
            Some(dir) => {
                std::fs::create_dir_all(dir)?;
                let mut f = std::io::BufWriter::new(std::fs::File::create(
                    dir.join(format!("two_particles_ly{ly:.2}.csv")),
                )?);
                writeln!(f, "step,t,particle,x,y,u,v,omega_cw")?;
                Some(f)
            }
            None => None,
        };
        let t0 = std::time::Instant::now();
        let mut obs = Collect {
            classifier: Classifier::new(&spec),
            csv: file.as_mut().map(|f| f as &mut dyn Write),
        };
        let res = SolverRunner.run(&spec, 1, &mut obs);
        let outcome = match &res.status {
            RunStatus::Finished => obs.classifier.finish(),
            RunStatus::Diverged { reason } | RunStatus::Failed { error: reason } => {
                obs.classifier.diverged(res.t, reason)
            }
        };
        out.push(TwoParticleRun {
            ly,
            kind: outcome.kind,
            expected,
            t_decided: outcome.t_decided,
            steps: res.steps,
            seconds: t0.elapsed().as_secs_f64(),
        });
    }
    Ok(out)
}
