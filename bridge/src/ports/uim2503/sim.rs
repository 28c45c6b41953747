//! The simulated gateway as a link kind: `shared::sim::Gateway` behind a virtual serial
//! line that is exactly as slow as a real one.
//!
//! The writer paces instructions at baud / 10 bytes/s like any link; each instruction
//! reaches the simulated gateway when its last byte would have crossed the line. The
//! gateway's answers come back at the same speed, byte by byte. [`SimEngine`] is that
//! line-plus-gateway; the in-process link and `floatball simulate` (the
//! gateway on the far end of a real serial device) both drive it.
//!
//! The gateway answers the link's greeting like a real one. A line-speed change
//! (`BDR=x;`) is stored by the gateway; the in-process link restarts the gateway itself
//! when the command has crossed the line ([`SimEngine::restart`]) and then switches its
//! own end of the line ([`SimEngine::set_host_baud`]): until both ends run at the same
//! speed nothing crosses.

use std::collections::VecDeque;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use floatball_shared::api::{LinkState, SimGateway, SimLineStats};
use floatball_shared::uim2503::ascii::GreetingWatch;
use floatball_shared::uim2503::feedback::FrameDecoder;
use floatball_shared::uim2503::sim::{Gateway, GatewayConfig, Uart};

use super::writer::{LineWrite, run_writer};
use super::{Input, Shared};
use floatball_shared::line::Line;

/// The longest the simulation sleeps, so positions and clocks stay fresh.
const TICK: Duration = Duration::from_millis(10);

/// A read-only window on a simulated gateway, for `GET /api/sim/positions` and tests.
#[derive(Debug, Clone)]
pub struct SimView {
    uart: Arc<Mutex<Uart>>,
    epoch: Instant,
}

impl SimView {
    fn lock(&self) -> MutexGuard<'_, Uart> {
        self.uart
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// Every unit's true state now, and the line's counts, for gateway number `index`.
    pub fn positions(&self, index: usize) -> SimGateway {
        let now_us = micros_since(self.epoch, Instant::now());
        let mut uart = self.lock();
        uart.gateway_mut().advance(now_us);
        uart.positions(index)
    }

    /// Instruction bytes the gateway has read so far (bytes lost to an overrun are not
    /// counted; see [`SimView::line`]).
    pub fn received_bytes(&self) -> u64 {
        self.lock().stats().received_bytes
    }

    /// What crossed the line so far, and what was lost (overrun, full answer queue).
    pub fn line(&self) -> SimLineStats {
        self.lock().stats()
    }

    /// Runs `change` on the gateway (fault injection in tests: a unit dropping off the
    /// bus, a garbled byte).
    pub fn with_gateway<T>(&self, change: impl FnOnce(&mut Gateway) -> T) -> T {
        change(self.lock().gateway_mut())
    }
}

fn micros_since(epoch: Instant, at: Instant) -> u64 {
    u64::try_from(at.saturating_duration_since(epoch).as_micros()).unwrap_or(u64::MAX)
}

/// A simulated gateway at the far end of a line of `baud`: takes instruction bytes at
/// the times they arrive, and releases its answers no faster than the line carries them.
///
/// The line is the shared [`Uart`]: bytes that come faster than the line carries them
/// overrun and are lost, and the answers wait in a bounded queue that drops its oldest
/// frames when full; both are counted ([`SimView::line`]).
#[derive(Debug)]
pub struct SimEngine {
    view: SimView,
}

impl SimEngine {
    /// A gateway built from `config`, on a line at `baud`, starting now.
    ///
    /// # Errors
    /// The simulator's refusal of the configuration.
    pub fn new(config: GatewayConfig, baud: u32) -> Result<Self, String> {
        let uart = Uart::new(config, baud).map_err(|err| format!("simulated gateway: {err}"))?;
        Ok(Self {
            view: SimView {
                uart: Arc::new(Mutex::new(uart)),
                epoch: Instant::now(),
            },
        })
    }

    /// The read-only window on the gateway.
    pub fn view(&self) -> SimView {
        self.view.clone()
    }

    /// Instruction bytes that finished arriving at `at` (back to back, the last one at
    /// `at`); those that came faster than the line carries are lost.
    pub fn receive(&mut self, at: Instant, bytes: &[u8]) {
        let at_us = micros_since(self.view.epoch, at);
        self.view.lock().receive(at_us, bytes);
    }

    /// Lets the gateway run until `now` and appends to `out` the answer bytes that have
    /// crossed the line by then.
    pub fn step(&mut self, now: Instant, out: &mut Vec<u8>) {
        let now_us = micros_since(self.view.epoch, now);
        self.view.lock().step(now_us, out);
    }

    /// The gateway's power cycle at `at`: a line speed stored by `BDR=x;` takes effect
    /// (see [`Uart::restart`]).
    pub fn restart(&mut self, at: Instant) {
        let at_us = micros_since(self.view.epoch, at);
        self.view.lock().restart(at_us);
    }

    /// The host's end of the line now runs at `baud`.
    pub fn set_host_baud(&mut self, baud: u32) {
        self.view.lock().set_host_baud(baud);
    }

    /// The gateway's line speed, baud.
    pub fn baud(&self) -> u32 {
        self.view.lock().baud()
    }

    /// The line speed the gateway stored from `BDR=x;`, if any (in effect from its next
    /// restart on).
    pub fn stored_baud(&self) -> Option<u32> {
        self.view.lock().gateway().stored_baud()
    }

    /// When [`SimEngine::step`] next has something to do (at the latest one tick on).
    pub fn next_wakeup(&self, now: Instant) -> Instant {
        let mut at = now + TICK;
        if let Some(event_us) = self.view.lock().next_event_us() {
            at = at.min(self.view.epoch + Duration::from_micros(event_us));
        }
        at.max(now)
    }
}

/// Starts an in-process simulated gateway behind `shared`'s link; returns its view.
pub(super) fn spawn(
    shared: Arc<Shared>,
    config: GatewayConfig,
    inbox: Receiver<Input>,
) -> Option<SimView> {
    let mut engine = match SimEngine::new(config, shared.config.baud) {
        Ok(engine) => engine,
        Err(reason) => {
            shared.set_state(LinkState::Down, Some(reason));
            return None;
        }
    };
    let view = engine.view();
    let (to_sim, deliveries) = channel::<(Instant, ToSim)>();
    let writer_shared = Arc::clone(&shared);
    let sim_shared = Arc::clone(&shared);
    let lost = Arc::new(AtomicBool::new(false));
    let writer = std::thread::Builder::new()
        .name(format!("link-{}-sim-write", shared.index))
        .spawn(move || {
            writer_shared.register_writer();
            let mut line = SimLine {
                to_sim,
                byte_time: Line::new(writer_shared.baud()).byte_time(),
                line_free_at: Instant::now(),
            };
            let reason = run_writer(&writer_shared, &inbox, &mut line, &lost);
            writer_shared.set_state(LinkState::Down, Some(reason));
        });
    let simulation = std::thread::Builder::new()
        .name(format!("link-{}-sim", shared.index))
        .spawn(move || simulate(&sim_shared, &mut engine, &deliveries));
    if let Err(err) = writer.and(simulation) {
        shared.set_state(
            LinkState::Down,
            Some(format!("cannot start the simulator: {err}")),
        );
    }
    Some(view)
}

/// What the writer's end of the virtual line hands the simulation, due at a time.
enum ToSim {
    /// Instruction bytes whose last byte crossed the line.
    Bytes(Vec<u8>),
    /// The gateway restarts (the in-process link does what the installer would).
    Restart,
    /// The host's end of the line switches speed.
    HostBaud(u32),
}

/// The writer's end of the virtual line: an instruction reaches the gateway when its
/// last byte has crossed.
struct SimLine {
    to_sim: Sender<(Instant, ToSim)>,
    byte_time: Duration,
    line_free_at: Instant,
}

impl SimLine {
    /// Hands `what` to the simulation, due once the line has carried what came before.
    fn hand(&mut self, what: ToSim) -> std::io::Result<()> {
        self.line_free_at = self.line_free_at.max(Instant::now());
        self.to_sim
            .send((self.line_free_at, what))
            .map_err(|_| std::io::Error::other("the simulator stopped"))
    }
}

impl LineWrite for SimLine {
    fn write_instruction(&mut self, instruction: &[u8]) -> std::io::Result<()> {
        let start = self.line_free_at.max(Instant::now());
        let len = u32::try_from(instruction.len()).unwrap_or(u32::MAX);
        self.line_free_at = start + self.byte_time * len;
        self.to_sim
            .send((self.line_free_at, ToSim::Bytes(instruction.to_vec())))
            .map_err(|_| std::io::Error::other("the simulator stopped"))
    }

    fn set_baud(&mut self, baud: u32) -> std::io::Result<()> {
        self.hand(ToSim::HostBaud(baud))?;
        self.byte_time = Line::new(baud).byte_time();
        Ok(())
    }

    fn restart_gateway(&mut self) -> bool {
        self.hand(ToSim::Restart).is_ok()
    }
}

/// The simulation thread: delivers instructions on time, runs the gateway, decodes its
/// answers and broadcasts the frames.
fn simulate(shared: &Shared, engine: &mut SimEngine, deliveries: &Receiver<(Instant, ToSim)>) {
    let mut pending: VecDeque<(Instant, ToSim)> = VecDeque::new();
    let mut decoder = FrameDecoder::new();
    let mut watch = GreetingWatch::new();
    let mut answers = Vec::new();
    while !shared.is_closed() {
        let now = Instant::now();
        let mut wake = engine.next_wakeup(now);
        if let Some((due, _)) = pending.front() {
            wake = wake.min(*due);
        }
        match deliveries.recv_timeout(wake.saturating_duration_since(now)) {
            Ok(delivery) => pending.push_back(delivery),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        while let Ok(delivery) = deliveries.try_recv() {
            pending.push_back(delivery);
        }
        let now = Instant::now();
        while pending.front().is_some_and(|(due, _)| *due <= now) {
            match pending.pop_front() {
                Some((due, ToSim::Bytes(bytes))) => engine.receive(due, &bytes),
                Some((due, ToSim::Restart)) => engine.restart(due),
                Some((_, ToSim::HostBaud(baud))) => engine.set_host_baud(baud),
                None => {}
            }
        }
        answers.clear();
        engine.step(now, &mut answers);
        if !answers.is_empty() {
            shared.heard(&mut watch, &mut decoder, &answers);
        }
    }
}
