//! The sbatch scripts of a submission round: the manifest split into job arrays of at most the
//! cluster's `MaxArraySize` tasks ([`split`]), one script per array ([`script`]) whose task k
//! runs `xpflow run-case` on manifest line `offset + k`.

use std::path::Path;

/// One job array: manifest lines `offset .. offset + count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Chunk {
    /// Position of the chunk in the round (0, 1, …).
    pub number: usize,
    /// Manifest line of array index 0.
    pub offset: usize,
    /// Array tasks.
    pub count: usize,
}

/// SLURM's default `MaxArraySize` (array indices 0 to 1000), used when `scontrol` cannot tell.
pub const DEFAULT_MAX_ARRAY_SIZE: usize = 1001;

/// Splits `cases` manifest lines into arrays of at most `max_array_size` tasks (indices
/// `0 ..= max_array_size − 1`, SLURM's rule).
pub fn split(cases: usize, max_array_size: usize) -> Vec<Chunk> {
    let size = max_array_size.max(1);
    (0..cases.div_ceil(size))
        .map(|number| Chunk {
            number,
            offset: number * size,
            count: size.min(cases - number * size),
        })
        .collect()
}

/// The resources of every task of a round.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Resources {
    /// `--partition`.
    pub partition: Option<String>,
    /// `--account`.
    pub account: Option<String>,
    /// `--time` as SLURM reads it.
    pub time: String,
    /// `--mem` as SLURM reads it (e.g. `700M`, `4G`).
    pub mem: String,
    /// `%K` of `--array`: most tasks of the array running at once.
    pub max_running: Option<usize>,
    /// Minutes between a task's saved (and published) states (`run-case --state-every`; its
    /// default when `None`).
    pub state_every: Option<f64>,
    /// Lines of `#` comments saying where the estimates come from.
    pub notes: Vec<String>,
}

/// `s` quoted for the shell (single quotes).
pub fn sh_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// Everything a round's scripts name.
#[derive(Debug, Clone, Copy)]
pub struct ScriptPaths<'a> {
    /// The xpflow binary the tasks run (the one that wrote the script).
    pub exe: &'a Path,
    /// The round's manifest.
    pub manifest: &'a Path,
    /// The shard directory.
    pub shards: &'a Path,
    /// The log directory.
    pub logs: &'a Path,
}

/// The sbatch script of `chunk`, named `job_name`.
pub fn script(chunk: Chunk, job_name: &str, res: &Resources, paths: ScriptPaths<'_>) -> String {
    let throttle = res.max_running.map_or(String::new(), |k| format!("%{k}"));
    let log = |ext: &str| {
        paths
            .logs
            .join(format!("{job_name}_%A_%a.{ext}"))
            .display()
            .to_string()
    };
    let mut s = String::from("#!/bin/bash\n");
    s += &format!("#SBATCH --job-name={job_name}\n");
    s += &format!("#SBATCH --array=0-{}{throttle}\n", chunk.count - 1);
    s += &format!("#SBATCH --output={}\n", log("out"));
    s += "#SBATCH --ntasks=1\n#SBATCH --cpus-per-task=1\n";
    s += &format!("#SBATCH --mem={}\n#SBATCH --time={}\n", res.mem, res.time);
    if let Some(p) = &res.partition {
        s += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(a) = &res.account {
        s += &format!("#SBATCH --account={a}\n");
    }
    s += &format!(
        "# xpflow: array task k runs the case on line {} + k of the manifest, into its own shard\n",
        chunk.offset
    );
    for note in &res.notes {
        s += &format!("# {note}\n");
    }
    let state_every = res
        .state_every
        .map_or(String::new(), |m| format!(" --state-every {m}"));
    s += &format!(
        "exec {} run-case --manifest {} --index $((SLURM_ARRAY_TASK_ID + {})) --shards {}{state_every} \\\n    \
         --log {}\"/{job_name}_${{SLURM_ARRAY_JOB_ID}}_${{SLURM_ARRAY_TASK_ID}}.out\"\n",
        sh_quote(&paths.exe.display().to_string()),
        sh_quote(&paths.manifest.display().to_string()),
        chunk.offset,
        sh_quote(&paths.shards.display().to_string()),
        sh_quote(&paths.logs.display().to_string()),
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 2503 cases with MaxArraySize 1001: arrays of 1001, 1001, 501 (indices up to 1000); an
    /// exact multiple has no empty array.
    #[test]
    fn arrays_split_at_max_array_size() {
        let chunks = split(2503, 1001);
        let counts: Vec<_> = chunks.iter().map(|c| (c.offset, c.count)).collect();
        assert_eq!(counts, [(0, 1001), (1001, 1001), (2002, 501)]);
        assert_eq!(split(4, 2).len(), 2);
        assert_eq!(
            split(3, 1001),
            [Chunk {
                number: 0,
                offset: 0,
                count: 3
            }]
        );
        assert!(split(0, 1001).is_empty());
    }

    /// The script asks for what it was given, throttles the array, and runs the chunk's lines.
    #[test]
    fn the_script_holds_the_array_resources_and_the_command() {
        let res = Resources {
            partition: Some("short".into()),
            account: None,
            time: "0-00:18:00".into(),
            mem: "700M".into(),
            max_running: Some(2),
            state_every: Some(2.5),
            notes: vec!["memory: estimate".into()],
        };
        let paths = ScriptPaths {
            exe: Path::new("/opt/xp flow/xpflow"),
            manifest: Path::new("/s/round-1/manifest.txt"),
            shards: Path::new("/s/shards"),
            logs: Path::new("/s/logs"),
        };
        let chunk = Chunk {
            number: 1,
            offset: 1001,
            count: 3,
        };
        let s = script(chunk, "xpflow-demo-r1c1", &res, paths);
        for line in [
            "#SBATCH --array=0-2%2\n",
            "#SBATCH --mem=700M\n",
            "#SBATCH --time=0-00:18:00\n",
            "#SBATCH --partition=short\n",
            "#SBATCH --output=/s/logs/xpflow-demo-r1c1_%A_%a.out\n",
            "# memory: estimate\n",
            "exec '/opt/xp flow/xpflow' run-case --manifest '/s/round-1/manifest.txt' \
             --index $((SLURM_ARRAY_TASK_ID + 1001)) --shards '/s/shards' --state-every 2.5",
        ] {
            assert!(s.contains(line), "{line} not in\n{s}");
        }
        assert!(!s.contains("--account"), "{s}");
        assert_eq!(sh_quote("it's"), r"'it'\''s'");
    }
}
