//! `xpflow run CASE`: one case through the same engine as a sweep.

use std::process::ExitCode;

/// `xpflow run CASE`: one case (the `[base]` of a sweep file, as its own TOML or JSON file) through
/// the same engine as a sweep: results in `results/<stem>.db`, trajectories also in
/// `results/<stem>.csv`; with `resolved`, print the case's resolved numerical settings instead.
pub(super) fn run_case(path: &std::path::Path, resolved: bool) -> anyhow::Result<ExitCode> {
    use crate::config::SweepSpec;
    use crate::store::{query::QueryKind, Format, Store};
    use crate::sweep::{default_runner, expand, run_sweep, SweepOptions};
    let text =
        std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let base = match crate::config::parse_text(&text, is_json, path) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(ExitCode::from(2));
        }
    };
    let name = path
        .file_stem()
        .map_or("case".into(), |s| s.to_string_lossy().into_owned());
    let sweep_json = serde_json::json!({ "name": name, "base": base });
    let spec = match SweepSpec::from_str(&sweep_json.to_string(), true, path)
        .and_then(|s| expand(&s).map(|c| (s, c)))
    {
        Ok(v) => v,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(ExitCode::from(2));
        }
    };
    let (spec, cases) = spec;
    if resolved {
        if let Err(e) = crate::simulate::Simulation::supports(&cases[0].spec) {
            eprintln!("error: {}: {e}", path.display());
            return Ok(ExitCode::from(2));
        }
        print!(
            "{}",
            crate::simulate::Settings::of(&cases[0].spec).to_toml()
        );
        return Ok(ExitCode::SUCCESS);
    }
    let db = std::path::Path::new("results").join(format!("{name}.db"));
    let mut opts = SweepOptions::new(db.clone());
    opts.progress = crate::sweep::progress::ProgressMode::detect(false);
    let runner = default_runner();
    let summary = match run_sweep(&spec, &cases, runner.as_ref(), &opts) {
        Ok(s) => s,
        Err(e @ crate::sweep::engine::SweepError::Unsupported { .. }) => {
            eprintln!("error: {}: {e}; nothing was run", path.display());
            return Ok(ExitCode::from(2));
        }
        Err(e) => return Err(e.into()),
    };
    let store = Store::open(&db)?;
    let table = store.query(&QueryKind::Trajectory(cases[0].id.clone()), None, &[])?;
    let csv = std::path::Path::new("results").join(format!("{name}.csv"));
    std::fs::write(&csv, table.render(Format::Csv)).map_err(|e| {
        let full = std::path::absolute(&csv).unwrap_or_else(|_| csv.clone());
        anyhow::anyhow!("{}: {e}", full.display())
    })?;
    let outcome = store.query(&QueryKind::Cases, None, &[])?;
    print!("{}", outcome.render(Format::Table));
    println!(
        "results: {} (trajectories also in {})",
        db.display(),
        csv.display()
    );
    Ok(if summary.failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
