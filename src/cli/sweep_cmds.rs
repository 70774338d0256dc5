//! Sweep, query and status subcommands.
