//! Sweeps with a `[tries]` section end to end with a fake runner whose outcomes are known: each
//! combination of the other axes stops at its first case that meets `until`, in the order the
//! tried values are written; a failed try passes to the next (and `--retry-failed` runs it
//! again); a rerun runs nothing; cases a grid run left in the database count; the command line
//! validates the section (exit 2, nothing written) and lists the grid with `--dry-run`; on a
//! cluster each round is a submission planned from the merged database.

mod common;
use common::Scratch;
use std::collections::BTreeSet;
use std::path::Path;
use std::process::ExitCode;

use xpflow::cli::sweep_cmds::run_sweep_with;
use xpflow::config::{CaseSpec, SweepSpec};
use xpflow::observe::OutcomeKind;
use xpflow::store::Store;
use xpflow::sweep::tries::{lines, run_tries, TriesSummary};
use xpflow::sweep::{expand, run_sweep, FakeBehaviour, FakeRunner, SweepOptions};

/// Three combinations (N = 2, 3, 4) × three initial spacings, tried closest first.
const SWEEP: &str = r#"
name = "tries"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.string = { n = 2, lx = 0.5, ly = 0.1 } }
numerics = { mesh = [40, 10], dt = 0.02, t_end = 20.0 }
output = { sample_every = 100 }
[axes]
particles.layout.string.n = [2, 3, 4]
[[zip]]
"particles.layout.string.lx" = [0.25, 0.3, 0.5]
"particles.layout.string.ly" = [0.025, 0.05, 0.1]
[tries]
over = "particles.layout.string.ly"
until = "string"
"#;

/// N = 2 strings from every spacing, N = 3 only from l_x = 0.3 and wider, N = 4 from none (not
/// physics: a table with one cell of each kind).
fn behaviour(spec: &CaseSpec) -> FakeBehaviour {
    let (n, lx) = (spec.n_particles(), spacing(spec));
    let string = n == 2 || (n == 3 && lx > 0.26);
    FakeBehaviour::Produce(if string {
        OutcomeKind::String
    } else {
        OutcomeKind::Repel
    })
}

fn spacing(spec: &CaseSpec) -> f64 {
    let v = serde_json::to_value(spec).unwrap();
    v["particles"]["layout"]["string"]["lx"].as_f64().unwrap()
}

fn parse(text: &str, dir: &Path) -> SweepSpec {
    let file = dir.join("tries.toml");
    std::fs::write(&file, text).unwrap();
    SweepSpec::from_file(&file).unwrap()
}

fn opts(db: &Path) -> SweepOptions {
    common::quiet_options(db)
}

fn tries(sweep: &SweepSpec, runner: &FakeRunner, opts: &SweepOptions) -> TriesSummary {
    let cases = expand(sweep).unwrap();
    let lines = lines(sweep, &cases).unwrap();
    run_tries(sweep, &cases, &lines, runner, opts, &mut |_| {}).unwrap()
}

/// The labels of the cases the database holds as finished (done or failed).
fn finished(db: &Path) -> BTreeSet<String> {
    labels(
        db,
        "SELECT label FROM cases WHERE status IN ('done', 'failed')",
    )
}

/// The labels of the cases linked to the sweep `tries` (what `--sweep` queries and `status` see).
fn linked(db: &Path) -> BTreeSet<String> {
    labels(
        db,
        "SELECT sc.label FROM sweep_cases sc JOIN sweeps s ON s.id = sc.sweep_id
         WHERE s.name = 'tries'",
    )
}

fn labels(db: &Path, sql: &str) -> BTreeSet<String> {
    let store = Store::open_read_only(db).unwrap();
    let mut st = store.connection().prepare(sql).unwrap();
    let rows = st.query_map([], |r| r.get::<_, String>(0)).unwrap();
    rows.map(Result::unwrap).collect()
}

/// The cases the tries of [`SWEEP`] run with [`behaviour`]: N = 2 at its first spacing, N = 3 at
/// its first two, N = 4 at all three.
const TRIED: [&str; 6] = [
    "n=2 lx=0.25 ly=0.025",
    "n=3 lx=0.25 ly=0.025",
    "n=3 lx=0.3 ly=0.05",
    "n=4 lx=0.25 ly=0.025",
    "n=4 lx=0.3 ly=0.05",
    "n=4 lx=0.5 ly=0.1",
];

fn set(labels: &[&str]) -> BTreeSet<String> {
    labels.iter().map(|s| s.to_string()).collect()
}

#[test]
fn each_combination_stops_at_its_first_string() {
    let dir = Scratch::new("tries", "first");
    let sweep = parse(SWEEP, &dir);
    let db = dir.join("r.db");
    let s = tries(&sweep, &FakeRunner::new(behaviour), &opts(&db));
    assert_eq!(
        (s.lines, s.met, s.grid, s.tried, s.ran, s.failed, s.finished),
        (3, 2, 9, 6, 6, 0, true),
        "{s:?}"
    );
    // N = 2 at its first spacing, N = 3 at its second, N = 4 through all three
    assert_eq!(s.rounds, 3, "one round per try of the longest combination");
    assert_eq!(finished(&db), set(&TRIED));
    // the sweep's cases are its tries, every round's (in the end: the finished ones)
    assert_eq!(linked(&db), finished(&db));
    // a rerun finds nothing left to try
    let again = tries(&sweep, &FakeRunner::new(behaviour), &opts(&db));
    assert_eq!(
        (again.ran, again.rounds, again.tried, again.finished),
        (0, 0, 6, true)
    );
    // a string of at least 3 is met by N = 3 (and 4, never) only: N = 2 now tries every spacing
    let at_least_3 = parse(
        &SWEEP.replace(
            "until = \"string\"",
            "until = { string_length_at_least = 3 }",
        ),
        &dir,
    );
    let s = tries(&at_least_3, &FakeRunner::new(behaviour), &opts(&db));
    assert_eq!((s.met, s.ran, s.tried), (1, 2, 8), "{s:?}");
}

#[test]
fn a_failed_try_passes_to_the_next_and_is_retried_when_asked() {
    let dir = Scratch::new("tries", "failed");
    let sweep = parse(SWEEP, &dir);
    let db = dir.join("r.db");
    // N = 2's first spacing fails: its second gives the string
    let failing = |spec: &CaseSpec| {
        if spec.n_particles() == 2 && spacing(spec) < 0.26 {
            FakeBehaviour::Fail("solver refused".into())
        } else {
            behaviour(spec)
        }
    };
    let s = tries(&sweep, &FakeRunner::new(failing), &opts(&db));
    assert_eq!((s.met, s.ran, s.failed), (2, 7, 1), "{s:?}");
    assert!(finished(&db).contains("n=2 lx=0.3 ly=0.05"));
    // --retry-failed runs the failed try once more (now it strings): nothing else runs
    let mut retry = opts(&db);
    retry.retry_failed = true;
    let s = tries(&sweep, &FakeRunner::new(behaviour), &retry);
    assert_eq!((s.ran, s.failed, s.rounds, s.met), (1, 0, 1, 2), "{s:?}");
}

#[test]
fn cases_a_grid_run_finished_count_as_tries() {
    let dir = Scratch::new("tries", "grid");
    let db = dir.join("r.db");
    // the grid (the same file without [tries]) ran N = 4 at l_x = 0.5 and N = 3 at 0.3 before
    let grid = parse(&SWEEP[..SWEEP.find("[tries]").unwrap()], &dir);
    let cases = expand(&grid).unwrap();
    let before: Vec<_> = cases
        .iter()
        .filter(|c| c.label == "n=4 lx=0.5 ly=0.1" || c.label == "n=3 lx=0.3 ly=0.05")
        .cloned()
        .collect();
    run_sweep(&grid, &before, &FakeRunner::new(behaviour), &opts(&db)).unwrap();
    let s = tries(&parse(SWEEP, &dir), &FakeRunner::new(behaviour), &opts(&db));
    // N = 3's first spacing still runs (it comes first); N = 4's last is not run again
    assert_eq!((s.ran, s.tried, s.met), (4, 6, 2), "{s:?}");
    // the grid's registration is replaced by the tries: N = 3's third spacing is not the sweep's
    {
        let mut store = Store::open(&db).unwrap();
        let id = store.register_sweep(&parse(SWEEP, &dir)).unwrap();
        store.add_cases(id, &cases).unwrap();
    }
    assert_eq!(linked(&db).len(), 9);
    let s = tries(&parse(SWEEP, &dir), &FakeRunner::new(behaviour), &opts(&db));
    assert_eq!((s.ran, s.tried), (0, 6));
    assert_eq!(linked(&db), finished(&db));
    assert!(!linked(&db).contains("n=3 lx=0.5 ly=0.1"));
}

#[test]
fn the_command_line_validates_lists_and_runs() {
    let dir = Scratch::new("tries", "cli");
    let runner = FakeRunner::new(behaviour);
    let run = |text: &str, dry: bool| -> (ExitCode, String) {
        let file = dir.join("cli.toml");
        std::fs::write(&file, text).unwrap();
        let mut args = common::sweep_args(&file, &dir.join("cli.db"));
        args.dry_run = dry;
        args.quiet = false;
        let mut out = Vec::new();
        let code = run_sweep_with(&args, &runner, &mut out).unwrap();
        (code, String::from_utf8(out).unwrap())
    };
    for bad in [
        SWEEP.replace("until = \"string\"", "until = \"strings\""),
        SWEEP.replace(
            "over = \"particles.layout.string.ly\"",
            "over = \"fluid.wi\"",
        ),
        format!("{SWEEP}\n[search]\naxis = \"fluid.wi\"\nrange = [0, 1]\ntol = 0.1\nbudget = 5\n"),
    ] {
        let (code, _) = run(&bad, false);
        assert_eq!(code, ExitCode::from(2));
        assert!(!dir.join("cli.db").exists(), "nothing written");
    }
    let (code, out) = run(SWEEP, true);
    assert_eq!(code, ExitCode::SUCCESS);
    assert!(
        out.contains("9 cases in sweep tries: 3 combination(s)")
            && out.contains("between 3 and 9 cases run"),
        "{out}"
    );
    assert!(!dir.join("cli.db").exists(), "a dry run writes nothing");
    let (code, out) = run(SWEEP, false);
    assert_eq!(code, ExitCode::SUCCESS);
    assert!(out.contains("6 of the grid's 9 cases tried"), "{out}");
    // a dry run against the database says where the tries stand, and writes nothing
    let before = std::fs::metadata(dir.join("cli.db"))
        .unwrap()
        .modified()
        .unwrap();
    let (code, out) = run(SWEEP, true);
    assert_eq!(code, ExitCode::SUCCESS);
    assert!(
        out.contains(
            "6 case(s) tried; 2 combination(s) ended in string, 1 tried every value \
             without it, 0 still trying (next: case(s) none)"
        ),
        "{out}"
    );
    let after = std::fs::metadata(dir.join("cli.db"))
        .unwrap()
        .modified()
        .unwrap();
    assert_eq!(before, after);
}

/// `--where` runs whole combinations of the other axes (e.g. one row of a table): the selected
/// ones to their end, the others not at all, and every case still listed as the sweep's; a
/// selection of some tries of a combination (a value of the tried axis), or `--case`, is refused
/// before anything is written (exit 2).
#[test]
fn where_selects_whole_combinations() {
    let dir = Scratch::new("tries", "where");
    let runner = FakeRunner::new(behaviour);
    let file = dir.join("where.toml");
    std::fs::write(&file, SWEEP).unwrap();
    let db = dir.join("where.db");
    let run = |edit: &dyn Fn(&mut xpflow::cli::sweep_cmds::SweepArgs)| -> (ExitCode, String) {
        let mut args = common::sweep_args(&file, &db);
        args.quiet = false;
        edit(&mut args);
        let mut out = Vec::new();
        let code = run_sweep_with(&args, &runner, &mut out).unwrap();
        (code, String::from_utf8(out).unwrap())
    };
    for refused in [
        &(|a: &mut xpflow::cli::sweep_cmds::SweepArgs| a.filters = vec!["lx=0.3".into()])
            as &dyn Fn(&mut xpflow::cli::sweep_cmds::SweepArgs),
        &|a| a.filters = vec!["n_particles=5".into()],
        &|a| a.cases = vec!["0".into()],
    ] {
        assert_eq!(run(refused).0, ExitCode::from(2));
        assert!(!db.exists(), "nothing written");
    }
    let (code, out) = run(&|a| {
        a.filters = vec!["n_particles=3".into()];
        a.dry_run = true;
    });
    assert_eq!(code, ExitCode::SUCCESS);
    assert!(
        out.contains(
            "3 cases in sweep tries: 1 combination(s) of the other axes (1 of its 3 selected)"
        ),
        "{out}"
    );
    // N = 3 alone: its two tries (the second forms the string), nothing of N = 2 or 4
    let (code, out) = run(&|a| a.filters = vec!["n_particles=3".into()]);
    assert_eq!(code, ExitCode::SUCCESS);
    assert!(
        out.contains("1 combination(s), 1 ended in string") && out.contains("2 of the grid's 3"),
        "{out}"
    );
    assert_eq!(
        finished(&db),
        set(&["n=3 lx=0.25 ly=0.025", "n=3 lx=0.3 ly=0.05"])
    );
    assert_eq!(linked(&db).len(), 2 + 3 + 3, "N = 2 and 4 listed, pending");
    // the rest without a selection: the same cases as one run of the whole sweep
    let (code, _) = run(&|_| {});
    assert_eq!(code, ExitCode::SUCCESS);
    assert_eq!(finished(&db), set(&TRIED));
}

/// `--slurm` without a scheduler: each invocation writes the current round's manifest; its tasks
/// run (`xpflow run-case`), their shards are merged, and `--slurm --resume` plans the next round
/// from the merged database, until the tries are over — the same cases as on one machine.
#[test]
fn on_a_cluster_each_round_is_a_submission_planned_from_the_merged_database() {
    let dir = Scratch::new("tries", "slurm");
    let file = dir.join("tries.toml");
    std::fs::write(&file, SWEEP).unwrap();
    let db = dir.join("r.db");
    let runner = FakeRunner::new(behaviour);
    let sizes = common::cluster_rounds(&file, &db, &runner, "tries tries: over", 4);
    assert_eq!(
        sizes,
        [3, 2, 1],
        "rounds: every line, then N = 3 and 4, then N = 4"
    );
    assert_eq!(finished(&db), set(&TRIED));
    assert_eq!(linked(&db), finished(&db));
}
