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
    let (need, free) = (case.memory_estimate(), available());
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
