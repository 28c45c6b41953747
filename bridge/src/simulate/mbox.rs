//! `floatball simulate --kind mbox`: MBOX boxes on real UDP sockets — for tests on
//! loopback and for demonstrations on a LAN — and the bridge's own simulated boxes
//! (`port = "sim"`).
//!
//! Each box is a [`MboxTwin`] (the sans-IO twin in `floatball_shared::mbox::twin`) on
//! its own socket, answered by **a thread of its own**, not a task on the bridge's
//! async runtime: a real box takes each frame when it arrives and answers a register
//! read whatever the bridge is busy with, and a box queued behind busy tasks on the
//! runtime's few workers would take frames late — which moves its axes as a late
//! frame does (`docs/protocol-notes.md`, "The twin") — and miss the bridge's polls
//! (the MOONS' simulator, [`super::scl`], moved to threads for the same reason). A
//! datagram is handed to the twin with the time since the boxes started, read as it
//! is received, and the twin's reply, if any, goes back to the sender's address and
//! port. N boxes listen on consecutive ports from the first (or each on a port of the
//! system's choosing when the first is 0), with consecutive IP addresses from the
//! first, so each has its own address in datagrams.
//!
//! [`MboxBoxes::snapshots`] shows every box now (`GET /api/sim/positions`);
//! [`MboxBoxes::stop`] ends every thread and returns each box's final [`SimBox`].

use std::net::{Ipv4Addr, SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use floatball_shared::api::SimBox;
use floatball_shared::mbox::AxisCount;
use floatball_shared::mbox::twin::{MboxTwin, TwinConfig};

/// The largest datagram a box takes (anything longer is cut and refused as malformed).
const MAX_DATAGRAM: usize = 65_536;

/// How often a box's thread looks whether it is to stop (its socket's read timeout).
const STOP_POLL: Duration = Duration::from_millis(50);

/// What to simulate, and where.
#[derive(Debug, Clone, Copy)]
pub struct MboxOptions {
    /// The first box's socket; box `i` listens on its port + `i` (all on port 0: each
    /// on a free port).
    pub listen: SocketAddr,
    /// How many boxes.
    pub boxes: u16,
    /// Axes of every box.
    pub axes: AxisCount,
    /// The first box's IP address; box `i` has this + `i`.
    pub ip: Ipv4Addr,
    /// Per cent of datagrams lost on the way in and of replies lost on the way out,
    /// each box drawing from its own generator seeded with `seed` + its index (a lossy
    /// network, for tests).
    pub drop_percent: u8,
    /// The seed of the losses.
    pub seed: u64,
}

/// A lossy network for one box: a seeded xorshift generator.
#[derive(Debug, Clone, Copy)]
struct Loss {
    percent: u64,
    state: u64,
}

impl Loss {
    fn new(percent: u8, seed: u64) -> Self {
        Self {
            percent: u64::from(percent.min(100)),
            // xorshift must not start at 0.
            state: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
        }
    }

    /// Whether the next datagram is lost.
    fn drops(&mut self) -> bool {
        if self.percent == 0 {
            return false;
        }
        self.state ^= self.state << 13;
        self.state ^= self.state >> 7;
        self.state ^= self.state << 17;
        self.state % 100 < self.percent
    }
}

/// One running box, as [`MboxBoxes::boxes`] lists it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunningBox {
    /// Where its socket listens.
    pub socket: SocketAddr,
    /// The IP address it stands for (its address in datagrams is the last two octets).
    pub ip: Ipv4Addr,
}

/// The boxes, each answering on its socket, on its own thread, until [`Self::stop`]
/// (or until dropped).
#[derive(Debug)]
pub struct MboxBoxes {
    boxes: Vec<RunningBox>,
    /// Per box: its twin, shared with its thread.
    twins: Vec<Arc<Mutex<MboxTwin>>>,
    epoch: Instant,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl MboxBoxes {
    /// Binds every box's socket and starts answering.
    ///
    /// # Errors
    /// A port or IP address past the last one, or a socket or thread that cannot be
    /// had.
    pub async fn start(options: MboxOptions) -> Result<Self, String> {
        Self::spawn(options)
    }

    /// As [`Self::start`], from code that is not async.
    ///
    /// # Errors
    /// As [`Self::start`].
    pub fn spawn(options: MboxOptions) -> Result<Self, String> {
        let epoch = Instant::now();
        let count = usize::from(options.boxes);
        let mut boxes = Vec::with_capacity(count);
        let mut sockets = Vec::with_capacity(count);
        for index in 0..options.boxes {
            let (listen, ip) = box_at(&options, index)?;
            let socket = UdpSocket::bind(listen)
                .and_then(|socket| {
                    socket.set_read_timeout(Some(STOP_POLL))?;
                    Ok(socket)
                })
                .map_err(|err| format!("cannot listen on UDP {listen}: {err}"))?;
            let local = socket
                .local_addr()
                .map_err(|err| format!("cannot read the address of UDP {listen}: {err}"))?;
            boxes.push(RunningBox { socket: local, ip });
            sockets.push(socket);
        }
        let mut running = Self {
            twins: boxes
                .iter()
                .map(|one| {
                    Arc::new(Mutex::new(MboxTwin::new(TwinConfig::new(
                        one.ip,
                        options.axes,
                    ))))
                })
                .collect(),
            boxes,
            epoch,
            stop: Arc::new(AtomicBool::new(false)),
            threads: Vec::with_capacity(count),
        };
        for (index, socket) in sockets.into_iter().enumerate() {
            let twin = Arc::clone(&running.twins[index]);
            let stop = Arc::clone(&running.stop);
            let loss = Loss::new(
                options.drop_percent,
                options.seed.wrapping_add(index as u64),
            );
            let thread = std::thread::Builder::new()
                .name(format!("sim-mbox-{index}"))
                .spawn(move || answer(&socket, &twin, loss, epoch, &stop))
                .map_err(|err| format!("cannot start simulated MBOX box {index}: {err}"))?;
            running.threads.push(thread);
        }
        Ok(running)
    }

    /// Every box's state now, in order.
    pub async fn snapshots(&self) -> Vec<SimBox> {
        self.snapshots_now()
    }

    /// Every box's state now, in order (from code that is not async).
    #[must_use]
    pub fn snapshots_now(&self) -> Vec<SimBox> {
        let now_us = micros(self.epoch, Instant::now());
        self.twins
            .iter()
            .map(|twin| {
                let mut twin = twin.lock().unwrap_or_else(PoisonError::into_inner);
                twin.advance(now_us);
                twin.snapshot()
            })
            .collect()
    }

    /// The boxes, in order.
    #[must_use]
    pub fn boxes(&self) -> &[RunningBox] {
        &self.boxes
    }

    /// Stops every box; returns each one's final state, in order.
    pub async fn stop(mut self) -> Vec<SimBox> {
        self.stop.store(true, Ordering::Release);
        let threads = std::mem::take(&mut self.threads);
        let joined = tokio::task::spawn_blocking(move || {
            threads
                .into_iter()
                .filter_map(|thread| thread.join().err())
                .count()
        })
        .await;
        if !matches!(joined, Ok(0)) {
            tracing::error!("a simulated MBOX stopped unexpectedly");
        }
        self.snapshots_now()
    }
}

impl Drop for MboxBoxes {
    /// The boxes stop answering (their threads see it within [`STOP_POLL`] and close
    /// their sockets).
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
    }
}

fn micros(epoch: Instant, at: Instant) -> u64 {
    u64::try_from(at.saturating_duration_since(epoch).as_micros()).unwrap_or(u64::MAX)
}

/// Box `index`'s socket and IP address.
fn box_at(options: &MboxOptions, index: u16) -> Result<(SocketAddr, Ipv4Addr), String> {
    let mut listen = options.listen;
    if listen.port() != 0 {
        let port = listen.port().checked_add(index).ok_or_else(|| {
            format!(
                "{} boxes from port {} run past port 65535",
                options.boxes,
                options.listen.port()
            )
        })?;
        listen.set_port(port);
    }
    let ip = u32::from(options.ip)
        .checked_add(u32::from(index))
        .map(Ipv4Addr::from)
        .ok_or_else(|| {
            format!(
                "{} boxes from {} run past 255.255.255.255",
                options.boxes, options.ip
            )
        })?;
    Ok((listen, ip))
}

/// One box, on its own thread: takes datagrams until `stop` (each at the time it was
/// received), answers the sender.
fn answer(
    socket: &UdpSocket,
    twin: &Mutex<MboxTwin>,
    mut loss: Loss,
    epoch: Instant,
    stop: &AtomicBool,
) {
    let mut buffer = vec![0u8; MAX_DATAGRAM];
    while !stop.load(Ordering::Acquire) {
        match socket.recv_from(&mut buffer) {
            Ok((len, sender)) => {
                let received_us = micros(epoch, Instant::now());
                if loss.drops() {
                    continue;
                }
                let datagram = buffer.get(..len).unwrap_or_default();
                let reply = twin
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .receive(received_us, datagram);
                if let Some(reply) = reply
                    && !loss.drops()
                    && let Err(err) = socket.send_to(&reply, sender)
                {
                    let ip = twin
                        .lock()
                        .unwrap_or_else(PoisonError::into_inner)
                        .saved_ip();
                    tracing::warn!("simulated MBOX {ip}: cannot reply to {sender}: {err}");
                }
            }
            // Timeouts (a look at `stop`), and, on Linux, an ICMP "port unreachable"
            // for an earlier reply: the box carries on, as a real one does.
            Err(err)
                if matches!(
                    err.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) => {}
            Err(err) => tracing::debug!("simulated MBOX: receive failed: {err}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::time::Duration;

    use floatball_shared::mbox::register::FN_IP;
    use floatball_shared::mbox::{Datagram, Encode, ReadBank, RegisterRange, RegisterRead, Route};

    use super::*;

    /// A simulated box answers a register read while the async runtime it was started
    /// from is busy (its one worker blocked): the bridge's own tasks under load must
    /// not keep a box from answering (its polls are counted missed after 500 ms, and
    /// the box is `down` after 1.6 s), nor from taking a frame when it comes.
    #[tokio::test(flavor = "multi_thread", worker_threads = 1)]
    async fn a_box_answers_while_the_runtime_is_busy() {
        let boxes = MboxBoxes::start(MboxOptions {
            listen: SocketAddr::from(([127, 0, 0, 1], 0)),
            boxes: 1,
            axes: AxisCount::Three,
            ip: Ipv4Addr::new(192, 168, 15, 201),
            drop_percent: 0,
            seed: 0,
        })
        .await
        .expect("the box");
        let to = boxes.boxes()[0].socket;
        // The runtime's only worker busy for 3 s (as a long synchronous stretch of work
        // would keep it).
        let busy = Arc::new(AtomicBool::new(true));
        let (started, began) = std::sync::mpsc::channel();
        let blocker = {
            let busy = Arc::clone(&busy);
            tokio::spawn(async move {
                let _ = started.send(());
                std::thread::sleep(Duration::from_secs(3));
                busy.store(false, Ordering::SeqCst);
            })
        };
        began.recv().expect("the worker is busy");
        let socket = std::net::UdpSocket::bind("127.0.0.1:0").expect("a socket");
        socket
            .set_read_timeout(Some(Duration::from_secs(10)))
            .expect("a timeout");
        let read = RegisterRead {
            bank: ReadBank::Fn,
            route: Route::BROADCAST,
            range: RegisterRange::new(FN_IP, 4).expect("a range"),
        };
        socket.send_to(&read.encode(), to).expect("sent");
        let mut buffer = [0u8; 256];
        let length = socket.recv(&mut buffer).expect("an answer");
        let answered_while_busy = busy.load(Ordering::SeqCst);
        match Datagram::decode(&buffer[..length]) {
            Ok(Datagram::ReadReply(reply)) => {
                assert_eq!(reply.block.values(), [192, 168, 15, 201]);
            }
            other => panic!("not a register reply: {other:?}"),
        }
        assert!(
            answered_while_busy,
            "the box answered only once the runtime was free again"
        );
        blocker.await.expect("the blocker");
        let snapshots = boxes.stop().await;
        assert_eq!(snapshots.len(), 1);
        assert_eq!(snapshots[0].counters.register_reads, 1);
    }
}
