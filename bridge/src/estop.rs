//! The e-stop latch: one generation counter that every link's writer and the playback
//! task read, and the one path that presses it ([`press`]).
//!
//! Pressing the e-stop increments the generation and wakes every link's writer thread;
//! that is all it does — two atomic operations and a thread unpark per link, no lock,
//! no await, no task or `spawn_blocking` slot, so nothing a writer, a status reader or a
//! slow client does can hold it up. Each writer notices the new generation before its
//! next instruction, drops everything queued, and writes its gateway's stop first.
//!
//! Stops sent as datagrams (MBOX boxes, eSCL drives) are repeated [`REPEATS`] times
//! [`REPEAT_INTERVAL`] apart ([`Repeats`], owned by each sender).
//!
//! Every family's stop goes through [`press`], over its ports ([`StopPort`]): a
//! UIM2503 link's writer writes the gateway's stop; the MBOX boxes' sender
//! ([`crate::ports::mbox::MboxNet`]) writes the boxes' e-stop register before any frame; the
//! owners of the MOONS' drives' links ([`crate::ports::scl::SclNet`]) write `SK` to every
//! drive — each woken the same way, no lock, no await.
//!
//! The latch stays set until a Start, Reset or Home issued *after* the e-stop is
//! accepted ([`Latch::release`] with the generation that request saw). While it is set,
//! the writers let only inert instructions through (queries, station selections, motor
//! off: [`Instruction::is_inert`](floatball_shared::uim2503::ascii::Instruction::is_inert)), and
//! every batch or request issued before the e-stop — a Start still being planned, a
//! batch the player queued a moment earlier, a console line — carries an older
//! generation and is void.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// How many times a stop (or its release) sent as a datagram is sent again after the
/// first: UDP may lose one (MBOX boxes, eSCL drives).
pub const REPEATS: u32 = 3;
/// The time between two repeats of a stop sent as a datagram.
pub const REPEAT_INTERVAL: Duration = Duration::from_millis(10);

/// The repeats of a stop sent as datagrams: what is repeated (`T`: MBOX's register
/// value; `()` for eSCL's `SK`), how often still, and when next. Owned by the sender
/// that writes the stop.
#[derive(Debug, Clone, Copy, Default)]
pub struct Repeats<T = ()> {
    pending: Option<(T, u32, Instant)>,
}

impl<T: Copy> Repeats<T> {
    /// `value` was just sent at `now`: send it [`REPEATS`] times more,
    /// [`REPEAT_INTERVAL`] apart (replacing any repeats still pending).
    pub fn start_with(&mut self, value: T, now: Instant) {
        self.pending = Some((value, REPEATS, now + REPEAT_INTERVAL));
    }

    /// The value to send again now, if a repeat is due at `now`.
    pub fn due_value(&mut self, now: Instant) -> Option<T> {
        let (value, left, at) = self.pending?;
        if now < at {
            return None;
        }
        self.pending = (left > 1).then_some((value, left - 1, now + REPEAT_INTERVAL));
        Some(value)
    }

    /// When the next repeat is due, if one is.
    pub fn next(&self) -> Option<Instant> {
        self.pending.map(|(_, _, at)| at)
    }

    /// The value being repeated, if any.
    pub fn value(&self) -> Option<T> {
        self.pending.map(|(value, _, _)| value)
    }
}

impl Repeats<()> {
    /// The stop was just sent at `now`: repeat it.
    pub fn start(&mut self, now: Instant) {
        self.start_with((), now);
    }

    /// Whether a repeat is due at `now` (and counts it as sent).
    pub fn due(&mut self, now: Instant) -> bool {
        self.due_value(now).is_some()
    }
}

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

/// The generation to issue a request at for a source that must never release an
/// e-stop (OSC, the schedule, timecode): `None` while one is latched, or when one is
/// pressed while `own_stop` runs (Reset and Home press their own stop first; a Start
/// presses none). The generation is read before the latch is looked at, so an e-stop
/// pressed after the look makes the request stale ([`Latch::release`] refuses it);
/// an e-stop pressed together with the request's own stop is seen as a second press.
pub fn unreleasing_generation(latch: &Latch, own_stop: Option<&dyn Fn()>) -> Option<u64> {
    let seen = latch.generation();
    if latch.is_latched() {
        return None;
    }
    match own_stop {
        None => Some(seen),
        Some(stop) => {
            stop();
            // Ours is exactly one press: anything more is somebody's e-stop.
            let after = latch.generation();
            (after == seen + 1).then_some(after)
        }
    }
}

/// What the e-stop reaches: a UIM2503 link's writer, the MBOX boxes' sender, the
/// owners of the MOONS' drives' links — each obeying the same latch.
pub trait StopPort {
    /// Wakes the writer(s): each looks at the latch, drops what was queued and writes
    /// its stop ahead of everything. No lock, no await.
    fn wake(&self);
    /// Where the stop cannot be confirmed to reach now, each with the reason.
    fn unreachable(&self) -> Vec<String>;
}

/// The e-stop, the one path for every family: presses `latch` and wakes every port in
/// `ports` (which must obey `latch`), so each writes its stop ahead of everything and
/// drops what was queued. Returns where the stop cannot reach now, each with the
/// reason; those get the stop as soon as they are back, before anything else.
pub fn press(latch: &Latch, ports: &[&dyn StopPort]) -> Vec<String> {
    latch.trip();
    for port in ports {
        port.wake();
    }
    ports.iter().flat_map(|port| port.unreachable()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stop_is_repeated_three_times_ten_ms_apart() {
        let start = Instant::now();
        let mut repeats = Repeats::<u16>::default();
        assert_eq!(repeats.next(), None);
        repeats.start_with(1, start);
        assert_eq!(repeats.due_value(start), None, "not before its interval");
        let mut now = start;
        let mut sent = 0;
        while let Some(at) = repeats.next() {
            now = at;
            assert_eq!(repeats.due_value(now), Some(1));
            sent += 1;
        }
        assert_eq!(sent, REPEATS);
        assert_eq!(now - start, REPEAT_INTERVAL * REPEATS);
        assert_eq!(repeats.value(), None);
    }

    #[test]
    fn an_unreleasing_request_is_refused_while_latched_and_stale_after_a_press() {
        let latch = Latch::new();
        let issued = unreleasing_generation(&latch, None).expect("nothing latched");
        assert_eq!(issued, 0);
        // An e-stop pressed after the look: the request is stale, the latch stays.
        latch.trip();
        assert!(!latch.release(issued));
        assert!(latch.is_latched());
        assert_eq!(unreleasing_generation(&latch, None), None);
        let pressed_by_own_stop = std::cell::Cell::new(false);
        assert_eq!(
            unreleasing_generation(&latch, Some(&|| pressed_by_own_stop.set(true))),
            None,
            "a Reset from OSC or the schedule does not even press its stop while latched"
        );
        assert!(!pressed_by_own_stop.get());
    }

    #[test]
    fn an_e_stop_pressed_with_an_unreleasing_reset_stays_latched() {
        let latch = Latch::new();
        // Reset's own stop, and an operator's e-stop in the same instant.
        let generation = unreleasing_generation(
            &latch,
            Some(&|| {
                latch.trip();
                latch.trip();
            }),
        );
        assert_eq!(generation, None, "the operator's e-stop is not released");
        assert!(latch.is_latched());
        // Alone, its own stop is released by its own acceptance.
        let latch = Latch::new();
        let generation = unreleasing_generation(
            &latch,
            Some(&|| {
                latch.trip();
            }),
        )
        .expect("only its own stop");
        assert!(latch.release(generation));
        assert!(!latch.is_latched());
    }

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
