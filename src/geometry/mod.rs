//! Problem set-ups and initial particle layouts.

pub mod layout;
