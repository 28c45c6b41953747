//! The e-stop latch: one generation counter that every link's writer and the playback
//! task read, and the one path that presses it ([`press`]).
//!
//! Pressing the e-stop increments the generation and wakes every link's writer thread;
//! that is all it does — two atomic operations and a thread unpark per link, no lock,
//! no await, no task or `spawn_blocking` slot, so nothing a writer, a status reader or a
//! slow client does can hold it up. Each writer notices the new generation before its
//! next instruction, drops everything queued, and writes its gateway's stop first.
//!
//! MBOX boxes are not on a link: [`crate::playback::Playback::estop`] wakes their
//! sender ([`crate::mbox::MboxNet::wake`]) right after pressing, in the same way — no
//! lock, no await — and the sender writes the boxes' e-stop register before any frame.
//!
//! The latch stays set until a Start, Reset or Home issued *after* the e-stop is
//! accepted ([`Latch::release`] with the generation that request saw). While it is set,
//! the writers let only inert instructions through (queries, station selections, motor
//! off: [`Instruction::is_inert`](floatball_shared::ascii::Instruction::is_inert)), and
//! every batch or request issued before the e-stop — a Start still being planned, a
//! batch the player queued a moment earlier, a console line — carries an older
//! generation and is void.

use std::sync::atomic::{AtomicU64, Ordering};

use crate::link::Link;

/// The e-stop generation and the last generation released by a Start, Reset or Home.
#[derive(Debug, Default)]
pub struct Latch {
    generation: AtomicU64,
    released: AtomicU64,
}

impl Latch {
    /// A latch never pressed.
    pub fn new() -> Self {
        Self::default()
    }

    /// How many times the e-stop was pressed: requests and batches are tagged with it
    /// when they are issued, and are void once it has moved on.
    pub fn generation(&self) -> u64 {
        self.generation.load(Ordering::Acquire)
    }

    /// Whether an e-stop is in force: pressed, and no Start, Reset or Home issued after
    /// it was accepted since.
    pub fn is_latched(&self) -> bool {
        self.released.load(Ordering::Acquire) < self.generation.load(Ordering::Acquire)
    }

    /// Presses the latch; returns the new generation. Use [`press`], which also wakes
    /// the links.
    fn trip(&self) -> u64 {
        self.generation.fetch_add(1, Ordering::AcqRel) + 1
    }

    /// Releases the latch for a request issued at `generation`; returns whether that
    /// request is still current (no e-stop came after it). A stale release changes
    /// nothing: the latch stays set for the newer e-stop.
    pub fn release(&self, generation: u64) -> bool {
        if generation != self.generation() {
            return false;
        }
        self.released.fetch_max(generation, Ordering::AcqRel);
        generation == self.generation()
    }
}

/// The e-stop: presses `latch` and wakes the writer of every link in `links` (which
/// must share `latch`), so each writes its stop ahead of everything and drops what was
/// queued. Returns the gateways the stop cannot reach now (link not up), each with the
/// reason; they get the stop as soon as they are back, before anything else.
pub fn press(latch: &Latch, links: &[Link]) -> Vec<String> {
    latch.trip();
    for link in links {
        link.wake();
    }
    links
        .iter()
        .filter(|link| !link.is_up())
        .map(|link| {
            format!(
                "gateway {} ({}) is not connected",
                link.index(),
                link.port()
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_release_only_holds_for_the_current_generation() {
        let latch = Latch::new();
        assert!(!latch.is_latched());
        let issued = latch.generation();
        let pressed = latch.trip();
        assert!(latch.is_latched());
        assert!(
            !latch.release(issued),
            "a Start issued before the e-stop is void"
        );
        assert!(latch.is_latched());
        assert!(latch.release(pressed));
        assert!(!latch.is_latched());
        latch.trip();
        assert!(latch.is_latched());
    }
}
