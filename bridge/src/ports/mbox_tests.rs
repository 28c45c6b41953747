//! Golden wire test of the MBOX boxes: every datagram the bridge puts on the wire for
//! a fixed installation, playlist and operator's actions, in simulated time (no
//! sleeping, no socket), pinned in `bridge/tests/golden/mbox_*.txt`.
//!
//! The player is [`MboxPlayer`], driven as [`crate::playback`]'s `run_mbox` drives
//! it: woken [`FRAME_LEAD`] before its next slot and polled at that slot, every frame
//! handed over with the e-stop generation of the request that started the run. The
//! frames become bytes through the sender's own [`FrameEncoder`] (time code and
//! sequence numbers) and the e-stop and release writes through [`estop_datagram`].
//! When those go out follows the sender thread ([`Outbox`](super::Outbox)), which owns a
//! real socket and clock and so is mirrored here step by step: at an e-stop the stop
//! goes to every box at once and the frames handed over but not yet sent are dropped;
//! the first frame after a release is preceded by the release to every box; stops and
//! releases are repeated with the sender's own [`Repeats`]. The sender's polls of the
//! e-stop register (on their own timer, not the player's) are left out.
//!
//! Each line of a golden file is one datagram: the time it leaves (µs on the player's
//! clock: a frame's slot), the box, what it is (`frame`, `estop`, `release`) and its
//! bytes in hex. `# <µs> <action>` marks each operator action. To write the files
//! anew from the code as it is — only ever from code whose wire is known to be right:
//! `FLOATBALL_BLESS=1 cargo test -p floatball-bridge --lib mbox::tests`.
//!
//! The two wires of a run carry the same frames, but for the function code and the time
//! code: [`absolute_time_codes_count_on_by_each_frames_time`] checks that each box's
//! absolute time code counts on by exactly the time the relative wire gives the same
//! frame, and that twins fed the absolute wire count no time-code fault.
//!
//! The playlists here have no live frame, which the sender paces at the instant it
//! sends it ([`floatball_shared::mbox::pace`]): the golden wire is the shows' as it
//! was. [`live_frames_leave_paced_and_absolute_codes_count_on_by_the_paced_time`] runs
//! the real sender (its socket and thread) on a few frames instead.

use std::collections::VecDeque;
use std::fmt::Write as _;
use std::path::Path;
use std::time::{Duration, Instant};

use floatball_shared::api::PlayerState;
use floatball_shared::mbox::player::{MboxFrame, MboxPlayer};
use floatball_shared::mbox::twin::{MboxTwin, TwinConfig};
use floatball_shared::mbox::{AxisCount, Datagram, TimeCode, TimeMode};
use floatball_shared::plan::Installation;
use floatball_shared::player::Entry;
use floatball_shared::show::demo::Wave;
use floatball_shared::show::{AnalogKey, DigitalKey, OutputTrack, Show};

#[path = "../../tests/common/golden.rs"]
mod golden;
use golden::assert_golden;

use super::{FRAME_LEAD, FrameEncoder, estop_datagram};
use crate::config::{Config, Overrides};
use crate::estop::{Latch, Repeats};

/// Two boxes of 3 axes under a 2 × 3 matrix, 20 ms frames; `TIME` is the time mode.
/// Homing from unknown positions takes the whole travel at the approach speed: 100 ms.
const CONFIG: &str = r#"
[matrix]
rows = 2
cols = 3
travel_mm = 100.0
max_speed_mm_s = 2000.0
max_accel_mm_s2 = 40000.0
home_mm = 0.0

[safety]
approach_speed_mm_s = 1000.0

[mbox]
host_port = 0
frame_period_ms = 20
time = "TIME"

[[gateway]]
kind = "mbox"
address = "192.168.15.201:7408"
axes = 3
pulses_per_mm = 100.0
sign = -1
offset_pulses = 20000

[[gateway]]
kind = "mbox"
address = "192.168.15.202:7408"
axes = 3
"#;

/// The installation and the player, as the bridge builds them from [`CONFIG`].
fn installation(time: &str) -> (Installation, MboxPlayer, TimeMode, usize) {
    let text = CONFIG.replace("TIME", time);
    let config = Config::parse(Path::new("floatball.toml"), &text, &Overrides::default())
        .expect("the golden configuration");
    let mbox = config.mbox().expect("MBOX boxes");
    let player_config = crate::state::mbox_player_config(&config.installation, mbox);
    assert_eq!(player_config.period_us, 20_000);
    (
        config.installation.clone(),
        MboxPlayer::new(player_config),
        mbox.time,
        mbox.boxes.len(),
    )
}

/// 0.4 s of wave (4 rows of 100 ms), with outputs on both boxes.
fn first() -> Show {
    let mut show = Wave {
        centre_mm: 50.0,
        amplitude_mm: 30.0,
        period_s: 0.4,
        ..Wave::new(2, 3, 4, 100)
    }
    .show();
    show.name = "first".into();
    show.outputs = vec![
        OutputTrack {
            box_index: 0,
            digital: vec![
                DigitalKey {
                    time_ms: 0,
                    bits: 0b101,
                },
                DigitalKey {
                    time_ms: 200,
                    bits: 0x0800,
                },
            ],
            analog: vec![
                AnalogKey {
                    time_ms: 0,
                    channel: 0,
                    value: 0,
                },
                AnalogKey {
                    time_ms: 400,
                    channel: 0,
                    value: 4_000,
                },
            ],
        },
        OutputTrack {
            box_index: 1,
            digital: vec![DigitalKey {
                time_ms: 100,
                bits: 0x0FFF,
            }],
            analog: vec![AnalogKey {
                time_ms: 0,
                channel: 1,
                value: 0xABCD,
            }],
        },
    ];
    show
}

/// 0.3 s of another wave (3 rows of 100 ms), without outputs; it ends away from where
/// it starts, so a second cycle approaches.
fn second() -> Show {
    let mut show = Wave {
        centre_mm: 40.0,
        amplitude_mm: 20.0,
        period_s: 0.4,
        col_phase: 1.0,
        ..Wave::new(2, 3, 3, 100)
    }
    .show();
    show.name = "second".into();
    show
}

/// An operator's action, at a time on the player's clock.
#[derive(Debug, Clone, Copy)]
enum Action {
    Start,
    Estop,
    Home,
    Reset,
}

/// The player, the playback task around it and the boxes' sender, in simulated time.
struct Rig {
    installation: Installation,
    player: MboxPlayer,
    entries: Vec<Entry>,
    latch: Latch,
    now_us: u64,
    /// The task: the e-stop generation it has seen, that of the run it plays, and when
    /// it wakes next.
    seen_generation: u64,
    run_generation: u64,
    task_at_us: u64,
    /// The sender: the generation it has seen, whether a release must go first, the
    /// repeats, the frames handed over (with their generation), and its encoder.
    sender_generation: u64,
    needs_release: bool,
    repeats: Repeats<u16>,
    pending: VecDeque<(u64, MboxFrame)>,
    encoder: FrameEncoder,
    /// Frames handed over but dropped by an e-stop before their slot.
    dropped: usize,
    boxes: usize,
    epoch: Instant,
    /// The golden text.
    wire: String,
}

impl Rig {
    fn new(time: &str, entries: Vec<Entry>) -> Self {
        let (installation, player, mode, boxes) = installation(time);
        let latch = Latch::new();
        let generation = latch.generation();
        let mut wire = String::new();
        let _ = writeln!(
            wire,
            "# MBOX wire, time = \"{time}\": <µs> <box> <frame|estop|release> <bytes>"
        );
        Self {
            installation,
            player,
            entries,
            latch,
            now_us: 0,
            seen_generation: generation,
            run_generation: generation,
            task_at_us: 0,
            sender_generation: generation,
            needs_release: true,
            repeats: Repeats::default(),
            pending: VecDeque::new(),
            encoder: FrameEncoder::new(mode, boxes),
            dropped: 0,
            boxes,
            epoch: Instant::now(),
            wire,
        }
    }

    fn instant(&self, us: u64) -> Instant {
        self.epoch + Duration::from_micros(us)
    }

    fn us(&self, instant: Instant) -> u64 {
        u64::try_from(instant.duration_since(self.epoch).as_micros()).expect("µs")
    }

    fn record(&mut self, index: usize, kind: &str, bytes: &[u8]) {
        let hex: String = bytes.iter().map(|byte| format!("{byte:02x}")).collect();
        let _ = writeln!(self.wire, "{} {index} {kind} {hex}", self.now_us);
    }

    /// The sender's `write_estop`: FN `0x0090` = `value` to every box.
    fn write_estop(&mut self, value: u16) {
        let bytes = estop_datagram(value);
        let kind = if value == 0 { "release" } else { "estop" };
        for index in 0..self.boxes {
            self.record(index, kind, &bytes);
        }
    }

    /// The sender's `observe_latch`: a new e-stop goes out before anything else.
    fn observe_latch(&mut self) {
        let generation = self.latch.generation();
        if generation == self.sender_generation {
            return;
        }
        self.sender_generation = generation;
        self.write_estop(1);
        self.repeats.start_with(1, self.instant(self.now_us));
        self.needs_release = true;
        self.dropped += self.pending.len();
        self.pending.clear();
    }

    /// The sender's `frame`.
    fn send_frame(&mut self, generation: u64, frame: &MboxFrame) {
        if generation != self.sender_generation || self.latch.is_latched() {
            return;
        }
        if self.needs_release {
            self.needs_release = false;
            self.write_estop(0);
            self.repeats.start_with(0, self.instant(self.now_us));
        }
        for index in 0..frame.positions_pulses.len() {
            if let Some(datagram) = self.encoder.datagram(frame, index) {
                self.record(index, "frame", &datagram);
            }
        }
    }

    /// One turn of the sender's loop at `now_us`.
    fn sender_turn(&mut self) {
        self.observe_latch();
        while self
            .pending
            .front()
            .is_some_and(|(_, frame)| frame.slot_us <= self.now_us)
        {
            self.observe_latch();
            if let Some((generation, frame)) = self.pending.pop_front() {
                self.send_frame(generation, &frame);
            }
        }
        if let Some(value) = self.repeats.due_value(self.instant(self.now_us)) {
            self.write_estop(value);
        }
    }

    /// When the sender has something to do next.
    fn sender_at_us(&self) -> Option<u64> {
        let frame = self.pending.front().map(|(_, frame)| frame.slot_us);
        let repeat = self.repeats.next().map(|at| self.us(at));
        frame.into_iter().chain(repeat).min()
    }

    /// The bridge's `estop::press` (links none, the boxes' sender woken at once).
    fn press(&mut self) {
        crate::estop::press(&self.latch, &[]);
        self.sender_turn();
    }

    /// The task's `admit`: releases the latch for a request issued now.
    fn admit(&self) -> u64 {
        let generation = self.latch.generation();
        assert!(self.latch.release(generation), "admitted");
        generation
    }

    /// One turn of `run_mbox` at `now_us`, with the request it woke for.
    fn task_turn(&mut self, request: Option<Action>) {
        let now = self.now_us;
        let generation = self.latch.generation();
        if generation != self.seen_generation {
            self.seen_generation = generation;
            self.player.estop();
        }
        match request {
            None | Some(Action::Estop) => {}
            Some(Action::Start) => {
                MboxPlayer::check(&self.installation, &self.entries).expect("fits");
                let generation = self.admit();
                assert!(
                    self.player.start_checked(now, self.entries.clone(), false),
                    "started"
                );
                self.run_generation = generation;
            }
            Some(Action::Home) => {
                self.run_generation = self.admit();
                self.player.home(now);
            }
            Some(Action::Reset) => {
                self.run_generation = self.admit();
                self.player
                    .reset(now, Ok(self.entries.clone()), false)
                    .expect("reset");
            }
        }
        let lead_us = u64::try_from(FRAME_LEAD.as_micros()).expect("lead");
        self.player.poll(now + lead_us);
        for frame in self.player.take_frames() {
            self.pending.push_back((self.run_generation, frame));
        }
        let wake_us = self
            .player
            .next_wakeup_us(now)
            .unwrap_or(now + 100_000)
            .min(now + 100_000);
        self.task_at_us = wake_us.saturating_sub(lead_us).max(now);
    }

    /// An operator's action, as the bridge's `Playback` carries it out: Home and Reset
    /// press the e-stop first; the task then sees the e-stop and the request.
    fn act(&mut self, action: Action) {
        let name = match action {
            Action::Start => "start",
            Action::Estop => "estop",
            Action::Home => "home",
            Action::Reset => "reset",
        };
        let _ = writeln!(self.wire, "# {} {name}", self.now_us);
        match action {
            Action::Start => self.task_turn(Some(Action::Start)),
            Action::Estop => {
                self.press();
                self.task_turn(Some(Action::Estop));
            }
            Action::Home | Action::Reset => {
                self.press();
                self.task_turn(Some(Action::Estop));
                self.task_turn(Some(action));
            }
        }
    }

    /// Runs the actions at their times, each when the player is in the state given
    /// with it, then until the player rests and the sender has nothing left to send.
    /// At the same moment the sender goes first, then the operator.
    fn run(&mut self, actions: &[(u64, Action, PlayerState)]) {
        let mut actions = actions.iter().copied().peekable();
        loop {
            let sender_at = self.sender_at_us();
            let action_at = actions.peek().map(|&(at, ..)| at);
            if sender_at.is_none() && action_at.is_none() && !self.player.is_running() {
                break;
            }
            let at = [sender_at, action_at, Some(self.task_at_us)]
                .into_iter()
                .flatten()
                .min()
                .expect("a next event");
            assert!(at >= self.now_us, "time goes on");
            assert!(at < 60_000_000, "the run never ends");
            self.now_us = at;
            if sender_at == Some(at) {
                self.sender_turn();
            } else if action_at == Some(at) {
                let (_, action, state) = actions.next().expect("the action");
                assert_eq!(self.player.status().state, state, "{action:?} at {at} µs");
                self.act(action);
            } else {
                self.task_turn(None);
            }
        }
    }
}

/// The playlist of both entries: the first after a delay, the second twice.
fn playlist() -> Vec<Entry> {
    vec![
        Entry {
            show: first(),
            delay_ms: 60,
            cycles: 1,
        },
        Entry {
            show: second(),
            delay_ms: 0,
            cycles: 2,
        },
    ]
}

/// Start with the positions unknown: homing, the delay, the approach, the first show,
/// the approach to the second, its two cycles (with an approach between) and the
/// settle frames at the end.
fn playlist_wire(time: &str) -> String {
    let mut rig = Rig::new(time, playlist());
    rig.run(&[(0, Action::Start, PlayerState::Idle)]);
    assert!(!rig.player.is_running());
    assert_eq!(rig.player.status().last_error, None);
    rig.wire
}

/// One show (the first, no delay), with every action: Start (homing first), E-stop in
/// the show within [`FRAME_LEAD`] of a slot (the frame already handed to the sender is
/// dropped), Home, Start (from home: no homing), Reset in the show (homing first),
/// E-stop in the show between two hand-overs, Start (homing first, the positions being
/// unknown) played to its end. The slots are not on whole milliseconds, so the
/// absolute time codes are truncated.
fn operator_wire(time: &str) -> String {
    let entries = vec![Entry {
        show: first(),
        delay_ms: 0,
        cycles: 1,
    }];
    let mut rig = Rig::new(time, entries);
    rig.run(&[
        (1_500, Action::Start, PlayerState::Idle),
        (558_000, Action::Estop, PlayerState::Playing),
        (650_000, Action::Home, PlayerState::Stopped),
        (1_000_000, Action::Start, PlayerState::Idle),
        (1_250_250, Action::Reset, PlayerState::Playing),
        (1_900_300, Action::Estop, PlayerState::Playing),
        (2_000_000, Action::Start, PlayerState::Stopped),
    ]);
    assert!(!rig.player.is_running());
    assert_eq!(rig.player.status().last_error, None);
    assert_eq!(
        rig.dropped, 1,
        "the first e-stop drops the frame handed over"
    );
    rig.wire
}

#[test]
fn the_wire_carries_exactly_the_golden_datagrams_for_a_playlist() {
    assert_golden("mbox_playlist_relative.txt", &playlist_wire("relative"));
    assert_golden("mbox_playlist_absolute.txt", &playlist_wire("absolute"));
}

#[test]
fn the_wire_carries_exactly_the_golden_datagrams_for_estop_home_start_and_reset() {
    assert_golden("mbox_operator_relative.txt", &operator_wire("relative"));
    assert_golden("mbox_operator_absolute.txt", &operator_wire("absolute"));
}

/// The motion frames of a golden wire: (µs, box, the frame).
fn motion_frames(wire: &str) -> Vec<(u64, usize, floatball_shared::mbox::MotionFrame)> {
    wire.lines()
        .filter(|line| !line.starts_with('#'))
        .filter_map(|line| {
            let fields: Vec<&str> = line.split(' ').collect();
            if fields[2] != "frame" {
                return None;
            }
            let bytes: Vec<u8> = (0..fields[3].len())
                .step_by(2)
                .map(|at| u8::from_str_radix(&fields[3][at..at + 2], 16).expect("hex"))
                .collect();
            let Ok(Datagram::Motion(frame)) = Datagram::decode(&bytes) else {
                panic!("not a motion frame: {line}");
            };
            Some((
                fields[0].parse().expect("µs"),
                fields[1].parse().expect("box"),
                frame,
            ))
        })
        .collect()
}

#[test]
fn absolute_time_codes_count_on_by_each_frames_time() {
    let wires = [
        (playlist_wire("relative"), playlist_wire("absolute")),
        (operator_wire("relative"), operator_wire("absolute")),
    ];
    for (relative, absolute) in wires {
        let relative = motion_frames(&relative);
        let absolute = motion_frames(&absolute);
        assert_eq!(relative.len(), absolute.len());
        let mut last_code = [0u32; 2];
        let mut twins = [0, 1].map(|_| {
            MboxTwin::new(TwinConfig::new(
                floatball_shared::mbox::FACTORY_IP,
                AxisCount::Three,
            ))
        });
        for ((at_us, index, relative), (absolute_at_us, absolute_index, absolute)) in
            relative.iter().zip(&absolute)
        {
            assert_eq!((at_us, index), (absolute_at_us, absolute_index));
            assert_eq!(relative.mode, TimeMode::Relative);
            assert_eq!(absolute.mode, TimeMode::Absolute);
            // Homing, approach, settle and show frames alike: the box takes the code
            // minus the last one, exactly the time the frame asks for.
            let (TimeCode::Ms(time_ms), TimeCode::Ms(code)) =
                (relative.time_code, absolute.time_code)
            else {
                panic!("a time code of 0 at {at_us} µs");
            };
            assert_eq!(
                code.get(),
                last_code[*index] + time_ms.get(),
                "box {index} at {at_us} µs"
            );
            last_code[*index] = code.get();
            assert_eq!(
                (relative.positions_pulses, relative.digital, relative.analog),
                (absolute.positions_pulses, absolute.digital, absolute.analog),
            );
            twins[*index].receive(*at_us, &floatball_shared::mbox::Encode::encode(absolute));
        }
        for twin in &twins {
            let counters = twin.counters();
            assert!(counters.motion_frames > 50, "{counters:?}");
            assert_eq!(counters.time_code_faults, 0, "{counters:?}");
        }
    }
}

/// The sender itself — its socket, its pacers, its encoder: a frame that is not live
/// leaves as made; a live frame leaves paced (a box at rest where its model says gets
/// half a period; a step beyond what a line may do is brought in to the velocity
/// change the pacer allows, on a line of [`HOLD_PERIODS`] periods); in absolute time
/// each box's code counts on by the time its datagram asks.
#[test]
fn live_frames_leave_paced_and_absolute_codes_count_on_by_the_paced_time() {
    use std::sync::Arc;

    use floatball_shared::mbox::drive::BoxCalibration;
    use floatball_shared::mbox::pace::{
        ACCEL_WINDOW_US, BoxLimits, HOLD_PERIODS, PaceLimits, guard_accel_pulses_s2,
    };
    use floatball_shared::show::OutputSample;

    use super::MboxNet;

    let calibration = BoxCalibration {
        axes: 3,
        pulses_per_mm: 100.0,
        sign: 1,
        offset_pulses: 0,
    };
    let limits = BoxLimits::new(&calibration, 1000.0, 500.0, 2000.0);
    let pace: PaceLimits = Arc::from([limits]);
    // The velocity change a line may make, over the hold.
    let hold_ms = 20 * u32::try_from(HOLD_PERIODS).expect("periods");
    let brought_in = (guard_accel_pulses_s2(&limits, ACCEL_WINDOW_US) * 0.010 * f64::from(hold_ms)
        / 1000.0)
        .round() as i32;
    for (time, codes) in [
        (TimeMode::Relative, [20, 10, hold_ms]),
        (TimeMode::Absolute, [20, 30, 30 + hold_ms]),
    ] {
        let the_box = std::net::UdpSocket::bind("127.0.0.1:0").expect("the box's socket");
        the_box
            .set_read_timeout(Some(Duration::from_secs(2)))
            .expect("a timeout");
        let latch = Arc::new(Latch::new());
        let net = MboxNet::open(
            0,
            &[the_box.local_addr().expect("its address")],
            Duration::from_millis(20),
            time,
            Arc::clone(&latch),
        )
        .expect("the sender");
        let frame = |slot_us: u64, pulses: i32, live: bool| MboxFrame {
            slot_us,
            time_ms: 20,
            positions_pulses: vec![vec![pulses; 3]],
            outputs: vec![OutputSample::default()],
            pace: live.then(|| PaceLimits::clone(&pace)),
        };
        let epoch = Instant::now() + Duration::from_millis(10);
        let generation = latch.generation();
        // At rest at 0 (as made), live at rest there, then a live step of 10 mm in one
        // period (500 mm/s from rest) — 100 ms apart, so that a sender held up by a
        // loaded host still sends them apart.
        for (slot_us, pulses, live) in [(0, 0, false), (100_000, 0, true), (200_000, 1_000, true)] {
            net.send(
                frame(slot_us, pulses, live),
                epoch + Duration::from_micros(slot_us),
                generation,
            );
        }
        let mut motion = Vec::new();
        let mut buffer = [0u8; 256];
        while motion.len() < 3 {
            let length = the_box.recv(&mut buffer).expect("a datagram");
            if let Ok(Datagram::Motion(frame)) = Datagram::decode(&buffer[..length]) {
                motion.push(frame);
            }
        }
        assert!(motion.iter().all(|frame| frame.mode == time));
        let got: Vec<u32> = motion
            .iter()
            .map(|frame| frame.time_code.wire_ms())
            .collect();
        assert_eq!(got, codes, "{time:?}");
        let pulses: Vec<i32> = motion
            .iter()
            .map(|frame| frame.positions_pulses.as_slice()[0])
            .collect();
        assert_eq!(pulses, [0, 0, brought_in], "{time:?}");
        // The sender counts a frame once its datagrams are out.
        let deadline = Instant::now() + Duration::from_secs(2);
        while net.timing().frames_sent < 3 && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(1));
        }
        assert_eq!(net.timing().frames_sent, 3);
        assert!(net.recent_lateness_us() <= net.timing().max_lateness_us);
    }
}
