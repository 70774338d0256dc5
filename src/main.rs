//! The `xpflow` binary: parses arguments and calls the library.

fn main() -> std::process::ExitCode {
    xpflow::cli::main_with_args()
}
