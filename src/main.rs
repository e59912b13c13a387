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
    // faer's dense kernels called without an explicit `Par` (reduced-model solves and
    // eigenproblems, `*` products) use this global setting; parallel, their last bits depend
    // on the thread count (tests/threads.rs). Sequential, results are the same on every
    // machine; the large kernels (sparse factorisation, Lanczos) pass their own `Par`.
    faer::set_global_parallelism(faer::Par::Seq);
    femu::cli::main()
}
