//! The system allocator, with its large blocks backed by transparent huge pages where the
//! system offers them.
//!
//! A build fills hundreds of megabytes of fresh memory (the vertices of a mesh, the regions'
//! samples, the nodes), and on these machines touching a fresh 4 KiB page is costly: the 31 MB
//! that the dragon's vertices and triangles take cost 22–29 ms of page faults on the reading
//! thread, against 9–15 ms with 2 MiB pages. With transparent huge pages in `madvise` mode (the
//! Debian default), a block gets them only when asked for ([`libc::madvise`] with
//! `MADV_HUGEPAGE`), which this allocator does for every block of at least [`LARGE`] bytes: its
//! contents are untouched, only the size of the pages that will back it changes. Elsewhere
//! (another system, huge pages off) the advice is refused or ignored, and nothing else changes.
//!
//! A binary opts in with `#[global_allocator] static ALLOC: HugePages = HugePages;`.

use std::alloc::{GlobalAlloc, Layout, System};

/// The system allocator, asking for huge pages for blocks of at least [`LARGE`] bytes.
#[derive(Clone, Copy, Debug, Default)]
pub struct HugePages;

/// The size of a transparent huge page on x86-64 and most arm64 systems.
const HUGE: usize = 2 << 20;

/// Blocks at least this large get huge pages (for the whole 2 MiB pages inside them): smaller
/// ones would waste memory on their partly used pages.
pub const LARGE: usize = 4 << 20;

/// Asks for huge pages for the whole 2 MiB pages within `size` bytes at `ptr`, when `size` is at
/// least [`LARGE`].
#[cfg(target_os = "linux")]
#[allow(unsafe_code)]
fn advise(ptr: *mut u8, size: usize) {
    if let Some((start, end)) = huge_range(ptr as usize, size) {
        // SAFETY: the range lies within a block the system allocator has just handed out to
        // us; `MADV_HUGEPAGE` changes how its pages will be backed, never what they hold, and
        // its failure (huge pages off or not supported) changes nothing.
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise(_: *mut u8, _: usize) {}

/// The whole 2 MiB pages within `size` bytes at address `start`, as an address range, when the
/// block is at least [`LARGE`] bytes.
fn huge_range(start: usize, size: usize) -> Option<(usize, usize)> {
    if size < LARGE {
        return None;
    }
    let first = start.checked_next_multiple_of(HUGE)?;
    let end = start.checked_add(size)? & !(HUGE - 1);
    (end > first).then_some((first, end))
}

// SAFETY: every block comes from and goes back to `System`, with the layouts it was given; the
// advice only changes the page size behind a block.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for HugePages {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: `layout` is the caller's, as `GlobalAlloc::alloc` requires.
        let ptr = unsafe { System.alloc(layout) };
        if !ptr.is_null() {
            advise(ptr, layout.size());
        }
        ptr
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as in `alloc`.
        let ptr = unsafe { System.alloc_zeroed(layout) };
        if !ptr.is_null() {
            advise(ptr, layout.size());
        }
        ptr
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by `System` with `layout` (every block of this allocator is).
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as in `dealloc`, and `new_size` is the caller's, as `GlobalAlloc::realloc`
        // requires.
        let moved = unsafe { System.realloc(ptr, layout, new_size) };
        if !moved.is_null() && new_size > layout.size() {
            advise(moved, new_size);
        }
        moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_pages_are_asked_for_the_whole_2_mib_pages_inside_large_blocks_only() {
        assert_eq!(huge_range(HUGE, LARGE - 1), None, "a small block");
        assert_eq!(huge_range(HUGE, LARGE), Some((HUGE, HUGE + LARGE)), "an aligned block, whole");
        assert_eq!(huge_range(HUGE + 16, LARGE), Some((2 * HUGE, HUGE + LARGE)), "the pages inside");
        assert_eq!(huge_range(HUGE - 16, LARGE + 32), Some((HUGE, HUGE + LARGE)));
        assert_eq!(huge_range(usize::MAX - LARGE + 2, LARGE), None, "no wrap past the end of memory");
        for (start, size) in [(4096, LARGE), (12_345_678, 3 * LARGE + 1), (HUGE * 7 + 1, 5 * LARGE)] {
            let (first, end) = huge_range(start, size).expect("a large block");
            assert!(first >= start && end <= start + size && first % HUGE == 0 && end % HUGE == 0);
            assert!(first - start < HUGE && start + size - end < HUGE, "every whole page");
        }
    }

    #[test]
    fn blocks_small_and_large_hold_what_is_written_through_growth_and_zeroing() {
        let alloc = HugePages;
        for size in [1, 4096, LARGE - 1, LARGE, 3 * LARGE + 12345] {
            let layout = Layout::from_size_align(size, 16).expect("valid layout");
            #[allow(unsafe_code)]
            // SAFETY: each block is used within its size and freed once, with its layout.
            unsafe {
                let zeroed = alloc.alloc_zeroed(layout);
                assert!(!zeroed.is_null(), "{size} bytes");
                let bytes = std::slice::from_raw_parts_mut(zeroed, size);
                assert!(bytes.iter().all(|&b| b == 0), "{size} bytes zeroed");
                for (i, b) in bytes.iter_mut().enumerate() {
                    *b = (i % 251) as u8;
                }
                let grown = alloc.realloc(zeroed, layout, 2 * size + LARGE);
                assert!(!grown.is_null());
                let kept = std::slice::from_raw_parts(grown, size);
                assert!(kept.iter().enumerate().all(|(i, &b)| b == (i % 251) as u8), "{size} bytes kept");
                alloc.dealloc(grown, Layout::from_size_align(2 * size + LARGE, 16).expect("valid layout"));
            }
        }
    }
}
