//! The `femu` binary.

fn main() -> std::process::ExitCode {
    // Output piped into a reader that stops early (`femu show … | head`) ends the process
    // quietly, as a Unix tool should, instead of a panic on the broken pipe.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    femu::core::memory::keep_freed_memory();
    femu::cli::main()
}
