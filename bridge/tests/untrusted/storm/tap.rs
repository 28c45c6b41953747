//! Serial feedback noise: a UIM2503 gateway on a pseudo-terminal (the bridge opens its
//! slave through a symlink, as a USB serial adapter), answered by the simulator in this
//! process exactly as `common::process::Tap` does, with noise written into the bridge's
//! feedback direction — between the gateway's frames, never inside one.
//!
//! The noise ([`FeedbackNoise`]) is random bytes, valid frames mutated and frames
//! broken by hand (a byte `0x80`–`0xDF` inside, more than 8 data bytes, a tail before
//! the code, header bits for data that is not there, stray headers and tails). A chunk
//! that would give the bridge a whole valid frame is skipped: a copy of the bridge's
//! decoder (`FrameDecoder`), fed everything written to the line — the gateway's
//! answers and the noise sent — says so. A frame's header resets the decoder, so
//! noise left half a frame long never joins the gateway's next frame.

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use floatball_bridge::ports::uim2503::sim::{SimEngine, SimView};
use floatball_shared::api::SimGateway;
use floatball_shared::uim2503::feedback::{Frame, FrameDecoder};
use floatball_shared::uim2503::sim::{GatewayConfig, RxLine};
use serialport::{SerialPort, TTYPort};

use super::{Class, Draw, Generator, Rng, Tally, mutate, next_to_send};

/// Noise for the feedback direction, with the copy of the bridge's decoder that
/// classifies it.
#[derive(Debug, Default)]
pub struct FeedbackNoise {
    mirror: FrameDecoder,
}

impl FeedbackNoise {
    /// The gateway's own answer bytes, as they go on the line.
    fn real(&mut self, bytes: &[u8]) {
        for _ in self.mirror.push(bytes) {}
    }

    fn frame(rng: &mut Rng) -> Vec<u8> {
        let station = 1 + u8::try_from(rng.below(127)).unwrap_or(0);
        let data = {
            let len = rng.index(9);
            rng.bytes(len)
        };
        Frame::new(station, rng.byte() & 0x7F, &data)
            .map(|frame| frame.encode().as_bytes().to_vec())
            .unwrap_or_default()
    }

    fn crafted(rng: &mut Rng) -> Draw {
        let mut bytes = Self::frame(rng);
        let label = match rng.below(6) {
            0 if bytes.len() > 3 => {
                let at = 1 + rng.index(bytes.len() - 2);
                bytes[at] = 0x80 + rng.byte() % 0x60;
                "a frame with a byte 0x80-0xDF inside"
            }
            1 => {
                let mut long = vec![0xF0, 0x05, 0x0D];
                let len = 9 + rng.index(12);
                long.extend((0..len).map(|_| rng.byte() & 0x7F));
                long.push(0xE0);
                bytes = long;
                "a frame of more than 8 data bytes"
            }
            2 => {
                bytes = vec![0xF0, 0x05, 0xE0];
                "a tail before the code"
            }
            3 => {
                bytes = vec![0xFF, 0x05, 0x0D, 0x01, 0xEF];
                "header and tail bits for data that is not there"
            }
            4 => {
                bytes = vec![0xF0, 0xF0, 0x05, 0xF3, 0x05, 0x0D];
                "stray headers, half a frame"
            }
            _ => {
                let len = 1 + rng.index(8);
                bytes = (0..len).map(|_| 0xE0 + rng.byte() % 16).collect();
                "stray tails"
            }
        };
        Draw::new(Class::Crafted, label, bytes)
    }
}

impl Generator for FeedbackNoise {
    fn draw(&mut self, rng: &mut Rng) -> Draw {
        match rng.below(10) {
            0..=2 => {
                let len = 1 + rng.index(64);
                Draw::new(Class::Random, "random bytes", rng.bytes(len))
            }
            3..=6 => {
                let base = Self::frame(rng);
                Draw::new(Class::Mutated, "a valid frame mutated", mutate(rng, &base))
            }
            _ => Self::crafted(rng),
        }
    }

    fn is_command(&mut self, draw: &Draw) -> bool {
        let mut trial = self.mirror.clone();
        if trial.push(&draw.bytes).count() > 0 {
            return true;
        }
        self.mirror = trial;
        false
    }

    fn crafted_overrides(&self) -> bool {
        false
    }
}

/// How the noise is set: off until [`NoisyTap::storm`] turns it on.
#[derive(Debug)]
struct Noise {
    per_s: AtomicU64,
    started: Mutex<Option<Instant>>,
}

/// A gateway on a pseudo-terminal pair, answered by the simulator, with noise into
/// the feedback direction while a storm blows. Stops when dropped.
pub struct NoisyTap {
    pub path: std::path::PathBuf,
    view: SimView,
    noise: Arc<Noise>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl NoisyTap {
    /// A tap at `dir/name` on a line of `baud`, answering as a gateway with `units`;
    /// its noise is drawn with `rng` and counted in `tally`.
    pub fn new(
        dir: &std::path::Path,
        name: &str,
        baud: u32,
        units: GatewayConfig,
        mut rng: Rng,
        tally: Arc<Tally>,
    ) -> Self {
        let (mut master, slave) = TTYPort::pair().expect("pty pair");
        let slave_path = slave.name().expect("slave name");
        drop(slave);
        master
            .set_timeout(Duration::from_millis(2))
            .expect("timeout");
        let path = dir.join(name);
        std::os::unix::fs::symlink(slave_path, &path).expect("symlink");
        let stop = Arc::new(AtomicBool::new(false));
        let noise = Arc::new(Noise {
            per_s: AtomicU64::new(0),
            started: Mutex::new(None),
        });
        let mut engine = SimEngine::new(units, baud).expect("simulated gateway");
        let view = engine.view();
        let (stopping, noisy) = (Arc::clone(&stop), Arc::clone(&noise));
        let thread = std::thread::Builder::new()
            .name("storm serial".to_owned())
            .spawn(move || {
                let mut buffer = [0u8; 1024];
                let mut answers = Vec::new();
                let epoch = Instant::now();
                let micros = |at: Instant| {
                    u64::try_from(at.saturating_duration_since(epoch).as_micros())
                        .unwrap_or(u64::MAX)
                };
                let mut line = RxLine::new(baud);
                // The gateway's answers alone: noise goes only where they are between
                // frames.
                let mut real = FrameDecoder::new();
                let mut generator = FeedbackNoise::default();
                let mut sent = 0u64;
                // After a write of noise failed part way, no more noise until one of
                // the gateway's headers has put both decoders in step again.
                let mut healing = false;
                // `FLOATBALL_STORM_ONLY` left the noise nothing to send.
                let mut exhausted = false;
                while !stopping.load(Ordering::Acquire) {
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
                            engine.receive(at, &buffer[..n]);
                        }
                        Ok(_) => {}
                        Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
                        Err(_) => std::thread::sleep(Duration::from_millis(5)),
                    }
                    answers.clear();
                    engine.step(Instant::now(), &mut answers);
                    if !answers.is_empty() {
                        let _ = master.write_all(&answers);
                        for _ in real.push(&answers) {}
                        generator.real(&answers);
                        if answers.iter().any(|&byte| byte >= 0xF0) {
                            healing = false;
                        }
                    }
                    let per_s = noisy.per_s.load(Ordering::Acquire);
                    let started = *noisy.started.lock().unwrap_or_else(|e| e.into_inner());
                    let (Some(started), true) = (started, per_s > 0) else {
                        continue;
                    };
                    let due = (started.elapsed().as_secs_f64() * per_s as f64) as u64;
                    if sent >= due || real.pending() > 0 || healing || exhausted {
                        continue;
                    }
                    sent += 1;
                    let Some(draw) = next_to_send(&mut generator, &mut rng, &tally) else {
                        exhausted = true;
                        continue;
                    };
                    match master.write_all(&draw.bytes) {
                        Ok(()) => tally.sent(&draw),
                        Err(_) => {
                            tally.error();
                            healing = true;
                        }
                    }
                }
            })
            .expect("the tap's thread");
        Self {
            path,
            view,
            noise,
            stop,
            thread: Some(thread),
        }
    }

    /// Noise from now on, `per_s` chunks a second (0: none).
    pub fn storm(&self, per_s: f64) {
        *self.noise.started.lock().unwrap_or_else(|e| e.into_inner()) = Some(Instant::now());
        self.noise
            .per_s
            .store(per_s.round() as u64, Ordering::Release);
    }

    /// The gateway's units as the simulator has them now, as gateway `index` of the
    /// installation.
    pub fn positions(&self, index: usize) -> SimGateway {
        self.view.positions(index)
    }
}

impl Drop for NoisyTap {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
        let _ = std::fs::remove_file(&self.path);
    }
}
