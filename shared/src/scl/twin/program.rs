//! The queue, the stored segments and the program flow: `QL QS QX QE` load, save and
//! run (`QL` alone loads the host's buffered commands until `QS` or `QE`, HCR p. 216;
//! every `QS` is a write to the segment's non-volatile partition, counted); `QG` goes to a line, `QR` repeats, `QJ` jumps on the condition code, `QC`
//! calls a segment (at most [`MAX_CALL_DEPTH`] deep; a deeper call is ignored, a
//! return without a call too — HCR p. 163) and returns. A `QJ` to its own line or
//! past the end of the queue is ignored (HCR p. 167). The end of the queue ends the
//! program, in a called segment too (HCR p. 309: a program stops at a blank line).

use super::drive::{Drive, Step};
use crate::scl::command::{Command, Segment};

/// How deep `QC` calls nest (HCR p. 163).
pub const MAX_CALL_DEPTH: usize = 5;

/// A caller's place, kept while a called segment runs.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Frame {
    /// The stored segment the caller was loaded from: a return loads it again from
    /// memory (HCR p. 210); `None` (a queue loaded from the host) cannot be returned
    /// to.
    segment: Option<Segment>,
    /// Where it goes on: the line after its `QC`.
    return_index: usize,
    /// Its `QR` counters.
    repeats: [Option<i64>; 62],
}

/// A running program: where it is in the queue, its `QR` counters, its calls.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Program {
    /// The index of the next line in the queue (line number − 1).
    index: usize,
    /// Each `QR` line's remaining repeats, set the first time it is reached.
    repeats: [Option<i64>; 62],
    /// The callers, innermost last.
    stack: Vec<Frame>,
}

impl Program {
    fn at(index: usize) -> Self {
        Self {
            index,
            repeats: [None; 62],
            stack: Vec::new(),
        }
    }

    /// The line number it runs next (1-based).
    #[must_use]
    pub fn line(&self) -> usize {
        self.index + 1
    }

    /// How many calls deep it is.
    #[must_use]
    pub fn depth(&self) -> usize {
        self.stack.len()
    }
}

impl Drive {
    /// The running program, if any.
    #[must_use]
    pub fn program(&self) -> Option<&Program> {
        self.program.as_ref()
    }

    /// One line of the running program.
    pub(super) fn program_step(&mut self) {
        let Some(index) = self.program.as_ref().map(|p| p.index) else {
            return;
        };
        let Some(&command) = self.queue.get(index) else {
            // Past the last line: the program ends.
            self.program = None;
            return;
        };
        match self.execute(command) {
            Step::Next => self.goto(index + 1),
            Step::Goto(next) => self.goto(next),
            Step::Again => {}
            Step::Stop => self.program = None,
        }
    }

    fn goto(&mut self, index: usize) {
        if let Some(program) = &mut self.program {
            program.index = index;
        }
    }

    /// A stored segment's lines, or the Blank Q Segment alarm.
    fn load(&mut self, segment: Segment) -> Option<Vec<Command>> {
        if let Some(lines) = self.segment(segment).map(<[Command]>::to_vec) {
            return Some(lines);
        }
        self.blank_segment();
        None
    }

    /// `QL QS QE` (immediate) and `QX` (from the host's buffer): `false` if refused
    /// (nothing stored to load).
    pub(super) fn queue_command(&mut self, command: Command) -> bool {
        match command {
            Command::QueueLoad { segment: None } => {
                // HCR p. 216: from line 1, what follows from the host.
                self.queue.clear();
                self.running_segment = None;
                self.loading = true;
                true
            }
            Command::QueueLoad {
                segment: Some(segment),
            } => match self.segment(segment) {
                Some(lines) => {
                    self.queue = lines.to_vec();
                    self.running_segment = Some(segment);
                    self.loading = false;
                    true
                }
                None => false,
            },
            Command::QueueSave { segment } => {
                self.segments[usize::from(segment.get() - 1)] = Some(self.queue.clone());
                self.count_flash_write(segment);
                self.loading = false;
                true
            }
            Command::QueueExecute { segment } => match self.segment(segment) {
                Some(lines) => {
                    self.queue = lines.to_vec();
                    self.running_segment = Some(segment);
                    self.program = Some(Program::at(0));
                    true
                }
                None => {
                    self.blank_segment();
                    false
                }
            },
            Command::QueueExecuteLoaded => {
                self.loading = false;
                self.program = Some(Program::at(0));
                true
            }
            _ => false,
        }
    }

    /// A flow command met in the running program (`QG QR QJ QC QX`; from the host's
    /// buffer `QG QR QJ QC` were refused).
    pub(super) fn flow(&mut self, command: Command) -> Step {
        if self.program.is_none() {
            return Step::Next;
        }
        match command {
            Command::QueueGoto { line } => Step::Goto(usize::from(line.get()) - 1),
            Command::QueueJump { condition, line } => {
                let to = usize::from(line.get()) - 1;
                let here = self.program.as_ref().map(|p| p.index);
                // HCR p. 167: a jump to its own line or past the end of the queue is
                // ignored.
                if self.condition.meets(condition) && Some(to) != here && to < self.queue.len() {
                    Step::Goto(to)
                } else {
                    Step::Next
                }
            }
            Command::QueueRepeat {
                count_register,
                line,
            } => {
                let count = i64::from(self.register(count_register));
                let Some(program) = &mut self.program else {
                    return Step::Stop;
                };
                let slot = program.repeats.get_mut(program.index);
                let Some(slot) = slot else {
                    return Step::Next;
                };
                // The register holds how many times the lines run in all: the first
                // pass is done when QR is first met.
                let remaining = slot.unwrap_or(count - 1);
                if remaining > 0 {
                    *slot = Some(remaining - 1);
                    Step::Goto(usize::from(line.get()) - 1)
                } else {
                    *slot = None;
                    Step::Next
                }
            }
            Command::QueueCall {
                segment: Some(segment),
            } => {
                if self.program.as_ref().map_or(0, Program::depth) >= MAX_CALL_DEPTH {
                    // HCR p. 163: a call beyond five deep is ignored.
                    return Step::Next;
                }
                let Some(lines) = self.load(segment) else {
                    return Step::Stop;
                };
                self.queue = lines;
                let caller = self.running_segment.replace(segment);
                if let Some(program) = &mut self.program {
                    program.stack.push(Frame {
                        segment: caller,
                        return_index: program.index + 1,
                        repeats: std::mem::replace(&mut program.repeats, [None; 62]),
                    });
                }
                Step::Goto(0)
            }
            Command::QueueCall { segment: None } => {
                let Some(program) = &mut self.program else {
                    return Step::Stop;
                };
                match program.stack.pop() {
                    Some(frame) => {
                        program.repeats = frame.repeats;
                        let Some(lines) = frame.segment.and_then(|segment| self.load(segment))
                        else {
                            // Our choice (HCR silent): a caller not stored cannot be
                            // loaded again — the Blank Q Segment alarm.
                            if frame.segment.is_none() {
                                self.blank_segment();
                            }
                            return Step::Stop;
                        };
                        self.running_segment = frame.segment;
                        self.queue = lines;
                        Step::Goto(frame.return_index)
                    }
                    // HCR p. 163: a return without a call is ignored.
                    None => Step::Next,
                }
            }
            Command::QueueExecute { segment } => match self.load(segment) {
                Some(lines) => {
                    self.queue = lines;
                    self.running_segment = Some(segment);
                    self.program = Some(Program::at(0));
                    Step::Goto(0)
                }
                None => Step::Stop,
            },
            _ => Step::Next,
        }
    }
}
