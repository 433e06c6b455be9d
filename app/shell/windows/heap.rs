//! The heap of a kiosk that runs for months. glibc's allocator raises its mmap threshold each
//! time a large block is freed (up to 32 MB) and gives every thread that allocates its own arena;
//! the renderer's large buffers, renewed at every visitor reset, and the software rasteriser's
//! worker threads then fragment the heap, and resident memory climbs in steps: in a 24-hour soak
//! (docs/performance.md, Soak) it grew 44 % after the warm-up. A fixed threshold of 256 kB (large
//! blocks are mapped and go back to the system when freed) and two arenas keep it flat. Set once
//! at the start of the windows' loop; `ISOKIOSK_HEAP=default` leaves glibc's defaults (to measure
//! the difference side by side). After each renewal of the GPU device ([`super::graphics`]) the
//! heap's free pages are given back ([`trim`]). Other C libraries: nothing to do.

/// Applies the kiosk's heap settings (see the module's doc); returns whether they were applied.
pub fn settle() -> bool {
    if std::env::var_os("ISOKIOSK_HEAP").is_some_and(|v| v == "default") {
        tracing::info!("heap: glibc's defaults (ISOKIOSK_HEAP=default)");
        return false;
    }
    apply()
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[expect(unsafe_code, reason = "mallopt is a C call; it only changes two of the allocator's tunables")]
fn apply() -> bool {
    // SAFETY: mallopt takes plain integers and may be called at any time; the allocator applies
    // the thresholds to later allocations.
    let threshold = unsafe { libc::mallopt(libc::M_MMAP_THRESHOLD, 256 * 1024) };
    let arenas = unsafe { libc::mallopt(libc::M_ARENA_MAX, 2) };
    tracing::info!("heap: mmap threshold 256 kB ({threshold}), 2 arenas ({arenas})");
    threshold == 1 && arenas == 1
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn apply() -> bool {
    false
}

/// Gives the heap's free pages back to the system (after the GPU device was renewed, when most
/// of the heap was just freed); returns whether any were. Other C libraries: nothing to do.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[expect(unsafe_code, reason = "malloc_trim is a C call; it only releases free memory")]
pub fn trim() -> bool {
    // SAFETY: malloc_trim takes a plain integer and may be called at any time.
    unsafe { libc::malloc_trim(0) == 1 }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub fn trim() -> bool {
    false
}

/// Bytes the program holds in the heap (allocated, not free), in kB: beside the resident size, it
/// tells a leak (this grows) from fragmentation (only the resident size does). `None` off glibc.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
#[expect(unsafe_code, reason = "mallinfo2 is a C call; it only reads the allocator's counters")]
pub fn in_use_kb() -> Option<u64> {
    // SAFETY: mallinfo2 takes nothing and returns a plain struct of counters.
    let m = unsafe { libc::mallinfo2() };
    Some(((m.uordblks + m.hblkhd) / 1024) as u64)
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub fn in_use_kb() -> Option<u64> {
    None
}

#[cfg(test)]
mod tests {
    #[test]
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    fn glibc_takes_the_kiosks_heap_settings() {
        assert!(super::apply(), "mallopt refused the threshold or the arena count");
    }
}
