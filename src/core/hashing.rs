//! A blake3 hash of a stream of bytes and encoded values, on all threads: the content digest of
//! artefacts and the pattern key of sparse factorisations.

/// blake3 fed through a buffer, so that the hasher sees large slices rather than one 8-byte
/// value at a time, each hashed on all threads (blake3's tree splits a slice among them); the
/// digest equals that of the unbuffered stream, however it is cut.
pub struct StreamHasher {
    hasher: blake3::Hasher,
    buffer: Vec<u8>,
}

impl StreamHasher {
    const CAPACITY: usize = 1 << 22;

    /// An empty stream.
    pub fn new() -> Self {
        Self {
            hasher: blake3::Hasher::new(),
            buffer: Vec::with_capacity(Self::CAPACITY),
        }
    }

    fn flush(&mut self) {
        self.hasher.update_rayon(&self.buffer);
        self.buffer.clear();
    }

    /// Bytes appended as they are.
    pub fn bytes(&mut self, bytes: &[u8]) {
        if self.buffer.len() + bytes.len() > Self::CAPACITY {
            self.flush();
        }
        if bytes.len() > Self::CAPACITY {
            self.hasher.update_rayon(bytes);
        } else {
            self.buffer.extend_from_slice(bytes);
        }
    }

    /// Every value of `values` as the `N` bytes `encode` gives, in order, a buffer at a time,
    /// each buffer filled on all threads.
    pub fn values<T: Copy + Sync, const N: usize>(
        &mut self,
        values: &[T],
        encode: impl Fn(T) -> [u8; N] + Sync,
    ) {
        use rayon::prelude::*;
        /// Values encoded by one task.
        const PER_TASK: usize = 1 << 14;
        for chunk in values.chunks(Self::CAPACITY / N) {
            if self.buffer.len() + chunk.len() * N > Self::CAPACITY {
                self.flush();
            }
            let start = self.buffer.len();
            self.buffer.resize(start + chunk.len() * N, 0);
            self.buffer[start..]
                .par_chunks_mut(PER_TASK * N)
                .zip(chunk.par_chunks(PER_TASK))
                .for_each(|(out, part)| {
                    for (bytes, &x) in out.chunks_exact_mut(N).zip(part) {
                        bytes.copy_from_slice(&encode(x));
                    }
                });
        }
    }

    /// A length-prefixed field.
    pub fn field(&mut self, bytes: &[u8]) {
        self.bytes(&(bytes.len() as u64).to_le_bytes());
        self.bytes(bytes);
    }

    /// The hash of everything appended.
    pub fn finish(mut self) -> blake3::Hash {
        self.flush();
        self.hasher.finalize()
    }
}

impl Default for StreamHasher {
    fn default() -> Self {
        Self::new()
    }
}
