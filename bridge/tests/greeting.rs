//! Gateway presence and line speed through real pseudo-terminals: a link in this test
//! on pty A, `floatball simulate` (the real binary) on pty B, and a null-modem cable
//! between the two masters that carries bytes only while both ends run at the same
//! speed (a pty keeps the speed its slave was set to, and a master reports it), as a
//! real cable between UARTs at different speeds carries nothing readable.

use std::io::{BufRead, BufReader, Read, Write};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use floatball_bridge::ports::uim2503::{BaudError, Link, LinkConfig};
use floatball_shared::api::LinkState;
use serialport::{SerialPort, TTYPort};

/// `floatball simulate` on a device; killed when dropped. Its standard output lines
/// arrive on `lines`.
struct Simulator {
    child: Child,
    lines: mpsc::Receiver<String>,
}

impl Simulator {
    fn start(port: &str, baud: u32) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
            .args(["simulate", "--port", port, "--baud", &baud.to_string()])
            .args(["--units", "4"])
            .stdout(Stdio::piped())
            .spawn()
            .expect("start floatball simulate");
        let lines = read_lines(child.stdout.take().expect("stdout"));
        let simulator = Self { child, lines };
        let banner = simulator.line_with("simulating");
        assert!(banner.contains(port), "{banner}");
        simulator
    }

    /// Waits for a line of standard output containing `text`.
    fn line_with(&self, text: &str) -> String {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let line = self
                .lines
                .recv_timeout(left)
                .unwrap_or_else(|_| panic!("floatball simulate never said {text:?}"));
            if line.contains(text) {
                return line;
            }
        }
    }

    /// The gateway's power cycle.
    fn hang_up(&self) {
        let status = Command::new("kill")
            .args(["-HUP", &self.child.id().to_string()])
            .status()
            .expect("kill -HUP");
        assert!(status.success());
    }
}

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn read_lines(stdout: ChildStdout) -> mpsc::Receiver<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { return };
            if tx.send(line).is_err() {
                return;
            }
        }
    });
    rx
}

/// A pty pair: its master, and the slave's path.
fn pty() -> (TTYPort, String) {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("slave name");
    drop(slave);
    master.set_timeout(Duration::from_millis(10)).unwrap();
    (master, path)
}

/// Copies bytes both ways between two pty masters while `plugged`, and only when both
/// ends run at the same speed; other bytes are lost, as on a real line.
fn cable(a: &TTYPort, b: &TTYPort, plugged: &Arc<AtomicBool>) {
    fn pump(mut from: TTYPort, mut to: TTYPort, plugged: Arc<AtomicBool>) {
        std::thread::spawn(move || {
            let mut buffer = [0u8; 512];
            loop {
                match from.read(&mut buffer) {
                    Ok(n) if n > 0 => {
                        let same_speed = from.baud_rate().ok() == to.baud_rate().ok();
                        if plugged.load(Ordering::Acquire) && same_speed {
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
    pump(clone(a), clone(b), Arc::clone(plugged));
    pump(clone(b), clone(a), Arc::clone(plugged));
}

async fn wait_for_state(link: &Link, state: LinkState, within: Duration) {
    let mut status = link.status();
    tokio::time::timeout(within, status.wait_for(|status| status.state == state))
        .await
        .unwrap_or_else(|_| panic!("link never became {state:?}: {:?}", link.snapshot()))
        .unwrap();
}

const SOON: Duration = Duration::from_secs(5);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_greeting_marks_the_link_up_and_a_silent_gateway_not_answering() {
    let (master_a, path_a) = pty();
    let (master_b, path_b) = pty();
    let plugged = Arc::new(AtomicBool::new(true));
    let mut simulator = Simulator::start(&path_b, 9600);
    cable(&master_a, &master_b, &plugged);

    let opened = Instant::now();
    let link = Link::open(0, LinkConfig::new(path_a.clone(), 9600));
    wait_for_state(&link, LinkState::Up, SOON).await;
    assert!(opened.elapsed() < Duration::from_secs(1), "greeted at once");
    assert_eq!(link.baud(), 9600);

    // The far side closes (the gateway is switched off): not answering, not down.
    drop(simulator);
    wait_for_state(&link, LinkState::NotAnswering, SOON).await;
    assert!(
        link.estop().is_some(),
        "the e-stop reports the silent gateway"
    );
    // It comes back: the next greeting finds it.
    simulator = Simulator::start(&path_b, 9600);
    wait_for_state(&link, LinkState::Up, SOON).await;
    assert!(link.latch().release(link.latch().generation()));

    // The cable is pulled and plugged in again.
    plugged.store(false, Ordering::Release);
    wait_for_state(&link, LinkState::NotAnswering, SOON).await;
    plugged.store(true, Ordering::Release);
    wait_for_state(&link, LinkState::Up, SOON).await;
    drop(simulator);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_line_speed_change_from_9600_to_115200_follows_the_gateways_restart() {
    let (master_a, path_a) = pty();
    let (master_b, path_b) = pty();
    let plugged = Arc::new(AtomicBool::new(true));
    let simulator = Simulator::start(&path_b, 9600);
    cable(&master_a, &master_b, &plugged);
    let link = Link::open(0, LinkConfig::new(path_a, 9600));
    wait_for_state(&link, LinkState::Up, SOON).await;

    // Nobody power-cycles the gateway: it stores the speed but keeps 9600, nothing
    // answers at 115200, and the link goes back to 9600 where the gateway answers.
    let error = link
        .change_baud(115_200, Duration::from_millis(1500))
        .await
        .unwrap_err();
    assert!(
        matches!(
            error,
            BaudError::NotAnswering {
                baud: 115_200,
                from_baud: 9600,
                ..
            }
        ),
        "{error}"
    );
    simulator.line_with("stored BDR=115200");
    assert_eq!(link.baud(), 9600);
    assert_eq!(master_a.baud_rate().unwrap(), 9600);
    wait_for_state(&link, LinkState::Up, SOON).await;

    // Now the installer power-cycles the gateway while the link waits (the speed it
    // stored is the same, so it says nothing new about it).
    let change = {
        let link = link.clone();
        tokio::spawn(async move { link.change_baud(115_200, Duration::from_secs(8)).await })
    };
    let restarted = tokio::task::spawn_blocking(move || {
        std::thread::sleep(Duration::from_millis(300));
        simulator.hang_up();
        let line = simulator.line_with("restarted");
        (simulator, line)
    })
    .await
    .unwrap();
    let (simulator, line) = restarted;
    assert!(line.contains("115200"), "{line}");
    let changed = change.await.unwrap().unwrap();
    assert_eq!((changed.from_baud, changed.baud), (9600, 115_200));
    assert!(changed.took_ms < 8000);
    assert_eq!(link.baud(), 115_200);
    assert_eq!(master_a.baud_rate().unwrap(), 115_200);
    assert_eq!(master_b.baud_rate().unwrap(), 115_200);
    assert_eq!(link.snapshot().state, LinkState::Up);

    // And it stays up at the new speed: the idle greetings are answered.
    tokio::time::sleep(Duration::from_millis(3000)).await;
    assert_eq!(link.snapshot().state, LinkState::Up);
    drop(simulator);
}
