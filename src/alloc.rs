//! A global allocator that asks Linux for transparent huge pages on large buffers.
//!
//! Whole-image jobs touch a few large buffers once: the file's bytes, the decoded samples,
//! the inverse map's positions, the output samples and the encoded file. With the kernel's
//! usual setting (`/sys/kernel/mm/transparent_hugepage/enabled` = `madvise`), each 4 KiB page
//! of such a buffer costs a page fault on first touch, which is about 15 % of a 4096^2 warp
//! (issue 18's profile). [`HugePages`] wraps the system allocator and, for every allocation
//! of at least [`HUGE_MIN_BYTES`], advises the kernel to back the 2 MiB-aligned interior of
//! the block with huge pages (`madvise(MADV_HUGEPAGE)`): one fault per 2 MiB instead of per
//! 4 KiB. Measured on `benches/remap_compare.py` (4096^2, whole process), the same effect
//! as the kernel setting `always`: RGB8 56-61 -> 80 MP/s, gray16 87-91 -> 111 MP/s, gray8
//! 112-124 -> 129 MP/s.
//!
//! The advice changes only how the kernel backs the pages, never their contents, and it is
//! best effort: where the kernel refuses it (THP disabled, not Linux) nothing changes. The
//! `trimorph` binary installs it (`src/main.rs`), and so does the Python extension (for its
//! own buffers; numpy's arrays keep Python's allocator); a program using the library can too:
//!
//! ```
//! #[global_allocator]
//! static ALLOC: trimorph::alloc::HugePages = trimorph::alloc::HugePages;
//!
//! fn main() {
//!     let v = vec![7u8; 8 << 20];
//!     assert!(v.iter().all(|&x| x == 7));
//! }
//! ```

use std::alloc::{GlobalAlloc, Layout, System};

/// Smallest allocation advised to use huge pages: 4 MiB (at least one whole aligned 2 MiB
/// page inside; smaller blocks come from the allocator's arenas, shared with other data).
pub const HUGE_MIN_BYTES: usize = 4 << 20;

/// The huge page size the advice is aligned to (x86-64 and aarch64 with 4 KiB pages).
pub const HUGE_PAGE: usize = 2 << 20;

/// The system allocator, with the huge-page advice for large blocks (module docs).
#[derive(Clone, Copy, Debug, Default)]
pub struct HugePages;

/// The 2 MiB-aligned interior `[start, end)` of the block `[ptr, ptr + size)`, if any.
pub fn aligned_interior(ptr: usize, size: usize) -> Option<(usize, usize)> {
    let start = ptr.checked_add(HUGE_PAGE - 1)? & !(HUGE_PAGE - 1);
    let end = ptr.checked_add(size)? & !(HUGE_PAGE - 1);
    (start < end).then_some((start, end))
}

/// Advises huge pages for the aligned interior of a block just allocated (best effort).
fn advise(ptr: *mut u8, size: usize) {
    if size < HUGE_MIN_BYTES || ptr.is_null() {
        return;
    }
    #[cfg(target_os = "linux")]
    if let Some((start, end)) = aligned_interior(ptr as usize, size) {
        // SAFETY: `[start, end)` lies inside the block `[ptr, ptr + size)` that the system
        // allocator has just handed out to us (start >= ptr and end <= ptr + size by
        // construction), so it is mapped memory of this process that nobody else frees
        // meanwhile. MADV_HUGEPAGE only marks the range as eligible for transparent huge
        // pages: it reads or writes no byte and keeps every byte's value, so the block's
        // contents and its owner's view of them are unchanged. Errors (EINVAL where THP is
        // off) are ignored: the advice is optional.
        unsafe {
            let _ = rustix::mm::madvise(
                start as *mut std::ffi::c_void,
                end - start,
                rustix::mm::Advice::LinuxHugepage,
            );
        }
    }
}

// SAFETY: every method delegates to `System` with the same arguments and returns its result
// unchanged, so `HugePages` upholds `GlobalAlloc`'s contract exactly as `System` does; the
// extra `advise` call neither allocates nor touches the block's bytes (see `advise`).
unsafe impl GlobalAlloc for HugePages {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract for `alloc` is passed on unchanged.
        let p = unsafe { System.alloc(layout) };
        advise(p, layout.size());
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as for `alloc`.
        let p = unsafe { System.alloc_zeroed(layout) };
        advise(p, layout.size());
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract for `dealloc` is passed on unchanged.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller's contract for `realloc` is passed on unchanged.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        advise(p, new_size);
        p
    }
}

/// Extra bytes glibc's heap asks the kernel for each time it grows (`M_TOP_PAD`): 16 MiB.
pub const HEAP_TOP_PAD: usize = 16 << 20;

/// Drops `value` on one of rayon's workers instead of the calling thread: freeing a large
/// structure of many small allocations (a fit's objective, an exact spline's fractions) takes
/// a few milliseconds that need not delay the caller. The value is freed as soon as a worker
/// is free; if the process exits first, the operating system reclaims it.
pub fn drop_in_background<T: Send + 'static>(value: T) {
    rayon::spawn(move || drop(value));
}

/// Lets the process's main heap grow in [`HEAP_TOP_PAD`] steps (glibc's default pad is
/// 128 KiB), so that a job that allocates and frees many medium blocks (an exact solve's
/// thousands of big integers) does not move the heap's top back and forth, each move a
/// system call and fresh zeroed pages. Only address space is reserved: a page still costs
/// memory when it is first written, and glibc still trims the top when more than its trim
/// threshold lies free. Measured on `trimorph solve` of the 400 x 800 benchmark (issue 24),
/// best of 40: 29.6 -> 28.4 ms for the whole process. Does nothing where the C library is
/// not glibc. The `trimorph` binary calls it first thing (`src/main.rs`).
pub fn tune_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets one of glibc's allocator parameters; it takes no pointer,
    // and `M_TOP_PAD` accepts any non-negative size. It returns 0 on failure, which leaves
    // the default in place (the tuning is optional).
    unsafe {
        let _ = libc::mallopt(libc::M_TOP_PAD, HEAP_TOP_PAD as libc::c_int);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_dropped_in_the_background_is_dropped() {
        struct Signal(std::sync::mpsc::Sender<&'static str>);
        impl Drop for Signal {
            fn drop(&mut self) {
                let _ = self.0.send("dropped");
            }
        }
        let (tx, rx) = std::sync::mpsc::channel();
        drop_in_background((Signal(tx), vec![0u8; 1 << 20]));
        let got = rx.recv_timeout(std::time::Duration::from_secs(30));
        assert_eq!(got, Ok("dropped"));
    }

    #[test]
    fn heap_tuning_keeps_allocations_working() {
        tune_heap();
        let v: Vec<Vec<u64>> = (0..1000).map(|i| vec![i; 100 + i as usize]).collect();
        assert!(v.iter().enumerate().all(|(i, x)| x.len() == 100 + i && x[0] == i as u64));
    }

    #[test]
    fn the_aligned_interior_lies_inside_the_block() {
        let m = HUGE_PAGE;
        assert_eq!(aligned_interior(m, 2 * m), Some((m, 3 * m)));
        assert_eq!(aligned_interior(m + 1, 3 * m), Some((2 * m, 4 * m)));
        assert_eq!(aligned_interior(m + 1, m), None);
        assert_eq!(aligned_interior(usize::MAX - 10, 100), None);
        for (p, s) in [(4096usize, 5 << 20), (3 * m - 7, 9 << 20), (12345, 4 << 20)] {
            let (a, b) = aligned_interior(p, s).unwrap();
            assert!(a >= p && b <= p + s && a % m == 0 && b % m == 0 && a < b);
        }
    }

    /// Through the allocator directly: values kept through `realloc`, zeroed blocks zero,
    /// and (on Linux with THP available) the kernel marks the block's range `hg`.
    #[test]
    fn large_blocks_keep_their_contents_and_are_marked_for_huge_pages() {
        let a = HugePages;
        let n = 8 << 20;
        let layout = Layout::from_size_align(n, 64).unwrap();
        // SAFETY: a non-zero-size layout; the block is written and read within its size,
        // reallocated with the same alignment, and freed once with its final layout.
        unsafe {
            let p = a.alloc_zeroed(layout);
            assert!(!p.is_null());
            let s = std::slice::from_raw_parts_mut(p, n);
            assert!(s.iter().all(|&x| x == 0));
            for (i, x) in s.iter_mut().enumerate() {
                *x = (i % 251) as u8;
            }
            #[cfg(target_os = "linux")]
            {
                let thp = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled")
                    .unwrap_or_default();
                if thp.contains("[madvise]") || thp.contains("[always]") {
                    let smaps = std::fs::read_to_string("/proc/self/smaps").unwrap();
                    let addr = p as usize + HUGE_PAGE;
                    assert!(vm_flags_of(&smaps, addr).contains(" hg"), "no hg flag at {addr:x}");
                }
            }
            let q = a.realloc(p, layout, 2 * n);
            assert!(!q.is_null());
            let s = std::slice::from_raw_parts(q, n);
            assert!(s.iter().enumerate().all(|(i, &x)| x == (i % 251) as u8));
            a.dealloc(q, Layout::from_size_align(2 * n, 64).unwrap());
        }
    }

    /// The `VmFlags` line of the mapping of `/proc/self/smaps` that contains `addr`.
    #[cfg(target_os = "linux")]
    fn vm_flags_of(smaps: &str, addr: usize) -> String {
        let mut inside = false;
        for line in smaps.lines() {
            let head = line.split_whitespace().next().unwrap_or("");
            if let Some((lo, hi)) = head.split_once('-') {
                if let (Ok(lo), Ok(hi)) =
                    (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16))
                {
                    inside = lo <= addr && addr < hi;
                    continue;
                }
            }
            if inside && line.starts_with("VmFlags:") {
                return line.to_string();
            }
        }
        String::new()
    }
}
