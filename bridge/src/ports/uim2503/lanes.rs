//! The two write lanes of a link: **priority** (the synchronised start, the stop)
//! before **bulk** (everything else), one instruction at a time.
//!
//! [`Queues`] is plain logic owned by the link's writer thread alone (no lock): which
//! instruction goes next, and the station selection the gateway is left with. The
//! gateway's `*N;` selection is state: an e-stop `*0;MO=0;` written in the middle of a
//! bulk batch leaves the gateway addressing every unit, so before the next bulk
//! instruction the bulk lane's own selection is written again.

use std::collections::VecDeque;

use floatball_shared::uim2503::ascii::Batch;

/// One lane: instruction bytes back to back, and each instruction's length.
#[derive(Debug, Default)]
struct Lane {
    bytes: VecDeque<u8>,
    lens: VecDeque<u8>,
}

impl Lane {
    /// Queues the instructions of `batch` that `keep` accepts; returns the bytes of
    /// those it refused.
    fn push(&mut self, batch: &Batch, keep: impl Fn(&[u8]) -> bool) -> usize {
        let mut refused = 0;
        for instruction in batch.instructions() {
            if !keep(instruction) {
                refused += instruction.len();
                continue;
            }
            self.bytes.extend(instruction);
            self.lens
                .push_back(u8::try_from(instruction.len()).unwrap_or(u8::MAX));
        }
        refused
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

/// Where the instruction [`Queues::pop_into`] gave came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Popped {
    /// The priority lane.
    Priority,
    /// The bulk lane's selection, written again after a priority selection (not a
    /// queued instruction itself).
    Reselection,
    /// The bulk lane.
    Bulk,
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
    /// Queues with room for `bytes` of priority instructions already made: a start or
    /// a stop queued later allocates nothing (the synchronised start is queued on every
    /// line in one pass).
    pub fn with_priority_room(bytes: usize) -> Self {
        let mut queues = Self::default();
        queues.priority.bytes.reserve(bytes);
        queues.priority.lens.reserve(bytes);
        queues
    }

    /// Queues `batch` on the bulk lane.
    pub fn push_bulk(&mut self, batch: &Batch) {
        self.bulk.push(batch, |_| true);
    }

    /// Queues the instructions of `batch` that `keep` accepts on the bulk lane; returns
    /// the bytes of those it refused.
    pub fn push_bulk_filtered(&mut self, batch: &Batch, keep: impl Fn(&[u8]) -> bool) -> usize {
        self.bulk.push(batch, keep)
    }

    /// Queues `batch` on the priority lane.
    pub fn push_priority(&mut self, batch: &Batch) {
        self.priority.push(batch, |_| true);
    }

    /// Queues the instructions of `batch` that `keep` accepts on the priority lane;
    /// returns the bytes of those it refused.
    pub fn push_priority_filtered(&mut self, batch: &Batch, keep: impl Fn(&[u8]) -> bool) -> usize {
        self.priority.push(batch, keep)
    }

    /// Drops every queued bulk instruction; returns how many bytes were dropped.
    pub fn clear_bulk(&mut self) -> usize {
        let dropped = self.bulk.bytes.len();
        self.bulk.clear();
        dropped
    }

    /// Drops every queued priority instruction.
    pub fn clear_priority(&mut self) {
        self.priority.clear();
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

    /// Whether the instruction [`Queues::pop_into`] would write next is the priority
    /// lane's.
    pub fn next_is_priority(&self) -> bool {
        !self.priority.is_empty()
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
    /// Returns where it came from, or `None` when both lanes are empty.
    pub fn pop_into(&mut self, out: &mut Vec<u8>) -> Option<Popped> {
        out.clear();
        if self.priority.pop_into(out) {
            if is_selection(out) {
                self.reselect = true;
            }
            return Some(Popped::Priority);
        }
        if self.bulk.is_empty() {
            return None;
        }
        let next_is_selection = self.bulk.bytes.front() == Some(&b'*');
        if self.reselect && !next_is_selection {
            self.reselect = false;
            if let Some(selection) = &self.bulk_selection {
                out.extend_from_slice(selection);
                return Some(Popped::Reselection);
            }
        }
        self.bulk.pop_into(out);
        if is_selection(out) {
            self.bulk_selection = Some(out.clone());
            self.reselect = false;
        }
        Some(Popped::Bulk)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use floatball_shared::uim2503::ascii::{Form, parse_script};

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
    fn a_filter_keeps_only_what_it_accepts() {
        let mut queues = Queues::default();
        let refused =
            queues.push_bulk_filtered(&batch("*5;PA=100;PA;BG;"), |i| i == b"PA;" || i == b"*5;");
        assert_eq!(refused, "PA=100;BG;".len());
        assert_eq!(drain(&mut queues), ["*5;", "PA;"]);
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
