//! Talking to SLURM through its commands: `sbatch --parsable` (submit, chained by
//! `--dependency=afterany`), `squeue` (the tasks queued or running, one line per array task) and
//! `scontrol show config` (`MaxArraySize`). Accounting (`sacct`) is not used: clusters without it
//! are common, and the shards say what finished.

use std::path::Path;
use std::process::Command;

/// A task as `squeue -r` lists it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct QueuedTask {
    /// Job name (`xpflow-<sweep>-<tag>-r<round>c<chunk>`).
    pub name: String,
    /// Array job id.
    pub job: String,
    /// Array task id.
    pub task: Option<usize>,
    /// SLURM's state (`PENDING`, `RUNNING`, `COMPLETING`, …).
    pub state: String,
}

impl QueuedTask {
    /// Whether SLURM runs it now (running, completing, configuring).
    pub fn is_running(&self) -> bool {
        matches!(
            self.state.as_str(),
            "RUNNING" | "COMPLETING" | "CONFIGURING" | "STAGE_OUT"
        )
    }
}

/// A SLURM command that failed.
#[derive(Debug, thiserror::Error)]
#[error("{command}: {message}")]
pub struct SchedulerError {
    /// The command line.
    pub command: String,
    /// Its error or output.
    pub message: String,
}

/// Runs `program args`, returning its stdout.
fn run(program: &str, args: &[&str]) -> Result<String, SchedulerError> {
    let command = format!("{program} {}", args.join(" "));
    let out = Command::new(program)
        .args(args)
        .output()
        .map_err(|e| SchedulerError {
            command: command.clone(),
            message: format!("cannot run it ({e}); is SLURM installed here?"),
        })?;
    if !out.status.success() {
        return Err(SchedulerError {
            command,
            message: format!(
                "{}: {}",
                out.status,
                String::from_utf8_lossy(&out.stderr).trim()
            ),
        });
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Submits `script`, after `after` (a job id) has ended if given; returns the job id.
///
/// # Errors
/// [`SchedulerError`] with sbatch's message.
pub fn sbatch(script: &Path, after: Option<&str>) -> Result<String, SchedulerError> {
    let dependency = after.map(|j| format!("--dependency=afterany:{j}"));
    let script = script.display().to_string();
    let mut args = vec!["--parsable"];
    if let Some(d) = &dependency {
        args.push(d);
    }
    args.push(&script);
    let out = run("sbatch", &args)?;
    // `<job id>` or `<job id>;<cluster>`
    let id = out.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_digit()) {
        return Err(SchedulerError {
            command: format!("sbatch --parsable {script}"),
            message: format!("unexpected output `{}`", out.trim()),
        });
    }
    Ok(id)
}

/// The tasks in the queue whose job name starts with `prefix` (`None` when `squeue` cannot
/// be run or fails: no scheduler reachable from here).
pub fn squeue(prefix: &str) -> Option<Vec<QueuedTask>> {
    let out = run("squeue", &["-h", "-r", "-o", "%j|%F|%K|%T"]).ok()?;
    Some(parse_squeue(&out, prefix))
}

/// Parses `squeue -h -r -o '%j|%F|%K|%T'`.
fn parse_squeue(out: &str, prefix: &str) -> Vec<QueuedTask> {
    out.lines()
        .filter_map(|line| {
            let mut f = line.trim().split('|');
            let (name, job, task, state) = (f.next()?, f.next()?, f.next()?, f.next()?);
            name.starts_with(prefix).then(|| QueuedTask {
                name: name.to_string(),
                job: job.to_string(),
                task: task.parse().ok(),
                state: state.to_string(),
            })
        })
        .collect()
}

/// The cluster's `MaxArraySize` (`None` when `scontrol` cannot tell).
pub fn max_array_size() -> Option<usize> {
    let out = run("scontrol", &["show", "config"]).ok()?;
    parse_max_array_size(&out)
}

fn parse_max_array_size(config: &str) -> Option<usize> {
    config.lines().find_map(|l| {
        let (key, value) = l.split_once('=')?;
        (key.trim() == "MaxArraySize")
            .then(|| value.trim().parse().ok())
            .flatten()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lines of squeue and scontrol as slurm 22.05 prints them.
    #[test]
    fn squeue_and_scontrol_output_parse() {
        let out = "xpflow-s-ab12cd-r1c0|41|0|RUNNING\nxpflow-s-ab12cd-r1c0|41|3|PENDING\n\
                   other|7|N/A|RUNNING\n";
        let q = parse_squeue(out, "xpflow-s-ab12cd-");
        assert_eq!(q.len(), 2);
        assert_eq!(q[1].task, Some(3));
        assert!(q[0].is_running() && !q[1].is_running());
        let config =
            "Configuration data as of 2026-01-01T00:00:00\nMaxArraySize            = 1001\n\
                      MaxJobCount             = 10000\n";
        assert_eq!(parse_max_array_size(config), Some(1001));
        assert_eq!(parse_max_array_size("nothing"), None);
    }
}
