//! The two write lanes of a link: **priority** (e-stop) before **bulk** (everything
//! else), one instruction at a time.
//!
//! [`Queues`] is the plain logic: which instruction goes next, and the station selection
//! the gateway is left with. The gateway's `*N;` selection is state: an e-stop
//! `*0;MO=0;` written in the middle of a bulk batch leaves the gateway addressing every
//! unit, so before the next bulk instruction the bulk lane's own selection is written
//! again. [`Lanes`] wraps the queues for the writer thread and the async senders.

use std::collections::VecDeque;
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Duration;

use floatball_shared::ascii::Batch;

/// One lane: instruction bytes back to back, and each instruction's length.
#[derive(Debug, Default)]
struct Lane {
    bytes: VecDeque<u8>,
    lens: VecDeque<u8>,
}

impl Lane {
    fn push(&mut self, batch: &Batch) {
        for instruction in batch.instructions() {
            self.bytes.extend(instruction);
            self.lens
                .push_back(u8::try_from(instruction.len()).unwrap_or(u8::MAX));
        }
    }

    fn pop_into(&mut self, out: &mut Vec<u8>) -> bool {
        let Some(len) = self.lens.pop_front() else {
            return false;
        };
        out.extend(self.bytes.drain(..usize::from(len)));
        true
    }

    fn clear(&mut self) {
        self.bytes.clear();
        self.lens.clear();
    }

    fn is_empty(&self) -> bool {
        self.lens.is_empty()
    }
}

fn is_selection(instruction: &[u8]) -> bool {
    instruction.first() == Some(&b'*')
}

/// The queues of one link and the selection bookkeeping.
#[derive(Debug, Default)]
pub struct Queues {
    priority: Lane,
    bulk: Lane,
    /// The last `*N;` taken from the bulk lane: what bulk instructions are meant for.
    bulk_selection: Option<Vec<u8>>,
    /// A priority instruction changed the gateway's selection since.
    reselect: bool,
}

impl Queues {
    /// Queues `batch` on the bulk lane.
    pub fn push_bulk(&mut self, batch: &Batch) {
        self.bulk.push(batch);
    }

    /// Queues `batch` on the priority lane.
    pub fn push_priority(&mut self, batch: &Batch) {
        self.priority.push(batch);
    }

    /// Drops every queued bulk instruction; returns how many bytes were dropped.
    pub fn clear_bulk(&mut self) -> usize {
        let dropped = self.bulk.bytes.len();
        self.bulk.clear();
        dropped
    }

    /// Drops everything, e.g. when the link is lost: nothing stale is sent later.
    pub fn clear_all(&mut self) {
        self.priority.clear();
        self.bulk.clear();
        self.bulk_selection = None;
        self.reselect = false;
    }

    /// Bytes waiting on the bulk lane.
    pub fn bulk_bytes(&self) -> usize {
        self.bulk.bytes.len()
    }

    /// Whether anything waits to be written.
    pub fn has_work(&self) -> bool {
        !self.priority.is_empty() || !self.bulk.is_empty()
    }

    /// Length of the instruction [`Queues::pop_into`] would write next.
    pub fn next_len(&self) -> Option<usize> {
        if let Some(&len) = self.priority.lens.front() {
            return Some(usize::from(len));
        }
        let &len = self.bulk.lens.front()?;
        let next_is_selection = self.bulk.bytes.front() == Some(&b'*');
        match (&self.bulk_selection, self.reselect && !next_is_selection) {
            (Some(selection), true) => Some(selection.len()),
            _ => Some(usize::from(len)),
        }
    }

    /// Moves the next instruction to write into `out` (cleared first): priority first,
    /// then the bulk lane's selection again if a priority write changed it, then bulk.
    /// Returns whether it came from the bulk lane, or `None` when both lanes are empty.
    pub fn pop_into(&mut self, out: &mut Vec<u8>) -> Option<bool> {
        out.clear();
        if self.priority.pop_into(out) {
            if is_selection(out) {
                self.reselect = true;
            }
            return Some(false);
        }
        if self.bulk.is_empty() {
            return None;
        }
        let next_is_selection = self.bulk.bytes.front() == Some(&b'*');
        if self.reselect && !next_is_selection {
            self.reselect = false;
            if let Some(selection) = &self.bulk_selection {
                out.extend_from_slice(selection);
                return Some(true);
            }
        }
        self.bulk.pop_into(out);
        if is_selection(out) {
            self.bulk_selection = Some(out.clone());
            self.reselect = false;
        }
        Some(true)
    }
}

/// The queues shared between the link's writer thread and its senders.
#[derive(Debug)]
pub struct Lanes {
    queues: Mutex<Queues>,
    /// Wakes the writer: work arrived, or the link is closing.
    work: Condvar,
    /// Wakes senders waiting for room on the bulk lane.
    room: tokio::sync::Notify,
    /// Most bytes the bulk lane holds before senders wait.
    pub capacity_bytes: usize,
}

impl Lanes {
    /// Empty lanes whose bulk lane holds up to `capacity_bytes`.
    pub fn new(capacity_bytes: usize) -> Self {
        Self {
            queues: Mutex::new(Queues::default()),
            work: Condvar::new(),
            room: tokio::sync::Notify::new(),
            capacity_bytes,
        }
    }

    /// The queues, locked. A poisoned lock only means another thread panicked while
    /// holding it; the queues themselves are always consistent, so carry on.
    pub fn lock(&self) -> MutexGuard<'_, Queues> {
        self.queues
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Waits on the writer's condition variable for at most `timeout`.
    pub fn wait<'a>(
        &self,
        guard: MutexGuard<'a, Queues>,
        timeout: Duration,
    ) -> MutexGuard<'a, Queues> {
        match self.work.wait_timeout(guard, timeout) {
            Ok((guard, _)) => guard,
            Err(poisoned) => poisoned.into_inner().0,
        }
    }

    /// Wakes the writer.
    pub fn wake_writer(&self) {
        self.work.notify_all();
    }

    /// Tells waiting senders there may be room now.
    pub fn wake_senders(&self) {
        self.room.notify_waiters();
    }

    /// A future that completes at the next [`Lanes::wake_senders`].
    pub fn room(&self) -> tokio::sync::futures::Notified<'_> {
        self.room.notified()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use floatball_shared::ascii::{Form, parse_script};

    fn batch(script: &str) -> Batch {
        Batch::encode(&parse_script(script).unwrap(), Form::Standard).unwrap()
    }

    fn drain(queues: &mut Queues) -> Vec<String> {
        let mut out = Vec::new();
        let mut written = Vec::new();
        while queues.pop_into(&mut out).is_some() {
            written.push(String::from_utf8(out.clone()).unwrap());
        }
        written
    }

    #[test]
    fn priority_goes_first() {
        let mut queues = Queues::default();
        queues.push_bulk(&batch("*5;PV=0;"));
        queues.push_priority(&batch("*0;MO=0;"));
        assert_eq!(drain(&mut queues), ["*0;", "MO=0;", "*5;", "PV=0;"]);
    }

    #[test]
    fn bulk_selection_is_restored_after_a_priority_selection() {
        let mut queues = Queues::default();
        queues.push_bulk(&batch("*5;QP[3]=1000;QV[3]=0;QT[3]=100;"));
        let mut out = Vec::new();
        queues.pop_into(&mut out);
        queues.pop_into(&mut out);
        assert_eq!(out, b"QP[3]=1000;");
        queues.push_priority(&batch("*0;MO=0;"));
        assert_eq!(
            drain(&mut queues),
            ["*0;", "MO=0;", "*5;", "QV[3]=0;", "QT[3]=100;"]
        );
    }

    #[test]
    fn no_extra_selection_when_bulk_selects_anyway() {
        let mut queues = Queues::default();
        queues.push_bulk(&batch("*5;PV;"));
        let mut out = Vec::new();
        queues.pop_into(&mut out);
        queues.pop_into(&mut out);
        queues.push_priority(&batch("*0;MO=0;"));
        queues.push_bulk(&batch("*7;PV;"));
        assert_eq!(drain(&mut queues), ["*0;", "MO=0;", "*7;", "PV;"]);
    }

    #[test]
    fn next_len_announces_the_reselection() {
        let mut queues = Queues::default();
        queues.push_bulk(&batch("*12;PV;BG;"));
        let mut out = Vec::new();
        queues.pop_into(&mut out);
        queues.push_priority(&batch("*0;"));
        assert_eq!(queues.next_len(), Some(3));
        queues.pop_into(&mut out);
        assert_eq!(queues.next_len(), Some(4), "the *12; comes back before PV;");
    }

    #[test]
    fn clearing_bulk_keeps_priority() {
        let mut queues = Queues::default();
        queues.push_bulk(&batch("*5;PV=0;BG;"));
        queues.push_priority(&batch("*0;MO=0;"));
        assert_eq!(queues.clear_bulk(), 11);
        assert_eq!(drain(&mut queues), ["*0;", "MO=0;"]);
        assert!(!queues.has_work());
    }
}
