//! A show through Debian's `ser2net`, a real serial device server: the bridge (the
//! real binary) plays the same show to one gateway three ways — on a pseudo-terminal
//! directly, through ser2net in raw TCP mode (`tcp://`), and through ser2net in RFC
//! 2217 mode (`rfc2217://`, the line speed set by the bridge) — and the bytes that
//! reach the gateway are the same each time.
//!
//! The gateway is `floatball simulate` on pty G; the bridge's end is pty H (opened by
//! the bridge itself, or by ser2net as its serial device); a recording cable joins the
//! two masters. As on a real cable, bytes cross only while both ends run at the same
//! speed (a pty keeps the speed its slave was set to, and its master reports it), so in
//! RFC 2217 mode, where ser2net opens H at 9600 baud and the gateway runs at 115 200,
//! nothing crosses until the bridge has set the remote speed. Whole `ABC;` greetings
//! (sent when the link comes up and while idle, so their number depends on timing) are
//! left out of the bytes compared. Each run waits until the bridge has loaded the show
//! ahead of Start (it does 3 s after the playlist is set), and after the show until it
//! has loaded it again (once), so that timing changes nothing in what is compared.
//!
//! ser2net is found at `FLOATBALL_SER2NET` or `/usr/sbin/ser2net`. Without it the
//! tests say so and pass — unless `FLOATBALL_REQUIRE_SER2NET=1` (`cargo xtask test`
//! sets it, having installed ser2net), when its absence fails them.

use crate::common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::process::Process;
use common::send_text;
use floatball_shared::api::PlayerState;
use serialport::{SerialPort, TTYPort};

/// The gateway's line speed.
const GATEWAY_BAUD: u32 = 115_200;

/// The speed ser2net opens its device at in RFC 2217 mode, until the bridge sets it.
const SER2NET_BAUD: u32 = 9600;

/// The greeting, left out of the bytes compared.
const GREETING: &[u8] = b"ABC;";

/// How the bridge reaches the gateway.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Way {
    /// The pty as its serial port.
    Pty,
    /// ser2net in raw TCP mode.
    RawTcp,
    /// ser2net in RFC 2217 mode.
    Rfc2217,
}

/// ser2net's path, or `None` (with the reason said) when the test is to be skipped.
fn ser2net() -> Option<PathBuf> {
    let path = std::env::var_os("FLOATBALL_SER2NET")
        .map_or_else(|| PathBuf::from("/usr/sbin/ser2net"), PathBuf::from);
    if path.is_file() {
        return Some(path);
    }
    let required = std::env::var("FLOATBALL_REQUIRE_SER2NET").is_ok_and(|value| value == "1");
    assert!(
        !required,
        "ser2net is not at {} and FLOATBALL_REQUIRE_SER2NET=1: install it with \
         `apt-get install -y ser2net` (cargo xtask test does)",
        path.display()
    );
    eprintln!(
        "SKIPPED: ser2net is not at {} (install it with `apt-get install -y ser2net`, or \
         set FLOATBALL_SER2NET to its path)",
        path.display()
    );
    None
}

/// A pty pair: its master, and the slave's path.
fn pty() -> (TTYPort, String) {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("slave name");
    drop(slave);
    master.set_timeout(Duration::from_millis(10)).unwrap();
    (master, path)
}

/// Copies bytes both ways between the host's pty master and the gateway's, only while
/// both ends run at the same speed (other bytes are lost, as on a real line); records
/// what goes from the host to the gateway.
fn cable(host: &TTYPort, gateway: &TTYPort, stop: &Arc<AtomicBool>) -> Arc<Mutex<Vec<u8>>> {
    fn pump(
        mut from: TTYPort,
        mut to: TTYPort,
        record: Option<Arc<Mutex<Vec<u8>>>>,
        stop: Arc<AtomicBool>,
    ) {
        std::thread::spawn(move || {
            let mut buffer = [0u8; 512];
            while !stop.load(Ordering::Acquire) {
                match from.read(&mut buffer) {
                    Ok(n) if n > 0 => {
                        if from.baud_rate().ok() == to.baud_rate().ok() {
                            if let Some(record) = &record {
                                record.lock().unwrap().extend_from_slice(&buffer[..n]);
                            }
                            let _ = to.write_all(&buffer[..n]);
                        }
                    }
                    Ok(_) => {}
                    Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
                    // Nobody has that end open (yet, or any more).
                    Err(_) => std::thread::sleep(Duration::from_millis(5)),
                }
            }
        });
    }
    let clone = |port: &TTYPort| port.try_clone_native().expect("clone a pty master");
    let record = Arc::new(Mutex::new(Vec::new()));
    pump(
        clone(host),
        clone(gateway),
        Some(Arc::clone(&record)),
        Arc::clone(stop),
    );
    pump(clone(gateway), clone(host), None, Arc::clone(stop));
    record
}

/// A child process killed when dropped.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// `floatball simulate` on `port`, once it says it answers.
fn simulator(port: &str) -> Killed {
    let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
        .args(["simulate", "--port", port, "--baud"])
        .arg(GATEWAY_BAUD.to_string())
        .args(["--units", "4"])
        .stdout(Stdio::piped())
        .spawn()
        .expect("start floatball simulate");
    let mut banner = String::new();
    BufReader::new(child.stdout.take().expect("stdout"))
        .read_line(&mut banner)
        .expect("the simulator's banner");
    assert!(banner.contains(port), "{banner}");
    Killed(child)
}

/// A free TCP port on loopback (free a moment ago).
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|listener| listener.local_addr())
        .expect("a free port")
        .port()
}

/// ser2net serving `device` on a loopback port, raw or RFC 2217, with its v4 YAML
/// configuration written into `dir`; returns it and the port once it accepts.
fn start_ser2net(ser2net: &Path, dir: &Path, device: &str, way: Way) -> (Killed, u16) {
    let port = free_port();
    let (accepter, baud) = match way {
        Way::RawTcp => (format!("tcp,127.0.0.1,{port}"), GATEWAY_BAUD),
        Way::Rfc2217 => (
            format!("telnet(rfc2217),tcp,127.0.0.1,{port}"),
            SER2NET_BAUD,
        ),
        Way::Pty => unreachable!("no ser2net on the direct way"),
    };
    let config = dir.join("ser2net.yaml");
    std::fs::write(
        &config,
        format!(
            "%YAML 1.1\n---\n\
             connection: &gateway\n  \
               accepter: {accepter}\n  \
               connector: serialdev,{device},{baud}n81,local\n  \
               options:\n    kickolduser: true\n"
        ),
    )
    .expect("write ser2net.yaml");
    let log = std::fs::File::create(dir.join("ser2net.log")).expect("ser2net log");
    let child = Command::new(ser2net)
        // In the foreground, no UUCP lock files, this configuration and pid file.
        .args(["-n", "-u", "-c"])
        .arg(&config)
        .arg("-P")
        .arg(dir.join("ser2net.pid"))
        .stdout(log.try_clone().expect("log"))
        .stderr(log)
        .spawn()
        .expect("start ser2net");
    let ser2net = Killed(child);
    let deadline = Instant::now() + Duration::from_secs(5);
    let addr = SocketAddr::from(([127, 0, 0, 1], port));
    while TcpStream::connect_timeout(&addr, Duration::from_millis(100)).is_err() {
        assert!(
            Instant::now() < deadline,
            "ser2net does not accept on {addr}; its log:\n{}",
            std::fs::read_to_string(dir.join("ser2net.log")).unwrap_or_default()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    (ser2net, port)
}

/// What one play of the show wrote to the gateway, and the speed of the host's pty
/// while the bridge was connected.
struct Played {
    wire: Vec<u8>,
    host_baud: u32,
}

/// Plays a short show through `way` to the end; returns the bytes the gateway received
/// without the greetings.
async fn play(ser2net: &Path, way: Way) -> Played {
    let dir = tempfile::tempdir().expect("temp dir");
    let (host_master, host_path) = pty();
    let (gateway_master, gateway_path) = pty();
    // The host's end starts at another speed than the gateway's in RFC 2217 mode only
    // (ser2net sets it when it opens the device; the bridge, when it opens the pty).
    let _simulator = simulator(&gateway_path);
    let stop = Arc::new(AtomicBool::new(false));
    let record = cable(&host_master, &gateway_master, &stop);
    let (_server, port) = match way {
        Way::Pty => (None, host_path.clone()),
        Way::RawTcp | Way::Rfc2217 => {
            let (server, tcp_port) = start_ser2net(ser2net, dir.path(), &host_path, way);
            let scheme = if way == Way::RawTcp { "tcp" } else { "rfc2217" };
            (Some(server), format!("{scheme}://127.0.0.1:{tcp_port}"))
        }
    };
    let bridge = Process::start(&format!(
        "[matrix]\nrows = 2\ncols = 2\n\
         [[gateway]]\nport = \"{port}\"\nbaud = {GATEWAY_BAUD}\n\
         [safety]\napproach_speed_mm_s = 2000.0\n"
    ));
    let show = common::process::wave_json("wave", 2, 2, 2000, 30.0);
    let token = bridge.prepare_show("wave", &show, false).await;
    let mut ws = bridge.ws(&token).await;
    let context = |bridge: &Process| {
        format!(
            "{way:?}; bridge log:\n{}\nser2net log:\n{}",
            bridge.log(),
            std::fs::read_to_string(dir.path().join("ser2net.log")).unwrap_or_default()
        )
    };
    assert!(
        common::process::links_up(&mut ws).await,
        "the gateway did not come up: {}",
        context(&bridge)
    );
    // The bridge loads the show ahead of Start 3 s after the playlist was set (the
    // armer); waiting for that makes every run write the same sequence.
    armed(&mut ws).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let (states, _) = common::until(&mut ws, Duration::from_secs(20), |status| {
        status.state == PlayerState::Playing
    })
    .await;
    assert!(
        !states.contains(&PlayerState::Error),
        "{}",
        context(&bridge)
    );
    let (states, status) = common::until(&mut ws, Duration::from_secs(20), |status| {
        status.state != PlayerState::Playing
    })
    .await;
    assert_eq!(
        status.state,
        PlayerState::Idle,
        "{states:?} {:?}: {}",
        status.last_error,
        context(&bridge)
    );
    // Once the show has ended the armer loads it again (once): the bytes are taken
    // when it has, so that every run ends at the same place.
    armed(&mut ws).await;
    let wire = record.lock().unwrap().clone();
    let host_baud = host_master.baud_rate().expect("the host pty's speed");
    drop(bridge);
    stop.store(true, Ordering::Release);
    Played {
        wire: without_greetings(&wire),
        host_baud,
    }
}

/// Waits until the bridge has loaded the playlist's first show ahead of Start.
async fn armed(ws: &mut common::Ws) {
    common::until(ws, Duration::from_secs(20), |status| {
        status.state == PlayerState::Idle
            && status
                .armed
                .as_ref()
                .is_some_and(|armed| armed.progress >= 1.0)
    })
    .await;
}

/// `wire` without its whole `ABC;` instructions.
fn without_greetings(wire: &[u8]) -> Vec<u8> {
    let mut kept = Vec::with_capacity(wire.len());
    for instruction in wire.split_inclusive(|&byte| byte == b';') {
        if instruction != GREETING {
            kept.extend_from_slice(instruction);
        }
    }
    kept
}

fn assert_same_wire(direct: &[u8], through: &[u8], way: Way) {
    assert!(direct.len() > 200, "the show wrote {} bytes", direct.len());
    assert!(
        direct == through,
        "{way:?} wrote other bytes than the pty:\npty:     {}\n{way:?}: {}",
        String::from_utf8_lossy(direct),
        String::from_utf8_lossy(through)
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_show_through_ser2net_in_raw_tcp_mode_writes_what_it_writes_on_a_pty() {
    let Some(ser2net) = ser2net() else { return };
    let direct = play(&ser2net, Way::Pty).await;
    let raw = play(&ser2net, Way::RawTcp).await;
    assert_eq!(direct.host_baud, GATEWAY_BAUD);
    assert_eq!(raw.host_baud, GATEWAY_BAUD);
    assert_same_wire(&direct.wire, &raw.wire, Way::RawTcp);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_show_through_ser2net_in_rfc2217_mode_sets_the_line_speed_and_writes_what_it_writes_on_a_pty()
 {
    let Some(ser2net) = ser2net() else { return };
    let direct = play(&ser2net, Way::Pty).await;
    let remote = play(&ser2net, Way::Rfc2217).await;
    // ser2net opened the device at 9600 baud; the bridge set the gateway's speed.
    assert_eq!(remote.host_baud, GATEWAY_BAUD);
    assert_same_wire(&direct.wire, &remote.wire, Way::Rfc2217);
}
