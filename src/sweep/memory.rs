//! The machine's memory, for the memory check of cases: a sweep refuses a case whose estimate
//! ([`crate::config::CaseSpec::memory_estimate`]) is above a limit (default: the physical memory),
//! and a case that does not fit in the memory free when it starts fails instead of running —
//! an allocation that fails aborts the whole process, which no case may do to a sweep.

use crate::config::CaseSpec;

/// Assumed when `/proc/meminfo` cannot be read (not Linux): no limit.
const UNKNOWN: f64 = f64::INFINITY;

/// A field of `/proc/meminfo` in bytes.
fn meminfo(field: &str) -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with(field))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Physical memory of the machine, bytes (infinite when unknown).
pub fn total() -> f64 {
    meminfo("MemTotal:").unwrap_or(UNKNOWN)
}

/// Memory available now (free plus reclaimable), bytes (infinite when unknown).
pub fn available() -> f64 {
    meminfo("MemAvailable:").unwrap_or(UNKNOWN)
}

/// Bytes as "12.3 GB".
pub fn gb(bytes: f64) -> String {
    if bytes.is_finite() {
        format!("{:.1} GB", bytes / 1e9)
    } else {
        "unlimited".into()
    }
}

/// `Ok` if `case`'s estimated memory fits in the memory available now; otherwise why not.
///
/// # Errors
/// The estimate and what is available, as the error of a failed case.
pub fn fits(case: &CaseSpec) -> Result<(), String> {
    fits_in(case, available())
}

/// `Ok` if `case`'s estimated memory is at most `free` bytes; otherwise why not.
fn fits_in(case: &CaseSpec, free: f64) -> Result<(), String> {
    let need = case.memory_estimate();
    if need > free {
        let [n1, n2] = case.numerics.mesh;
        return Err(format!(
            "not started: the {n1}×{n2} mesh needs about {} of memory and only {} is available \
             now (other cases or programs use the rest); rerun with --retry-failed and fewer --jobs",
            gb(need),
            gb(free)
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A case that needs more than is free is refused with both figures, before it allocates
    /// (an allocation that fails aborts the process: issue 28, exit 134 with the case left
    /// `running` and the rest of the sweep never run).
    #[test]
    fn a_case_larger_than_the_free_memory_is_not_started() {
        let case = CaseSpec::from_value(serde_json::json!({
            "geometry": {"confined_shear": {"h": 1.0, "l": 4.0}},
            "fluid": {"model": "giesekus", "wi": 1.0, "alpha": 0.01, "beta": 0.1},
            "particles": {"radius": 0.1, "layout": {"string": {"n": 2, "lx": 0.5, "ly": 0.1}}},
            "numerics": {"mesh": [400, 100], "dt": 0.01, "t_end": 1.0}
        }))
        .unwrap();
        let need = case.memory_estimate();
        assert!(fits_in(&case, 2.0 * need).is_ok());
        let e = fits_in(&case, 0.5 * need).unwrap_err();
        assert!(e.contains("400×100") && e.contains("GB"), "{e}");
        assert_eq!(gb(f64::INFINITY), "unlimited");
    }
}
