//! Typed, validated case and sweep specifications.
