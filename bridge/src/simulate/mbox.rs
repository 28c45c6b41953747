//! `floatball simulate --kind mbox`: MBOX boxes on real UDP sockets — for tests on
//! loopback and for demonstrations on a LAN.
//!
//! Each box is a [`MboxTwin`] (the sans-IO twin in `floatball_shared::mbox::twin`) on
//! its own socket, owned by its own task: a datagram is handed to the twin with the
//! time since the boxes started, and the twin's reply, if any, goes back to the
//! sender's address and port. N boxes listen on consecutive ports from the first (or
//! each on a port of the system's choosing when the first is 0), with consecutive IP
//! addresses from the first, so each has its own address in datagrams.
//!
//! [`MboxBoxes::stop`] ends every task and returns each box's final [`SimBox`].

use std::net::{Ipv4Addr, SocketAddr};
use std::time::Instant;

use floatball_shared::api::SimBox;
use floatball_shared::mbox::AxisCount;
use floatball_shared::mbox::twin::{MboxTwin, TwinConfig};
use tokio::net::UdpSocket;
use tokio::sync::{mpsc, oneshot, watch};
use tokio::task::JoinHandle;

/// The largest datagram a box takes (anything longer is cut and refused as malformed).
const MAX_DATAGRAM: usize = 65_536;

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

/// The boxes, each answering on its socket until [`Self::stop`].
#[derive(Debug)]
pub struct MboxBoxes {
    boxes: Vec<RunningBox>,
    stop: watch::Sender<bool>,
    tasks: Vec<JoinHandle<SimBox>>,
    /// Per box: where to ask for its state now.
    asks: Vec<mpsc::UnboundedSender<oneshot::Sender<SimBox>>>,
}

impl MboxBoxes {
    /// Binds every box's socket and starts answering.
    ///
    /// # Errors
    /// A port or IP address past the last one, or a socket that cannot be bound.
    pub async fn start(options: MboxOptions) -> Result<Self, String> {
        Self::spawn(options)
    }

    /// As [`Self::start`], from code that is not async (inside the runtime).
    ///
    /// # Errors
    /// As [`Self::start`].
    pub fn spawn(options: MboxOptions) -> Result<Self, String> {
        let epoch = Instant::now();
        let (stop, stopped) = watch::channel(false);
        let mut boxes = Vec::with_capacity(usize::from(options.boxes));
        let mut tasks = Vec::with_capacity(usize::from(options.boxes));
        let mut asks = Vec::with_capacity(usize::from(options.boxes));
        for index in 0..options.boxes {
            let (listen, ip) = box_at(&options, index)?;
            let socket = std::net::UdpSocket::bind(listen)
                .and_then(|socket| {
                    socket.set_nonblocking(true)?;
                    UdpSocket::from_std(socket)
                })
                .map_err(|err| format!("cannot listen on UDP {listen}: {err}"))?;
            let local = socket
                .local_addr()
                .map_err(|err| format!("cannot read the address of UDP {listen}: {err}"))?;
            let twin = MboxTwin::new(TwinConfig::new(ip, options.axes));
            boxes.push(RunningBox { socket: local, ip });
            let loss = Loss::new(
                options.drop_percent,
                options.seed.wrapping_add(u64::from(index)),
            );
            let (ask, asked) = mpsc::unbounded_channel();
            asks.push(ask);
            tasks.push(tokio::spawn(answer(
                socket,
                twin,
                loss,
                epoch,
                asked,
                stopped.clone(),
            )));
        }
        Ok(Self {
            boxes,
            stop,
            tasks,
            asks,
        })
    }

    /// Every box's state now, in order (a box that stopped is left out).
    pub async fn snapshots(&self) -> Vec<SimBox> {
        let mut snapshots = Vec::with_capacity(self.asks.len());
        for ask in &self.asks {
            let (reply, answer) = oneshot::channel();
            if ask.send(reply).is_ok()
                && let Ok(snapshot) = answer.await
            {
                snapshots.push(snapshot);
            }
        }
        snapshots
    }

    /// The boxes, in order.
    #[must_use]
    pub fn boxes(&self) -> &[RunningBox] {
        &self.boxes
    }

    /// Stops every box; returns each one's final state, in order.
    pub async fn stop(self) -> Vec<SimBox> {
        // Receivers may be gone if a task ended already; the join below says so.
        let _ = self.stop.send(true);
        let mut snapshots = Vec::with_capacity(self.tasks.len());
        for task in self.tasks {
            match task.await {
                Ok(snapshot) => snapshots.push(snapshot),
                Err(err) => tracing::error!("a simulated MBOX stopped unexpectedly: {err}"),
            }
        }
        snapshots
    }
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

/// One box: takes datagrams until `stop`, answers the sender; returns the box's state.
async fn answer(
    socket: UdpSocket,
    mut twin: MboxTwin,
    mut loss: Loss,
    epoch: Instant,
    mut asked: mpsc::UnboundedReceiver<oneshot::Sender<SimBox>>,
    mut stop: watch::Receiver<bool>,
) -> SimBox {
    let micros = || u64::try_from(epoch.elapsed().as_micros()).unwrap_or(u64::MAX);
    let mut buffer = vec![0u8; MAX_DATAGRAM];
    loop {
        tokio::select! {
            received = socket.recv_from(&mut buffer) => match received {
                Ok((len, sender)) => {
                    let datagram = buffer.get(..len).unwrap_or_default();
                    if loss.drops() {
                        continue;
                    }
                    if let Some(reply) = twin.receive(micros(), datagram)
                        && !loss.drops()
                        && let Err(err) = socket.send_to(&reply, sender).await
                    {
                        tracing::warn!("simulated MBOX {}: cannot reply to {sender}: {err}", twin.snapshot().ip);
                    }
                }
                // On Linux an ICMP "port unreachable" for an earlier reply surfaces
                // here; the box carries on, as a real one does.
                Err(err) => tracing::debug!("simulated MBOX: receive failed: {err}"),
            },
            Some(reply) = asked.recv() => {
                twin.advance(micros());
                let _ = reply.send(twin.snapshot());
            }
            _ = stop.changed() => break,
        }
    }
    twin.advance(micros());
    twin.snapshot()
}
