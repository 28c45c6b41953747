//! The player driven by the bridge in real time: on the in-process simulated gateway,
//! and through real pseudo-terminals with `floatball simulate` at the far end.

use std::io::{Read, Write};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use floatball_bridge::playback::{Begin, Playback, Playlist, PlaylistKey};
use floatball_bridge::ports::uim2503::{Link, LinkConfig};
use floatball_shared::api::{LinkState, PlayerState, Status};
use floatball_shared::plan::{GatewaySpec, Installation};
use floatball_shared::show::demo::Wave;
use floatball_shared::show::{Limits, Sampler, Show};
use floatball_shared::uim2503::player::Entry;
use floatball_shared::uim2503::sim::GatewayConfig;
use serialport::{SerialPort, TTYPort};

/// A slow, gentle wave (≤ 40 mm/s) so a few ms of scheduling jitter stay far below a
/// millimetre.
fn gentle_wave(rows: u32, cols: u32, row_count: usize, row_ms: u32) -> Show {
    let mut show = Wave {
        centre_mm: 2000.0,
        amplitude_mm: 25.0,
        col_phase: 0.7,
        row_phase: f64::from(cols) * 0.7,
        tenths: false,
        ..Wave::new(rows, cols, row_count, row_ms)
    }
    .show();
    show.name = "gentle".into();
    show
}

fn installation(rows: u32, cols: u32, port: &str, baud: u32) -> Installation {
    let mut installation = Installation::row_major(
        Limits::for_layout(rows, cols),
        100.0,
        vec![GatewaySpec::uim2503(port, baud)],
        1,
    )
    .unwrap();
    installation.approach_speed_mm_s = 2000.0;
    installation
}

async fn wait_for(playback: &Playback, within: Duration, what: impl Fn(&Status) -> bool) -> Status {
    let mut status = playback.status();
    tokio::time::timeout(within, status.wait_for(|status| what(status)))
        .await
        .unwrap_or_else(|_| {
            panic!(
                "status never matched; last: {:?}",
                playback.status().borrow()
            )
        })
        .unwrap()
        .clone()
}

async fn up(link: &Link) {
    let mut status = link.status();
    tokio::time::timeout(
        Duration::from_secs(10),
        status.wait_for(|s| s.state == LinkState::Up),
    )
    .await
    .expect("link up")
    .unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_show_plays_on_the_simulated_gateway_and_follows_its_track() {
    let show = gentle_wave(2, 3, 30, 200);
    let installation = installation(2, 3, "sim", 115_200);
    let mut config = LinkConfig::new("sim", 115_200);
    config.sim = GatewayConfig::numbered(6);
    let link = Link::open(0, config);
    up(&link).await;
    let view = link.sim_view().unwrap().clone();
    let playback = Playback::spawn(installation, vec![link]);
    playback
        .start(
            vec![Entry {
                show: show.clone(),
                delay_ms: 0,
                cycles: 1,
            }],
            false,
        )
        .await
        .unwrap();
    // Playing, and past the start's instant (the show time stays 0 until then).
    let playing = wait_for(&playback, Duration::from_secs(30), |s| {
        s.state == PlayerState::Playing && s.show_time_ms > 0
    })
    .await;
    assert_eq!(playing.show.as_deref(), Some("gentle"));
    assert_eq!(playing.gateways[0].link, LinkState::Up);
    // Compare the twin's true positions with the show, at the player's show time.
    let started = Instant::now() - Duration::from_millis(playing.show_time_ms);
    let mut sampler = Sampler::new(&show);
    let mut expected = vec![0.0f32; 6];
    let mut worst: f64 = 0.0;
    for _ in 0..20 {
        tokio::time::sleep(Duration::from_millis(250)).await;
        let show_ms = started.elapsed().as_secs_f64() * 1000.0;
        let positions = view.positions(0);
        if show_ms > show.duration_ms() as f64 {
            break;
        }
        sampler.sample(show_ms, &mut expected, None);
        for (unit, expected) in positions.units.iter().zip(&expected) {
            worst = worst.max((unit.position_counts / 100.0 - f64::from(*expected)).abs());
        }
    }
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off its show");
    let done = wait_for(&playback, Duration::from_secs(30), |s| {
        s.state == PlayerState::Idle
    })
    .await;
    assert_eq!(done.last_error, None);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn estop_stops_every_simulated_ball_at_once() {
    let show = gentle_wave(1, 4, 200, 200);
    let mut config = LinkConfig::new("sim", 115_200);
    config.sim = GatewayConfig::numbered(4);
    let link = Link::open(0, config);
    up(&link).await;
    let view = link.sim_view().unwrap().clone();
    let playback = Playback::spawn(installation(1, 4, "sim", 115_200), vec![link]);
    let entries = vec![Entry {
        show,
        delay_ms: 0,
        cycles: 1,
    }];
    playback.start(entries.clone(), false).await.unwrap();
    wait_for(&playback, Duration::from_secs(30), |s| {
        s.state == PlayerState::Playing
    })
    .await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert!(view.positions(0).units.iter().any(|unit| unit.moving));
    playback.estop();
    // The stop is 8 bytes behind at most one instruction: a few ms at 115200 baud.
    tokio::time::sleep(Duration::from_millis(50)).await;
    let stopped = view.positions(0);
    assert!(
        stopped
            .units
            .iter()
            .all(|unit| !unit.moving && !unit.motor_on),
        "{stopped:?}"
    );
    wait_for(&playback, Duration::from_secs(2), |s| {
        s.state == PlayerState::Stopped
    })
    .await;
    // Start after an e-stop homes first.
    playback.start(entries, false).await.unwrap();
    wait_for(&playback, Duration::from_secs(2), |s| {
        s.state == PlayerState::Homing
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_playlist_is_planned_once_and_its_plan_shared_by_the_armer_the_player_and_start() {
    let show = gentle_wave(1, 4, 40, 200);
    let mut config = LinkConfig::new("sim", 115_200);
    config.sim = GatewayConfig::numbered(4);
    let link = Link::open(0, config);
    up(&link).await;
    let playback = Playback::spawn(installation(1, 4, "sim", 115_200), vec![link]);
    let key = |sha: &str| PlaylistKey::new(vec![("gentle".into(), sha.into(), 0, 1)], false);
    assert!(playback.prepared_for(&key("a")).is_none());
    let read = Playlist::Read {
        entries: vec![Entry {
            show,
            delay_ms: 0,
            cycles: 1,
        }],
        loop_playlist: false,
        key: Some(key("a")),
    };
    assert!(playback.arm(read, playback.disarms()).await);
    let armed = playback.prepared_for(&key("a")).expect("kept");
    // Another file of the show, or another playlist: planned anew.
    assert!(playback.prepared_for(&key("b")).is_none());
    assert!(
        playback
            .prepared_for(&PlaylistKey::new(
                vec![("gentle".into(), "a".into(), 0, 1)],
                true
            ))
            .is_none()
    );
    wait_for(&playback, Duration::from_secs(10), |s| {
        s.armed.as_ref().is_some_and(|armed| armed.progress >= 1.0)
    })
    .await;
    let plan = std::sync::Arc::clone(&armed.plans()[0]);
    playback
        .play(
            Playlist::Prepared(armed),
            playback.latch().generation(),
            Begin::Start,
        )
        .await
        .unwrap();
    let playing = wait_for(&playback, Duration::from_secs(30), |s| {
        s.state == PlayerState::Playing
    })
    .await;
    assert_eq!(playing.last_error, None);
    // One plan: the one kept for the next Start, the player's, and this test's.
    let again = playback.prepared_for(&key("a")).expect("still kept");
    assert!(std::sync::Arc::ptr_eq(&again.plans()[0], &plan));
    assert!(std::sync::Arc::strong_count(&plan) >= 3);
    let done = wait_for(&playback, Duration::from_secs(30), |s| {
        s.state == PlayerState::Idle
    })
    .await;
    assert_eq!(done.last_error, None);
}

/// Copies bytes both ways between two pty masters: a null-modem cable. A master reads
/// as hung up until its slave is opened; the cable then just waits, as a real one would.
fn cable(a: TTYPort, b: TTYPort) {
    fn pump(mut from: TTYPort, mut to: TTYPort) {
        std::thread::spawn(move || {
            let mut buffer = [0u8; 512];
            loop {
                match from.read(&mut buffer) {
                    Ok(n) => {
                        if n > 0 && to.write_all(&buffer[..n]).is_err() {
                            std::thread::sleep(Duration::from_millis(5));
                        }
                    }
                    Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
                    Err(_) => std::thread::sleep(Duration::from_millis(5)),
                }
            }
        });
    }
    let a_reader = a.try_clone_native().unwrap();
    let b_reader = b.try_clone_native().unwrap();
    pump(a_reader, b);
    pump(b_reader, a);
}

struct Simulator(Child);

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_show_plays_through_real_serial_devices() {
    // bridge ── pty A ══ cable ══ pty B ── floatball simulate
    let (mut master_a, slave_a) = TTYPort::pair().unwrap();
    let (mut master_b, slave_b) = TTYPort::pair().unwrap();
    let (path_a, path_b) = (slave_a.name().unwrap(), slave_b.name().unwrap());
    drop((slave_a, slave_b));
    master_a.set_timeout(Duration::from_millis(20)).unwrap();
    master_b.set_timeout(Duration::from_millis(20)).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
        .args([
            "simulate", "--port", &path_b, "--baud", "115200", "--units", "4",
        ])
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let mut banner = [0u8; 1];
    child
        .stdout
        .as_mut()
        .unwrap()
        .read_exact(&mut banner)
        .unwrap();
    let _simulator = Simulator(child);
    cable(master_a, master_b);

    let link = Link::open(0, LinkConfig::new(path_a, 115_200));
    up(&link).await;
    let playback = Playback::spawn(installation(2, 2, "pty", 115_200), vec![link]);
    // 300 rows of 40 ms: streamed through the FIFOs, over the cable.
    let show = gentle_wave(2, 2, 300, 40);
    playback
        .start(
            vec![Entry {
                show,
                delay_ms: 0,
                cycles: 1,
            }],
            false,
        )
        .await
        .unwrap();
    wait_for(&playback, Duration::from_secs(60), |s| {
        s.state == PlayerState::Playing
    })
    .await;
    let done = wait_for(&playback, Duration::from_secs(60), |s| {
        s.state != PlayerState::Playing
    })
    .await;
    assert_eq!(done.state, PlayerState::Idle, "{:?}", done.last_error);
    assert_eq!(done.last_error, None);
    assert!(
        done.gateways[0]
            .lowest_water_level
            .is_some_and(|level| level >= 2)
    );
}
