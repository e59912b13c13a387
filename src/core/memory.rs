//! Process-wide allocator settings for large numerical work.

/// Lets glibc's allocator keep and reuse large freed blocks instead of returning each to the
/// kernel.
///
/// By default glibc serves large blocks (above 128 KiB to 32 MiB, adaptively) by a fresh `mmap`
/// and unmaps them on `free`. The eigensolver's block vectors, the triangular solves' work
/// arrays and the substructures' dense blocks are that size at a million DOFs and are allocated
/// thousands of times: every one then costs page faults, the kernel's zeroing of every page and
/// TLB shoot-downs across threads (perf: 20 % of a 300k-DOF eigen solve). With `mmap` off and
/// trimming off, freed blocks stay in the heap for the next allocation (measured: the 300k
/// plate's 50 modes 25.5 s → 22.0 s). The cost is a peak resident size up to ~10 % higher,
/// from fragmentation. Call once at start-up, before threads start; a no-op off glibc.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only changes allocator tuning parameters; it is called before any
    // other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_MAX, 0);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
    }
}

/// Returns the heap's free memory to the kernel (glibc `malloc_trim`), e.g. between benchmark
/// phases whose peaks are measured apart; a no-op off glibc.
pub fn release_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `malloc_trim` only releases free heap pages; it is thread-safe.
    unsafe {
        libc::malloc_trim(0);
    }
}
