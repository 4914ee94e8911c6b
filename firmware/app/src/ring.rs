//! A single-producer single-consumer byte ring that cannot panic. `head` and `tail` count
//! the bytes ever written and read (wrapping); byte `k` lives at `buf[k % N]`. Each side
//! stores only its own counter, Release after its byte accesses, Acquire on the other
//! side, so an interrupt may produce while a task consumes without a lock.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicUsize, Ordering};

/// The ring had no room (a write) or no byte (a read) at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Empty;

/// A byte ring of `N` bytes for one producer and one consumer (see the module).
pub struct ByteRing<const N: usize> {
    buf: UnsafeCell<[u8; N]>,
    head: AtomicUsize,
    tail: AtomicUsize,
}

// SAFETY: the producer writes only outside `[tail, head)` and publishes with the Release
// store of `head`; the consumer reads only inside and frees with the Release store of
// `tail`. With one producer and one consumer no byte is accessed by both at once.
#[allow(unsafe_code)]
unsafe impl<const N: usize> Sync for ByteRing<N> {}

impl<const N: usize> Default for ByteRing<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> ByteRing<N> {
    /// An empty ring.
    pub const fn new() -> Self {
        Self {
            buf: UnsafeCell::new([0; N]),
            head: AtomicUsize::new(0),
            tail: AtomicUsize::new(0),
        }
    }

    /// Bytes held now.
    fn len(&self) -> usize {
        let head = self.head.load(Ordering::Acquire);
        head.wrapping_sub(self.tail.load(Ordering::Acquire))
    }

    /// Room for this many more bytes (`N - len`).
    pub fn free_capacity(&self) -> usize {
        N.saturating_sub(self.len())
    }

    /// Copies as much of `data` as fits; the bytes taken, or [`Empty`] if none. One producer only.
    pub fn try_write(&self, data: &[u8]) -> Result<usize, Empty> {
        let head = self.head.load(Ordering::Relaxed);
        let tail = self.tail.load(Ordering::Acquire);
        let free = N.saturating_sub(head.wrapping_sub(tail));
        let n = free.min(data.len());
        if n == 0 {
            return Err(Empty);
        }
        let base = self.buf.get().cast::<u8>();
        for (k, &b) in data.iter().take(n).enumerate() {
            // `% N` keeps the index inside the buffer (N > 0: `n` is 0 otherwise).
            let at = head.wrapping_add(k) % N;
            // SAFETY: `at < N`; the byte is outside `[tail, head)`, unread until `head` is stored.
            #[allow(unsafe_code)]
            unsafe {
                base.add(at).write(b)
            };
        }
        self.head.store(head.wrapping_add(n), Ordering::Release);
        Ok(n)
    }

    /// Moves as many held bytes as fit into `out`; the count, or [`Empty`] if none. One consumer only.
    pub fn try_read(&self, out: &mut [u8]) -> Result<usize, Empty> {
        let tail = self.tail.load(Ordering::Relaxed);
        let head = self.head.load(Ordering::Acquire);
        let n = head.wrapping_sub(tail).min(out.len());
        if n == 0 {
            return Err(Empty);
        }
        let base = self.buf.get().cast::<u8>();
        for (k, o) in out.iter_mut().take(n).enumerate() {
            let at = tail.wrapping_add(k) % N;
            // SAFETY: `at < N`; the byte is inside `[tail, head)`, published by the producer.
            #[allow(unsafe_code)]
            let b = unsafe { base.add(at).read() };
            *o = b;
        }
        self.tail.store(tail.wrapping_add(n), Ordering::Release);
        Ok(n)
    }

    /// Hands the held bytes up to the ring's end to `f` in place, then frees them; their
    /// count, or [`Empty`]. One consumer only.
    pub fn read_in_place(&self, f: impl FnOnce(&[u8])) -> Result<usize, Empty> {
        let tail = self.tail.load(Ordering::Relaxed);
        let head = self.head.load(Ordering::Acquire);
        let at = tail % N;
        let n = head.wrapping_sub(tail).min(N - at);
        if n == 0 {
            return Err(Empty);
        }
        // SAFETY: `at + n <= N`; the bytes are held, so the producer leaves them until the
        // Release store of `tail` below, after `f` has returned.
        #[allow(unsafe_code)]
        let held = unsafe { core::slice::from_raw_parts(self.buf.get().cast::<u8>().add(at), n) };
        f(held);
        self.tail.store(tail.wrapping_add(n), Ordering::Release);
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_come_out_in_order_across_the_end_and_full_empty_are_reported() {
        let r = ByteRing::<8>::new();
        let mut out = [0u8; 8];
        assert_eq!(r.try_read(&mut out), Err(Empty));
        assert_eq!(r.try_write(&[1, 2, 3, 4, 5, 6]), Ok(6));
        assert_eq!(r.try_read(&mut out[..4]), Ok(4));
        assert_eq!(out[..4], [1, 2, 3, 4]);
        // 2 held, 6 free: the write wraps past the end of the buffer and stops when full.
        assert_eq!(r.free_capacity(), 6);
        assert_eq!(r.try_write(&[7, 8, 9, 10, 11, 12, 13]), Ok(6));
        assert_eq!(r.try_write(&[14]), Err(Empty));
        assert_eq!(r.len(), 8);
        assert_eq!(r.try_read(&mut out), Ok(8));
        assert_eq!(out, [5, 6, 7, 8, 9, 10, 11, 12]);
        assert_eq!(r.len(), 0);
        assert_eq!(r.try_write(&[]), Err(Empty));
    }

    #[test]
    fn read_in_place_gives_the_held_bytes_in_order_in_at_most_two_runs() {
        let r = ByteRing::<8>::new();
        assert_eq!(r.read_in_place(|_| panic!("no bytes are held")), Err(Empty));
        assert_eq!(r.try_write(&[1, 2, 3, 4, 5, 6]), Ok(6));
        let mut got = Vec::new();
        assert_eq!(r.read_in_place(|b| got.extend_from_slice(b)), Ok(6));
        assert_eq!(got, [1, 2, 3, 4, 5, 6]);
        // Wraps: 2 bytes up to the end, then 3 from the start.
        assert_eq!(r.try_write(&[7, 8, 9, 10, 11]), Ok(5));
        let mut runs = Vec::new();
        while let Ok(n) = r.read_in_place(|b| runs.push(b.to_vec())) {
            assert!(n > 0);
        }
        assert_eq!(runs, [vec![7, 8], vec![9, 10, 11]]);
        assert_eq!(r.len(), 0);
        assert_eq!(r.free_capacity(), 8);
    }

    #[test]
    fn a_long_stream_through_a_small_ring_arrives_whole() {
        // Counters far beyond N (and the stream's bytes) check the modular indexing.
        let r = ByteRing::<5>::new();
        let stream: Vec<u8> = (0..1000u32).map(|k| (k * 7 % 251) as u8).collect();
        let (mut sent, mut got) = (0, Vec::new());
        let mut chunk = [0u8; 3];
        while got.len() < stream.len() {
            if let Ok(n) = r.try_write(&stream[sent..(sent + 4).min(stream.len())]) {
                sent += n;
            }
            if let Ok(n) = r.try_read(&mut chunk) {
                got.extend_from_slice(&chunk[..n]);
            }
            assert!(r.len() <= 5);
        }
        assert_eq!(got, stream);
    }
}
