//! The fuzz storm with a motion oracle (issue 52): every reader of untrusted input of
//! the real `floatball` binary is fed random, mutated and structure-aware hostile
//! input at once, on each family's simulated matrix, and the test fails if any ball
//! moves, the player leaves idle or the e-stop latches — none of what is sent is a
//! valid, allowed command — or on a panic or a stall. Then the bridge must still obey:
//! a valid OSC Start moves every ball and an e-stop stops them.
//!
//! **The bridges.** One per family, in turn (a lock keeps them one at a time): a 1 × 3
//! matrix — UIM2503 (two units on the simulated gateway, the third on a gateway on a
//! pseudo-terminal whose feedback direction gets noise: `storm::tap`), MBOX (a
//! simulated 3-axis box), MOONS' drives (three simulated drives) — a 4 s show uploaded
//! and alone in the playlist, the initial password changed, nothing playing, live
//! mode off (`[live] enabled = true` runs the Art-Net and sACN receivers; live mode
//! is only ever the operator's request), OSC on with `motion = true`, `allow =
//! ["127.0.0.1"]` and a feedback address, and the timecode chase on with a playlist
//! start (10:00:00:00), so a valid timecode would start the show: Art-Net timecode on
//! the live input's socket (UIM2503: one socket, one reader), MIDI timecode through a
//! FIFO the bridge reads as it would a raw MIDI device (MBOX), Art-Net timecode on a
//! socket of its own (MOONS'). Every port is a free one on 127.0.0.1.
//!
//! **The readers and what they get** (`storm::inputs`, `storm::tap`, `storm::web`):
//! OSC from the allowed sender and from 127.0.0.2 (not allowed), Art-Net (ArtDmx,
//! ArtPoll, ArtTimeCode and broken ones), sACN, the MBOX host socket (datagrams from a
//! stranger), MIDI timecode, the UIM2503 serial feedback, the WebSocket and HTTP. Each
//! gets random bytes, valid packets mutated (bits flipped, cut, extended, size fields
//! lying) and hand-built hostile packets — OSC: bundles whose element sizes are not a
//! multiple of 4 with a valid Start behind them (issue 52's finding byte for byte),
//! strings without padding, type tags that do not match the data, bundles nested 100
//! deep, bytes left over, arguments the docs refuse (`start 1 -inf`, `reset 2` with
//! one entry, `reset 1 9.995` past the show's end, `home 2`), unknown and feedback
//! addresses; Art-Net: wrong ID and OpCode, short ArtDmx and ArtTimeCode, lengths that
//! lie; sACN: bad vectors, lengths that lie, wrong universes; WebSocket: malformed
//! JSON, unknown types, Start and Reset at entry 2 or past the end, messages over the
//! limit; HTTP: random paths, methods and bodies with the token, a wrong one or none,
//! and broken HTTP on TCP.
//!
//! **What counts as valid, and is never sent.** Each candidate is classified before it
//! goes; a valid, allowed command is counted as skipped:
//! - OSC from the allowed sender: a packet in which the bridge's own reader
//!   (`floatball_bridge::osc::decode`, then `command`) finds an e-stop, a Home, or a
//!   Start, Reset or goto the playlist can carry out (entry 1, a time before the
//!   show's end; docs/show-control.md: one it cannot is refused before it changes
//!   anything). The hand-built hostile packets are invalid by construction (OSC 1.0
//!   and docs/show-control.md) and are sent whatever that reader says: they are the
//!   independent check of the reader itself (the figures count those it misreads as
//!   commands). From 127.0.0.2 nothing is allowed: everything is sent.
//! - Art-Net: a well-formed ArtTimeCode (`floatball_shared::timecode::artnet::decode`):
//!   one near the cue may rightly start the chase. MIDI timecode: a chunk that would
//!   complete a quarter-frame time or a full frame in a copy of the bridge's decoder
//!   fed everything sent so far. Serial feedback: a chunk that would complete a valid
//!   frame in a copy of the bridge's frame decoder (the gateway's own frames pass, and
//!   noise goes only between them). DMX (Art-Net, sACN) is sent as it is: with live
//!   mode off no DMX may move a ball. The MBOX host socket: nothing from a stranger is
//!   valid.
//! - WebSocket: a frame `serde_json` reads as a `ClientMessage` that the playlist can
//!   carry out (a Start or Reset at entry 1 before the show's end), Home, the e-stop,
//!   a console line or `live`. HTTP with the token: requests that could change
//!   something only ever carry a body that is not valid (see `storm::web`).
//!
//! **The oracle**, from the storm's start until a second after its end: every 50 ms
//! `GET /api/sim/positions` (and the pseudo-terminal gateway's simulator) — no ball
//! more than 1 count (0.01 mm) from where it stood, none moving, no motor, move
//! counter, target, e-stop register, program or alarm changed; every status on a
//! WebSocket of its own says `idle`, not live, every link up; the OSC feedback says
//! `idle` and not latched and keeps coming; the process runs and its log has no panic;
//! a WebSocket ping gets its pong, and the positions their answer, within 2 s (else a
//! stall), and no HTTP request goes unanswered for 5 s; HTTP requests that could
//! change something are never answered 2xx with the token; and after the storm the
//! shows, playlist, installation, patch and schedule are as before. On the first
//! violation the storm stops and the test fails, naming it and what each reader sent
//! last. An answer 5xx to any request fails it too (it named a path segment of 256
//! bytes or more, which the static files answered 500, until that was fixed).
//!
//! **Length.** The short version (the default, in the normal test run) blows
//! [`storm::DEFAULT_SECONDS`] per family at [`storm::DEFAULT_RATE_PER_S`] datagrams a
//! second in all; `FLOATBALL_STORM_SECONDS`, `FLOATBALL_STORM_RATE` and
//! `FLOATBALL_STORM_SEED` change it (`cargo xtask fuzz` runs it for a minute per family
//! at 2,000 a second). `FLOATBALL_STORM_BIN` aims it at another build of `floatball`
//! (one from before a fix, to see the oracle catch the bug); `FLOATBALL_STORM_ONLY`
//! sends only the hand-built cases whose label holds its text (`"issue 52"`: the
//! finding alone). The figures are printed (`--nocapture` shows them).

use crate::common;
mod storm;

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use common::process::{links_up, wave_json};
use common::{Remote, Ws, send_text};
use floatball_shared::api::{PlayerState, ServerMessage, SimGateway, SimPositions};
use floatball_shared::uim2503::sim::GatewayConfig;
use futures_util::{SinkExt, StreamExt};
use storm::inputs::{ArtNet, MboxStranger, Mtc, Osc, STRANGER, Sacn};
use storm::tap::NoisyTap;
use storm::web::{HttpCounts, WsCounts};
use storm::{Playable, Rng, Settings, StopOnDrop, StormBridge, Tally, free_udp_port};
use tokio_tungstenite::tungstenite::Message;

/// The show's length, ms.
const SHOW_MS: u32 = 4_000;

/// Longer than this for a pong or an answer is a stall.
const STALL: Duration = Duration::from_secs(2);

/// How often the positions are read.
const SAMPLE_EVERY: Duration = Duration::from_millis(50);

/// How far a ball may be from where it stood, counts (pulses): 0.01 mm.
const TOLERANCE_COUNTS: f64 = 1.0;

/// How long the oracle watches on after the storm (a command's effect may lag).
const TAIL: Duration = Duration::from_secs(1);

/// One family's storm at a time: their loads and deadlines do not mix.
static ONE_AT_A_TIME: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn uim2503_storm_moves_nothing() {
    storm_family(Family::Uim2503).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mbox_storm_moves_nothing() {
    storm_family(Family::Mbox).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn scl_storm_moves_nothing() {
    storm_family(Family::Scl).await;
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Family {
    Uim2503,
    Mbox,
    Scl,
}

impl Family {
    fn name(self) -> &'static str {
        match self {
            Self::Uim2503 => "UIM2503",
            Self::Mbox => "MBOX",
            Self::Scl => "MOONS'",
        }
    }

    /// A number for the generators' streams.
    fn stream(self) -> u64 {
        match self {
            Self::Uim2503 => 100,
            Self::Mbox => 200,
            Self::Scl => 300,
        }
    }
}

/// One ball as the simulation has it: where, whether it moves, and everything else
/// that must not change (motor, move counter, target, e-stop register, program…).
#[derive(Debug, Clone, PartialEq)]
struct Ball {
    name: String,
    counts: f64,
    moving: bool,
    rest: String,
}

/// Every simulated ball of the installation.
fn balls(positions: &SimPositions, tap: Option<&SimGateway>) -> Vec<Ball> {
    let mut balls = Vec::new();
    for gateway in positions.gateways.iter().chain(tap) {
        for unit in &gateway.units {
            balls.push(Ball {
                name: format!("gateway {} station {}", gateway.gateway, unit.station),
                counts: unit.position_counts,
                moving: unit.moving || unit.velocity_counts_s != 0.0,
                rest: format!("motor on {}, moves {}", unit.motor_on, unit.ptp_moves),
            });
        }
    }
    for one in &positions.boxes {
        for (axis, &pulses) in one.positions_pulses.iter().enumerate() {
            balls.push(Ball {
                name: format!("box {} axis {}", one.ip, axis + 1),
                counts: f64::from(pulses),
                moving: one.moving,
                rest: format!(
                    "target {:?}, e-stop {}, play control {}",
                    one.targets_pulses.get(axis),
                    one.estop,
                    one.play_control
                ),
            });
        }
    }
    for drive in &positions.drives {
        balls.push(Ball {
            name: format!("drive {}:{}", drive.gateway, drive.address),
            counts: drive.position_counts,
            moving: drive.moving,
            rest: format!(
                "executing {}, waiting {}, segments {}, moves {}, alarm {:04x}, motor {}",
                drive.executing,
                drive.waiting_input,
                drive.segments_stored,
                drive.moves_ended,
                drive.alarm_code,
                drive.motor_enabled
            ),
        });
    }
    balls
}

/// What differs between `before` and `now`, if anything.
fn moved(before: &[Ball], now: &[Ball]) -> Option<String> {
    if before.len() != now.len() {
        return Some(format!("the balls were {before:?}, now {now:?}"));
    }
    let changes: Vec<String> = before
        .iter()
        .zip(now)
        .filter(|(was, is)| {
            (was.counts - is.counts).abs() > TOLERANCE_COUNTS || is.moving || was.rest != is.rest
        })
        .map(|(was, is)| {
            format!(
                "{}: {:.2} → {:.2} counts, moving {}, {} → {}",
                is.name, was.counts, is.counts, is.moving, was.rest, is.rest
            )
        })
        .collect();
    (!changes.is_empty()).then(|| changes.join("; "))
}

/// `GET /api/sim/positions` within `STALL`: the answer and how long it took. (Not
/// `Remote::request`, which panics when the bridge does not answer: here that is a
/// finding to report.)
async fn read_positions(remote: Remote, token: &str) -> Result<(SimPositions, Duration), String> {
    use http_body_util::BodyExt;
    let started = Instant::now();
    let client: hyper_util::client::legacy::Client<_, http_body_util::Empty<axum::body::Bytes>> =
        hyper_util::client::legacy::Client::builder(hyper_util::rt::TokioExecutor::new())
            .build(hyper_util::client::legacy::connect::HttpConnector::new());
    let request = axum::http::Request::get(remote.url("/api/sim/positions"))
        .header(axum::http::header::AUTHORIZATION, format!("Bearer {token}"))
        .body(http_body_util::Empty::new())
        .expect("a request");
    let exchange = async {
        let response = client
            .request(request)
            .await
            .map_err(|error| format!("GET /api/sim/positions failed: {error}"))?;
        let status = response.status();
        let body = response
            .into_body()
            .collect()
            .await
            .map_err(|error| format!("GET /api/sim/positions: the body failed: {error}"))?
            .to_bytes();
        Ok::<_, String>((status, body))
    };
    let (status, body) = tokio::time::timeout(STALL, exchange)
        .await
        .map_err(|_| format!("GET /api/sim/positions unanswered after {STALL:?} (a stall)"))??;
    let took = started.elapsed();
    if status != StatusCode::OK {
        return Err(format!(
            "GET /api/sim/positions answered {status}: {}",
            String::from_utf8_lossy(&body)
        ));
    }
    serde_json::from_slice(&body)
        .map(|positions| (positions, took))
        .map_err(|error| format!("GET /api/sim/positions: not the positions ({error})"))
}

/// Every simulated ball now, the pseudo-terminal gateway's too.
async fn snapshot(remote: Remote, token: &str, tap: Option<&NoisyTap>) -> Vec<Ball> {
    let (positions, _) = read_positions(remote, token)
        .await
        .unwrap_or_else(|why| panic!("{why}"));
    let tapped = tap.map(|tap| tap.positions(1));
    balls(&positions, tapped.as_ref())
}

/// What the oracle saw, and the first thing wrong.
#[derive(Debug, Default)]
struct Watch {
    /// The oracle looks (set until the storm and its tail are over).
    guarding: AtomicBool,
    violations: Mutex<Vec<(Instant, String)>>,
    samples: AtomicU64,
    worst_sample_us: AtomicU64,
    pongs: AtomicU64,
    worst_pong_us: AtomicU64,
    statuses: AtomicU64,
    feedback: AtomicU64,
    refusals: AtomicU64,
    /// The OSC feedback's last state and latch.
    fed_state: Mutex<String>,
    fed_latched: AtomicU64,
    fed_at: Mutex<Option<Instant>>,
}

impl Watch {
    fn guarding(&self) -> bool {
        self.guarding.load(Ordering::Acquire)
    }

    /// Records a violation (while guarding); the storm stops at the first.
    fn violate(&self, what: String, stop: &AtomicBool) {
        if !self.guarding() {
            return;
        }
        self.violations
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push((Instant::now(), what));
        stop.store(true, Ordering::Release);
    }

    fn first(&self) -> Option<(Instant, String)> {
        self.violations
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .first()
            .cloned()
    }
}

fn max_us(cell: &AtomicU64, took: Duration) {
    cell.fetch_max(
        u64::try_from(took.as_micros()).unwrap_or(u64::MAX),
        Ordering::Relaxed,
    );
}

/// Reads the positions every [`SAMPLE_EVERY`] while `watch` guards.
async fn watch_positions(
    remote: Remote,
    token: String,
    baseline: Vec<Ball>,
    tap: Option<Arc<NoisyTap>>,
    watch: Arc<Watch>,
    stop: Arc<AtomicBool>,
) {
    while watch.guarding() {
        match read_positions(remote, &token).await {
            Ok((positions, took)) => {
                watch.samples.fetch_add(1, Ordering::Relaxed);
                max_us(&watch.worst_sample_us, took);
                let tapped = tap.as_ref().map(|tap| tap.positions(1));
                if let Some(change) = moved(&baseline, &balls(&positions, tapped.as_ref())) {
                    watch.violate(format!("unintended motion: {change}"), &stop);
                }
            }
            Err(why) => watch.violate(why, &stop),
        }
        tokio::time::sleep(SAMPLE_EVERY).await;
    }
}

/// What a status must say while the storm blows: idle, not live, every link up.
fn check_status(status: &floatball_shared::api::Status, watch: &Watch, stop: &AtomicBool) {
    watch.statuses.fetch_add(1, Ordering::Relaxed);
    let summary = &status.gateway_summary;
    if summary.up != summary.total {
        let links: Vec<_> = status
            .gateways
            .iter()
            .map(|gateway| (gateway.index, gateway.link, gateway.error.clone()))
            .collect();
        watch.violate(
            format!(
                "a link went down: {} of {} up ({links:?})",
                summary.up, summary.total
            ),
            stop,
        );
    }
    if status.state != PlayerState::Idle || status.live.is_some() {
        watch.violate(
            format!(
                "the player left idle: {} (entry {:?}, live {:?}, last error {:?})",
                status.state.as_str(),
                status.entry,
                status.live,
                status.last_error
            ),
            stop,
        );
    }
}

/// Pings on `ws` every 250 ms and reads every status while `watch` guards; gives the
/// WebSocket back.
async fn watch_ws(mut ws: Ws, watch: Arc<Watch>, stop: Arc<AtomicBool>) -> Ws {
    let mut pings: std::collections::VecDeque<Instant> = std::collections::VecDeque::new();
    let mut ticker = tokio::time::interval(Duration::from_millis(250));
    while watch.guarding() {
        let frame = tokio::select! {
            _ = ticker.tick() => None,
            frame = ws.next() => Some(frame),
        };
        let Some(frame) = frame else {
            if pings.front().is_some_and(|oldest| oldest.elapsed() > STALL) {
                let why = format!("a WebSocket ping unanswered after {STALL:?} (a stall)");
                watch.violate(why, &stop);
            }
            let ping = ws.send(Message::text(r#"{"type":"ping"}"#));
            if tokio::time::timeout(STALL, ping).await.is_err() {
                let why = format!("a WebSocket ping could not be sent within {STALL:?}");
                watch.violate(why, &stop);
            }
            pings.push_back(Instant::now());
            continue;
        };
        let Some(Ok(frame)) = frame else {
            watch.violate(format!("the oracle's WebSocket closed: {frame:?}"), &stop);
            break;
        };
        let Message::Text(text) = frame else {
            continue;
        };
        match serde_json::from_str::<ServerMessage>(text.as_str()) {
            Ok(ServerMessage::Pong) => {
                if let Some(sent) = pings.pop_front() {
                    watch.pongs.fetch_add(1, Ordering::Relaxed);
                    max_us(&watch.worst_pong_us, sent.elapsed());
                }
            }
            Ok(ServerMessage::Status(status)) => check_status(&status, &watch, &stop),
            _ => {}
        }
    }
    ws
}

/// Reads the OSC feedback on `socket` until `done`: its state must say `idle` and its
/// latch 0 while `watch` guards, and it must keep coming (every second at least).
fn watch_feedback(
    socket: UdpSocket,
    watch: Arc<Watch>,
    stop: Arc<AtomicBool>,
    done: Arc<AtomicBool>,
) -> std::thread::JoinHandle<()> {
    socket
        .set_read_timeout(Some(Duration::from_millis(100)))
        .expect("a read timeout");
    std::thread::Builder::new()
        .name("storm feedback".to_owned())
        .spawn(move || {
            let mut buffer = vec![0u8; 2048];
            while !done.load(Ordering::Acquire) {
                if let Some(at) = *watch.fed_at.lock().unwrap_or_else(|e| e.into_inner())
                    && at.elapsed() > Duration::from_secs(3)
                {
                    watch.violate(
                        "the OSC feedback stopped for 3 s (its refresh is every second)".to_owned(),
                        &stop,
                    );
                }
                let Ok(length) = socket.recv(&mut buffer) else {
                    continue;
                };
                let Ok((_, rosc::OscPacket::Message(message))) =
                    rosc::decoder::decode_udp(&buffer[..length])
                else {
                    continue;
                };
                watch.feedback.fetch_add(1, Ordering::Relaxed);
                match (message.addr.as_str(), message.args.as_slice()) {
                    ("/floatball/state", [rosc::OscType::String(state)]) => {
                        *watch.fed_at.lock().unwrap_or_else(|e| e.into_inner()) =
                            Some(Instant::now());
                        state.clone_into(
                            &mut *watch.fed_state.lock().unwrap_or_else(|e| e.into_inner()),
                        );
                        if state != "idle" {
                            watch.violate(format!("the OSC feedback says {state:?}"), &stop);
                        }
                    }
                    ("/floatball/latched", [rosc::OscType::Int(latched)]) => {
                        watch
                            .fed_latched
                            .store(u64::from(*latched != 0), Ordering::Release);
                        if *latched != 0 {
                            watch.violate(
                                "the OSC feedback says the e-stop is latched".to_owned(),
                                &stop,
                            );
                        }
                    }
                    ("/floatball/refused", _) => {
                        watch.refusals.fetch_add(1, Ordering::Relaxed);
                    }
                    _ => {}
                }
            }
        })
        .expect("the feedback thread")
}

/// The bodies of what must not change: shows, playlist, installation, patch, schedule.
async fn stored(remote: Remote, token: &str) -> Vec<(String, String)> {
    let mut bodies = Vec::new();
    for path in [
        "/api/shows",
        "/api/playlist",
        "/api/installation",
        "/api/live/patch",
        "/api/schedule",
    ] {
        let reply = remote.request(Method::GET, path, Some(token), None).await;
        bodies.push((
            format!("{path} ({})", reply.status),
            String::from_utf8_lossy(&reply.body).into_owned(),
        ));
    }
    bodies
}

/// Sends `address` with no arguments over OSC from the allowed sender.
fn osc_send(port: u16, address: &str) {
    let socket = UdpSocket::bind("127.0.0.1:0").expect("an OSC socket");
    let packet = rosc::encoder::encode(&rosc::OscPacket::Message(rosc::OscMessage {
        addr: address.to_owned(),
        args: vec![],
    }))
    .expect("encode");
    socket
        .send_to(&packet, ("127.0.0.1", port))
        .expect("OSC sent");
}

/// Reads statuses on `ws` until `wanted` holds (within `within`); the time it took.
async fn status_until(
    ws: &mut Ws,
    within: Duration,
    what: &str,
    wanted: impl Fn(&floatball_shared::api::Status) -> bool,
) -> Duration {
    let started = Instant::now();
    let found = tokio::time::timeout(within, async {
        loop {
            let Some(Ok(frame)) = ws.next().await else {
                panic!("the WebSocket closed waiting for {what}");
            };
            if let Message::Text(text) = frame
                && let Ok(ServerMessage::Status(status)) = serde_json::from_str(text.as_str())
                && wanted(&status)
            {
                return;
            }
        }
    })
    .await;
    assert!(found.is_ok(), "no status with {what} within {within:?}");
    started.elapsed()
}

/// The storm on one family's bridge, then the proof that it still obeys.
#[allow(clippy::too_many_lines)]
async fn storm_family(family: Family) {
    let _one = ONE_AT_A_TIME.lock().await;
    let settings = Settings::from_env();
    let started_at = Instant::now();
    let dir = tempfile::tempdir().expect("temp dir");
    let stop = Arc::new(AtomicBool::new(false));
    let _stop_on_drop = StopOnDrop(Arc::clone(&stop));
    let rng = |stream: u64| Rng::new(settings.seed, family.stream() + stream);

    // The ports, the feedback's socket first (the bridge sends to it from its start).
    let feedback = UdpSocket::bind("127.0.0.1:0").expect("the feedback socket");
    // Room for the refusals a long, fast storm has reported there.
    let _ = socket2::SockRef::from(&feedback).set_recv_buffer_size(4 << 20);
    let feedback_addr = feedback.local_addr().expect("its address");
    let (osc_port, artnet_port, sacn_port) = (free_udp_port(), free_udp_port(), free_udp_port());
    let serial_tally = Tally::new("serial feedback");
    let mut tap = None;
    let mut mbox_port = None;
    let mut timecode_port = None;
    let mut fifo = None;
    let (gateways, timecode) = match family {
        Family::Uim2503 => {
            let noisy = NoisyTap::new(
                dir.path(),
                "gateway1",
                115_200,
                GatewayConfig::numbered(1),
                rng(9),
                Arc::clone(&serial_tally),
            );
            let gateways = format!(
                "[[gateway]]\nport = \"sim\"\nbaud = 115200\nunits = 2\n\
                 [[gateway]]\nport = \"{}\"\nbaud = 115200\nunits = 1\n",
                noisy.path.display()
            );
            tap = Some(Arc::new(noisy));
            (
                gateways,
                format!("source = \"artnet\"\nlisten = \"127.0.0.1:{artnet_port}\"\n"),
            )
        }
        Family::Mbox => {
            let host = free_udp_port();
            mbox_port = Some(host);
            let path = dir.path().join("midi");
            let made = std::process::Command::new("mkfifo").arg(&path).status();
            assert!(made.is_ok_and(|status| status.success()), "mkfifo");
            let timecode = format!("source = \"mtc\"\ndevice = \"{}\"\n", path.display());
            fifo = Some(path);
            (
                format!(
                    "[mbox]\nhost_port = {host}\n\
                     [[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n"
                ),
                timecode,
            )
        }
        Family::Scl => {
            let port = free_udp_port();
            timecode_port = Some(port);
            (
                "[scl]\nhost_port = 0\ntolerance_mm = 50.0\n\
                 [[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n"
                    .to_owned(),
                format!("source = \"artnet\"\nlisten = \"127.0.0.1:{port}\"\n"),
            )
        }
    };
    let config = format!(
        "[matrix]\nrows = 1\ncols = 3\ntravel_mm = 500.0\n\
         [safety]\napproach_speed_mm_s = 2000.0\n{gateways}\
         [osc]\nlisten = \"127.0.0.1:{osc_port}\"\nallow = [\"127.0.0.1\"]\nmotion = true\n\
         feedback = \"{feedback_addr}\"\n\
         [timecode]\n{timecode}start = \"10:00:00:00\"\n\
         [live]\nenabled = true\nartnet_listen = \"127.0.0.1:{artnet_port}\"\n\
         sacn_listen = \"127.0.0.1:{sacn_port}\"\nsacn_interface = \"127.0.0.1\"\n"
    );
    let mut bridge = StormBridge::start(&config);
    let remote = bridge.remote();
    let show = wave_json("wave", 1, 3, SHOW_MS, 100.0);
    let token = bridge.prepare_show("wave", &show, false).await;
    let mut ws = bridge.ws(&token).await;
    assert!(
        links_up(&mut ws).await,
        "the links come up:\n{}",
        bridge.log()
    );
    drop(ws);
    // Idle, whatever is armed loaded, and the balls standing still. (A new session
    // gets the status at once: statuses come only on changes.)
    let mut ws = bridge.ws(&token).await;
    send_text(&mut ws, r#"{"type":"feedback","relay":false}"#).await;
    status_until(
        &mut ws,
        Duration::from_secs(15),
        "idle and armed",
        |status| {
            status.state == PlayerState::Idle
                && status
                    .armed
                    .as_ref()
                    .is_none_or(|armed| armed.progress >= 1.0)
        },
    )
    .await;
    let mut baseline = snapshot(remote, &token, tap.as_deref()).await;
    let settle_until = Instant::now() + Duration::from_secs(10);
    loop {
        tokio::time::sleep(Duration::from_millis(300)).await;
        let again = snapshot(remote, &token, tap.as_deref()).await;
        if moved(&baseline, &again).is_none() {
            break;
        }
        assert!(
            Instant::now() < settle_until,
            "the balls do not stand still before the storm: {:?}",
            moved(&baseline, &again)
        );
        baseline = again;
    }
    let before = stored(remote, &token).await;

    // The oracle.
    let watch = Arc::new(Watch::default());
    watch.guarding.store(true, Ordering::Release);
    let feedback_done = Arc::new(AtomicBool::new(false));
    let _feedback_done_on_drop = StopOnDrop(Arc::clone(&feedback_done));
    let feedback_thread = watch_feedback(
        feedback,
        Arc::clone(&watch),
        Arc::clone(&stop),
        Arc::clone(&feedback_done),
    );
    let positions_task = tokio::spawn(watch_positions(
        remote,
        token.clone(),
        baseline.clone(),
        tap.clone(),
        Arc::clone(&watch),
        Arc::clone(&stop),
    ));
    let ws_task = tokio::spawn(watch_ws(ws, Arc::clone(&watch), Arc::clone(&stop)));

    // The storm.
    let playable = Playable {
        entries: 1,
        show_ms: u64::from(SHOW_MS),
    };
    let artnet_to: Vec<SocketAddr> = std::iter::once(artnet_port)
        .chain(timecode_port)
        .map(|port| SocketAddr::from(([127, 0, 0, 1], port)))
        .collect();
    let local = |port: u16| vec![SocketAddr::from(([127, 0, 0, 1], port))];
    // Each UDP reader: its tally, its generator, where it sends from and to.
    type Reader = (
        Arc<Tally>,
        Box<dyn storm::Generator>,
        String,
        Vec<SocketAddr>,
    );
    let mut readers: Vec<Reader> = vec![
        (
            Tally::new("OSC (allowed sender)"),
            Box::new(Osc::allowed(playable)),
            "127.0.0.1:0".to_owned(),
            local(osc_port),
        ),
        (
            Tally::new("OSC (127.0.0.2)"),
            Box::new(Osc::stranger(playable)),
            format!("{STRANGER}:0"),
            local(osc_port),
        ),
        (
            Tally::new(if timecode_port.is_some() {
                "Art-Net (live, timecode)"
            } else {
                "Art-Net (live+timecode)"
            }),
            Box::new(ArtNet),
            "127.0.0.1:0".to_owned(),
            artnet_to,
        ),
        (
            Tally::new("sACN"),
            Box::new(Sacn::default()),
            "127.0.0.1:0".to_owned(),
            local(sacn_port),
        ),
    ];
    if let Some(port) = mbox_port {
        readers.push((
            Tally::new("MBOX host socket"),
            Box::new(MboxStranger),
            "127.0.0.1:0".to_owned(),
            local(port),
        ));
    }
    let byte_readers = readers.len() + usize::from(fifo.is_some()) + usize::from(tap.is_some());
    let per_reader_s = settings.rate_per_s / byte_readers as f64;
    let mut tallies: Vec<Arc<Tally>> = Vec::new();
    let mut threads = Vec::new();
    for (index, (tally, generator, from, to)) in readers.into_iter().enumerate() {
        tallies.push(Arc::clone(&tally));
        threads.push(storm::udp_feeder(
            &from,
            to,
            per_reader_s,
            generator,
            rng(index as u64),
            tally,
            Arc::clone(&stop),
        ));
    }
    if let Some(path) = fifo.clone() {
        let tally = Tally::new("MIDI timecode (FIFO)");
        tallies.push(Arc::clone(&tally));
        threads.push(storm::fifo_feeder(
            path,
            per_reader_s,
            Box::new(Mtc::default()),
            rng(8),
            tally,
            Arc::clone(&stop),
        ));
    }
    if let Some(tap) = &tap {
        tallies.push(Arc::clone(&serial_tally));
        tap.storm(per_reader_s);
    }
    let ws_tally = Tally::new("WebSocket");
    let ws_counts = Arc::new(WsCounts::default());
    let ws_fuzz = tokio::spawn(storm::web::ws_fuzz(
        remote,
        token.clone(),
        (settings.rate_per_s / 10.0).max(10.0),
        playable,
        rng(10),
        Arc::clone(&ws_tally),
        Arc::clone(&ws_counts),
        Arc::clone(&stop),
    ));
    let http_tally = Tally::new("HTTP");
    let http_counts = Arc::new(HttpCounts::default());
    let http_fuzz = tokio::spawn(storm::web::http_fuzz(
        remote,
        token.clone(),
        (settings.rate_per_s / 40.0).max(5.0),
        rng(11),
        Arc::clone(&http_tally),
        Arc::clone(&http_counts),
        Arc::clone(&stop),
    ));
    let set_up_s = started_at.elapsed().as_secs_f64();
    let storm_started = Instant::now();
    while storm_started.elapsed() < settings.duration() && !stop.load(Ordering::Acquire) {
        tokio::time::sleep(Duration::from_millis(100)).await;
        if !bridge.is_running() {
            watch.violate("the bridge exited".to_owned(), &stop);
        }
    }
    let storm_s = storm_started.elapsed().as_secs_f64();
    stop.store(true, Ordering::Release);
    // The tail: effects that lag (a Start's approach) still count.
    let tail_until = Instant::now() + TAIL;
    if let Some(tap) = &tap {
        tap.storm(0.0);
    }
    // The storm's threads end within a send (a FIFO's write blocks only while the
    // bridge does not read: then it is let go, and ends when the bridge is killed).
    for thread in threads {
        let deadline = Instant::now() + Duration::from_secs(5);
        while !thread.is_finished() && Instant::now() < deadline {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        if !thread.is_finished() {
            watch.violate(
                format!(
                    "{} is stuck: the bridge stopped reading it",
                    thread.thread().name().unwrap_or("a storm thread")
                ),
                &stop,
            );
        }
    }
    let _ = tokio::time::timeout(Duration::from_secs(10), ws_fuzz).await;
    let _ = tokio::time::timeout(Duration::from_secs(10), http_fuzz).await;
    while Instant::now() < tail_until && watch.first().is_none() {
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    if !bridge.is_running() {
        watch.violate("the bridge exited".to_owned(), &stop);
    }
    if bridge.log().contains("panicked") {
        watch.violate("the bridge's log has a panic".to_owned(), &stop);
    }
    watch.guarding.store(false, Ordering::Release);
    let _ = tokio::time::timeout(Duration::from_secs(5), positions_task).await;
    let mut ws = tokio::time::timeout(Duration::from_secs(5), ws_task)
        .await
        .expect("the WebSocket watch ends")
        .expect("the WebSocket watch");

    tallies.push(ws_tally);
    tallies.push(http_tally);
    let figures = figures(
        family,
        &settings,
        storm_s,
        &tallies,
        &watch,
        &ws_counts,
        &http_counts,
    );
    if let Some((at, first)) = watch.first() {
        let all: Vec<String> = watch
            .violations
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
            .take(10)
            .map(|(_, what)| what.clone())
            .collect();
        let recent: String = tallies
            .iter()
            .map(|tally| format!("  {}, last sent:\n{}", tally.reader, tally.recent(at)))
            .collect();
        panic!(
            "{}: the storm changed something {:.2} s in: {first}\nall (first 10): {all:#?}\n\
             what each reader sent last before it:\n{recent}\n{figures}\nthe bridge's log \
             (last lines):\n{}",
            family.name(),
            at.saturating_duration_since(storm_started).as_secs_f64(),
            bridge.log_tail(40)
        );
    }
    let unanswered = http_counts
        .unanswered
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .clone();
    assert!(
        unanswered.is_empty(),
        "{}: HTTP requests left unanswered for 5 s: {unanswered:#?}\n{figures}",
        family.name()
    );
    let accepted = http_counts
        .accepted
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .clone();
    assert!(
        accepted.is_empty(),
        "{}: requests with the token that should have been refused were answered 2xx: \
         {accepted:#?}\n{figures}",
        family.name()
    );
    let server_errors = http_counts
        .server_errors
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .clone();
    assert!(
        server_errors.is_empty(),
        "{}: requests answered 5xx (untrusted input is a client's error, never the \
         server's): {server_errors:#?}\n{figures}",
        family.name()
    );
    let after = stored(remote, &token).await;
    assert_eq!(
        before,
        after,
        "{}: the storm changed what is stored\n{figures}",
        family.name()
    );
    println!("{figures}");
    let proof_started = Instant::now();

    // Still obeys: a valid OSC Start moves every ball, an e-stop stops them.
    let start_sent = Instant::now();
    osc_send(osc_port, "/floatball/start");
    let left_idle = status_until(
        &mut ws,
        Duration::from_secs(10),
        "the Start taken",
        |status| status.state != PlayerState::Idle,
    )
    .await;
    let mut moved_balls = vec![false; baseline.len()];
    let move_until = Instant::now() + Duration::from_secs(30);
    while !moved_balls.iter().all(|&moved| moved) {
        assert!(
            Instant::now() < move_until,
            "{}: after a valid OSC Start not every ball moved within 30 s: {moved_balls:?}\n{}",
            family.name(),
            bridge.log_tail(30)
        );
        let now = snapshot(remote, &token, tap.as_deref()).await;
        for (index, (was, is)) in baseline.iter().zip(&now).enumerate() {
            // 1 mm: 100 counts or pulses.
            if (was.counts - is.counts).abs() > 100.0 {
                moved_balls[index] = true;
            }
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let every_ball_moved = start_sent.elapsed();
    let estop_sent = Instant::now();
    osc_send(osc_port, "/floatball/estop");
    status_until(&mut ws, Duration::from_secs(5), "stopped", |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    let stop_until = Instant::now() + Duration::from_secs(5);
    let mut last = snapshot(remote, &token, tap.as_deref()).await;
    loop {
        tokio::time::sleep(Duration::from_millis(200)).await;
        let now = snapshot(remote, &token, tap.as_deref()).await;
        let still = now
            .iter()
            .zip(&last)
            .all(|(is, was)| !is.moving && (is.counts - was.counts).abs() <= TOLERANCE_COUNTS);
        if still {
            break;
        }
        assert!(
            Instant::now() < stop_until,
            "{}: the balls still move 5 s after the e-stop: {now:?}",
            family.name()
        );
        last = now;
    }
    let stopped = estop_sent.elapsed();
    let latched_until = Instant::now() + Duration::from_secs(3);
    while watch.fed_latched.load(Ordering::Acquire) != 1 {
        assert!(
            Instant::now() < latched_until,
            "{}: the OSC feedback does not say the e-stop is latched",
            family.name()
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    feedback_done.store(true, Ordering::Release);
    while !feedback_thread.is_finished() {
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert!(
        !bridge.log().contains("panicked"),
        "{}: a panic in the log:\n{}",
        family.name(),
        bridge.log()
    );
    println!(
        "{}: still obeys: a valid OSC Start left idle in {:.0} ms and moved every ball in \
         {:.0} ms; the e-stop stopped them in {:.0} ms. {:.1} s in all: {set_up_s:.1} s to \
         set up, {:.1} s of storm and watching on, {:.1} s to prove it obeys",
        family.name(),
        left_idle.as_secs_f64() * 1e3,
        every_ball_moved.as_secs_f64() * 1e3,
        stopped.as_secs_f64() * 1e3,
        started_at.elapsed().as_secs_f64(),
        proof_started
            .saturating_duration_since(storm_started)
            .as_secs_f64(),
        proof_started.elapsed().as_secs_f64(),
    );
}

/// The storm's figures: per reader, and the oracle's.
fn figures(
    family: Family,
    settings: &Settings,
    storm_s: f64,
    tallies: &[Arc<Tally>],
    watch: &Watch,
    ws: &WsCounts,
    http: &HttpCounts,
) -> String {
    let mut text = format!(
        "storm on {}: {storm_s:.1} s at {:.0} datagrams/s in all (seed {})\n",
        family.name(),
        settings.rate_per_s,
        settings.seed
    );
    for tally in tallies {
        text.push_str("  ");
        text.push_str(&tally.figures(storm_s));
        text.push('\n');
    }
    text.push_str(&format!(
        "  WebSocket: {} connections, {} refused (wrong token), {} replies read\n",
        ws.connections.load(Ordering::Relaxed),
        ws.refused_connections.load(Ordering::Relaxed),
        ws.replies.load(Ordering::Relaxed)
    ));
    text.push_str(&format!("  HTTP answers: {}\n", http.summary()));
    for error in http
        .server_errors
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .iter()
    {
        text.push_str(&format!("    5xx: {error}\n"));
    }
    let violations = watch
        .violations
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .len();
    text.push_str(&format!(
        "  oracle: {} position samples (slowest {:.0} ms), {} pongs (slowest {:.0} ms), {} \
         statuses, {} OSC feedback messages ({} refusals); violations (unintended motion, \
         state changes, e-stop, stalls): {violations}",
        watch.samples.load(Ordering::Relaxed),
        watch.worst_sample_us.load(Ordering::Relaxed) as f64 / 1e3,
        watch.pongs.load(Ordering::Relaxed),
        watch.worst_pong_us.load(Ordering::Relaxed) as f64 / 1e3,
        watch.statuses.load(Ordering::Relaxed),
        watch.feedback.load(Ordering::Relaxed),
        watch.refusals.load(Ordering::Relaxed),
    ));
    text
}
