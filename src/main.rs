//! The `femu` binary.

fn main() -> std::process::ExitCode {
    femu::cli::main()
}
