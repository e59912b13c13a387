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

    /// Bytes appended as they are (a slice of the buffer's size or more is hashed in place).
    pub fn bytes(&mut self, bytes: &[u8]) {
        if self.buffer.len() + bytes.len() > Self::CAPACITY {
            self.flush();
        }
        if bytes.len() >= Self::CAPACITY {
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

    /// Every value of `values` as its little-endian bytes (`to_le`): on a little-endian
    /// machine the values' own memory, hashed in place with no copy; elsewhere encoded as
    /// [`Self::values`] does.
    pub fn le_values<T: bytemuck::Pod + Sync, const N: usize>(
        &mut self,
        values: &[T],
        to_le: impl Fn(T) -> [u8; N] + Sync,
    ) {
        if cfg!(target_endian = "little") {
            self.bytes(bytemuck::cast_slice(values));
        } else {
            self.values(values, to_le);
        }
    }

    /// Length-prefixed fields, one per item, as [`Self::field`] appends them; encoded on all
    /// threads a batch at a time (a million DOF labels one by one took 0.05 s).
    pub fn fields<S: AsRef<[u8]> + Sync>(&mut self, items: &[S]) {
        use rayon::prelude::*;
        /// Items encoded by one task, and per batch (which bounds the memory held).
        const PER_TASK: usize = 1 << 12;
        const PER_BATCH: usize = 1 << 18;
        for batch in items.chunks(PER_BATCH) {
            let encoded: Vec<Vec<u8>> = batch
                .par_chunks(PER_TASK)
                .map(|part| {
                    let len = part.iter().map(|s| 8 + s.as_ref().len()).sum();
                    let mut out = Vec::with_capacity(len);
                    for s in part {
                        let s = s.as_ref();
                        out.extend_from_slice(&(s.len() as u64).to_le_bytes());
                        out.extend_from_slice(s);
                    }
                    out
                })
                .collect();
            for e in &encoded {
                self.bytes(e);
            }
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
