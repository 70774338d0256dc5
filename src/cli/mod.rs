//! Command-line interface: thin wrappers over the library.
pub mod sweep_cmds;
