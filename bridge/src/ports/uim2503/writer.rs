//! A link's writer: the one owner of its queues while a line is open.
//!
//! [`Drive`] is the writer's state (the two lanes, the e-stop generation it acted on,
//! pacing, the bytes/s meter, the greetings) and [`Drive::step`] one turn of it: take
//! what the handles handed over, act on a moved e-stop latch (everything queued void,
//! the stop first), keep the link's state by the greetings' answers, and write when the
//! pacer allows. A step never blocks: it says how long its host may wait
//! ([`Step::Wait`]), that the line is done ([`Step::Done`]), or that a line-speed change
//! is due ([`Step::ChangeBaud`], carried out by [`Drive::change_baud`] with the line to
//! itself).
//!
//! Two hosts run steps: [`run_writer`], a thread of its own for one serial or simulated
//! link (one instruction a turn, the thread parked until the pacer allows the next),
//! and the network driver ([`super::driver`]), one thread for every network link, which
//! passes an `ahead` window: it writes whenever the line will be free within that
//! window, gathering consecutive whole instructions into one write of at most
//! [`floatball_shared::uim2503::ascii::MAX_LEN`] bytes (the longest single instruction) or
//! [`CHUNK_TIME`] of line time, whichever is more — so an e-stop waits for at most
//! that write plus the window: at 9,600 baud one instruction's time as before (up to
//! 20.8 ms), at 115,200 baud about 12 ms. Fewer, larger writes are what lets one thread
//! stream to a hundred gateways.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use floatball_shared::api::{BaudChanged, LinkState};
use floatball_shared::uim2503::ascii::gateway::GREETING;
use floatball_shared::uim2503::ascii::{
    Batch, Form, GatewayCommand, Instruction, MAX_LEN, parse_script,
};

use super::lanes::{Popped, Queues};
use super::pacer::{Pacer, RateMeter};
use super::{
    ANSWER_TIMEOUT, BaudError, BaudReply, GREETING_INTERVAL, GREETING_RETRY, Input, LinkError,
    MISSED_GREETINGS, NOT_ANSWERING, Shared,
};

/// Writes to a line (a serial port, a device server's socket, the simulator's input).
pub(super) trait LineWrite {
    /// Hands `bytes` (one instruction, or several whole ones) to the line.
    fn write_instruction(&mut self, bytes: &[u8]) -> std::io::Result<()>;

    /// Switches the line (this end of it) to `baud`.
    fn set_baud(&mut self, baud: u32) -> std::io::Result<()>;

    /// Restarts the gateway, if this line can (the in-process simulator); `false` when
    /// someone else has to (a real gateway is power-cycled by the installer).
    fn restart_gateway(&mut self) -> bool;

    /// Bytes handed over that the line has not taken yet (a non-blocking socket keeps
    /// what the kernel would not take; the writer writes nothing more meanwhile).
    fn backlog(&self) -> usize {
        0
    }

    /// Reads what came in and hands on what was waiting, for a line whose reading and
    /// writing one owner does (a network line); a line with a reader thread of its own
    /// has nothing to do. `Err` when the line is lost.
    fn service(&mut self, _shared: &Shared) -> std::io::Result<()> {
        Ok(())
    }
}

/// What a [`Drive::step`] asks its host to do.
#[derive(Debug, PartialEq, Eq)]
pub(super) enum Step {
    /// Step again after at most this long (at once if zero); the host is woken earlier
    /// by a handle or the e-stop.
    Wait(Duration),
    /// The writer stopped (the link closed, the line lost or a write failed): why.
    Done(String),
    /// A line-speed change is due and the line is idle: the host calls
    /// [`Drive::change_baud`].
    ChangeBaud,
}

/// The line time one write of the network driver may hold (at least one longest
/// instruction): fewer, larger writes on a fast line.
pub(super) const CHUNK_TIME: Duration = Duration::from_millis(10);

/// How long a line is left idle before a held start at least: what the far end's line
/// still carries when the pacer thinks it free (a late read, a device server's own
/// delay) is gone by the instant.
const START_GUARD: Duration = Duration::from_millis(2);

/// Room made ahead for the priority lane (a start, a stop: a few instructions).
const PRIORITY_ROOM_BYTES: usize = 64;

/// How long a line with a backlog is left before it is tried again.
const BACKLOG_RETRY: Duration = Duration::from_millis(1);

/// How often an idle writer wakes up to update the bytes/s figure.
pub(super) const IDLE_TICK: Duration = Duration::from_millis(250);

/// The greeting the writer is waiting to see answered.
struct Greeting {
    /// Answers and frames read before it was sent.
    answers_before: u64,
    frames_before: u64,
    /// When it counts as unanswered.
    deadline: Instant,
}

/// The writer's greetings: when the next is due, the one awaiting its answer, and how
/// many in a row went unanswered.
struct Greeter {
    next_at: Instant,
    pending: Option<Greeting>,
    missed: u32,
}

/// What became of a greeting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Answer {
    /// The gateway answered (the greeting, or with any frame).
    Answered,
    /// [`MISSED_GREETINGS`] deadlines passed in a row.
    Unanswered,
}

impl Greeter {
    /// Greets at once.
    fn now(now: Instant) -> Self {
        Self {
            next_at: now,
            pending: None,
            missed: 0,
        }
    }

    /// Whether a greeting is due at `now` on a line with nothing else to write.
    fn due(&self, now: Instant) -> bool {
        self.pending.is_none() && now >= self.next_at
    }

    /// A greeting went out at `now`; the line is free again after `line_busy`.
    fn sent(&mut self, shared: &Shared, now: Instant, line_busy: Duration) {
        self.pending = Some(Greeting {
            answers_before: shared.greetings_answered.load(Ordering::Acquire),
            frames_before: shared.frames_read.load(Ordering::Acquire),
            deadline: now + line_busy + ANSWER_TIMEOUT,
        });
        shared.awaiting_answer.store(true, Ordering::Release);
    }

    /// Something other than a greeting was written at `now`: the line is not idle.
    fn wrote(&mut self, now: Instant) {
        if self.pending.is_none() {
            self.next_at = self.next_at.max(now + GREETING_INTERVAL);
        }
    }

    /// Whether the pending greeting has been answered or has timed out by `now`.
    fn check(&mut self, shared: &Shared, now: Instant) -> Option<Answer> {
        let pending = self.pending.as_ref()?;
        let answered = shared.greetings_answered.load(Ordering::Acquire) > pending.answers_before
            || shared.frames_read.load(Ordering::Acquire) > pending.frames_before;
        let answer = if answered {
            self.next_at = now + GREETING_INTERVAL;
            self.missed = 0;
            Some(Answer::Answered)
        } else if now >= pending.deadline {
            self.next_at = now + GREETING_RETRY;
            self.missed = self.missed.saturating_add(1);
            (self.missed >= MISSED_GREETINGS).then_some(Answer::Unanswered)
        } else {
            return None;
        };
        self.pending = None;
        shared.awaiting_answer.store(false, Ordering::Release);
        answer
    }

    /// How long the writer may sleep before the greeter needs it.
    fn wait(&self, now: Instant) -> Duration {
        match &self.pending {
            Some(pending) => pending.deadline.saturating_duration_since(now),
            None => self.next_at.saturating_duration_since(now),
        }
    }
}

/// Whether one instruction's bytes may be written while the e-stop is latched.
pub(super) fn is_inert(instruction: &[u8]) -> bool {
    std::str::from_utf8(instruction)
        .ok()
        .and_then(|text| parse_script(text).ok())
        .is_some_and(|parsed| {
            parsed
                .iter()
                .all(floatball_shared::uim2503::ascii::Instruction::is_inert)
        })
}

/// The writer's queues, and the e-stop generation it last acted on.
struct Writer {
    queues: Queues,
    /// A priority batch waiting for its instant (the synchronised start).
    held: Option<(Instant, Batch)>,
    seen_generation: u64,
    /// A line-speed change asked for and not carried out yet.
    baud_change: Option<(u32, Duration, BaudReply)>,
}

impl Writer {
    /// Acts on a new e-stop generation: everything queued is void, the stop goes first.
    fn observe_latch(&mut self, shared: &Shared) {
        let generation = shared.config.latch.generation();
        if generation == self.seen_generation {
            return;
        }
        self.seen_generation = generation;
        self.stop(shared);
    }

    fn stop(&mut self, shared: &Shared) {
        let dropped = self.queues.clear_bulk();
        self.queues.clear_priority();
        self.held = None;
        shared.unqueue(dropped);
        self.queues.push_priority(&shared.config.estop);
    }

    /// Takes one handed-over input into the queues, dropping it if it is void; a
    /// line-speed change is kept for the writer to carry out once the queues are empty.
    fn accept(&mut self, shared: &Shared, input: Input) {
        let (generation, batch, bulk, not_before) = match input {
            Input::Bulk { generation, batch } => (generation, batch, true, None),
            Input::Priority {
                generation,
                batch,
                not_before,
            } => (generation, batch, false, not_before),
            Input::ChangeBaud {
                baud,
                restart_wait,
                reply,
            } => {
                if self.baud_change.is_some() {
                    let _ = reply.send(Err(BaudError::Link(LinkError::Down {
                        port: shared.config.port.clone(),
                        reason: Some("another line-speed change is under way".to_owned()),
                    })));
                } else {
                    self.baud_change = Some((baud, restart_wait, reply));
                }
                return;
            }
        };
        if generation > self.seen_generation {
            // Issued after an e-stop this writer has not acted on yet: act first.
            self.observe_latch(shared);
        }
        let count = batch.instruction_count() as u64;
        let void = generation < self.seen_generation;
        if void {
            shared
                .dropped_instructions
                .fetch_add(count, Ordering::Relaxed);
            if bulk {
                shared.unqueue(batch.len());
            }
            return;
        }
        let latched = shared.config.latch.is_latched();
        if let Some(at) = not_before
            && !latched
            && at > Instant::now()
        {
            // A second held batch before the first went: the first goes now.
            if let Some((_, earlier)) = self.held.replace((at, batch)) {
                self.queues.push_priority(&earlier);
            }
            return;
        }
        let keep = |instruction: &[u8]| !latched || is_inert(instruction);
        let refused = if bulk {
            self.queues.push_bulk_filtered(&batch, keep)
        } else {
            self.queues.push_priority_filtered(&batch, keep)
        };
        if refused > 0 {
            tracing::warn!(
                "gateway {}: {refused} bytes of motion refused while the e-stop is latched",
                shared.config.port
            );
            shared.dropped_instructions.fetch_add(1, Ordering::Relaxed);
            if bulk {
                shared.unqueue(refused);
            }
        }
    }
}

/// A writer's state while its line is open. Whatever is still queued when the line is
/// done is dropped ([`Drive::finish`]).
pub(super) struct Drive {
    writer: Writer,
    pacer: Pacer,
    meter: RateMeter,
    greeter: Greeter,
    /// The instruction being taken from the queues.
    instruction: Vec<u8>,
    /// What one write hands the line.
    chunk: Vec<u8>,
}

impl Drive {
    /// The writer of a line opened at `now`: it greets the gateway at once, and writes
    /// the stop first if the e-stop is latched (the units behind this gateway may not
    /// have heard it).
    pub(super) fn new(shared: &Shared, now: Instant) -> Self {
        let mut writer = Writer {
            queues: Queues::with_priority_room(PRIORITY_ROOM_BYTES),
            held: None,
            seen_generation: shared.config.latch.generation(),
            baud_change: None,
        };
        if shared.config.latch.is_latched() {
            writer.stop(shared);
        }
        Self {
            writer,
            pacer: Pacer::new(shared.baud(), now),
            meter: RateMeter::new(now),
            greeter: Greeter::now(now),
            instruction: Vec::with_capacity(MAX_LEN),
            chunk: Vec::with_capacity(MAX_LEN),
        }
    }

    /// One turn of the writer at `now`. With `ahead` zero it writes one instruction
    /// when the pacer allows; otherwise whenever the line will be free within `ahead`,
    /// whole instructions up to [`MAX_LEN`] bytes or [`CHUNK_TIME`] of line time
    /// (whichever is more) in one write.
    pub(super) fn step(
        &mut self,
        shared: &Shared,
        inbox: &Receiver<Input>,
        line: &mut impl LineWrite,
        lost: &AtomicBool,
        now: Instant,
        ahead: Duration,
    ) -> Step {
        if shared.is_closed() {
            return Step::Done("shut down".to_owned());
        }
        if lost.load(Ordering::Acquire) {
            return Step::Done("the line was lost".to_owned());
        }
        self.writer.observe_latch(shared);
        if self.start_due(now) && line.backlog() == 0 && self.pacer.wait_before_next(now) <= ahead {
            // A start due and its line free goes before anything handed over since is
            // even looked at (the rows that follow it can be many).
            if let Some((_, start)) = self.writer.held.take() {
                self.writer.queues.push_priority(&start);
            }
            return self.write_next(shared, line, ahead, MAX_LEN);
        }
        while let Ok(input) = inbox.try_recv() {
            self.writer.accept(shared, input);
        }
        if let Some(rate) = self.meter.roll(now) {
            shared.publish_rate(rate);
        }
        match self.greeter.check(shared, now) {
            Some(Answer::Answered) => shared.set_state(LinkState::Up, None),
            Some(Answer::Unanswered) => {
                shared.set_state(LinkState::NotAnswering, Some(NOT_ANSWERING.to_owned()));
            }
            None => {}
        }
        let held_until = match &self.writer.held {
            Some((at, _)) if *at <= now => {
                if let Some((_, batch)) = self.writer.held.take() {
                    self.writer.queues.push_priority(&batch);
                }
                None
            }
            Some((at, _)) => Some(*at),
            None => None,
        };
        let has_work = self.writer.queues.has_work() || held_until.is_some();
        if !has_work && self.greeter.pending.is_none() && self.writer.baud_change.is_some() {
            return Step::ChangeBaud;
        }
        if line.backlog() > 0 {
            return Step::Wait(BACKLOG_RETRY);
        }
        let line_wait = self.pacer.wait_before_next(now);
        if !has_work {
            if self.greeter.due(now) && line_wait.is_zero() {
                if let Err(err) = line.write_instruction(GREETING) {
                    return Step::Done(format!("write failed: {err}"));
                }
                let free_at = self.pacer.wrote(now, GREETING.len());
                self.meter.add(now, GREETING.len());
                shared
                    .written_bytes
                    .fetch_add(GREETING.len() as u64, Ordering::AcqRel);
                self.greeter
                    .sent(shared, now, free_at.saturating_duration_since(now));
                return Step::Wait(Duration::ZERO);
            }
            let wait = IDLE_TICK.min(self.greeter.wait(now)).max(line_wait);
            return Step::Wait(wait.min(IDLE_TICK));
        }
        let chunk_limit = if ahead.is_zero() {
            MAX_LEN
        } else {
            MAX_LEN.max(self.pacer.bytes_in(CHUNK_TIME))
        };
        if let Some(at) = held_until
            && (!self.writer.queues.has_work()
                || self.pacer.free_after(now, chunk_limit) + START_GUARD > at)
        {
            // The line stays free for the held start: only what leaves it before.
            return Step::Wait(at.saturating_duration_since(now).min(IDLE_TICK));
        }
        if line_wait > ahead {
            return Step::Wait((line_wait - ahead).min(IDLE_TICK));
        }
        self.write_next(shared, line, ahead, chunk_limit)
    }

    /// Writes the next instructions: one, or with an `ahead` window whole ones up to
    /// `chunk_limit` bytes, the priority lane's in a write of their own.
    fn write_next(
        &mut self,
        shared: &Shared,
        line: &mut impl LineWrite,
        ahead: Duration,
        chunk_limit: usize,
    ) -> Step {
        self.chunk.clear();
        let mut bulk_bytes = 0;
        let mut priority = None;
        while let Some(popped) = self.writer.queues.pop_into(&mut self.instruction) {
            self.chunk.extend_from_slice(&self.instruction);
            if popped == Popped::Bulk {
                bulk_bytes += self.instruction.len();
            }
            // The priority lane's instructions (a start, a stop) go in a write of their
            // own: as short as they are.
            let first_was_priority = *priority.get_or_insert(popped == Popped::Priority);
            let fits = self
                .writer
                .queues
                .next_len()
                .is_some_and(|next| self.chunk.len() + next <= chunk_limit);
            let next_is_priority = self.writer.queues.next_is_priority();
            if ahead.is_zero() || !fits || first_was_priority != next_is_priority {
                break;
            }
        }
        if self.chunk.is_empty() {
            return Step::Wait(Duration::ZERO);
        }
        if let Err(err) = line.write_instruction(&self.chunk) {
            shared.unqueue(bulk_bytes);
            return Step::Done(format!("write failed: {err}"));
        }
        let now = Instant::now();
        self.pacer.wrote(now, self.chunk.len());
        self.meter.add(now, self.chunk.len());
        self.greeter.wrote(now);
        shared
            .written_bytes
            .fetch_add(self.chunk.len() as u64, Ordering::AcqRel);
        shared.unqueue(bulk_bytes);
        Step::Wait(Duration::ZERO)
    }

    /// Whether a held start is due at `now`.
    pub(super) fn start_due(&self, now: Instant) -> bool {
        self.writer.held.as_ref().is_some_and(|(at, _)| *at <= now)
    }

    /// Carries out the line-speed change [`Step::ChangeBaud`] announced, with `line` to
    /// itself (it blocks for as long as the change takes, writing the e-stop if it is
    /// pressed meanwhile). `Err` only when the line failed.
    pub(super) fn change_baud(
        &mut self,
        shared: &Shared,
        line: &mut impl LineWrite,
        lost: &AtomicBool,
    ) -> std::io::Result<()> {
        let Some((baud, restart_wait, reply)) = self.writer.baud_change.take() else {
            return Ok(());
        };
        let mut change = Change {
            shared,
            writer: &mut self.writer,
            line,
            pacer: &mut self.pacer,
            lost,
            buffer: &mut self.instruction,
        };
        let result = change.run(baud, restart_wait)?;
        let _ = reply.send(result);
        self.greeter = Greeter {
            next_at: Instant::now() + GREETING_INTERVAL,
            pending: None,
            missed: 0,
        };
        Ok(())
    }

    /// The line is done (`reason`): drops everything queued and handed over, and
    /// answers a line-speed change still waiting.
    pub(super) fn finish(&mut self, shared: &Shared, inbox: &Receiver<Input>, reason: &str) {
        shared.awaiting_answer.store(false, Ordering::Release);
        self.writer.held = None;
        let left = self.writer.queues.clear_bulk();
        shared.unqueue(left);
        shared.drop_inbox(inbox);
        if let Some((_, _, reply)) = self.writer.baud_change.take() {
            let _ = reply.send(Err(BaudError::Link(LinkError::Down {
                port: shared.config.port.clone(),
                reason: Some(reason.to_owned()),
            })));
        }
    }
}

/// Writes queued instructions to `line` from a thread of its own until the link is
/// closed, `lost` is set, or a write fails; returns why it stopped. Greets the gateway
/// at once and whenever the line is idle, and keeps the link's state (`Connecting`
/// until the first answer, `Up`, `NotAnswering`) by the answers. The calling thread
/// must have registered as the link's writer. Whatever is still queued when it returns
/// is dropped.
pub(super) fn run_writer(
    shared: &Shared,
    inbox: &Receiver<Input>,
    line: &mut impl LineWrite,
    lost: &AtomicBool,
) -> String {
    let mut drive = Drive::new(shared, Instant::now());
    let reason = loop {
        match drive.step(shared, inbox, line, lost, Instant::now(), Duration::ZERO) {
            Step::Wait(wait) => {
                if !wait.is_zero() {
                    std::thread::park_timeout(wait);
                }
            }
            Step::Done(reason) => break reason,
            Step::ChangeBaud => {
                if let Err(err) = drive.change_baud(shared, line, lost) {
                    break format!("write failed: {err}");
                }
            }
        }
    };
    drive.finish(shared, inbox, &reason);
    reason
}

/// How often a line-speed change looks at the latch and the line while it waits.
const CHANGE_POLL: Duration = Duration::from_millis(5);

/// A line-speed change, carried out by the writer thread (it owns the line).
struct Change<'w, L> {
    shared: &'w Shared,
    writer: &'w mut Writer,
    line: &'w mut L,
    pacer: &'w mut Pacer,
    lost: &'w AtomicBool,
    buffer: &'w mut Vec<u8>,
}

impl<L: LineWrite> Change<'_, L> {
    /// `BDR=x;`, the restart, the switch, the greetings; on failure back to the old
    /// speed. `Err` only when the line failed.
    fn run(
        &mut self,
        baud: u32,
        restart_wait: Duration,
    ) -> std::io::Result<Result<BaudChanged, BaudError>> {
        let shared = self.shared;
        let port = shared.config.port.clone();
        let from_baud = shared.baud();
        let started = Instant::now();
        // An e-stop pressed since the change was asked for: `BDR` is not inert, and
        // nothing but inert instructions goes out while the latch is set.
        self.writer.observe_latch(self.shared);
        if shared.config.latch.is_latched() {
            return Ok(Err(BaudError::EstopLatched));
        }
        shared.set_state(
            LinkState::Connecting,
            Some(format!(
                "changing the line speed from {from_baud} to {baud} baud"
            )),
        );
        let mut bdr = Vec::new();
        let command = Instruction::Gateway(GatewayCommand::SetBaud { baud });
        if let Err(err) = command.encode_into(Form::Standard, &mut bdr) {
            shared.set_state(LinkState::Up, None);
            return Ok(Err(BaudError::Port {
                port,
                baud,
                reason: err.to_string(),
            }));
        }
        self.write(&bdr)?;
        // Until the gateway has read all of it.
        let crossed = self.pacer.wrote(Instant::now(), 0) + ANSWER_MARGIN;
        self.idle_until(crossed)?;
        let restarted_here = self.line.restart_gateway();
        if let Err(err) = self.switch(baud) {
            self.switch(from_baud)?;
            self.greet_until(Instant::now() + ANSWER_TIMEOUT * 2)?;
            return Ok(Err(BaudError::Port {
                port,
                baud,
                reason: err.to_string(),
            }));
        }
        tracing::info!(
            "gateway {port}: BDR={baud} sent; {}; greeting at {baud} baud",
            if restarted_here {
                "the simulated gateway restarted"
            } else {
                "waiting for the gateway's power cycle"
            }
        );
        if self.greet_until(started + restart_wait)? {
            let took_ms = u64::try_from(started.elapsed().as_millis()).unwrap_or(u64::MAX);
            return Ok(Ok(BaudChanged {
                from_baud,
                baud,
                took_ms,
            }));
        }
        let waited_ms = u64::try_from(started.elapsed().as_millis()).unwrap_or(u64::MAX);
        tracing::warn!(
            "gateway {port}: no answer at {baud} baud within {waited_ms} ms; back to \
             {from_baud} baud"
        );
        self.switch(from_baud)?;
        self.greet_until(Instant::now() + ANSWER_TIMEOUT * 2)?;
        Ok(Err(BaudError::NotAnswering {
            port,
            baud,
            from_baud,
            waited_ms,
        }))
    }

    /// Switches this end of the line to `baud`.
    fn switch(&mut self, baud: u32) -> std::io::Result<()> {
        self.line.set_baud(baud)?;
        self.shared.baud.store(baud, Ordering::Release);
        *self.pacer = Pacer::new(baud, Instant::now());
        Ok(())
    }

    /// Writes `bytes` when the pacer allows.
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        let wait = self.pacer.wait_before_next(Instant::now());
        if !wait.is_zero() {
            std::thread::sleep(wait);
        }
        self.check_line()?;
        self.line.write_instruction(bytes)?;
        // A change has the line to itself: what the line did not take yet goes now.
        while self.line.backlog() > 0 {
            self.check_line()?;
            self.line.service(self.shared)?;
            if self.line.backlog() > 0 {
                std::thread::sleep(BACKLOG_RETRY);
            }
        }
        self.pacer.wrote(Instant::now(), bytes.len());
        self.shared
            .written_bytes
            .fetch_add(bytes.len() as u64, Ordering::AcqRel);
        Ok(())
    }

    fn check_line(&self) -> std::io::Result<()> {
        if self.shared.is_closed() || self.lost.load(Ordering::Acquire) {
            return Err(std::io::Error::other("the line was lost"));
        }
        Ok(())
    }

    /// Waits until `until`, writing the e-stop if it is pressed meanwhile.
    fn idle_until(&mut self, until: Instant) -> std::io::Result<()> {
        loop {
            self.check_line()?;
            self.line.service(self.shared)?;
            self.writer.observe_latch(self.shared);
            // Only the stop can be queued here: the inbox is not read during a change.
            while self.writer.queues.pop_into(self.buffer).is_some() {
                let instruction = std::mem::take(self.buffer);
                self.write(&instruction)?;
                *self.buffer = instruction;
            }
            let now = Instant::now();
            if now >= until {
                return Ok(());
            }
            std::thread::park_timeout((until - now).min(CHANGE_POLL));
        }
    }

    /// Greets every [`GREETING_RETRY`] until the gateway answers (`true`, and the link is
    /// `Up`) or `deadline` passes (`false`, and the link is `NotAnswering`).
    fn greet_until(&mut self, deadline: Instant) -> std::io::Result<bool> {
        let shared = self.shared;
        let answers_before = shared.greetings_answered.load(Ordering::Acquire);
        shared.awaiting_answer.store(true, Ordering::Release);
        let answered = loop {
            self.write(GREETING)?;
            let retry_at = Instant::now() + GREETING_RETRY;
            while Instant::now() < retry_at.min(deadline) {
                if shared.greetings_answered.load(Ordering::Acquire) > answers_before {
                    break;
                }
                self.idle_until((Instant::now() + Duration::from_millis(5)).min(retry_at))?;
            }
            if shared.greetings_answered.load(Ordering::Acquire) > answers_before {
                break true;
            }
            if Instant::now() >= deadline {
                break false;
            }
        };
        shared.awaiting_answer.store(false, Ordering::Release);
        if answered {
            shared.set_state(LinkState::Up, None);
            if shared.config.latch.is_latched() {
                // A stop written while the two ends' speeds differed was lost: the
                // gateway hears it again now that they agree.
                self.writer.stop(shared);
                self.idle_until(Instant::now())?;
            }
        } else {
            shared.set_state(LinkState::NotAnswering, Some(NOT_ANSWERING.to_owned()));
        }
        Ok(answered)
    }
}

/// Time left for the gateway to take in `BDR=x;` after its last byte crossed the line.
const ANSWER_MARGIN: Duration = Duration::from_millis(20);
