//! The real `floatball` binary as a child process on a temporary data directory, and a
//! gateway on a pseudo-terminal whose far end is a tap: it records every byte the
//! bridge writes, and answers as a UIM2503 with the simulator.

use std::io::{BufRead, BufReader, Read, Write};

use futures_util::StreamExt;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use floatball_bridge::ports::uim2503::sim::SimEngine;
use floatball_shared::uim2503::sim::{GatewayConfig, RxLine};
use serialport::{SerialPort, TTYPort};
use tempfile::TempDir;

use super::Remote;

/// A running `floatball` process; killed when dropped.
pub struct Process {
    child: Child,
    remote: Remote,
    pub data: TempDir,
}

impl Process {
    /// Starts `floatball` with `config` as its floatball.toml, listening on a free
    /// loopback port; returns once it listens. Its log goes to `floatball.log` in the
    /// data directory.
    pub fn start(config: &str) -> Self {
        Self::start_with_args(config, &[])
    }

    /// As [`Process::start`], with more command-line arguments.
    pub fn start_with_args(config: &str, args: &[&str]) -> Self {
        let data = tempfile::tempdir().expect("temp dir");
        std::fs::write(data.path().join("floatball.toml"), config).expect("write config");
        Self::start_in(data, args)
    }

    /// Starts `floatball` with `args` on an existing data directory.
    pub fn start_in(data: TempDir, args: &[&str]) -> Self {
        let static_dir = super::static_dir(data.path());
        let log = std::fs::File::options()
            .create(true)
            .append(true)
            .open(data.path().join("floatball.log"))
            .expect("log");
        let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
            .arg("--data-dir")
            .arg(data.path())
            .arg("--static-dir")
            .arg(&static_dir)
            .args(["--listen", "127.0.0.1:0"])
            .args(args)
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(log)
            .spawn()
            .expect("start floatball");
        let addr = listening_address(child.stdout.take().expect("stdout"));
        Self {
            child,
            remote: Remote { addr },
            data,
        }
    }

    /// Stops this process and starts another with `args` on the same data directory.
    pub fn restart(mut self, args: &[&str]) -> Self {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let data = std::mem::replace(&mut self.data, tempfile::tempdir().expect("temp dir"));
        Self::start_in(data, args)
    }

    /// The log so far.
    pub fn log(&self) -> String {
        std::fs::read_to_string(self.data.path().join("floatball.log")).unwrap_or_default()
    }

    /// Its process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Whether the process still runs.
    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }
}

impl std::ops::Deref for Process {
    type Target = Remote;

    fn deref(&self) -> &Remote {
        &self.remote
    }
}

impl Drop for Process {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A gateway on a pseudo-terminal pair: the bridge opens the slave through a symlink;
/// the tap records what arrives on the master and answers with the simulator.
pub struct Tap {
    pub path: std::path::PathBuf,
    wire: Arc<Mutex<Vec<u8>>>,
    /// When each read from the line ended, and the wire's length then.
    arrivals: Arc<Mutex<Vec<(Instant, usize)>>>,
    answering: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
}

impl Tap {
    /// A tap at `dir/name` on a line of `baud`, answering as a gateway with `units`.
    pub fn new(dir: &std::path::Path, name: &str, baud: u32, units: GatewayConfig) -> Self {
        let (mut master, slave) = TTYPort::pair().expect("pty pair");
        let slave_path = slave.name().expect("slave name");
        drop(slave);
        master
            .set_timeout(Duration::from_millis(2))
            .expect("timeout");
        let path = dir.join(name);
        std::os::unix::fs::symlink(slave_path, &path).expect("symlink");
        let wire = Arc::new(Mutex::new(Vec::new()));
        let arrivals = Arc::new(Mutex::new(Vec::new()));
        let answering = Arc::new(AtomicBool::new(true));
        let stop = Arc::new(AtomicBool::new(false));
        let mut engine = SimEngine::new(units, baud).expect("simulated gateway");
        {
            let (wire, arrivals, answering, stop) = (
                Arc::clone(&wire),
                Arc::clone(&arrivals),
                Arc::clone(&answering),
                Arc::clone(&stop),
            );
            std::thread::spawn(move || {
                let mut buffer = [0u8; 1024];
                let mut answers = Vec::new();
                // Read no faster than the line carries, as a UART does: what the
                // bridge wrote meanwhile waits in the pseudo-terminal.
                let epoch = Instant::now();
                let micros = |at: Instant| {
                    u64::try_from(at.saturating_duration_since(epoch).as_micros())
                        .unwrap_or(u64::MAX)
                };
                let mut line = RxLine::new(baud);
                while !stop.load(Ordering::Acquire) {
                    if !answering.load(Ordering::Acquire) {
                        // A gateway that stopped reading: the line backs up.
                        std::thread::sleep(Duration::from_millis(5));
                        continue;
                    }
                    let room = line
                        .room(micros(Instant::now()))
                        .saturating_sub(4)
                        .min(buffer.len());
                    let read = if room == 0 {
                        std::thread::sleep(Duration::from_micros(200));
                        Ok(0)
                    } else {
                        master.read(&mut buffer[..room])
                    };
                    match read {
                        Ok(n) if n > 0 => {
                            let at = Instant::now();
                            line.accept(micros(at), n);
                            let mut bytes = wire.lock().expect("wire");
                            bytes.extend_from_slice(&buffer[..n]);
                            arrivals.lock().expect("arrivals").push((at, bytes.len()));
                            drop(bytes);
                            engine.receive(at, &buffer[..n]);
                        }
                        Ok(_) => {}
                        Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
                        // No one has the slave open (yet, or between reconnects).
                        Err(_) => std::thread::sleep(Duration::from_millis(5)),
                    }
                    answers.clear();
                    engine.step(Instant::now(), &mut answers);
                    if !answers.is_empty() {
                        let _ = master.write_all(&answers);
                    }
                }
            });
        }
        Self {
            path,
            wire,
            arrivals,
            answering,
            stop,
        }
    }

    /// Every byte the bridge wrote so far, and when each read of them ended (with the
    /// wire's length then), as the line paced them.
    pub fn wire_timed(&self) -> (Vec<u8>, Vec<(Instant, usize)>) {
        let wire = self.wire.lock().expect("wire").clone();
        let arrivals = self.arrivals.lock().expect("arrivals").clone();
        (wire, arrivals)
    }

    /// Every byte the bridge wrote so far.
    pub fn wire(&self) -> Vec<u8> {
        self.wire.lock().expect("wire").clone()
    }

    /// How many bytes the bridge wrote so far.
    pub fn len(&self) -> usize {
        self.wire.lock().expect("wire").len()
    }

    /// Stops (`false`) or resumes reading and answering, as a gateway that hangs.
    pub fn set_answering(&self, answering: bool) {
        self.answering.store(answering, Ordering::Release);
    }
}

impl Drop for Tap {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
    }
}

/// A native show for a `rows` × `cols` matrix lasting `duration_ms`: a wave that
/// travels along each row, every ball still at 0 mm until its column's turn, then
/// dipping `depth_mm` once a second until a second before the end, in rows of 100 ms
/// (within the default limits up to about 200 mm).
pub fn wave_json(name: &str, rows: u32, cols: u32, duration_ms: u32, depth_mm: f64) -> Vec<u8> {
    use std::f64::consts::{PI, TAU};
    let steps = (duration_ms / 100).max(2);
    let units: Vec<serde_json::Value> = (0..rows * cols)
        .map(|unit| {
            let delay_s = f64::from(unit % cols) * 0.1;
            let active_s = (f64::from(duration_ms) / 1000.0 - 1.0 - delay_s)
                .floor()
                .max(0.0);
            let track: Vec<serde_json::Value> = (1..=steps)
                .map(|step| {
                    let local_s = f64::from(step) / 10.0 - delay_s;
                    if local_s <= 0.0 || local_s >= active_s {
                        return serde_json::json!([0.0, 0.0, 100]);
                    }
                    let angle = local_s * TAU;
                    let position = depth_mm * (1.0 - angle.cos()) / 2.0;
                    let velocity = depth_mm * PI * angle.sin();
                    serde_json::json!([position, velocity, 100])
                })
                .collect();
            serde_json::json!({ "start_mm": 0.0, "rows": track })
        })
        .collect();
    super::native_show(name, rows, cols, units)
}

impl Remote {
    /// Changes the initial password, uploads `show` as `name` and makes it the whole
    /// playlist; returns the operator's token.
    pub async fn prepare_show(&self, name: &str, show: &[u8], loop_playlist: bool) -> String {
        self.prepare_upload(name, "application/json", show, loop_playlist)
            .await
    }

    /// As [`Remote::prepare_show`], for a show file of any type (a CSV: `text/csv`).
    pub async fn prepare_upload(
        &self,
        name: &str,
        content_type: &str,
        show: &[u8],
        loop_playlist: bool,
    ) -> String {
        let token = self.operator().await;
        let upload = self.upload(&token, name, content_type, show).await;
        assert_eq!(
            upload.status,
            StatusCode::CREATED,
            "{}",
            String::from_utf8_lossy(&upload.body)
        );
        let entries = serde_json::json!([{ "show": name, "delay_ms": 0, "cycles": 1 }]);
        let reply = self.put_playlist(&token, entries, loop_playlist).await;
        assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
        token
    }

    /// `PUT /api/playlist` with `entries` (a JSON array), default delay 0 and cycles 1.
    pub async fn put_playlist(
        &self,
        token: &str,
        entries: serde_json::Value,
        loop_playlist: bool,
    ) -> super::Reply {
        let playlist = serde_json::json!({
            "entries": entries,
            "loop": loop_playlist,
            "default_delay_ms": 0,
            "default_cycles": 1,
        });
        self.request(
            Method::PUT,
            "/api/playlist",
            Some(token),
            Some(("application/json", playlist.to_string().into_bytes())),
        )
        .await
    }
}

/// A bridge on one tapped pseudo-terminal gateway of 4 units at 9600 baud (a 2 × 2
/// matrix), its operator's token, and a WebSocket that relays no feedback, the link
/// up.
pub async fn tapped_bridge(dir: &std::path::Path) -> (Tap, Process, String, super::Ws) {
    let tap = Tap::new(dir, "gateway0", 9600, GatewayConfig::numbered(4));
    let bridge = Process::start(&format!(
        "[matrix]\nrows = 2\ncols = 2\n[[gateway]]\nport = \"{}\"\nbaud = 9600\n",
        tap.path.display()
    ));
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    super::send_text(&mut ws, r#"{"type":"feedback","relay":false}"#).await;
    assert!(links_up(&mut ws).await, "the link comes up");
    (tap, bridge, token, ws)
}

/// Reads statuses until every gateway's link is up; `false` if they are not within
/// 10 s.
pub async fn links_up(ws: &mut super::Ws) -> bool {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    loop {
        let Ok(Some(Ok(frame))) = tokio::time::timeout_at(deadline, ws.next()).await else {
            return false;
        };
        let tokio_tungstenite::tungstenite::Message::Text(text) = frame else {
            continue;
        };
        // The summary counts every gateway (beyond 16 the details list only those
        // with a problem).
        if let Ok(floatball_shared::api::ServerMessage::Status(status)) =
            serde_json::from_str(text.as_str())
            && status.gateway_summary.total > 0
            && status.gateway_summary.up == status.gateway_summary.total
        {
            return true;
        }
    }
}

/// Where a starting `floatball` listens, read from its stdout (`floatball listening
/// on http://…`); the rest of its stdout is read on and dropped, so the child never
/// blocks on a full pipe.
pub fn listening_address(stdout: std::process::ChildStdout) -> std::net::SocketAddr {
    let mut lines = BufReader::new(stdout).lines();
    let addr = loop {
        let line = lines
            .next()
            .expect("floatball said where it listens")
            .expect("stdout line");
        if let Some(url) = line.strip_prefix("floatball listening on http://") {
            break url.trim().parse().expect("address");
        }
    };
    std::thread::spawn(move || for _ in lines {});
    addr
}
