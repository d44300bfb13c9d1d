//! Test and benchmark helpers for trees, shared by this crate's tests and the agent's
//! (feature `testing`): an action that stays busy, and an allocator that counts.
//!
//! Not for production builds: the allocator is for test binaries that install it as their
//! global allocator, one per binary.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::{Io, StatefulAction, Status};

/// A stateful action that stays Running: the load of the allocation tests and the `bt`
/// benchmark.
pub struct Busy;

impl<C> StatefulAction<C> for Busy {
    fn on_start(&mut self, _: &mut Io<'_>, _: &mut C) -> Status {
        Status::Running
    }
    fn on_running(&mut self, _: &mut Io<'_>, _: &mut C) -> Status {
        Status::Running
    }
    fn on_halted(&mut self, _: &mut Io<'_>, _: &mut C) {}
}

/// A global allocator that counts the allocations made on threads that ask it to (a
/// test binary has one global allocator; it installs this one with
/// `#[global_allocator] static A: CountingAlloc = CountingAlloc;`).
pub struct CountingAlloc;

static ALLOCS: AtomicUsize = AtomicUsize::new(0);
thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

// SAFETY: every call is forwarded unchanged to the system allocator; counting touches
// only an atomic and a thread-local flag, neither of which allocates.
#[allow(unsafe_code, reason = "a global allocator is an unsafe trait")]
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(Cell::get) {
            ALLOCS.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Allocations made on this thread while running `f` (0 unless [`CountingAlloc`] is the
/// binary's global allocator).
pub fn allocations_during(f: impl FnOnce()) -> usize {
    let before = ALLOCS.load(Ordering::Relaxed);
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCS.load(Ordering::Relaxed) - before
}
