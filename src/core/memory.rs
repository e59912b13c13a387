//! Process-wide allocator settings for large numerical work.

/// Lets glibc's allocator keep and reuse large freed blocks instead of returning each to the
/// kernel.
///
/// By default glibc serves large blocks (above 128 KiB to 32 MiB, adaptively) by a fresh `mmap`
/// and unmaps them on `free`. The eigensolver's block vectors, the triangular solves' work
/// arrays and the substructures' dense blocks are that size at a million DOFs and are allocated
/// thousands of times: every one then costs page faults, the kernel's zeroing of every page and
/// TLB shoot-downs across threads, a noticeable share of an eigen solve. With `mmap` off and
/// trimming off, freed blocks stay in the heap for the next allocation. The cost is a peak
/// resident size up to ~10 % higher, from fragmentation. Call once at start-up, before threads
/// start; a no-op off glibc.
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

/// Drops `value` on a thread of its own, for a stage that is done with a structure of
/// hundreds of megabytes and has more to do.
///
/// Blocks that large come from `mmap` whatever [`keep_freed_memory`] asks when a worker thread
/// allocated them (glibc's thread arenas cannot hold them), and unmapping them takes time (the
/// 1M-DOF plate's full `K` and `M`, 0.5 GB: 0.1 s).
pub fn drop_in_background<T: Send + 'static>(value: T) {
    // A thread that cannot start drops its closure, and `value` with it, here.
    let _ = std::thread::Builder::new()
        .name("femu-drop".into())
        .spawn(move || drop(value));
}

/// A vector of `len` zeros, or `None` when the memory is not available.
///
/// Allocated zeroed (`calloc`), not zeroed by a write: memory fresh from the kernel is zero
/// already, so no single-threaded pass touches every page up front, and the pages are first
/// touched by whichever threads then fill them. (A `memset` of a Cholesky factor of gigabytes
/// would fault every page in on one thread before the parallel factorisation starts.)
pub fn zeroed_f64(len: usize) -> Option<Vec<f64>> {
    if len == 0 {
        return Some(Vec::new());
    }
    let layout = std::alloc::Layout::array::<f64>(len).ok()?;
    // SAFETY: `layout` has a non-zero size. The pointer, when not null, is an allocation of
    // the global allocator with the layout of `len` `f64`s, all bytes zero, and an all-zero
    // `f64` is `0.0`: exactly what `Vec::from_raw_parts` requires with length and capacity
    // `len`.
    unsafe {
        let ptr = std::alloc::alloc_zeroed(layout).cast::<f64>();
        (!ptr.is_null()).then(|| Vec::from_raw_parts(ptr, len, len))
    }
}

/// A vector of `len` zeros written by the pool's threads, for arrays that are then updated in
/// place (`+=`), such as an assembled matrix's values.
///
/// [`zeroed_f64`] suits arrays whose entries are first written. An array first *read* maps each
/// untouched page to the kernel's shared zero page, and the first write to it then copies the
/// page and flushes the TLBs of every thread of the process (an inter-processor interrupt per
/// page). Written zeros fault each page in once, on the thread that writes it. At 302,400 DOFs
/// the copy-on-write faults were about half of the assembly's time.
pub fn written_zeros_f64(len: usize) -> Vec<f64> {
    use rayon::prelude::*;
    /// Entries per task: 512 KiB, a hundred pages.
    const CHUNK: usize = 1 << 16;
    // Zeroed by the allocator (fresh pages untouched), then written: each page's first touch
    // is this write, on the thread that makes it.
    let mut values = vec![0.0; len];
    values
        .par_chunks_mut(CHUNK)
        .for_each(|chunk| chunk.fill(0.0));
    values
}

/// An `nrows × ncols` matrix of zeros whose columns are written by the pool's threads.
///
/// `Mat::zeros` fills the matrix on the calling thread, so a fresh matrix of a gigabyte (the
/// Krylov basis at 10⁶ DOFs) is first touched, page fault by page fault, on one core, for
/// seconds. Here the threads share that first touch.
pub fn parallel_zeros(nrows: usize, ncols: usize) -> faer::Mat<f64> {
    use rayon::prelude::*;
    /// The matrix's storage, shared by the threads that fill disjoint columns of it.
    struct Storage(*mut f64);
    // SAFETY: the threads write disjoint columns (see below) and nothing reads the storage
    // until they have all finished.
    unsafe impl Sync for Storage {}
    let mut m = faer::Mat::<f64>::with_capacity(nrows, ncols);
    // Column j starts `col_stride · j` entries into an allocation of at least
    // `col_stride · ncols` entries, with `col_stride` (the row capacity) ≥ `nrows`.
    let stride = m.col_stride().unsigned_abs();
    debug_assert!(stride >= nrows);
    let storage = Storage(m.as_ptr_mut());
    (0..ncols).into_par_iter().for_each(|j| {
        let storage = &storage;
        for i in 0..nrows {
            // SAFETY: `i < nrows ≤ stride` and `j < ncols`, so the entry lies inside the
            // allocation that `with_capacity` made, and only this task writes column `j`.
            // Writing through the raw pointer initialises it.
            unsafe { storage.0.add(j * stride + i).write(0.0) };
        }
    });
    // SAFETY: the dimensions are within the capacity reserved above, and every entry now in
    // bounds was initialised by the loop.
    unsafe { m.set_dims(nrows, ncols) };
    m
}

/// An `nrows × ncols` column-major matrix in a plain vector, column `j` at `j · nrows`.
///
/// Unlike a `faer::Mat`, its storage can give up its trailing columns in place
/// ([`Columns::keep_leading`]: the allocator shortens the block, nothing is copied). The
/// eigensolver's Krylov basis is one: at its end the Ritz images are formed over the basis's
/// leading columns and the rest handed back, so the images never sit beside the basis (400 MB
/// of the solver's peak at a million DOFs).
///
/// Storage may also hold spare columns past the matrix's own ([`Columns::split_spare`]): the
/// refinement forms `K X` in the basis's columns after the Ritz images rather than in fresh
/// memory (0.8 GB at a million DOFs and 100 modes, its pages first touched again otherwise).
#[derive(Clone, Debug)]
pub struct Columns {
    /// `nrows · stored` entries: the matrix's columns, then the spare ones.
    data: Vec<f64>,
    nrows: usize,
    ncols: usize,
    stored: usize,
}

impl Columns {
    /// Zeros, first touched by the pool's threads (see [`parallel_zeros`]).
    pub fn zeros(nrows: usize, ncols: usize) -> Self {
        use rayon::prelude::*;
        let len = nrows * ncols;
        let mut data: Vec<f64> = Vec::with_capacity(len);
        let chunk = nrows.max(1 << 16);
        data.spare_capacity_mut()
            .par_chunks_mut(chunk)
            .for_each(|c| {
                for x in c {
                    x.write(0.0);
                }
            });
        // SAFETY: every one of the `len` entries was initialised just above.
        unsafe { data.set_len(len) };
        Columns {
            data,
            nrows,
            ncols,
            stored: ncols,
        }
    }

    /// A copy of `a`.
    pub fn from_mat(a: faer::MatRef<'_, f64>) -> Self {
        let (nrows, ncols) = (a.nrows(), a.ncols());
        let mut data = Vec::with_capacity(nrows * ncols);
        for j in 0..ncols {
            data.extend(a.col(j).iter().copied());
        }
        Columns {
            data,
            nrows,
            ncols,
            stored: ncols,
        }
    }

    /// Rows.
    pub fn nrows(&self) -> usize {
        self.nrows
    }

    /// Columns.
    pub fn ncols(&self) -> usize {
        self.ncols
    }

    /// Spare columns stored past the matrix's.
    pub fn spare(&self) -> usize {
        self.stored - self.ncols
    }

    /// The matrix.
    pub fn as_ref(&self) -> faer::MatRef<'_, f64> {
        let len = self.nrows * self.ncols;
        faer::MatRef::from_column_major_slice(&self.data[..len], self.nrows, self.ncols)
    }

    /// The matrix, writable.
    pub fn as_mut(&mut self) -> faer::MatMut<'_, f64> {
        self.split_spare().0
    }

    /// The matrix and its spare columns (whatever values they hold), both writable.
    pub fn split_spare(&mut self) -> (faer::MatMut<'_, f64>, faer::MatMut<'_, f64>) {
        let (matrix, spare) = self.data.split_at_mut(self.nrows * self.ncols);
        (
            faer::MatMut::from_column_major_slice_mut(matrix, self.nrows, self.ncols),
            faer::MatMut::from_column_major_slice_mut(spare, self.nrows, self.stored - self.ncols),
        )
    }

    /// Keeps the leading `ncols` columns (at most those it has) and up to `spare` of the
    /// columns stored after them as spare; returns the storage of the rest to the allocator.
    pub fn keep_leading(&mut self, ncols: usize, spare: usize) {
        self.ncols = ncols.min(self.ncols);
        self.stored = (self.ncols + spare).min(self.stored);
        self.data.truncate(self.nrows * self.stored);
        self.data.shrink_to_fit();
    }

    /// Makes sure at least `spare` spare columns are stored (new ones hold zeros).
    pub fn reserve_spare(&mut self, spare: usize) {
        if self.spare() < spare {
            self.stored = self.ncols + spare;
            self.data.resize(self.nrows * self.stored, 0.0);
        }
    }
}

/// `data` cut into consecutive slices, slice `j` of length `offsets[j + 1] − offsets[j]`
/// (`offsets` ascending from 0 to at most `data.len()`), for filling the parts side by side.
pub fn split_at_offsets<'a, T>(mut data: &'a mut [T], offsets: &[usize]) -> Vec<&'a mut [T]> {
    let mut slices = Vec::with_capacity(offsets.len().saturating_sub(1));
    for w in offsets.windows(2) {
        let (head, tail) = std::mem::take(&mut data).split_at_mut(w[1] - w[0]);
        slices.push(head);
        data = tail;
    }
    slices
}

#[cfg(test)]
mod tests {
    /// Spare columns are kept, grown and handed back without touching the matrix's columns.
    #[test]
    fn spare_columns_sit_after_the_matrix() {
        let a = faer::Mat::from_fn(5, 3, |i, j| (10 * i + j) as f64);
        let mut c = super::Columns::from_mat(a.as_ref());
        assert_eq!(c.spare(), 0);
        c.reserve_spare(2);
        assert_eq!((c.ncols(), c.spare()), (3, 2));
        c.split_spare().1.fill(7.0);
        assert_eq!(c.as_ref(), a.as_ref());
        c.keep_leading(2, 1);
        assert_eq!((c.ncols(), c.spare()), (2, 1));
        assert_eq!(c.as_ref(), a.as_ref().subcols(0, 2));
        // The spare column is the matrix's old third.
        assert_eq!(c.split_spare().1.col(0), a.col(2));
        c.keep_leading(2, 5);
        assert_eq!(c.spare(), 1, "no more spare than was stored");
        c.keep_leading(1, 0);
        assert_eq!((c.ncols(), c.spare()), (1, 0));
        assert_eq!(c.as_ref(), a.as_ref().subcols(0, 1));
    }

    /// The value is dropped, on another thread.
    #[test]
    fn a_value_dropped_in_the_background_is_dropped_elsewhere() {
        struct Tell(std::sync::mpsc::Sender<std::thread::ThreadId>);
        impl Drop for Tell {
            fn drop(&mut self) {
                let _ = self.0.send(std::thread::current().id());
            }
        }
        let (send, receive) = std::sync::mpsc::channel();
        super::drop_in_background(Tell(send));
        let by = receive
            .recv_timeout(std::time::Duration::from_secs(60))
            .unwrap();
        assert_ne!(by, std::thread::current().id());
    }

    #[test]
    fn zeroed_vectors_hold_zeros_and_grow() {
        let mut v = super::zeroed_f64(1 << 20).unwrap();
        assert_eq!(v.len(), 1 << 20);
        assert!(v.iter().all(|x| *x == 0.0));
        v.push(1.0);
        assert_eq!(v[1 << 20], 1.0);
        assert!(super::zeroed_f64(0).unwrap().is_empty());
    }

    /// The bounds of the `unsafe` block: a length whose layout overflows is refused before
    /// any allocation, and one the allocator cannot serve (the null pointer) gives `None`,
    /// not a vector over a null pointer.
    #[test]
    fn impossible_sizes_are_refused() {
        assert!(super::zeroed_f64(usize::MAX).is_none());
        assert!(super::zeroed_f64(isize::MAX as usize / 8).is_none());
        assert_eq!(super::zeroed_f64(1).unwrap(), vec![0.0]);
    }

    /// `Columns`: zeros of every shape (the threads' chunks cross column boundaries), a copy
    /// of a matrix, writes through the view, and the leading columns kept with their values
    /// while the storage shrinks to them (asking for more columns than held keeps all).
    #[test]
    fn columns_hold_a_matrix_and_give_back_trailing_columns() {
        use super::Columns;
        for (r, c) in [(0, 0), (0, 3), (3, 0), (1, 1), (7, 5), (70_001, 3)] {
            let z = Columns::zeros(r, c);
            assert_eq!((z.nrows(), z.ncols()), (r, c));
            assert_eq!(z.as_ref(), faer::Mat::<f64>::zeros(r, c));
        }
        let a = faer::Mat::from_fn(9, 6, |i, j| (10 * i + j) as f64);
        let mut cols = Columns::from_mat(a.as_ref());
        assert_eq!(cols.as_ref(), a);
        cols.as_mut()[(8, 5)] = -1.0;
        assert_eq!(cols.as_ref()[(8, 5)], -1.0);
        cols.keep_leading(4, 0);
        assert_eq!((cols.nrows(), cols.ncols()), (9, 4));
        assert_eq!(cols.as_ref(), a.as_ref().subcols(0, 4));
        assert_eq!(cols.data.capacity(), 9 * 4);
        cols.keep_leading(10, 0);
        assert_eq!(cols.ncols(), 4);
    }

    /// A matrix zeroed by the threads is an ordinary matrix of zeros of its shape, and empty
    /// shapes work.
    #[test]
    fn parallel_zeros_are_a_zero_matrix() {
        for (r, c) in [(0, 0), (0, 3), (3, 0), (1, 1), (7, 5), (1001, 17)] {
            let mut m = super::parallel_zeros(r, c);
            assert_eq!((m.nrows(), m.ncols()), (r, c));
            assert!(m.col_iter().all(|col| col.iter().all(|x| x.to_bits() == 0)));
            if r > 0 && c > 0 {
                m[(r - 1, c - 1)] = 2.0;
                let product = m.transpose() * &m;
                assert_eq!(product[(c - 1, c - 1)], 4.0);
            }
        }
    }

    /// Every entry written, across chunk boundaries and for the empty vector.
    #[test]
    fn written_zeros_are_zeros() {
        for len in [0, 1, (1 << 16) - 1, 1 << 16, 3 * (1 << 16) + 5] {
            let v = super::written_zeros_f64(len);
            assert_eq!(v.len(), len);
            assert!(v.iter().all(|x| x.to_bits() == 0));
        }
    }
}
