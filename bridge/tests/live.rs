//! Live input's receivers (issue 38, step 3) through the real `floatball` binary on the
//! simulated matrix (1 × 4 balls, position-only profile: balls 0–2 on universe 1 from
//! address 1, ball 3 patched apart on universe 2), with the timecode chase on the same
//! Art-Net address (one socket, one reader), fed by real senders nobody here wrote:
//! Debian's `ola` — `olad` with its Art-Net plugin on the loopback (ArtDmx broadcast,
//! driven by `ola_set_dmx`) and its E1.31 plugin (multicast, driven by
//! `ola_streaming_client --priority`, its stream terminated by unpatching the port) —
//! and by this test's own datagrams where only they can say it (unicast sACN out of
//! sequence, malformed datagrams, an `ArtPoll`).
//!
//! One bridge and one `olad` serve every case, in order (the ports are fixed):
//! 1. a fader ramp on Art-Net: `GET /api/live/status` shows the balls' targets follow;
//! 2. sACN at priority 150 on the same universe wins over Art-Net, and once its
//!    stream is terminated it drops out and Art-Net has the universe again;
//! 3. an sACN packet out of sequence is counted and not used;
//! 4. an `ArtPoll` (broadcast) is answered by `ArtPollReply`s to the poller's address
//!    on port 6454, which `floatball_shared::live::artnet::PollReply` reads with the
//!    bridge's universes;
//! 5. malformed datagrams (and noise) on both ports are counted by reason;
//! 6. a new patch (`PUT /api/live/patch`) moves ball 3 to universe 7: its multicast
//!    group is joined without a restart and ball 3 follows;
//! 7. silence: the input is lost once `hold_after_ms` passed;
//! 8. ArtTimeCode on the shared socket reaches the chase, not live input;
//! 9. where the kernel loops multicast back on `lo`, a second bridge joining on
//!    `sacn_interface = "127.0.0.1"` takes this test's own multicast sACN.
//!
//! Live mode end to end (the balls following the input through a bridge of each
//! family) is `live_mode.rs`'s, with the helpers here.
//!
//! `olad`, `ola_set_dmx`, `ola_streaming_client` and `ola_patch` are found on the
//! `PATH`; without them this test's own Art-Net and sACN (unicast) senders stand in
//! and the test says so — unless `FLOATBALL_REQUIRE_OLA=1` (`cargo xtask test` sets
//! it), when their absence fails it. `olad` refuses to run as root: as root it is run
//! as `nobody` (setpriv). It runs alone in CI: `olad` and the bridge use the fixed
//! ports 6454 and 5568 (`live_mode.rs`, which uses them too, runs before it, beside
//! tests that do not).

use crate::common;

use std::io::Write;
use std::net::{Ipv4Addr, SocketAddr, UdpSocket};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use common::next_message;
use common::olad::Olad;
use common::process::Process;
use floatball_bridge::live::LiveStatus;
use floatball_shared::api::ServerMessage;
use floatball_shared::live::artnet::{self, ArtPoll, PollReply, PortAddress};
use floatball_shared::live::sacn::{self, DataPacket, Options};
use floatball_shared::timecode::artnet as timecode_artnet;
use floatball_shared::timecode::{FrameRate, Timecode};

/// `[matrix] travel_mm`: position 65535 is this deep.
pub(crate) const TRAVEL_MM: f64 = 2000.0;

/// `[live] hold_after_ms`.
pub(crate) const HOLD_AFTER_MS: u64 = 400;

/// This test's own sACN source.
const CID: [u8; 16] = *b"floatball-test-1";

/// Whether `program` is on the `PATH`.
fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|path| std::env::split_paths(&path).any(|dir| dir.join(program).is_file()))
}

/// Whether `ola` is there; `false` (with the reason said) when the test is to go
/// without it.
pub(crate) fn ola() -> bool {
    let programs = ["olad", "ola_set_dmx", "ola_streaming_client", "ola_patch"];
    if programs.iter().all(|program| on_path(program)) {
        return true;
    }
    let required = std::env::var("FLOATBALL_REQUIRE_OLA").is_ok_and(|value| value == "1");
    assert!(
        !required,
        "{programs:?} are not on the PATH and FLOATBALL_REQUIRE_OLA=1: install them with \
         `apt-get install -y ola` (cargo xtask test does)"
    );
    eprintln!(
        "SKIPPED the real Art-Net and sACN senders: {programs:?} are not on the PATH \
         (install them with `apt-get install -y ola`); this test's own senders are used"
    );
    false
}

/// Runs an `ola_*` client; whether it succeeded.
pub(crate) fn ola_run(program: &str, args: &[&str]) -> bool {
    Command::new(program)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|status| status.success())
}

/// `olad` with its Art-Net plugin on the loopback (always broadcasting ArtDmx: the
/// bridge's ArtPollReply, sent to 127.0.0.1:6454, reaches whichever socket bound that
/// port last, not necessarily olad's) and its E1.31 plugin; OLA universe 0 out on
/// Art-Net Port-Address 0:0:0 (universe 1), OLA universe 1 on E1.31 universe 1.
pub(crate) fn start_olad() -> Olad {
    let olad = Olad::start(
        &[
            (
                "artnet",
                "enabled = true\nip = 127.0.0.1\nuse_loopback = true\nalways_broadcast = true\n",
            ),
            ("e131", "enabled = true\n"),
        ],
        // Ready when its ports can be patched (Art-Net is device 1, E1.31 device 2).
        || ola_run("ola_patch", &["-d", "1", "-p", "0", "-u", "0"]),
    );
    assert!(ola_run("ola_patch", &["-d", "2", "-p", "0", "-u", "1"]));
    olad
}

/// The slots of balls 0–2: each one's 16-bit position `value`, `step` apart.
fn slots(value: u16, step: u16) -> Vec<u8> {
    (0..3u16)
        .flat_map(|ball| value.saturating_add(ball * step).to_be_bytes())
        .collect()
}

/// Where a 16-bit position puts a ball, mm.
pub(crate) fn mm(value: u16) -> f64 {
    f64::from(value) / 65535.0 * TRAVEL_MM
}

/// This test's own datagrams, to the bridge on the loopback.
struct Wire {
    socket: UdpSocket,
    sequence: u8,
}

impl Wire {
    fn new() -> Self {
        Self {
            socket: UdpSocket::bind("127.0.0.1:0").expect("a socket"),
            sequence: 0,
        }
    }

    fn artnet(&self, universe: u16, data: &[u8]) {
        let address = PortAddress::of_universe(universe).expect("an Art-Net universe");
        let packet = artnet::encode_dmx(0, address, data);
        self.socket
            .send_to(&packet, ("127.0.0.1", artnet::PORT))
            .expect("sent");
    }

    /// An sACN packet with the next sequence number (or `sequence`).
    fn sacn(&mut self, universe: u16, priority: u8, data: &[u8], terminated: bool) {
        self.sequence = self.sequence.wrapping_add(1);
        self.sacn_numbered(universe, priority, data, terminated, self.sequence);
    }

    fn sacn_numbered(
        &self,
        universe: u16,
        priority: u8,
        data: &[u8],
        terminated: bool,
        sequence: u8,
    ) {
        let packet = sacn::encode_data(&DataPacket {
            cid: CID,
            source_name: b"floatball test",
            priority,
            sync_address: 0,
            sequence,
            options: Options {
                terminated,
                ..Options::default()
            },
            universe,
            start_code: 0,
            data,
        });
        self.socket
            .send_to(&packet, ("127.0.0.1", sacn::PORT))
            .expect("sent");
    }

    fn raw(&self, port: u16, bytes: &[u8]) {
        self.socket
            .send_to(bytes, ("127.0.0.1", port))
            .expect("sent");
    }
}

/// A sender run every 100 ms on a thread of its own until dropped, as a console
/// sends continuously; `value` is what it sends now.
pub(crate) struct Repeat {
    running: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Repeat {
    pub(crate) fn start(send: impl Fn() + Send + 'static) -> Self {
        let running = Arc::new(AtomicBool::new(true));
        let run = Arc::clone(&running);
        let thread = std::thread::spawn(move || {
            while run.load(Ordering::SeqCst) {
                send();
                std::thread::sleep(Duration::from_millis(100));
            }
        });
        Self {
            running,
            thread: Some(thread),
        }
    }
}

impl Drop for Repeat {
    fn drop(&mut self) {
        self.running.store(false, Ordering::SeqCst);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// The console's Art-Net on universe 1, through `olad` (`ola_set_dmx` on OLA universe
/// 0) or this test's own socket.
pub(crate) struct Console {
    pub(crate) ola: bool,
}

impl Console {
    /// Art-Net, universe 1.
    pub(crate) fn artnet(&self, data: &[u8]) {
        if self.ola {
            let values: Vec<String> = data.iter().map(u8::to_string).collect();
            ola_run("ola_set_dmx", &["-u", "0", "-d", &values.join(",")]);
        } else {
            Wire::new().artnet(1, data);
        }
    }
}

/// An sACN stream at priority 150 on one universe, sent every 50 ms as consoles do:
/// through a long-running `ola_streaming_client` (OLA universe = E1.31 universe,
/// values written to its standard input), or this test's own unicast sender. Its
/// values are changed with [`SacnStream::set`]; it stops when dropped.
pub(crate) struct SacnStream {
    values: Arc<Mutex<Vec<u8>>>,
    running: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
    child: Option<Child>,
}

impl SacnStream {
    pub(crate) fn start(ola: bool, universe: u16, data: &[u8]) -> Self {
        let values = Arc::new(Mutex::new(data.to_vec()));
        let running = Arc::new(AtomicBool::new(true));
        let mut child = ola.then(|| {
            Command::new("ola_streaming_client")
                .args(["-u", &universe.to_string(), "--priority", "150"])
                .stdin(Stdio::piped())
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("ola_streaming_client starts")
        });
        let mut stdin = child.as_mut().and_then(|child| child.stdin.take());
        let (now, run) = (Arc::clone(&values), Arc::clone(&running));
        let thread = std::thread::spawn(move || {
            let mut wire = Wire::new();
            while run.load(Ordering::SeqCst) {
                let data = now.lock().expect("values").clone();
                match stdin.as_mut() {
                    Some(stdin) => {
                        let line: Vec<String> = data.iter().map(u8::to_string).collect();
                        let _ = writeln!(stdin, "{}", line.join(","));
                        let _ = stdin.flush();
                    }
                    None => wire.sacn(universe, 150, &data, false),
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        });
        Self {
            values,
            running,
            thread: Some(thread),
            child,
        }
    }

    pub(crate) fn set(&self, data: &[u8]) {
        *self.values.lock().expect("values") = data.to_vec();
    }
}

impl Drop for SacnStream {
    fn drop(&mut self) {
        self.running.store(false, Ordering::SeqCst);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        if let Some(mut child) = self.child.take() {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// `GET /api/live/status` until `done` says yes (at most 5 s); the last status.
pub(crate) async fn status_until(
    bridge: &Process,
    token: &str,
    what: &str,
    mut done: impl FnMut(&LiveStatus) -> bool,
) -> LiveStatus {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let reply = bridge
            .request(
                Method::GET,
                "/api/live/status?from=0&count=10",
                Some(token),
                None,
            )
            .await;
        assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
        let status: LiveStatus = reply.json();
        if done(&status) {
            return status;
        }
        assert!(
            Instant::now() < deadline,
            "{what}: not within 5 s: {status:#?}\n{}",
            bridge.log()
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// Ball `ball`'s target position, mm, if it has one.
fn position(status: &LiveStatus, ball: usize) -> Option<f64> {
    status
        .targets
        .get(ball)
        .and_then(|target| target.as_ref())
        .map(|target| target.position_mm)
}

/// Whether balls 0–2 are at `value`, `step` apart.
pub(crate) fn follows(status: &LiveStatus, value: u16, step: u16) -> bool {
    (0..3u16).all(|ball| {
        position(status, usize::from(ball))
            .is_some_and(|at| (at - mm(value.saturating_add(ball * step))).abs() < 1e-6)
    })
}

/// A malformed count.
fn malformed(status: &LiveStatus, reason: &str) -> u64 {
    status.counters.malformed.get(reason).copied().unwrap_or(0)
}

/// Whether a multicast datagram sent the default way reaches a member on this host
/// (no route for multicast in some sandboxes).
pub(crate) fn multicast_works() -> bool {
    let group = Ipv4Addr::new(239, 255, 77, 77);
    let Ok(member) = UdpSocket::bind("0.0.0.0:0") else {
        return false;
    };
    let Ok(port) = member.local_addr().map(|address| address.port()) else {
        return false;
    };
    if member
        .join_multicast_v4(&group, &Ipv4Addr::UNSPECIFIED)
        .is_err()
    {
        return false;
    }
    let _ = member.set_read_timeout(Some(Duration::from_millis(500)));
    let Ok(sender) = UdpSocket::bind("0.0.0.0:0") else {
        return false;
    };
    if sender.send_to(b"probe", (group, port)).is_err() {
        return false;
    }
    let mut buffer = [0u8; 16];
    member.recv_from(&mut buffer).is_ok()
}

/// A socket sending multicast out of the loopback interface.
fn loopback_multicast_sender() -> UdpSocket {
    use socket2::{Domain, Protocol, Socket, Type};
    let socket = Socket::new(Domain::IPV4, Type::DGRAM, Some(Protocol::UDP)).expect("socket");
    socket
        .set_multicast_if_v4(&Ipv4Addr::LOCALHOST)
        .expect("multicast out of lo");
    socket.set_multicast_loop_v4(true).expect("loop");
    let address: SocketAddr = ([127, 0, 0, 1], 0).into();
    socket.bind(&address.into()).expect("bind");
    UdpSocket::from(socket)
}

/// Whether multicast sent out of the loopback reaches a member joined on it.
fn loopback_multicast_works() -> bool {
    let group = Ipv4Addr::new(239, 255, 77, 78);
    let Ok(member) = UdpSocket::bind("0.0.0.0:0") else {
        return false;
    };
    let Ok(port) = member.local_addr().map(|address| address.port()) else {
        return false;
    };
    if member
        .join_multicast_v4(&group, &Ipv4Addr::LOCALHOST)
        .is_err()
    {
        return false;
    }
    let _ = member.set_read_timeout(Some(Duration::from_millis(500)));
    if loopback_multicast_sender()
        .send_to(b"probe", (group, port))
        .is_err()
    {
        return false;
    }
    let mut buffer = [0u8; 16];
    member.recv_from(&mut buffer).is_ok()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn consoles_move_the_targets_over_art_net_and_sacn() {
    let started = Instant::now();
    let ola = ola();
    let multicast = multicast_works();
    let ola_sacn = ola && multicast;
    if ola && !multicast {
        eprintln!(
            "SKIPPED olad's sACN: multicast does not reach this host's own members (no \
             route); this test's own unicast sACN is used"
        );
    }
    // olad first: a unicast datagram to a port two sockets share goes to the one
    // bound last — the bridge's.
    let olad = ola.then(start_olad);
    let config = format!(
        "[matrix]\nrows = 1\ncols = 4\ntravel_mm = {TRAVEL_MM:.1}\n\
         [[gateway]]\nport = \"sim\"\nbaud = 115200\n\
         [timecode]\nsource = \"artnet\"\nlisten = \"0.0.0.0:6454\"\n\
         [live]\nenabled = true\nhold_after_ms = {HOLD_AFTER_MS}\n\
         artnet_listen = \"0.0.0.0:6454\"\nsacn_listen = \"0.0.0.0:5568\"\n\
         [[live.ball]]\nball = 3\nuniverse = 2\naddress = 1\n"
    );
    let bridge = Process::start(&config);
    let token = bridge.operator().await;
    let console = Console { ola };
    let wire = Wire::new();

    let status = status_until(&bridge, &token, "running", |status| status.running).await;
    assert!(status.lost, "{status:?}");
    assert_eq!(
        status
            .universes
            .iter()
            .map(|universe| universe.universe)
            .collect::<Vec<_>>(),
        [1, 2]
    );
    assert_eq!(status.balls, 4);

    // 1. A fader ramp on Art-Net.
    let ramp = [0u16, 0x2000, 0x4000, 0x8000, 0xc000, 0xff00];
    for &value in &ramp {
        console.artnet(&slots(value, 0x100));
        let status = status_until(&bridge, &token, "the ramp", |status| {
            follows(status, value, 0x100)
        })
        .await;
        assert!(!status.lost, "{status:?}");
        // Ball 3's universe has no source: no target.
        assert_eq!(position(&status, 3), None, "{status:?}");
    }
    let status = status_until(&bridge, &token, "an Art-Net source", |status| {
        status
            .sources
            .iter()
            .any(|source| source.universe == 1 && source.winning && source.priority == 100)
    })
    .await;
    assert!(status.counters.accepted >= ramp.len() as u64, "{status:?}");
    assert!(status.counters.artnet_packets >= ramp.len() as u64);
    println!("Art-Net ramp followed: {:?}", status.sources);

    // 2. sACN at 150 wins over Art-Net (which goes on sending) for universe 1.
    let artnet_value = Arc::new(AtomicU8::new(0x30));
    let art = {
        let value = Arc::clone(&artnet_value);
        let ola = console.ola;
        Repeat::start(move || {
            Console { ola }.artnet(&slots(u16::from(value.load(Ordering::SeqCst)) << 8, 0x100));
        })
    };
    status_until(&bridge, &token, "Art-Net again", |status| {
        follows(status, 0x3000, 0x100)
    })
    .await;
    let stream = SacnStream::start(ola_sacn, 1, &slots(0x9000, 0x10));
    let status = status_until(&bridge, &token, "sACN's priority", |status| {
        follows(status, 0x9000, 0x10)
    })
    .await;
    let winner = status
        .sources
        .iter()
        .find(|source| source.universe == 1 && source.winning);
    assert!(
        winner.is_some_and(|source| source.priority == 150 && source.cid.is_some()),
        "{status:?}"
    );
    // Art-Net keeps sending (new values) and still loses.
    artnet_value.store(0x40, Ordering::SeqCst);
    tokio::time::sleep(Duration::from_millis(300)).await;
    stream.set(&slots(0x9100, 0x10));
    let status = status_until(&bridge, &token, "sACN still", |status| {
        follows(status, 0x9100, 0x10)
    })
    .await;
    assert_eq!(
        status
            .sources
            .iter()
            .filter(|source| source.universe == 1)
            .count(),
        2,
        "{status:?}"
    );
    // The stream terminated: sACN drops out, Art-Net has the universe again.
    if ola_sacn {
        assert!(ola_run(
            "ola_patch",
            &["-r", "-d", "2", "-p", "0", "-u", "1"]
        ));
        drop(stream);
    } else {
        drop(stream);
        Wire::new().sacn(1, 150, &[], true);
    }
    let status = status_until(&bridge, &token, "the stream terminated", |status| {
        status.counters.terminated >= 1 && follows(status, 0x4000, 0x100)
    })
    .await;
    assert!(
        status
            .sources
            .iter()
            .all(|source| source.protocol == floatball_bridge::live::Protocol::Artnet),
        "{status:?}"
    );
    println!(
        "sACN at 150 won over Art-Net, then terminated: {:?}",
        status.counters
    );

    // 3. Out of sequence (this test's own unicast sACN): counted, not used.
    wire.sacn_numbered(1, 160, &slots(0xa000, 0), false, 100);
    status_until(&bridge, &token, "unicast sACN", |status| {
        follows(status, 0xa000, 0)
    })
    .await;
    wire.sacn_numbered(1, 160, &slots(0xb000, 0), false, 95);
    wire.sacn_numbered(1, 160, &slots(0xa100, 0), false, 101);
    let status = status_until(&bridge, &token, "out of sequence", |status| {
        status.counters.out_of_sequence >= 1 && follows(status, 0xa100, 0)
    })
    .await;
    assert_eq!(status.counters.out_of_sequence, 1, "{status:?}");
    wire.sacn_numbered(1, 160, &[], true, 102);

    // 4. An ArtPoll, broadcast from a socket on 127.0.0.1:6454 (the most specific
    // binding: the bridge's replies to the poller's address, port 6454, come to it).
    let poller = {
        use socket2::{Domain, Protocol, Socket, Type};
        let socket = Socket::new(Domain::IPV4, Type::DGRAM, Some(Protocol::UDP)).expect("socket");
        socket.set_reuse_address(true).expect("reuse");
        socket.set_broadcast(true).expect("broadcast");
        let address: SocketAddr = ([127, 0, 0, 1], artnet::PORT).into();
        socket.bind(&address.into()).expect("bind 127.0.0.1:6454");
        UdpSocket::from(socket)
    };
    poller
        .set_read_timeout(Some(Duration::from_millis(200)))
        .expect("timeout");
    let poll = artnet::encode_poll(ArtPoll {
        flags: 0,
        diag_priority: 0,
    });
    let mut ours: Vec<PollReply> = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(5);
    while ours.is_empty() {
        assert!(
            Instant::now() < deadline,
            "no ArtPollReply\n{}",
            bridge.log()
        );
        poller
            .send_to(&poll, ("127.255.255.255", artnet::PORT))
            .expect("poll sent");
        let mut buffer = [0u8; 1024];
        let until = Instant::now() + Duration::from_millis(300);
        while Instant::now() < until {
            let Ok((length, _)) = poller.recv_from(&mut buffer) else {
                break;
            };
            if let Some(reply) = PollReply::decode(&buffer[..length])
                && reply.short_name == "Floatball"
            {
                ours.push(reply);
            }
        }
    }
    drop(poller);
    let universes: Vec<u16> = ours.iter().flat_map(PollReply::universes).collect();
    assert_eq!(universes[..2], [1, 2], "{ours:?}");
    assert_ne!(ours[0].ip, [0, 0, 0, 0], "{ours:?}");
    println!("ArtPollReply: {:?}", ours[0]);

    // 5. Malformed datagrams and noise, on both ports.
    let before = status_until(&bridge, &token, "counters", |_| true).await;
    wire.raw(
        artnet::PORT,
        &artnet::encode_dmx(0, PortAddress::of_universe(1).expect("1"), &[1, 2])[..16],
    );
    wire.raw(sacn::PORT, b"ASC-E1.17 is not how it starts");
    let mut noise = 0x2545_f491_4f6c_dd1du64;
    for length in 0..200usize {
        let mut bytes: Vec<u8> = (0..length)
            .map(|_| {
                noise ^= noise << 13;
                noise ^= noise >> 7;
                noise ^= noise << 17;
                noise as u8
            })
            .collect();
        if length % 2 == 0 && length >= 10 {
            bytes[..8].copy_from_slice(&artnet::ID);
        }
        wire.raw(
            if length % 3 == 0 {
                sacn::PORT
            } else {
                artnet::PORT
            },
            &bytes,
        );
    }
    let status = status_until(&bridge, &token, "malformed counted", |status| {
        malformed(status, "artnet_truncated") > malformed(&before, "artnet_truncated")
            && malformed(status, "sacn_truncated") + malformed(status, "sacn_bad_preamble")
                > malformed(&before, "sacn_truncated") + malformed(&before, "sacn_bad_preamble")
    })
    .await;
    println!("malformed: {:?}", status.counters.malformed);

    // 6. A new patch: ball 3 on universe 7, its group joined without a restart.
    let operator = token.clone();
    let mut patch: serde_json::Value = bridge
        .request(Method::GET, "/api/live/patch", Some(&operator), None)
        .await
        .json();
    patch["patch"]["balls"][3] = serde_json::json!({"universe": 7, "address": 1});
    let reply = bridge
        .request(
            Method::PUT,
            "/api/live/patch",
            Some(&operator),
            Some((
                "application/json",
                serde_json::to_vec(&patch["patch"]).expect("json"),
            )),
        )
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    status_until(&bridge, &token, "universe 7 patched", |status| {
        status
            .universes
            .iter()
            .any(|universe| universe.universe == 7)
    })
    .await;
    if ola_sacn {
        assert!(ola_run("ola_patch", &["-d", "2", "-p", "1", "-u", "7"]));
    }
    let seven = SacnStream::start(ola_sacn, 7, &[0x12, 0x34]);
    let status = status_until(&bridge, &token, "ball 3 on universe 7", |status| {
        position(status, 3).is_some_and(|at| (at - mm(0x1234)).abs() < 1e-6)
    })
    .await;
    println!("ball 3 follows universe 7: {:?}", status.sources);

    // 7. Silence: lost after hold_after_ms.
    drop(art);
    drop(seven);
    let status = status_until(&bridge, &token, "lost", |status| status.lost).await;
    assert!(
        status
            .received_ms_ago
            .is_some_and(|ago| ago >= HOLD_AFTER_MS),
        "{status:?}"
    );
    assert!(status.targets.iter().all(Option::is_none), "{status:?}");
    assert!(status.universes.iter().all(|universe| !universe.live));

    // 8. The timecode chase reads the same socket: ArtTimeCode reaches it, and is not
    // live input's.
    let before = status_until(&bridge, &token, "counters", |_| true).await;
    let mut ws = bridge.ws(&token).await;
    let sent = Instant::now();
    let mut ms = 10 * 3_600_000;
    let chased = loop {
        assert!(
            sent.elapsed() < Duration::from_secs(5),
            "the chase saw no timecode\n{}",
            bridge.log()
        );
        ms += 40;
        wire.raw(
            artnet::PORT,
            &timecode_artnet::encode(Timecode::from_ms(ms, FrameRate::Ebu25)),
        );
        let message = tokio::time::timeout(Duration::from_millis(40), next_message(&mut ws)).await;
        if let Ok(ServerMessage::Timecode(chase)) = message
            && chase.timecode.is_some()
        {
            break chase;
        }
    };
    let after = status_until(&bridge, &token, "counters", |_| true).await;
    assert_eq!(
        after.counters.artnet_packets, before.counters.artnet_packets,
        "{after:?}"
    );
    println!("the chase reads the shared socket: {:?}", chased.timecode);

    drop(ws);
    drop(bridge);

    // 9. Multicast on the loopback (where the kernel allows it): a bridge joining on
    // sacn_interface = 127.0.0.1 takes this test's own multicast sACN.
    if loopback_multicast_works() {
        let bridge = Process::start(&format!(
            "[matrix]\nrows = 1\ncols = 4\ntravel_mm = {TRAVEL_MM:.1}\n\
             [[gateway]]\nport = \"sim\"\nbaud = 115200\n\
             [live]\nenabled = true\nartnet = false\nsacn_interface = \"127.0.0.1\"\n"
        ));
        let token = bridge.token().await;
        let sender = loopback_multicast_sender();
        let group = SocketAddr::from((sacn::multicast_address(1), sacn::PORT));
        let deadline = Instant::now() + Duration::from_secs(5);
        for sequence in 0u8.. {
            let packet = sacn::encode_data(&DataPacket {
                cid: CID,
                source_name: b"floatball test multicast",
                priority: 100,
                sync_address: 0,
                sequence,
                options: Options::default(),
                universe: 1,
                start_code: 0,
                data: &slots(0x5000, 0x100),
            });
            sender.send_to(&packet, group).expect("multicast sent");
            let status = status_until(&bridge, &token, "counters", |_| true).await;
            if follows(&status, 0x5000, 0x100) {
                println!("multicast on the loopback: {:?}", status.sources);
                break;
            }
            assert!(
                Instant::now() < deadline,
                "multicast on lo not taken: {status:?}\n{}",
                bridge.log()
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    } else {
        eprintln!("SKIPPED multicast on the loopback: this kernel does not loop it back");
    }

    drop(olad);
    println!("live input checked in {:?}", started.elapsed());
}
