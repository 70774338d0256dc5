//! Sweep expansion, case ids, scheduling, resume and progress.
