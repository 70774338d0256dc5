//! The SQLite schema (version [`SCHEMA_VERSION`]). DESIGN.md's tables plus: `meta` (code version, machine),
//! `runs` (one row per invocation of a sweep), `sweep_cases` (a case shared by several sweeps is run once),
//! `snapshots` (HDF5 files), `merged_shards` (the cluster shards merged in, by publication: [`super::merge`]), and on `cases` the columns `label`, `geometry`, `t_end`, `owner`, `owner_pid`,
//! `steps`, `t_reached`, `run_id`. Views: `case_outcomes`, `string_formation`.

/// Bumped whenever the schema changes; an older database is migrated by [`MIGRATIONS`].
pub const SCHEMA_VERSION: i64 = 4;

/// The column lists `parts` one after the other, as one array of `N` names: lists of `cases`
/// columns built on [`PARAMETER_COLUMNS`](crate::config::PARAMETER_COLUMNS) without repeating
/// them (a wrong `N` fails to compile).
pub(super) const fn columns<const N: usize>(parts: &[&[&'static str]]) -> [&'static str; N] {
    let mut out = [""; N];
    let (mut k, mut p) = (0, 0);
    while p < parts.len() {
        let mut i = 0;
        while i < parts[p].len() {
            out[k] = parts[p][i];
            k += 1;
            i += 1;
        }
        p += 1;
    }
    assert!(k == N, "the parts hold another number of columns");
    out
}

/// Statements creating the current version from nothing (all idempotent).
pub const CREATE: &str = r#"
CREATE TABLE IF NOT EXISTS schema_version (version INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS sweeps (
    id INTEGER PRIMARY KEY,
    name TEXT NOT NULL UNIQUE,
    spec_json TEXT NOT NULL,
    created_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    code_version TEXT NOT NULL,
    machine TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS runs (
    id INTEGER PRIMARY KEY,
    sweep_id INTEGER NOT NULL REFERENCES sweeps(id),
    started_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
    finished_at TEXT,
    code_version TEXT NOT NULL,
    machine TEXT NOT NULL,
    pid INTEGER NOT NULL,
    jobs INTEGER NOT NULL,
    spec_json TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS cases (
    id INTEGER PRIMARY KEY,
    sweep_id INTEGER NOT NULL REFERENCES sweeps(id),
    case_hash TEXT NOT NULL UNIQUE,
    label TEXT NOT NULL,
    geometry TEXT NOT NULL,
    params_json TEXT NOT NULL,
    wi REAL, alpha REAL, beta REAL, delta REAL, n_particles INTEGER, a REAL, h REAL, l REAL,
    lx REAL, ly REAL, r0 REAL, eps REAL, mesh TEXT, dt REAL, t_end REAL,
    status TEXT NOT NULL DEFAULT 'pending' CHECK (status IN ('pending', 'running', 'done', 'failed')),
    owner TEXT, owner_pid INTEGER,
    started_at TEXT, finished_at TEXT, wall_s REAL, steps INTEGER, t_reached REAL,
    run_id INTEGER REFERENCES runs(id),
    error TEXT,
    settings_json TEXT
);
CREATE INDEX IF NOT EXISTS cases_by_status ON cases(status);
CREATE INDEX IF NOT EXISTS cases_by_wi_n ON cases(wi, n_particles);
CREATE TABLE IF NOT EXISTS sweep_cases (
    sweep_id INTEGER NOT NULL REFERENCES sweeps(id),
    case_id INTEGER NOT NULL REFERENCES cases(id),
    case_index INTEGER NOT NULL,
    label TEXT NOT NULL,
    PRIMARY KEY (sweep_id, case_id)
);
CREATE TABLE IF NOT EXISTS samples (
    case_id INTEGER NOT NULL REFERENCES cases(id),
    step INTEGER NOT NULL, t REAL NOT NULL, particle INTEGER NOT NULL,
    x REAL, y REAL, u REAL, v REAL, omega REAL, theta REAL, separation REAL,
    PRIMARY KEY (case_id, step, particle)
) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS outcomes (
    case_id INTEGER PRIMARY KEY REFERENCES cases(id),
    kind TEXT NOT NULL CHECK (kind IN ('string', 'repel', 'pass', 'jammed', 'wall_contact',
                                        'surface_contact', 'exited', 'migrated', 'steady',
                                        'diverged', 'timeout')),
    string_length INTEGER, t_decided REAL, mean_gap REAL, final_json TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS snapshots (
    case_id INTEGER NOT NULL REFERENCES cases(id),
    step INTEGER NOT NULL, t REAL NOT NULL, file TEXT NOT NULL,
    PRIMARY KEY (case_id, step)
);
CREATE TABLE IF NOT EXISTS merged_shards (
    publish_id TEXT PRIMARY KEY,
    file TEXT NOT NULL,
    case_hash TEXT NOT NULL,
    status TEXT NOT NULL,
    merged_at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);
CREATE VIEW IF NOT EXISTS case_outcomes AS
    SELECT c.*, o.kind, o.string_length, o.t_decided, o.mean_gap, o.final_json
    FROM cases c LEFT JOIN outcomes o ON o.case_id = c.id;
CREATE VIEW IF NOT EXISTS string_formation AS
    SELECT c.wi, c.n_particles, c.alpha, c.beta, c.delta,
           MAX(o.kind = 'string') AS formed, COUNT(*) AS cases
    FROM cases c JOIN outcomes o ON o.case_id = c.id
    GROUP BY c.wi, c.n_particles, c.alpha, c.beta, c.delta;
"#;

/// Migrations from version i to i + 1, applied in order after [`CREATE`]. 1 → 2:
/// `cases.settings_json`, the resolved numerical settings a case ran with (`simulate::Settings`;
/// the code version is the run's). 2 → 3: `merged_shards`, the shards `xpflow merge` folded in
/// (made by [`CREATE`], which runs first). 3 → 4: the outcome kinds of an extrusion
/// (`surface_contact`, `exited`) in `outcomes.kind`'s check: SQLite cannot alter a check, so the
/// table is copied into a new one (the views that read it dropped and made again); and
/// `samples.separation`, a particle's separation from the undisturbed free surface (thesis
/// Eq. 6.65).
pub const MIGRATIONS: &[&str] = &[
    "ALTER TABLE cases ADD COLUMN settings_json TEXT;",
    "",
    r#"
ALTER TABLE samples ADD COLUMN separation REAL;
DROP VIEW IF EXISTS case_outcomes;
DROP VIEW IF EXISTS string_formation;
CREATE TABLE outcomes_v4 (
    case_id INTEGER PRIMARY KEY REFERENCES cases(id),
    kind TEXT NOT NULL CHECK (kind IN ('string', 'repel', 'pass', 'jammed', 'wall_contact',
                                        'surface_contact', 'exited', 'migrated', 'steady',
                                        'diverged', 'timeout')),
    string_length INTEGER, t_decided REAL, mean_gap REAL, final_json TEXT NOT NULL
);
INSERT INTO outcomes_v4 SELECT case_id, kind, string_length, t_decided, mean_gap, final_json
    FROM outcomes;
DROP TABLE outcomes;
ALTER TABLE outcomes_v4 RENAME TO outcomes;
CREATE VIEW case_outcomes AS
    SELECT c.*, o.kind, o.string_length, o.t_decided, o.mean_gap, o.final_json
    FROM cases c LEFT JOIN outcomes o ON o.case_id = c.id;
CREATE VIEW string_formation AS
    SELECT c.wi, c.n_particles, c.alpha, c.beta, c.delta,
           MAX(o.kind = 'string') AS formed, COUNT(*) AS cases
    FROM cases c JOIN outcomes o ON o.case_id = c.id
    GROUP BY c.wi, c.n_particles, c.alpha, c.beta, c.delta;
"#,
];
