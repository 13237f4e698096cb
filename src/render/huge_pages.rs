//! Large arrays backed by 2 MiB pages where the kernel offers them.
//!
//! Tracing a large mesh touches nodes and triangles all over tens of megabytes; with 4 KiB pages
//! most of those accesses also miss the TLB. And a render's per-pixel buffers (sample sums,
//! the G-buffer, the film) are written for the first time in pass 0, where every fresh 4 KiB
//! page costs a kernel fault: at preview sizes those faults cost as much as the first pass's
//! arithmetic, and 512 times fewer of them with huge pages. Linux hands out transparent huge
//! pages to ranges marked with `madvise(MADV_HUGEPAGE)` (the default policy on many systems is
//! "madvise", which gives them to no one else), and Embree marks its BVH memory the same way.
//! The advice must come before the pages are first written.
use rayon::prelude::*;

/// Arrays smaller than this stay as they are (a few huge pages at most would be gained).
const MIN_BYTES: usize = 4 << 20;

/// `v` moved into memory advised to use huge pages (on Linux, when it is large enough).
pub fn advise<T: Copy>(v: Vec<T>) -> Vec<T> {
    let bytes = std::mem::size_of_val(v.as_slice());
    if !cfg!(target_os = "linux") || bytes < MIN_BYTES {
        return v;
    }
    let mut out: Vec<T> = Vec::with_capacity(v.len());
    mark(out.as_ptr() as usize, bytes);
    out.extend_from_slice(&v);
    out
}

/// `n` copies of `value` in memory advised to use huge pages (when large enough), written by
/// the rayon pool's threads so that the first-touch cost is shared.
pub fn filled<T: Clone + Send + Sync>(n: usize, value: T) -> Vec<T> {
    let mut out = reserved(n);
    out.par_extend(rayon::iter::repeat_n(value, n));
    out
}

/// The items of `iter` collected in parallel into memory advised to use huge pages (when large
/// enough): for the large per-pixel arrays a frame builds from scratch.
pub fn collected<I>(iter: I) -> Vec<I::Item>
where
    I: IndexedParallelIterator,
    I::Item: Send,
{
    let mut out = reserved(iter.len());
    // Writes into the capacity reserved (rayon reallocates only a smaller vector).
    iter.collect_into_vec(&mut out);
    out
}

/// An empty vector with room for `n` items, advised to use huge pages when large enough; the
/// advice must come before the first write.
fn reserved<T>(n: usize) -> Vec<T> {
    let out: Vec<T> = Vec::with_capacity(n);
    let bytes = n * std::mem::size_of::<T>();
    if cfg!(target_os = "linux") && bytes >= MIN_BYTES {
        mark(out.as_ptr() as usize, bytes);
    }
    out
}

#[cfg(target_os = "linux")]
fn mark(start: usize, bytes: usize) {
    const HUGE: usize = 2 << 20;
    // The whole 2 MiB pages inside the allocation.
    let (lo, hi) = (start.div_ceil(HUGE) * HUGE, (start + bytes) / HUGE * HUGE);
    if hi > lo {
        // SAFETY: [lo, hi) lies inside an allocation this process owns and has not yet written;
        // MADV_HUGEPAGE is advice about how to back it and changes no contents. Failure (a
        // kernel without THP) leaves ordinary pages, so the result is ignored.
        unsafe {
            libc::madvise(lo as *mut libc::c_void, hi - lo, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn mark(_start: usize, _bytes: usize) {}

#[cfg(test)]
mod tests {
    #[test]
    fn contents_survive_the_move() {
        let big: Vec<u64> = (0..(1u64 << 20)).collect();
        assert_eq!(super::advise(big.clone()), big);
        let small = vec![1.5f32; 10];
        assert_eq!(super::advise(small.clone()), small);
    }

    #[test]
    fn collected_holds_the_items_in_order_in_the_reserved_memory() {
        use rayon::prelude::*;
        for n in [0usize, 1, 1000, 3 << 20] {
            let v = super::collected((0..n).into_par_iter().map(|i| i as u32 * 3));
            assert_eq!(v.len(), n);
            assert!(v.iter().enumerate().all(|(i, &x)| x == i as u32 * 3));
            assert_eq!(v.capacity(), n, "no reallocation");
        }
    }

    #[test]
    fn filled_holds_n_copies_at_every_size() {
        for n in [0usize, 1, 1000, 3 << 20] {
            let v = super::filled(n, [7u32, 9]);
            assert_eq!(v.len(), n);
            assert!(v.iter().all(|&x| x == [7, 9]));
        }
    }
}
