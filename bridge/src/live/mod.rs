//! Live input's receivers (issue 38, step 3; `docs/live.md`): Art-Net and sACN in,
//! merged and patched into what each ball's slots ask for, published as a
//! [`LiveInput`] snapshot that the live mode reads each step. Nothing here moves a
//! ball: input is only observed.
//!
//! The receivers run while `[live] enabled` ([`crate::config::LiveConfig`]):
//! - **Art-Net** on `artnet_listen` (UDP 6454): `ArtDmx` for the patched universes,
//!   and every `ArtPoll` answered with the bridge's `ArtPollReply`s (one per four
//!   patched universes of a Net and Sub-Net) sent to the poller's address on port
//!   6454 (Art-Net 4), and to its own port too when it polled from another one. When
//!   the timecode chase takes Art-Net on the same address, ONE socket and ONE reader
//!   serve both ([`crate::timecode::receive::artnet`] dispatches on the OpCode:
//!   OpTimeCode to the chase, everything else here).
//! - **sACN** on `sacn_listen` (UDP 5568): unicast, and multicast — the group
//!   239.255.hi.lo of every patched universe joined on `sacn_interface`.
//!
//! The readers ([`receive`]) hold no state: each datagram goes, with its sender and
//! arrival, over a bounded channel ([`Feed`]) to the one live task, which owns the
//! state — the merge ([`floatball_shared::live::merge`]: highest priority, then
//! latest; sACN's sequence rule and stream termination), the sources seen, the
//! counters — and publishes a new `Arc<LiveInput>` on a `watch` channel
//! ([`AppState::subscribe_live`]) at most every [`PUBLISH_EVERY`] (a change after a
//! quiet period at once; new values are not held back by a snapshot that only
//! counted packets, a console repeating its values), when something
//! changed. No lock is taken: the snapshot is a value.
//!
//! A universe's balls have a target while the universe is **live**: a source of it
//! is live in the merge and its latest accepted packet is at most `hold_after_ms` old;
//! otherwise their targets are `None` (the live mode holds them). The input is
//! **lost** when no patched universe is live. Sources drop out of the merge after
//! E1.31's network data loss (2.5 s) or `hold_after_ms`, whichever is longer, or at
//! once with an sACN stream-terminated packet.
//!
//! A new patch (`PUT /api/live/patch`, which replaces the configuration) is taken by
//! the live task from the configuration's watch: the merge is rebuilt for the new
//! universes and the multicast groups joined and left, without a restart.
//!
//! Every datagram is counted ([`LiveCounters`]): per protocol, accepted, malformed by
//! reason, out of sequence and the other refusals of the merge; nothing panics on any
//! datagram (the decoders are the shared ones, fuzzed). `GET /api/live/status`
//! ([`status`]) reports them.

pub mod receive;
pub mod record;

use std::collections::{BTreeMap, BTreeSet};
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use floatball_shared::live::artnet::{self, ArtNetError, PollReply};
use floatball_shared::live::merge::{Fed, Merge, SourceId};
use floatball_shared::live::patch::{BallTarget, Patch, Scale};
use floatball_shared::live::sacn::{self, SacnError};
use serde::{Deserialize, Serialize};
use tokio::net::UdpSocket;
use tokio::sync::mpsc;
use tokio::time::Instant;

use crate::config::{Config, LiveConfig};
use crate::state::AppState;

/// Most snapshots a second: one every this long at most, when input changed.
pub const PUBLISH_EVERY: Duration = Duration::from_millis(10);

/// Datagrams waiting for the live task, at most; more are dropped and counted.
pub const QUEUED: usize = 4096;

/// Most `ArtPoll`s answered a second (the rest are counted, not answered): a reply is
/// up to ten datagrams, so a flood of polls is not amplified.
pub const POLLS_ANSWERED_PER_S: u32 = 20;

/// Most unpatched universes remembered as seen.
pub const UNPATCHED_SEEN_MAX: usize = 256;

/// Which protocol a datagram came in on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Protocol {
    /// Art-Net (UDP 6454).
    Artnet,
    /// sACN, E1.31 (UDP 5568).
    Sacn,
}

/// One datagram as it arrived.
#[derive(Debug)]
pub struct Datagram {
    /// The socket it came in on.
    pub protocol: Protocol,
    /// Its bytes.
    pub bytes: Vec<u8>,
    /// Its sender.
    pub from: SocketAddr,
    /// When it arrived.
    pub at: Instant,
}

/// Where the readers hand datagrams to the live task.
#[derive(Debug, Clone)]
pub struct Feed {
    sender: mpsc::Sender<Datagram>,
    dropped: Arc<AtomicU64>,
}

impl Feed {
    /// Hands a datagram over (a copy of `bytes`); counts it dropped when the live task
    /// is behind. `false` once the live task is gone.
    pub fn offer(&self, protocol: Protocol, bytes: &[u8], from: SocketAddr, at: Instant) -> bool {
        let datagram = Datagram {
            protocol,
            bytes: bytes.to_vec(),
            from,
            at,
        };
        match self.sender.try_send(datagram) {
            Ok(()) => true,
            Err(mpsc::error::TrySendError::Full(_)) => {
                self.dropped.fetch_add(1, Ordering::Relaxed);
                true
            }
            Err(mpsc::error::TrySendError::Closed(_)) => false,
        }
    }
}

/// What the receivers counted since the bridge started.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LiveCounters {
    /// Datagrams on the Art-Net socket (timecode aside).
    pub artnet_packets: u64,
    /// Datagrams on the sACN socket.
    pub sacn_packets: u64,
    /// DMX packets whose slots the merge took.
    pub accepted: u64,
    /// Datagrams refused as malformed, by reason (`artnet_truncated`,
    /// `sacn_bad_length`…).
    pub malformed: BTreeMap<String, u64>,
    /// sACN packets out of sequence (E1.31 §6.7.2), dropped.
    pub out_of_sequence: u64,
    /// DMX for a universe that is not patched.
    pub not_patched: u64,
    /// sACN preview data, not used.
    pub preview: u64,
    /// DMX with a start code other than 0, not used.
    pub start_code: u64,
    /// sACN stream-terminated packets (the source left its universe).
    pub terminated: u64,
    /// DMX refused because its universe already had the most sources.
    pub too_many_sources: u64,
    /// Valid packets of no use here (other Art-Net OpCodes, sACN discovery and sync).
    pub ignored: u64,
    /// `ArtPoll`s received.
    pub polls: u64,
    /// `ArtPollReply` datagrams sent.
    pub poll_replies: u64,
    /// `ArtPoll`s left unanswered (more than [`POLLS_ANSWERED_PER_S`] a second).
    pub polls_unanswered: u64,
    /// Datagrams dropped because the live task was behind.
    pub dropped: u64,
    /// Multicast groups that could not be joined.
    pub joins_failed: u64,
}

/// One source of one universe, as last heard.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceInfo {
    /// Its universe.
    pub universe: u16,
    /// Art-Net or sACN.
    pub protocol: Protocol,
    /// The address its packets come from.
    pub from: SocketAddr,
    /// sACN: its CID, as a UUID.
    pub cid: Option<String>,
    /// sACN: its source name.
    pub name: String,
    /// Its priority (Art-Net: 100).
    pub priority: u8,
    /// Whether its slots are the universe's.
    pub winning: bool,
    /// When its latest accepted packet arrived.
    pub received_at: Instant,
    /// Its packets accepted.
    pub packets: u64,
}

/// One patched universe.
#[derive(Debug, Clone, PartialEq)]
pub struct UniverseInput {
    /// The universe (1–63999, as consoles number them).
    pub universe: u16,
    /// Balls patched on it.
    pub balls: usize,
    /// Its sources in the merge.
    pub sources: usize,
    /// Whether its balls have targets (a live source, heard within `hold_after_ms`).
    pub live: bool,
    /// When its latest accepted packet arrived.
    pub received_at: Option<Instant>,
}

/// The live input as received: what the live mode reads each step
/// ([`AppState::subscribe_live`]). A new value is published whenever input changes
/// (at most every [`PUBLISH_EVERY`]) or a universe is lost or found.
#[derive(Debug, Clone, Default)]
pub struct LiveInput {
    /// Whether the receivers run (`[live] enabled`).
    pub running: bool,
    /// One more with every snapshot.
    pub generation: u64,
    /// Per ball, row-major as the patch and the show: what its slots ask for; `None`
    /// while its universe is not live (no source, or silent for `hold_after_ms`),
    /// or the slots sent do not reach its channels. Shared between snapshots until it
    /// changes.
    pub targets: Arc<Vec<Option<BallTarget>>>,
    /// When the latest accepted DMX packet (any patched universe) arrived.
    pub received_at: Option<Instant>,
    /// No patched universe is live: input is lost (or never came).
    pub lost: bool,
    /// `[live] hold_after_ms` in force.
    pub hold_after_ms: u32,
    /// The patched universes, in order.
    pub universes: Vec<UniverseInput>,
    /// Unpatched universes DMX arrived for (at most [`UNPATCHED_SEEN_MAX`]).
    pub unpatched_seen: Vec<u16>,
    /// Every source in the merge, by universe.
    pub sources: Vec<SourceInfo>,
    /// The counters.
    pub counters: LiveCounters,
}

/// The sockets bound for live input before the bridge starts.
#[derive(Debug)]
pub struct Bound {
    /// Art-Net's socket, and whether the timecode chase's reader reads it.
    artnet: Option<(Arc<UdpSocket>, bool)>,
    /// sACN's socket.
    sacn: Option<Arc<UdpSocket>>,
}

/// Binds the live input's sockets as `config` says (before the bridge starts, so
/// that a port in use stops the start with its reason); `timecode` is the timecode
/// chase's Art-Net socket and its address, shared when it is `artnet_listen`.
///
/// # Errors
/// An address cannot be bound.
pub fn bind(
    config: &LiveConfig,
    timecode: Option<(&Arc<UdpSocket>, SocketAddr)>,
) -> std::io::Result<Bound> {
    let artnet = if config.artnet {
        match timecode {
            Some((socket, listen)) if listen == config.artnet_listen => {
                Some((Arc::clone(socket), true))
            }
            _ => Some((
                Arc::new(crate::timecode::receive::bind_artnet(config.artnet_listen)?),
                false,
            )),
        }
    } else {
        None
    };
    let sacn = if config.sacn {
        Some(Arc::new(receive::bind_sacn(config.sacn_listen)?))
    } else {
        None
    };
    Ok(Bound { artnet, sacn })
}

/// Starts the live task and the readers of its own sockets; returns the [`Feed`] the
/// timecode chase's Art-Net reader hands datagrams to when the socket is shared.
/// Must run inside the async runtime.
pub fn spawn(state: AppState, bound: Bound) -> Option<Feed> {
    let (sender, datagrams) = mpsc::channel(QUEUED);
    let dropped = Arc::new(AtomicU64::new(0));
    let feed = Feed {
        sender,
        dropped: Arc::clone(&dropped),
    };
    let mut shared = None;
    if let Some((socket, is_shared)) = &bound.artnet {
        if *is_shared {
            shared = Some(feed.clone());
        } else {
            tokio::spawn(receive::read(
                Arc::clone(socket),
                Protocol::Artnet,
                feed.clone(),
                state.stopping(),
            ));
        }
    }
    if let Some(socket) = &bound.sacn {
        tokio::spawn(receive::read(
            Arc::clone(socket),
            Protocol::Sacn,
            feed.clone(),
            state.stopping(),
        ));
    }
    drop(feed);
    tokio::spawn(run(state, bound, datagrams, dropped));
    shared
}

/// The live task: owns the merge and the counters until the bridge stops.
async fn run(
    state: AppState,
    bound: Bound,
    mut datagrams: mpsc::Receiver<Datagram>,
    dropped: Arc<AtomicU64>,
) {
    let mut configs = state.subscribe_config();
    let mut stopping = state.stopping();
    let config = Arc::clone(&configs.borrow_and_update());
    let mut live = Live::new(
        &config,
        bound.artnet.map(|(socket, _)| socket),
        bound.sacn,
        Instant::now(),
    );
    let mut tick = tokio::time::interval(PUBLISH_EVERY);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    state.publish_live(live.snapshot(Instant::now()));
    // When the last snapshot went out, and the last that carried new values: a change
    // after a quiet period goes out at once (its latency is the drive's alone), changes
    // coming faster at most every `PUBLISH_EVERY` (the tick sends what waited); a
    // snapshot that only counted packets (a console repeating its values) holds no
    // new value back ([`publish_now`]).
    let mut published_at = Instant::now();
    let mut values_published_at = published_at;
    loop {
        tokio::select! {
            _ = stopping.changed() => return,
            changed = configs.changed() => {
                if changed.is_err() {
                    return;
                }
                let config = Arc::clone(&configs.borrow_and_update());
                live.reconfigure(&config);
            }
            datagram = datagrams.recv() => {
                let Some(datagram) = datagram else { return };
                live.take(&datagram);
                // What else waits, at once (bounded: the tick still comes).
                for _ in 0..256 {
                    match datagrams.try_recv() {
                        Ok(datagram) => live.take(&datagram),
                        Err(_) => break,
                    }
                }
                let now = Instant::now();
                let values = live.values_changed;
                if publish_now(now, published_at, values.then_some(values_published_at)) {
                    live.counters.dropped = dropped.load(Ordering::Relaxed);
                    if live.due(now) {
                        state.publish_live(live.snapshot(now));
                        published_at = now;
                        if values {
                            values_published_at = now;
                        }
                    }
                }
            }
            _ = tick.tick() => {
                live.counters.dropped = dropped.load(Ordering::Relaxed);
                let now = Instant::now();
                let values = live.values_changed;
                if live.due(now) {
                    state.publish_live(live.snapshot(now));
                    published_at = now;
                    if values {
                        values_published_at = now;
                    }
                }
            }
        }
    }
}

/// Whether a datagram just taken publishes a snapshot at `now` (the last went out at
/// `published_at`): when the last is [`PUBLISH_EVERY`] old, or when the datagram
/// brought new values (`values`: when the last snapshot with new values went out)
/// and that one is. A snapshot that only counted packets — a console repeating its
/// values — then does not hold a new value back by up to a tick.
fn publish_now(now: Instant, published_at: Instant, values: Option<Instant>) -> bool {
    now.saturating_duration_since(published_at) >= PUBLISH_EVERY
        || values.is_some_and(|at| now.saturating_duration_since(at) >= PUBLISH_EVERY)
}

/// What a source was last heard as.
#[derive(Debug, Clone)]
struct Heard {
    protocol: Protocol,
    from: SocketAddr,
    name: String,
    priority: u8,
    received_at: Instant,
    packets: u64,
}

/// The live task's state (no I/O but the poll replies and the multicast joins).
struct Live {
    patch: Patch,
    scale: Scale,
    hold_after: Duration,
    /// How long a silent source stays in the merge, ms.
    timeout_ms: u64,
    merge: Merge,
    /// The balls of each patched universe.
    balls_of: BTreeMap<u16, Vec<usize>>,
    targets: Arc<Vec<Option<BallTarget>>>,
    /// Universes whose targets are to be worked out again.
    dirty: BTreeSet<u16>,
    /// The latest accepted packet of each patched universe.
    universe_heard: BTreeMap<u16, Instant>,
    /// The universes live at the last snapshot.
    live_then: BTreeSet<u16>,
    received_at: Option<Instant>,
    sources: BTreeMap<(u16, SourceId), Heard>,
    unpatched_seen: BTreeSet<u16>,
    counters: LiveCounters,
    counters_then: LiveCounters,
    generation: u64,
    epoch: Instant,
    artnet: Option<Arc<UdpSocket>>,
    artnet_listen: SocketAddr,
    sacn: Option<Arc<UdpSocket>>,
    interface: Ipv4Addr,
    joined: BTreeSet<u16>,
    /// The second polls are answered in, and how many were.
    poll_second: (u64, u32),
    last_expire: Instant,
    config_live: LiveConfig,
    /// Each universe's merged slots as last compared ([`Live::values_changed`]).
    slots_seen: BTreeMap<u16, Vec<u8>>,
    /// An accepted packet changed a universe's merged slots since the last snapshot
    /// (a repeat of the same values does not).
    values_changed: bool,
}

/// The installation's scale for DMX values.
fn scale_of(config: &Config) -> Scale {
    Scale {
        travel_mm: config.installation.limits.travel_mm,
        max_speed_mm_s: config.installation.limits.max_speed_mm_s,
    }
}

/// The malformation's name in the counters.
fn artnet_reason(error: &ArtNetError) -> &'static str {
    match error {
        ArtNetError::Truncated { .. } => "artnet_truncated",
        ArtNetError::BadId => "artnet_bad_id",
        ArtNetError::OldVersion { .. } => "artnet_old_version",
        ArtNetError::BadLength { .. } => "artnet_bad_length",
        ArtNetError::BadNet { .. } => "artnet_bad_net",
    }
}

/// The malformation's name in the counters.
fn sacn_reason(error: &SacnError) -> &'static str {
    match error {
        SacnError::Truncated { .. } => "sacn_truncated",
        SacnError::TooLong { .. } => "sacn_too_long",
        SacnError::BadPreamble { .. } => "sacn_bad_preamble",
        SacnError::BadIdentifier => "sacn_bad_identifier",
        SacnError::BadLength { .. } => "sacn_bad_length",
        SacnError::BadRootVector { .. } => "sacn_bad_root_vector",
        SacnError::BadFramingVector { .. } => "sacn_bad_framing_vector",
        SacnError::BadDmp => "sacn_bad_dmp",
        SacnError::BadCount { .. } => "sacn_bad_count",
        SacnError::BadPriority { .. } => "sacn_bad_priority",
        SacnError::BadUniverse { .. } => "sacn_bad_universe",
    }
}

/// A CID as a UUID.
fn uuid(cid: &[u8; 16]) -> String {
    let hex: String = cid.iter().map(|byte| format!("{byte:02x}")).collect();
    format!(
        "{}-{}-{}-{}-{}",
        &hex[..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..]
    )
}

impl Live {
    fn new(
        config: &Config,
        artnet: Option<Arc<UdpSocket>>,
        sacn: Option<Arc<UdpSocket>>,
        now: Instant,
    ) -> Self {
        let live = &config.live;
        let mut this = Self {
            patch: Patch::default(),
            scale: scale_of(config),
            hold_after: Duration::ZERO,
            timeout_ms: sacn::NETWORK_DATA_LOSS_MS,
            merge: Merge::new([], sacn::NETWORK_DATA_LOSS_MS),
            balls_of: BTreeMap::new(),
            targets: Arc::new(Vec::new()),
            dirty: BTreeSet::new(),
            universe_heard: BTreeMap::new(),
            live_then: BTreeSet::new(),
            received_at: None,
            sources: BTreeMap::new(),
            unpatched_seen: BTreeSet::new(),
            counters: LiveCounters::default(),
            counters_then: LiveCounters::default(),
            generation: 0,
            epoch: now,
            artnet,
            artnet_listen: live.artnet_listen,
            sacn,
            interface: live.sacn_interface,
            joined: BTreeSet::new(),
            poll_second: (u64::MAX, 0),
            last_expire: now,
            config_live: live.clone(),
            slots_seen: BTreeMap::new(),
            values_changed: false,
        };
        this.apply(config);
        this
    }

    /// Milliseconds since the task started (the merge's clock).
    fn ms(&self, at: Instant) -> u64 {
        u64::try_from(at.saturating_duration_since(self.epoch).as_millis()).unwrap_or(u64::MAX)
    }

    /// Takes `config`'s patch, hold time and scale: a new merge for the universes,
    /// the multicast groups joined and left.
    fn apply(&mut self, config: &Config) {
        let live = &config.live;
        self.config_live = live.clone();
        self.patch = live.patch.clone();
        self.scale = scale_of(config);
        self.hold_after = Duration::from_millis(u64::from(live.hold_after_ms));
        self.timeout_ms = sacn::NETWORK_DATA_LOSS_MS.max(u64::from(live.hold_after_ms));
        let universes = self.patch.universes();
        self.merge = Merge::new(universes.iter().copied(), self.timeout_ms);
        self.balls_of = BTreeMap::new();
        for (ball, entry) in self.patch.balls.iter().enumerate() {
            self.balls_of.entry(entry.universe).or_default().push(ball);
        }
        self.targets = Arc::new(vec![None; self.patch.balls.len()]);
        self.dirty.clear();
        self.universe_heard.clear();
        self.live_then.clear();
        self.sources.clear();
        self.unpatched_seen.clear();
        self.join(&universes);
        self.generation += 1;
    }

    /// A new configuration: applied when `[live]` or the scale changed.
    fn reconfigure(&mut self, config: &Config) {
        if config.live == self.config_live && scale_of(config) == self.scale {
            return;
        }
        tracing::info!(
            "live input: a new patch, {} balls on {} universe(s)",
            config.live.patch.balls.len(),
            config.live.patch.universes().len()
        );
        self.apply(config);
    }

    /// Joins the multicast groups of `universes` (and leaves the others).
    fn join(&mut self, universes: &[u16]) {
        let Some(socket) = &self.sacn else { return };
        let wanted: BTreeSet<u16> = universes.iter().copied().collect();
        for &universe in self.joined.difference(&wanted) {
            let group = Ipv4Addr::from(sacn::multicast_address(universe));
            if let Err(error) = socket.leave_multicast_v4(group, self.interface) {
                tracing::debug!("sACN: leaving {group}: {error}");
            }
        }
        self.joined.retain(|universe| wanted.contains(universe));
        let mut failed = Vec::new();
        for &universe in &wanted {
            if self.joined.contains(&universe) {
                continue;
            }
            let group = Ipv4Addr::from(sacn::multicast_address(universe));
            match socket.join_multicast_v4(group, self.interface) {
                Ok(()) => {
                    self.joined.insert(universe);
                }
                Err(error) => {
                    self.counters.joins_failed += 1;
                    failed.push(format!("{group} ({error})"));
                }
            }
        }
        if !failed.is_empty() {
            tracing::warn!(
                "sACN: cannot join {} multicast group(s) on {}: {} — those universes \
                 come only by unicast (Linux joins 20 groups a socket unless \
                 net.ipv4.igmp_max_memberships is raised)",
                failed.len(),
                self.interface,
                failed.join(", ")
            );
        }
    }

    /// One datagram.
    fn take(&mut self, datagram: &Datagram) {
        let now_ms = self.ms(datagram.at);
        match datagram.protocol {
            Protocol::Artnet => {
                self.counters.artnet_packets += 1;
                match artnet::decode(&datagram.bytes) {
                    Ok(artnet::Packet::Dmx(dmx)) => {
                        let IpAddr::V4(ip) = datagram.from.ip() else {
                            self.counters.ignored += 1;
                            return;
                        };
                        let universe = dmx.port_address.universe();
                        let fed = self.merge.artnet(ip.octets(), &dmx, now_ms);
                        self.fed(
                            fed,
                            universe,
                            SourceId::ArtNet(ip.octets()),
                            datagram,
                            String::new(),
                            sacn::DEFAULT_PRIORITY,
                        );
                    }
                    Ok(artnet::Packet::Poll(_)) => {
                        self.counters.polls += 1;
                        self.answer_poll(datagram.from, datagram.at);
                    }
                    Ok(artnet::Packet::Other { .. }) => self.counters.ignored += 1,
                    Err(error) => self.malformed(artnet_reason(&error), datagram, &error),
                }
            }
            Protocol::Sacn => {
                self.counters.sacn_packets += 1;
                match sacn::decode(&datagram.bytes) {
                    Ok(sacn::Packet::Data(packet)) => {
                        let fed = self.merge.sacn(&packet, now_ms);
                        let name = String::from_utf8_lossy(packet.source_name).into_owned();
                        self.fed(
                            fed,
                            packet.universe,
                            SourceId::Sacn(packet.cid),
                            datagram,
                            name,
                            packet.priority,
                        );
                    }
                    Ok(sacn::Packet::Discovery { .. } | sacn::Packet::Sync { .. }) => {
                        self.counters.ignored += 1;
                    }
                    Err(error) => self.malformed(sacn_reason(&error), datagram, &error),
                }
            }
        }
    }

    /// Counts a malformed datagram (logged at debug level).
    fn malformed(&mut self, reason: &str, datagram: &Datagram, error: &dyn std::fmt::Display) {
        tracing::debug!("live input from {}: {error}", datagram.from);
        *self
            .counters
            .malformed
            .entry(reason.to_owned())
            .or_default() += 1;
    }

    /// What the merge did with a DMX packet.
    fn fed(
        &mut self,
        fed: Fed,
        universe: u16,
        source: SourceId,
        datagram: &Datagram,
        name: String,
        priority: u8,
    ) {
        match fed {
            Fed::Accepted => {
                self.counters.accepted += 1;
                let slots = self.merge.slots(universe, self.ms(datagram.at));
                let seen = self.slots_seen.entry(universe).or_default();
                if slots.is_some_and(|slots| slots != seen.as_slice()) {
                    seen.clear();
                    seen.extend_from_slice(slots.unwrap_or_default());
                    self.values_changed = true;
                }
                self.received_at = Some(datagram.at);
                self.universe_heard.insert(universe, datagram.at);
                self.dirty.insert(universe);
                let heard = self.sources.entry((universe, source)).or_insert(Heard {
                    protocol: datagram.protocol,
                    from: datagram.from,
                    name: String::new(),
                    priority,
                    received_at: datagram.at,
                    packets: 0,
                });
                heard.from = datagram.from;
                heard.name = name;
                heard.priority = priority;
                heard.received_at = datagram.at;
                heard.packets += 1;
            }
            Fed::NotPatched => {
                self.counters.not_patched += 1;
                if self.unpatched_seen.len() < UNPATCHED_SEEN_MAX {
                    self.unpatched_seen.insert(universe);
                }
            }
            Fed::OutOfSequence => self.counters.out_of_sequence += 1,
            Fed::Preview => self.counters.preview += 1,
            Fed::StartCode => self.counters.start_code += 1,
            Fed::TooManySources => self.counters.too_many_sources += 1,
            Fed::Terminated => {
                self.counters.terminated += 1;
                self.sources.remove(&(universe, source));
                self.dirty.insert(universe);
            }
        }
    }

    /// Answers an `ArtPoll` from `from` with the bridge's `ArtPollReply`s.
    fn answer_poll(&mut self, from: SocketAddr, at: Instant) {
        let Some(socket) = &self.artnet else { return };
        let second = self.ms(at) / 1000;
        if self.poll_second.0 != second {
            self.poll_second = (second, 0);
        }
        if self.poll_second.1 >= POLLS_ANSWERED_PER_S {
            self.counters.polls_unanswered += 1;
            return;
        }
        self.poll_second.1 += 1;
        let IpAddr::V4(poller) = from.ip() else {
            self.counters.polls_unanswered += 1;
            return;
        };
        let ip = match self.artnet_listen.ip() {
            IpAddr::V4(ip) if !ip.is_unspecified() => ip,
            _ => local_ip_towards(poller).unwrap_or(Ipv4Addr::UNSPECIFIED),
        };
        let universes: Vec<u16> = self.balls_of.keys().copied().collect();
        let template = PollReply {
            ip: ip.octets(),
            version: 1,
            net: 0,
            sub_net: 0,
            oem: artnet::OEM_UNKNOWN,
            esta: artnet::ESTA_PROTOTYPE,
            short_name: "Floatball".to_owned(),
            long_name: "Floatball kinetic ball matrix: live input".to_owned(),
            node_report: format!(
                "#0001 [{:04}] {} universe(s) patched, {} live",
                self.counters.polls % 10_000,
                universes.len(),
                self.live_then.len()
            ),
            outputs: Vec::new(),
            receiving: [false; 4],
            mac: [0; 6],
            bind_ip: ip.octets(),
            bind_index: 1,
        };
        let mut targets = vec![SocketAddr::new(IpAddr::V4(poller), artnet::PORT)];
        if from.port() != artnet::PORT {
            targets.push(from);
        }
        for mut reply in PollReply::for_universes(&template, &universes) {
            for (port, &low) in reply.outputs.iter().enumerate().take(4) {
                let universe = (u16::from(reply.net) << 8 | u16::from(reply.sub_net) << 4)
                    + u16::from(low)
                    + 1;
                reply.receiving[port] = self.live_then.contains(&universe);
            }
            let bytes = reply.encode();
            for to in &targets {
                match socket.try_send_to(&bytes, *to) {
                    Ok(_) => self.counters.poll_replies += 1,
                    Err(error) => tracing::debug!("Art-Net: ArtPollReply to {to}: {error}"),
                }
            }
        }
    }

    /// The universes live at `now`.
    fn live_universes(&self, now: Instant) -> BTreeSet<u16> {
        let now_ms = self.ms(now);
        self.universe_heard
            .iter()
            .filter(|&(&universe, &heard)| {
                now.saturating_duration_since(heard) <= self.hold_after
                    && self.merge.winner(universe, now_ms).is_some()
            })
            .map(|(&universe, _)| universe)
            .collect()
    }

    /// Whether a snapshot is due at `now`: input changed, a universe was lost or
    /// found, or the counters moved.
    fn due(&mut self, now: Instant) -> bool {
        if now.saturating_duration_since(self.last_expire) >= Duration::from_secs(1) {
            self.last_expire = now;
            let now_ms = self.ms(now);
            if self.merge.expire(now_ms) > 0 {
                let timeout = Duration::from_millis(self.timeout_ms);
                self.sources
                    .retain(|_, heard| now.saturating_duration_since(heard.received_at) <= timeout);
            }
        }
        !self.dirty.is_empty()
            || self.live_universes(now) != self.live_then
            || self.counters != self.counters_then
    }

    /// A snapshot at `now`, the targets of the universes that changed worked out.
    fn snapshot(&mut self, now: Instant) -> Arc<LiveInput> {
        let now_ms = self.ms(now);
        let live = self.live_universes(now);
        let changed: BTreeSet<u16> = live
            .symmetric_difference(&self.live_then)
            .copied()
            .chain(self.dirty.iter().copied())
            .collect();
        if !changed.is_empty() {
            let targets = Arc::make_mut(&mut self.targets);
            for universe in &changed {
                let slots = if live.contains(universe) {
                    self.merge.slots(*universe, now_ms)
                } else {
                    None
                };
                for &ball in self.balls_of.get(universe).into_iter().flatten() {
                    if let Some(target) = targets.get_mut(ball) {
                        *target =
                            slots.and_then(|slots| self.patch.target(ball, slots, self.scale));
                    }
                }
            }
        }
        self.dirty.clear();
        self.values_changed = false;
        self.live_then = live;
        self.counters_then = self.counters.clone();
        self.generation += 1;
        let winners: BTreeMap<u16, SourceId> = self
            .balls_of
            .keys()
            .filter_map(|&universe| {
                self.merge
                    .winner(universe, now_ms)
                    .map(|winner| (universe, winner.source))
            })
            .collect();
        Arc::new(LiveInput {
            running: true,
            generation: self.generation,
            targets: Arc::clone(&self.targets),
            received_at: self.received_at,
            lost: self.live_then.is_empty(),
            hold_after_ms: self.config_live.hold_after_ms,
            universes: self
                .balls_of
                .iter()
                .map(|(&universe, balls)| UniverseInput {
                    universe,
                    balls: balls.len(),
                    sources: self.merge.source_count(universe),
                    live: self.live_then.contains(&universe),
                    received_at: self.universe_heard.get(&universe).copied(),
                })
                .collect(),
            unpatched_seen: self.unpatched_seen.iter().copied().collect(),
            sources: self
                .sources
                .iter()
                .map(|(&(universe, source), heard)| SourceInfo {
                    universe,
                    protocol: heard.protocol,
                    from: heard.from,
                    cid: match source {
                        SourceId::Sacn(cid) => Some(uuid(&cid)),
                        SourceId::ArtNet(_) => None,
                    },
                    name: heard.name.clone(),
                    priority: heard.priority,
                    winning: winners.get(&universe) == Some(&source),
                    received_at: heard.received_at,
                    packets: heard.packets,
                })
                .collect(),
            counters: self.counters.clone(),
        })
    }
}

/// The bridge's own address on the way to `peer` (no packet is sent).
fn local_ip_towards(peer: Ipv4Addr) -> Option<Ipv4Addr> {
    let socket = std::net::UdpSocket::bind((Ipv4Addr::UNSPECIFIED, 0)).ok()?;
    socket.connect((peer, artnet::PORT)).ok()?;
    match socket.local_addr().ok()?.ip() {
        IpAddr::V4(ip) => Some(ip),
        IpAddr::V6(_) => None,
    }
}

/// A ball's target as `GET /api/live/status` gives it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetStatus {
    /// The ball, row-major from 0.
    pub ball: usize,
    /// Position, mm below the top.
    pub position_mm: f64,
    /// Speed limit, mm/s, if patched.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_limit_mm_s: Option<f64>,
    /// Whether the ball follows.
    pub enabled: bool,
    /// Colour, if patched.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rgb: Option<[u8; 3]>,
}

/// A patched universe as `GET /api/live/status` gives it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct UniverseStatus {
    /// The universe.
    pub universe: u16,
    /// Balls patched on it.
    pub balls: usize,
    /// Sources in the merge.
    pub sources: usize,
    /// Its balls have targets.
    pub live: bool,
    /// Since its latest accepted packet, ms (none yet: absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub received_ms_ago: Option<u64>,
}

/// A source as `GET /api/live/status` gives it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SourceStatus {
    /// Its universe.
    pub universe: u16,
    /// `artnet` or `sacn`.
    pub protocol: Protocol,
    /// Where its packets come from.
    pub from: String,
    /// sACN: its CID.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cid: Option<String>,
    /// sACN: its name.
    #[serde(default)]
    pub name: String,
    /// Its priority (Art-Net: 100).
    pub priority: u8,
    /// Its slots are the universe's.
    pub winning: bool,
    /// Since its latest accepted packet, ms.
    pub received_ms_ago: u64,
    /// Its packets accepted.
    pub packets: u64,
}

/// `GET /api/live/status`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LiveStatus {
    /// The receivers run (`[live] enabled`).
    pub running: bool,
    /// Which snapshot this is.
    pub generation: u64,
    /// No patched universe is live.
    pub lost: bool,
    /// `[live] hold_after_ms`.
    pub hold_after_ms: u32,
    /// Since the latest accepted packet, ms (none yet: absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub received_ms_ago: Option<u64>,
    /// The counters.
    pub counters: LiveCounters,
    /// The patched universes.
    pub universes: Vec<UniverseStatus>,
    /// Unpatched universes DMX came for.
    pub unpatched_seen: Vec<u16>,
    /// The sources in the merge.
    pub sources: Vec<SourceStatus>,
    /// Balls patched.
    pub balls: usize,
    /// The first ball of `targets`.
    pub from: usize,
    /// Balls `from`… (at most `count`): each one's target, or `null` while it has
    /// none.
    pub targets: Vec<Option<TargetStatus>>,
}

/// Most targets one `GET /api/live/status` gives.
pub const MAX_STATUS_TARGETS: usize = 1000;

/// The status of `input` at `now`, with the targets of balls `from`… (at most
/// `count`, itself at most [`MAX_STATUS_TARGETS`]).
pub fn status(input: &LiveInput, now: Instant, from: usize, count: usize) -> LiveStatus {
    let ago = |at: Instant| {
        u64::try_from(now.saturating_duration_since(at).as_millis()).unwrap_or(u64::MAX)
    };
    let count = count.min(MAX_STATUS_TARGETS);
    LiveStatus {
        running: input.running,
        generation: input.generation,
        lost: input.lost,
        hold_after_ms: input.hold_after_ms,
        received_ms_ago: input.received_at.map(ago),
        counters: input.counters.clone(),
        universes: input
            .universes
            .iter()
            .map(|universe| UniverseStatus {
                universe: universe.universe,
                balls: universe.balls,
                sources: universe.sources,
                live: universe.live,
                received_ms_ago: universe.received_at.map(ago),
            })
            .collect(),
        unpatched_seen: input.unpatched_seen.clone(),
        sources: input
            .sources
            .iter()
            .map(|source| SourceStatus {
                universe: source.universe,
                protocol: source.protocol,
                from: source.from.to_string(),
                cid: source.cid.clone(),
                name: source.name.clone(),
                priority: source.priority,
                winning: source.winning,
                received_ms_ago: ago(source.received_at),
                packets: source.packets,
            })
            .collect(),
        balls: input.targets.len(),
        from,
        targets: input
            .targets
            .iter()
            .enumerate()
            .skip(from)
            .take(count)
            .map(|(ball, target)| {
                target.map(|target| TargetStatus {
                    ball,
                    position_mm: target.position_mm,
                    speed_limit_mm_s: target.speed_limit_mm_s,
                    enabled: target.enabled,
                    rgb: target.rgb,
                })
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use floatball_shared::live::artnet::PortAddress;
    use floatball_shared::live::sacn::{DataPacket, Options};

    use super::*;
    use crate::config::Overrides;

    /// 1 × 4 balls, travel 2000 mm, balls 0–2 on universe 1, ball 3 on universe 2.
    fn config(ball_3_universe: u16) -> Config {
        let text = format!(
            "[matrix]\nrows = 1\ncols = 4\ntravel_mm = 2000.0\n\
             [[gateway]]\nport = \"sim\"\n\
             [live]\nenabled = true\nhold_after_ms = 500\n\
             [[live.ball]]\nball = 3\nuniverse = {ball_3_universe}\naddress = 1\n"
        );
        Config::parse(
            Path::new("data/floatball.toml"),
            &text,
            &Overrides::default(),
        )
        .unwrap()
    }

    fn artnet(live: &mut Live, universe: u16, data: &[u8], at: Instant) {
        live.take(&Datagram {
            protocol: Protocol::Artnet,
            bytes: artnet::encode_dmx(0, PortAddress::of_universe(universe).unwrap(), data),
            from: "10.0.0.5:6454".parse().unwrap(),
            at,
        });
    }

    fn sacn(live: &mut Live, universe: u16, sequence: u8, data: &[u8], at: Instant) {
        live.take(&Datagram {
            protocol: Protocol::Sacn,
            bytes: sacn::encode_data(&DataPacket {
                cid: [7; 16],
                source_name: b"desk",
                priority: 150,
                sync_address: 0,
                sequence,
                options: Options::default(),
                universe,
                start_code: 0,
                data,
            }),
            from: "10.0.0.6:5568".parse().unwrap(),
            at,
        });
    }

    fn position(input: &LiveInput, ball: usize) -> Option<f64> {
        input.targets[ball].map(|target| target.position_mm)
    }

    #[tokio::test]
    async fn merges_patches_and_loses_input() {
        let start = Instant::now();
        let mut live = Live::new(&config(2), None, None, start);
        assert!(live.snapshot(start).lost);
        let at = start + Duration::from_millis(10);
        artnet(&mut live, 1, &[0x80, 0, 0xff, 0xff, 0, 0], at);
        assert!(live.due(at));
        let input = live.snapshot(at);
        assert!(!input.lost);
        assert_eq!(position(&input, 0), Some(0x8000 as f64 / 65535.0 * 2000.0));
        assert_eq!(position(&input, 1), Some(2000.0));
        assert_eq!(position(&input, 2), Some(0.0));
        assert_eq!(position(&input, 3), None, "universe 2 has no source");
        assert!(!live.due(at), "nothing changed");
        // sACN at 150 wins; out of sequence is dropped and counted.
        sacn(&mut live, 1, 10, &[0x10, 0], at);
        sacn(&mut live, 1, 5, &[0x20, 0], at);
        let input = live.snapshot(at);
        assert_eq!(position(&input, 0), Some(0x1000 as f64 / 65535.0 * 2000.0));
        assert_eq!(
            position(&input, 1),
            None,
            "sACN's slots do not reach ball 1"
        );
        assert_eq!(input.counters.out_of_sequence, 1);
        assert_eq!(
            input.sources.iter().filter(|source| source.winning).count(),
            1
        );
        // Silence for longer than hold_after_ms: lost, no targets.
        let later = at + Duration::from_millis(501);
        assert!(live.due(later));
        let input = live.snapshot(later);
        assert!(input.lost);
        assert!(input.targets.iter().all(Option::is_none));
        assert!(!live.due(later));
    }

    /// Issue 38's latency: a console repeating its values every 100 ms publishes a
    /// snapshot each time (the counters); a new value 2 ms after such a repeat goes
    /// out at once, not at the next tick; new values keep their 10 ms pace.
    #[tokio::test]
    async fn a_new_value_is_not_held_back_by_a_repeat_of_the_old_one() {
        let start = Instant::now();
        let mut live = Live::new(&config(2), None, None, start);
        artnet(&mut live, 1, &[0x80, 0], start);
        assert!(live.values_changed);
        let _ = live.snapshot(start);
        assert!(!live.values_changed);
        let repeat = start + Duration::from_millis(100);
        artnet(&mut live, 1, &[0x80, 0], repeat);
        assert!(!live.values_changed, "the same values again");
        assert!(live.due(repeat), "the counters changed");
        let _ = live.snapshot(repeat);
        let new = repeat + Duration::from_millis(2);
        artnet(&mut live, 1, &[0x90, 0], new);
        assert!(live.values_changed);
        assert!(publish_now(new, repeat, Some(start)));
        assert!(
            !publish_now(new, repeat, None),
            "a repeat waits for the tick"
        );
        assert!(
            !publish_now(new, repeat, Some(repeat)),
            "new values at most every 10 ms"
        );
    }

    #[tokio::test]
    async fn a_new_patch_takes_new_universes() {
        let start = Instant::now();
        let mut live = Live::new(&config(2), None, None, start);
        artnet(&mut live, 9, &[1, 2], start);
        assert_eq!(live.counters.not_patched, 1);
        live.reconfigure(&config(9));
        artnet(&mut live, 9, &[0xff, 0xff], start);
        let input = live.snapshot(start);
        assert_eq!(position(&input, 3), Some(2000.0));
        assert_eq!(
            input
                .universes
                .iter()
                .map(|one| one.universe)
                .collect::<Vec<_>>(),
            [1, 9]
        );
    }

    #[tokio::test]
    async fn every_datagram_is_counted_and_none_is_fatal() {
        let start = Instant::now();
        let mut live = Live::new(&config(2), None, None, start);
        let mut noise = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            noise ^= noise << 13;
            noise ^= noise >> 7;
            noise ^= noise << 17;
            noise
        };
        let valid_dmx = artnet::encode_dmx(0, PortAddress::of_universe(1).unwrap(), &[1; 8]);
        let valid_sacn = sacn::encode_data(&DataPacket {
            cid: [1; 16],
            source_name: b"x",
            priority: 100,
            sync_address: 0,
            sequence: 1,
            options: Options::default(),
            universe: 1,
            start_code: 0,
            data: &[1; 8],
        });
        for round in 0..20_000usize {
            let protocol = if round % 2 == 0 {
                Protocol::Artnet
            } else {
                Protocol::Sacn
            };
            // Valid packets with a few bytes changed, or noise.
            let mut bytes = match (round % 3, protocol) {
                (0, _) => (0..(next() % 700) as usize).map(|_| next() as u8).collect(),
                (_, Protocol::Artnet) => valid_dmx.clone(),
                (_, Protocol::Sacn) => valid_sacn.clone(),
            };
            for _ in 0..(next() % 4) {
                if !bytes.is_empty() {
                    let at = (next() as usize) % bytes.len();
                    bytes[at] = next() as u8;
                }
            }
            bytes.truncate(bytes.len() - (next() as usize % 3).min(bytes.len()));
            live.take(&Datagram {
                protocol,
                bytes,
                from: "10.0.0.9:1234".parse().unwrap(),
                at: start,
            });
        }
        let input = live.snapshot(start);
        let counters = &input.counters;
        assert_eq!(counters.artnet_packets + counters.sacn_packets, 20_000);
        let malformed: u64 = counters.malformed.values().sum();
        assert!(malformed > 1_000, "{counters:?}");
        assert!(counters.accepted > 0, "{counters:?}");
    }
}
