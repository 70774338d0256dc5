//! A rigid particle in extrusion flow (thesis §6.5) through the one simulation path: the
//! extrusion set-up in the moving-particle step (free surface predicted with the particles, the
//! surface's stretch under their ALE map, the fluid bounded by it) and a case continued from a
//! saved state. (The swell study itself is a case of this path: tests/extrudate_swell.rs.)

use xpflow::config::CaseSpec;
use xpflow::simulate::Simulation;

/// The §6.5.1 set-up on a coarse mesh (h = 0.1, a = 0.2 so that the particle spans four
/// elements): a Giesekus fluid, Wi = 0.25, α = 0.1, the particle starting in the die.
fn coarse_case() -> CaseSpec {
    CaseSpec::from_value(serde_json::json!({
        "geometry": { "extrusion": { "die_length": 3.0, "extrudate_length": 4.0 } },
        "fluid": { "model": "giesekus", "wi": 0.25, "alpha": 0.1 },
        "particles": { "radius": 0.2, "layout": { "explicit": { "positions": [[-2.3, 0.6]] } } },
        "numerics": { "mesh": [70, 20], "dt": 0.05, "t_end": 1.0 }
    }))
    .unwrap()
}

/// In the die the particle is carried by the fully developed flow: it moves downstream a little
/// slower than the fluid at its centre, u(0.6) = 0.96 (a free cylinder lags the Poiseuille flow
/// by its curvature and the confinement: measured 0.9466 after 10 steps), hardly across, and
/// turns clockwise with about half the local vorticity, γ̇/2 = 0.9 (measured 0.78); the surface
/// starts to swell at the die exit.
#[test]
fn in_the_die_the_particle_rides_the_fully_developed_flow() {
    // the lag and rotation this mesh gives, with room for round-off changes only
    const LAG: (f64, f64) = (0.92, 0.96);
    const SPIN: (f64, f64) = (0.7, 0.9);
    let mut sim = Simulation::new(&coarse_case()).unwrap();
    for _ in 0..10 {
        sim.step().unwrap().into_report().unwrap();
    }
    let s = sim.sample();
    let p = &s.particles[0];
    assert!(p.u > LAG.0 && p.u < LAG.1, "u = {}", p.u);
    assert!(p.v.abs() < 0.05, "v = {}", p.v);
    assert!(-p.omega > SPIN.0 && -p.omega < SPIN.1, "ω = {}", p.omega);
    // the narrowest gap is the film to the die wall, 1 − (y + a) ≈ 0.2 = 2 rows of 0.1 (not the
    // 1.2 to the mesh top, which bounds no fluid, nor the 0.4 to the symmetry line)
    let film = s.gap_elements.expect("a particle");
    assert!(
        (film - 10.0 * (1.0 - p.y - 0.2)).abs() < 1e-9,
        "{film} elements"
    );
    let surface = sim.stepper().surface().unwrap();
    assert_eq!(surface.heights()[0], 1.0, "pinned at the die exit");
    assert!(surface.max() > 1.0, "swelling: {}", surface.max());
}

/// A case continued from its saved state (JSON and back, into a freshly built simulation)
/// takes the same steps as the run that saved it: the surface, its predictor history and the
/// configuration of the fields are part of the state.
#[test]
fn a_restored_extrusion_continues_the_saved_run() {
    // the restored flow rebuilds its pattern and orderings: round-off only
    const SAME: f64 = 1e-9;
    let case = coarse_case();
    let mut first = Simulation::new(&case).unwrap();
    for _ in 0..4 {
        first.step().unwrap();
    }
    let saved = first.checkpoint();
    let mut second = Simulation::new(&case).unwrap();
    second.restore(&saved).unwrap();
    for _ in 0..3 {
        first.step().unwrap();
        second.step().unwrap();
    }
    let (a, b) = (first.sample(), second.sample());
    let (pa, pb) = (&a.particles[0], &b.particles[0]);
    for (x, y) in [
        (pa.x, pb.x),
        (pa.y, pb.y),
        (pa.u, pb.u),
        (pa.omega, pb.omega),
    ] {
        assert!((x - y).abs() < SAME, "{x} against {y}");
    }
    let (ha, hb) = (
        first.stepper().surface().unwrap().heights(),
        second.stepper().surface().unwrap().heights(),
    );
    assert!(ha.iter().zip(hb).all(|(x, y)| (x - y).abs() < SAME));
}

/// Before its first sample an extrusion case computes its undisturbed steady surface H̄ (the case
/// without its particle, to the steady test), and every sample carries the separation
/// s = Y + a − H̄(X) of thesis Eq. 6.65; H̄ swells above H0 (Giesekus, Wi = 0.25) and is pinned
/// at the die exit.
#[test]
fn separations_are_measured_from_the_undisturbed_steady_surface() {
    // every separation is the same arithmetic on the same numbers
    const SAME: f64 = 1e-14;
    let mut case = coarse_case();
    case.numerics.mesh = [35, 10];
    case.particles.as_mut().unwrap().radius = 0.25;
    case.particles.as_mut().unwrap().layout = xpflow::config::Layout::Explicit {
        positions: vec![[-2.3, 0.5]],
    };
    let case = CaseSpec::from_value(serde_json::to_value(&case).unwrap()).unwrap();
    let mut sim = Simulation::new(&case).unwrap();
    assert!(sim.undisturbed().is_none());
    sim.settle().unwrap();
    let u = sim.undisturbed().unwrap().clone();
    assert!(u.steady, "{} steps", u.steps);
    assert_eq!(u.surface.heights()[0], 1.0);
    assert!(u.swell() > 1.0 && u.swell() < 1.3, "swell {}", u.swell());
    for _ in 0..3 {
        sim.step().unwrap();
    }
    let p = sim.sample().particles[0];
    let want = p.y + 0.25 - u.surface.at(p.x);
    assert!((p.separation.unwrap() - want).abs() < SAME);
    assert!(
        (want - (p.y + 0.25 - 1.0)).abs() < SAME,
        "H̄ = H0 in the die"
    );
}

/// What a run reports of its prelude (the undisturbed flow before the first sample): the steps
/// it took in this process, its saved states, and the surface it reached. It stops the case at
/// its first sample, and dies (a panic, as a kill) at save number `die_at`.
#[derive(Default)]
struct PreludeWatch {
    resume: Option<String>,
    die_at: Option<usize>,
    steps_here: std::cell::Cell<usize>,
    saved: Vec<String>,
    surface: Option<xpflow::observe::UndisturbedSurface>,
    /// The finished prelude offered to the case (as another case with its key shared it).
    offer: Option<String>,
    /// The keys the case asked for, and what it shared.
    asked: Vec<String>,
    shared: Vec<(String, String)>,
}

impl xpflow::observe::CaseObserver for PreludeWatch {
    fn on_step(&mut self, _: &xpflow::observe::Sample) -> xpflow::observe::Control {
        xpflow::observe::Control::Stop
    }
    fn snapshot_due(&self, _: u64) -> bool {
        false
    }
    fn on_snapshot(&mut self, _: &xpflow::observe::FieldSnapshot) {}
    fn checkpoint(&mut self) {}
    fn on_undisturbed_surface(&mut self, s: &xpflow::observe::UndisturbedSurface) {
        self.surface = Some(s.clone());
    }
    fn prelude_due(&self) -> bool {
        self.steps_here.set(self.steps_here.get() + 1);
        true
    }
    fn save_prelude(&mut self, state: &str) {
        if Some(self.saved.len()) == self.die_at {
            panic!("killed");
        }
        self.saved.push(state.to_string());
    }
    fn resume_prelude(&mut self) -> Option<String> {
        self.resume.take()
    }
    fn shared_prelude(&mut self, key: &str) -> Option<String> {
        self.asked.push(key.to_string());
        self.offer.clone()
    }
    fn share_prelude(&mut self, key: &str, finished: &str) {
        self.shared.push((key.to_string(), finished.to_string()));
    }
}

/// The prelude of an extrusion case (its undisturbed flow, thousands of steps on a fine mesh) is
/// saved as it goes: a case killed during it continues from its last saved state, takes only the
/// steps that were left, and reaches the surface the uninterrupted run reaches. (A state that
/// does not fit the case starts the prelude over: `simulate::run`.)
#[test]
fn a_killed_prelude_continues_from_its_saved_state() {
    // a restored flow rebuilds its pattern and orderings: round-off only
    const SAME: f64 = 1e-9;
    let mut case = coarse_case();
    case.numerics.mesh = [35, 10];
    let case = CaseSpec::from_value(serde_json::to_value(&case).unwrap()).unwrap();
    let run = |watch: &mut PreludeWatch| xpflow::simulate::run::run_case(&case, watch);

    let mut whole = PreludeWatch::default();
    run(&mut whole);
    let want = whole.surface.expect("the surface is reported");
    assert!(want.steady && want.steps > 6, "{} steps", want.steps);
    assert_eq!(whole.steps_here.get(), want.steps);

    // killed at the 6th save: the 5th saved state (after step 5) survives
    let mut killed = PreludeWatch {
        die_at: Some(5),
        ..PreludeWatch::default()
    };
    let died = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run(&mut killed))).is_err();
    assert!(died && killed.surface.is_none());
    let mut resumed = PreludeWatch {
        resume: killed.saved.pop(),
        ..PreludeWatch::default()
    };
    run(&mut resumed);
    let got = resumed.surface.expect("the surface is reported");
    assert_eq!(got.steps, want.steps, "the same prelude");
    assert_eq!(
        resumed.steps_here.get(),
        want.steps - 5,
        "only the steps left"
    );
    assert_eq!(got.steady, want.steady);
    for (a, b) in got.profile.iter().zip(&want.profile) {
        assert!((a[1] - b[1]).abs() < SAME, "{a:?} against {b:?}");
    }
}

/// `output.undisturbed_surface = false` skips the prelude: the run's first sample comes without
/// a prelude step, reports no undisturbed surface and leaves the separation empty, and its
/// particle takes the same steps as the case with the prelude (which only measures from H̄).
/// Other geometries refuse the field.
#[test]
fn a_case_may_skip_the_undisturbed_surface() {
    // the particle's run does not read the prelude: bitwise the same steps
    const SAME: f64 = 0.0;
    let mut case = coarse_case();
    case.numerics.mesh = [35, 10];
    let with = CaseSpec::from_value(serde_json::to_value(&case).unwrap()).unwrap();
    case.output.undisturbed_surface = false;
    let without = CaseSpec::from_value(serde_json::to_value(&case).unwrap()).unwrap();
    assert!(!without.output.undisturbed_surface);
    let mut skipped = PreludeWatch::default();
    xpflow::simulate::run::run_case(&without, &mut skipped);
    assert_eq!(skipped.steps_here.get(), 0, "no prelude step");
    assert!(skipped.surface.is_none());

    let (mut a, mut b) = (
        Simulation::new(&with).unwrap(),
        Simulation::new(&without).unwrap(),
    );
    a.settle().unwrap();
    b.settle().unwrap();
    assert!(a.undisturbed().is_some() && b.undisturbed().is_none());
    for _ in 0..2 {
        a.step().unwrap();
        b.step().unwrap();
    }
    let (pa, pb) = (a.sample().particles[0], b.sample().particles[0]);
    assert!(pa.separation.is_some() && pb.separation.is_none());
    assert!((pa.y - pb.y).abs() <= SAME && (pa.u - pb.u).abs() <= SAME);

    let err = CaseSpec::from_value(serde_json::json!({
        "geometry": { "confined_shear": { "h": 1.0, "l": 4.0 } },
        "fluid": { "model": "oldroyd_b", "wi": 1.0, "beta": 0.1 },
        "particles": { "radius": 0.1, "layout": { "explicit": { "positions": [[0.0, 0.0]] } } },
        "numerics": { "mesh": [40, 10], "dt": 0.02, "t_end": 1.0 },
        "output": { "undisturbed_surface": false }
    }))
    .unwrap_err();
    assert!(
        err.to_string().contains("output.undisturbed_surface"),
        "{err}"
    );
}

/// Cases that differ only in their particles have the same undisturbed flow: the first shares its
/// finished prelude under the flow's key, and a case of that key takes it instead of stepping its
/// own (the same surface, no prelude step); a case of another fluid has another key.
#[test]
fn cases_with_the_same_undisturbed_flow_share_one_prelude() {
    use xpflow::simulate::undisturbed::prelude_key;
    let mut case = coarse_case();
    case.numerics.mesh = [35, 10];
    let first = CaseSpec::from_value(serde_json::to_value(&case).unwrap()).unwrap();
    case.particles.as_mut().unwrap().radius = 0.15;
    case.particles.as_mut().unwrap().layout = xpflow::config::Layout::Explicit {
        positions: vec![[-2.0, 0.5]],
    };
    case.numerics.t_end = 2.0;
    let second = CaseSpec::from_value(serde_json::to_value(&case).unwrap()).unwrap();
    case.fluid.wi = 0.3;
    let other_fluid = CaseSpec::from_value(serde_json::to_value(&case).unwrap()).unwrap();
    assert_eq!(prelude_key(&first), prelude_key(&second));
    assert_ne!(prelude_key(&first), prelude_key(&other_fluid));

    let mut computed = PreludeWatch::default();
    xpflow::simulate::run::run_case(&first, &mut computed);
    let want = computed.surface.clone().expect("the surface is reported");
    assert!(computed.steps_here.get() > 0);
    assert_eq!(computed.asked, vec![prelude_key(&first)]);
    let [(key, finished)] = computed.shared.as_slice() else {
        panic!("one prelude shared: {:?}", computed.shared.len())
    };
    assert_eq!(key, &prelude_key(&first));

    let mut taken = PreludeWatch {
        offer: Some(finished.clone()),
        ..PreludeWatch::default()
    };
    xpflow::simulate::run::run_case(&second, &mut taken);
    let got = taken.surface.expect("the surface is reported");
    assert_eq!(taken.steps_here.get(), 0, "no prelude step of its own");
    assert!(taken.shared.is_empty());
    assert_eq!((got.steps, got.steady), (want.steps, want.steady));
    assert_eq!(got.profile, want.profile);
}
