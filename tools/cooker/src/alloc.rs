//! The cooker's heap: glibc's allocator, set up for a short process that builds large
//! temporaries, frees them and builds more.
//!
//! By default glibc maps every block from 128 KiB up on its own and unmaps it when freed, so
//! each large temporary of the mesh pipeline (per-corner ids, weights, the vertex buffers) was
//! page-faulted and zeroed afresh, in 4 KiB pages. Here blocks up to 32 MiB come from one heap
//! that is not trimmed while the cook runs (only once, before the pack is assembled: see
//! [`release_free`]), so freed memory is reused, and the heap asks for transparent huge pages
//! (one fault per 2 MiB). One arena serves every thread: the worker threads allocate little,
//! and a second arena would touch memory of its own.
//!
//! Huge pages make a large cook's time depend on the machine: where free memory is
//! fragmented the kernel compacts it at the fault (the 819k-triangle grid took 338–558 ms,
//! system time 0.04–0.24 s). Advising only the first 64 MiB was steady there, at 425–450 ms,
//! but its median over interleaved runs was slower (the 1M grid 549 against 394–467 ms), so
//! the whole heap is advised.
//!
//! Measured against mimalloc, which the cooker linked before (it reused little of what it
//! freed: the bunny's cook allocated 47 MB in all with 15 MB live at most, and touched 82 MB
//! in huge pages), in docs/performance.md.

const HUGE_PAGE: usize = 2 << 20;
/// The heap's first size: what a 1M-triangle mesh's cook allocates at most.
const INITIAL: usize = 512 << 20;

/// Call first thing in `main`, before any thread starts.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub fn tune() {
    // SAFETY: mallopt only changes allocator parameters; sbrk(0) reads the break; the block
    // is freed once, right after; madvise only advises on the heap's own pages.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, 1);
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
        // Grow the heap now by INITIAL (address space only: pages are touched as the cook
        // uses them), so the advice covers where the cook allocates; later growth, which only
        // very large meshes need, is in steps of 64 MiB.
        libc::mallopt(libc::M_TOP_PAD, INITIAL as libc::c_int);
        let start = libc::sbrk(0) as usize;
        // black_box: the compiler would drop an unused malloc and free pair.
        let block = std::hint::black_box(libc::malloc(1 << 20));
        libc::free(block);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
        let end = libc::sbrk(0) as usize;
        let from = start.next_multiple_of(HUGE_PAGE);
        if end > from {
            libc::madvise(from as *mut libc::c_void, end - from, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub fn tune() {}

/// Gives the pages of the heap's free blocks back to the system. The heap is never trimmed
/// while a cook runs (see above), so its resident size is the most it ever held, and a
/// large block asked for later that fits no freed block lands above all of it: the pack's
/// bytes, assembled last, took the 1M-triangle grid's peak RSS from 80 to 102 MB in most
/// runs. Called once the cook's temporaries are gone, that block reuses pages the trim gave
/// back instead. Only where more than [`TRIM_ABOVE`] is resident but free: a page given back
/// is zeroed again when touched, and trimming the 100k grid's few free MB cost it 3 ms.
///
/// Resident but free, not free below the heap's top: what a cook freed last (its vertex
/// cache step's tables) is part of the top block, and the 1M grid's free blocks below it
/// were 18 MB in some runs and 35 in others, as the threads' blocks fell; untrimmed, its
/// pack's bytes then took its peak from 75 to 81 MB.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub fn release_free() {
    // SAFETY: mallinfo2 reads the allocator's counters.
    let info = unsafe { libc::mallinfo2() };
    let live = info.uordblks + info.hblkhd;
    if resident().is_some_and(|r| r.saturating_sub(live) > TRIM_ABOVE) {
        // SAFETY: malloc_trim only returns pages of free heap blocks to the system.
        unsafe {
            libc::malloc_trim(0);
        }
    }
}

/// The process's resident bytes, from `/proc/self/statm` (its second field, in pages).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn resident() -> Option<usize> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: usize = statm.split_whitespace().nth(1)?.parse().ok()?;
    // SAFETY: sysconf only reads a system constant.
    let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    Some(pages * usize::try_from(page).ok()?)
}

/// Resident but free heap bytes worth giving back before the pack is assembled.
const TRIM_ABOVE: usize = 32 << 20;

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub fn release_free() {}
