//! What the player and the console ask of MOONS' drives, as sequences of requests on
//! the [`SclNet`]'s links: a console line resolved to its drives ([`console`]); moves
//! to a position (`VE AC DE DI FP`, [`move_all`]) and the wait until every drive is
//! there ([`wait_positions`]); a Q program's segments written with `QW` and read back
//! with `QU` ([`upload`]); the common start (the trigger output low, then high after
//! [`TRIGGER_PULSE`], or `QX1` to every drive, [`fire`]); the wait until every drive's
//! program has ended ([`wait_ended`]).
//!
//! Every request carries the e-stop generation of the Start, Reset or Home it belongs
//! to: after an e-stop each one fails as void, and the sequence ends there.

use std::time::{Duration, Instant};

use floatball_shared::api::ServerMessage;
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::params;
use floatball_shared::plan::Installation;
use floatball_shared::scl::qprogram::{QProgram, QProgramConfig, QProgramError, compile};
use floatball_shared::scl::{
    Answer, Command, Decimal, Level, QueueUpload, Reply, Request, Segment, parse_script,
};
use floatball_shared::show::Show;

use super::{Expect, SclError, SclNet};
use crate::config::SclConfig;

/// How long the trigger output stays low before it goes high (the falling edge, then
/// the rising one).
pub const TRIGGER_PULSE: Duration = Duration::from_millis(100);

/// Status code bit: a Q program is running (HCR, `SC`).
pub const SC_PROGRAM_RUNNING: u16 = 0x4000;

/// Status code bit: the motor is moving (HCR, `SC`).
pub const SC_MOVING: u16 = 0x0010;

/// How often the player asks the drives while it waits for them.
const WAIT_POLL: Duration = Duration::from_millis(20);

/// A unit's drive: its gateway entry and its place there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriveRef {
    /// The gateway entry.
    pub gateway: usize,
    /// The drive's index on it (station − 1).
    pub drive: usize,
}

/// Every unit's drive, in unit order.
pub fn drives_of(installation: &Installation) -> Vec<DriveRef> {
    installation
        .units
        .iter()
        .map(|unit| DriveRef {
            gateway: unit.gateway,
            drive: usize::from(unit.station.saturating_sub(1)),
        })
        .collect()
}

/// The compiler's settings for this installation: the same as `GET /api/qprogram`
/// uses ([`crate::http::qprogram::qprogram_config`]), so a program downloaded for Q
/// Programmer is the one Start would upload.
pub fn qprogram_config(installation: &Installation, scl: &SclConfig) -> QProgramConfig {
    crate::http::qprogram::qprogram_config(installation, &crate::http::qprogram::scl_overrides(scl))
}

/// Compiles every ball's track of `show` with `settings`, in ball order, on as many
/// threads as the machine has cores (each ball is independent; a 10-minute show takes
/// about 0.1–0.3 s a ball). Blocking: call it from a blocking thread.
pub fn compile_every_ball(
    show: &Show,
    settings: &QProgramConfig,
) -> Vec<Result<QProgram, QProgramError>> {
    let threads = std::thread::available_parallelism()
        .map_or(1, std::num::NonZeroUsize::get)
        .clamp(1, show.tracks.len().max(1));
    let share = show.tracks.len().div_ceil(threads).max(1);
    std::thread::scope(|scope| {
        let workers: Vec<_> = show
            .tracks
            .chunks(share)
            .map(|tracks| {
                scope.spawn(move || {
                    tracks
                        .iter()
                        .map(|track| compile(track, settings))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        workers
            .into_iter()
            // A panic in the compiler (a bug) goes on to the caller's blocking thread,
            // which reports that the compiler stopped.
            .flat_map(|worker| {
                worker
                    .join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
            })
            .collect()
    })
}

/// `value` with `scale` decimals, as a parameter.
fn decimal(value: f64, scale: u8) -> Decimal {
    let mantissa = (value * 10f64.powi(i32::from(scale))).round();
    // Within i64 by the limits the configuration checks.
    Decimal::new(mantissa as i64, scale).unwrap_or(Decimal::from_int(0))
}

impl SclNet {
    /// Sends `command` to `drive` and returns its answer (one line, or an upload's).
    ///
    /// # Errors
    /// No answer, void, or a refusal (`?`) in words naming the drive.
    pub async fn ask(
        &self,
        drive: DriveRef,
        command: Command,
        generation: u64,
    ) -> Result<Vec<String>, String> {
        let link = self
            .links()
            .get(drive.gateway)
            .ok_or_else(|| format!("there is no SCL gateway {}", drive.gateway))?;
        let expect = super::expect_of(&command);
        let lines = link
            .request(drive.drive, command.to_string(), expect, generation)
            .await
            .map_err(|error| error.to_string())?;
        if let Some(Ok(Reply {
            answer: Answer::Refused { code },
            ..
        })) = lines.first().map(|line| Reply::parse(line))
        {
            return Err(format!(
                "{} refused {command}{}",
                self.name(drive),
                code.map(|code| format!(" (code {code})"))
                    .unwrap_or_default()
            ));
        }
        Ok(lines)
    }

    /// How the errors name a drive: `drive '1' on gateway 0`.
    pub fn name(&self, drive: DriveRef) -> String {
        let name = self
            .links()
            .get(drive.gateway)
            .and_then(|link| link.drive(drive.drive))
            .map(|status| status.address)
            .unwrap_or_default();
        format!("drive {name:?} on SCL gateway {}", drive.gateway)
    }

    /// Asks `drive` for a value (`IP`, `SC`, `AL`).
    async fn value(
        &self,
        drive: DriveRef,
        command: Command,
        generation: u64,
    ) -> Result<Answer, String> {
        let lines = self.ask(drive, command, generation).await?;
        match lines.first().map(|line| Reply::parse(line)) {
            Some(Ok(reply)) => Ok(reply.answer),
            _ => Err(format!(
                "{} answered {command} with {:?}",
                self.name(drive),
                lines.join(" ")
            )),
        }
    }
}

/// Sends `commands` to every drive in turn, each drive's in order (the drives of one
/// line one after the other, the lines side by side).
async fn each_drive(
    net: &SclNet,
    drives: &[DriveRef],
    generation: u64,
    commands: impl Fn(usize) -> Vec<Command>,
) -> Result<(), String> {
    let mut lines = Vec::new();
    for gateway in 0..net.links().len() {
        let mine: Vec<(usize, DriveRef)> = drives
            .iter()
            .copied()
            .enumerate()
            .filter(|(_, drive)| drive.gateway == gateway)
            .collect();
        let commands = &commands;
        lines.push(async move {
            for (unit, drive) in mine {
                for command in commands(unit) {
                    net.ask(drive, command, generation).await?;
                }
            }
            Ok::<(), String>(())
        });
    }
    for result in futures_util::future::join_all(lines).await {
        result?;
    }
    Ok(())
}

/// Moves every unit's drive to `targets_counts[unit]` (`FP`) at `speed_mm_s` and the
/// installation's acceleration.
///
/// # Errors
/// A drive refused or did not answer; void after an e-stop.
pub async fn move_all(
    net: &SclNet,
    installation: &Installation,
    scl: &SclConfig,
    targets_counts: &[i32],
    speed_mm_s: f64,
    generation: u64,
) -> Result<(), String> {
    let per_rev = f64::from(scl.steps_per_rev);
    let velocity = decimal(speed_mm_s * installation.counts_per_mm / per_rev, 4);
    let accel = decimal(
        installation.limits.max_accel_mm_s2 * installation.counts_per_mm / per_rev,
        3,
    );
    each_drive(net, &drives_of(installation), generation, |unit| {
        vec![
            Command::Velocity {
                rev_s: Some(velocity),
            },
            Command::Acceleration {
                rev_s2: Some(accel),
            },
            Command::Deceleration {
                rev_s2: Some(accel),
            },
            Command::Distance {
                counts: Some(targets_counts.get(unit).copied().unwrap_or(0)),
            },
            Command::FeedToPosition,
        ]
    })
    .await
}

/// Waits until every unit's drive stands at `targets_counts[unit]` (`IP`), at most
/// `limit`.
///
/// # Errors
/// A drive not there in time (with where it is), no answer, or void.
pub async fn wait_positions(
    net: &SclNet,
    installation: &Installation,
    targets_counts: &[i32],
    limit: Duration,
    generation: u64,
) -> Result<(), String> {
    let drives = drives_of(installation);
    let until = Instant::now() + limit;
    for (unit, &drive) in drives.iter().enumerate() {
        let target = i64::from(targets_counts.get(unit).copied().unwrap_or(0));
        loop {
            let answer = net
                .value(drive, Command::ImmediatePosition, generation)
                .await?;
            let at = answer.value_i64();
            if at == Some(target) {
                break;
            }
            if Instant::now() >= until {
                return Err(format!(
                    "{} is at {} counts, not {target}, {} ms after it was sent there",
                    net.name(drive),
                    at.map_or_else(|| "?".to_owned(), |at| at.to_string()),
                    limit.as_millis()
                ));
            }
            tokio::time::sleep(WAIT_POLL).await;
        }
    }
    Ok(())
}

/// Writes `segments` to `drive` with `QW` (the drive answers `%`, then `*` a line,
/// then `%` to the empty line that ends the segment) and reads each back with `QU`.
///
/// # Errors
/// A refusal — a drive that refuses `QW` is a real drive, loaded with Q Programmer —
/// a missed answer, or a segment read back that is not what was written.
pub async fn upload(
    net: &SclNet,
    drive: DriveRef,
    segments: &[(Segment, Vec<Command>)],
    generation: u64,
) -> Result<(), String> {
    let link = net
        .links()
        .get(drive.gateway)
        .ok_or_else(|| format!("there is no SCL gateway {}", drive.gateway))?;
    let answer = |lines: Result<Vec<String>, SclError>| -> Result<Answer, String> {
        let lines = lines.map_err(|error| error.to_string())?;
        match lines.first().map(|line| Reply::parse(line)) {
            Some(Ok(reply)) => Ok(reply.answer),
            _ => Err(format!(
                "{} answered {:?}",
                net.name(drive),
                lines.join(" ")
            )),
        }
    };
    for (segment, commands) in segments {
        let write = Command::QueueWrite { segment: *segment };
        match answer(
            link.request(drive.drive, write.to_string(), Expect::One, generation)
                .await,
        )? {
            Answer::Executed => {}
            Answer::Refused { .. } => {
                return Err(format!(
                    "{} refused {write}: it does not take programs from the bridge. Load \
                     each drive's program with MOONS' Q Programmer (the app offers every \
                     ball's program as a download) and set programs = \"stored\" in [scl]",
                    net.name(drive)
                ));
            }
            other => {
                return Err(format!("{} answered {write} with {other}", net.name(drive)));
            }
        }
        for command in commands {
            match answer(
                link.request(drive.drive, command.to_string(), Expect::One, generation)
                    .await,
            )? {
                Answer::Buffered | Answer::Executed => {}
                other => {
                    return Err(format!(
                        "{} answered line {command} of segment {segment} with {other}",
                        net.name(drive)
                    ));
                }
            }
        }
        match answer(
            link.request(drive.drive, String::new(), Expect::One, generation)
                .await,
        )? {
            Answer::Executed => {}
            other => {
                return Err(format!(
                    "{} answered the end of segment {segment} with {other}",
                    net.name(drive)
                ));
            }
        }
        let read = Command::QueueUpload {
            segment: Some(*segment),
        };
        let lines = link
            .request(drive.drive, read.to_string(), Expect::Upload, generation)
            .await
            .map_err(|error| error.to_string())?;
        let rest: Vec<&str> = lines.iter().skip(1).map(String::as_str).collect();
        match QueueUpload::parse(&rest) {
            Ok((_, QueueUpload::Lines(read_back))) if read_back == *commands => {}
            Ok((_, QueueUpload::Lines(read_back))) => {
                return Err(format!(
                    "{} holds {} lines in segment {segment} after the upload, not the {} \
                     written (or not the same)",
                    net.name(drive),
                    read_back.len(),
                    commands.len()
                ));
            }
            Ok((_, other)) => {
                return Err(format!(
                    "{} answered {read} with {}",
                    net.name(drive),
                    other.lines().join(" ")
                ));
            }
            Err(error) => {
                return Err(format!(
                    "{} answered {read} with {:?}: {error}",
                    net.name(drive),
                    lines.join(" ")
                ));
            }
        }
    }
    Ok(())
}

/// Starts every drive's program 1 together: the trigger output low, then high after
/// [`TRIGGER_PULSE`] (every drive waits for that edge on its start input), or `QX1`
/// to every drive when no trigger is configured. Returns when the show's time 0 was:
/// when the trigger drive confirmed the edge, or when the first `QX1` went.
///
/// # Errors
/// A refusal or a missed answer; void after an e-stop.
pub async fn fire(
    net: &SclNet,
    installation: &Installation,
    scl: &SclConfig,
    generation: u64,
) -> Result<Instant, String> {
    let Some((address, output)) = scl.trigger else {
        let started = Instant::now();
        each_drive(net, &drives_of(installation), generation, |_| {
            Segment::new(1)
                .map(|segment| Command::QueueExecute { segment })
                .into_iter()
                .collect()
        })
        .await?;
        return Ok(started);
    };
    let trigger = net
        .links()
        .first()
        .and_then(|link| link.drive_of(address))
        .map(|drive| DriveRef { gateway: 0, drive })
        .ok_or_else(|| format!("the trigger drive {address} is not on SCL gateway 0"))?;
    // Every drive's program 1 runs to its WI and waits for the edge.
    each_drive(net, &drives_of(installation), generation, |_| {
        Segment::new(1)
            .map(|segment| Command::QueueExecute { segment })
            .into_iter()
            .collect()
    })
    .await?;
    let set = |level| Command::SetOutput { output, level };
    net.ask(trigger, set(Level::Low), generation).await?;
    let started = Instant::now();
    tokio::time::sleep(TRIGGER_PULSE).await;
    net.ask(trigger, set(Level::High), generation).await?;
    Ok(started)
}

/// Waits until no drive runs its program any more (`SC` without
/// [`SC_PROGRAM_RUNNING`] nor [`SC_MOVING`]), at most until `limit`.
///
/// # Errors
/// A drive still running at `limit`, an alarm, no answer, or void.
pub async fn wait_ended(
    net: &SclNet,
    installation: &Installation,
    limit: Instant,
    generation: u64,
) -> Result<(), String> {
    for drive in drives_of(installation) {
        loop {
            let code = net
                .value(drive, Command::StatusCode, generation)
                .await?
                .value_hex_u16()
                .unwrap_or(0);
            if code & (SC_PROGRAM_RUNNING | SC_MOVING) == 0 {
                break;
            }
            if Instant::now() >= limit {
                return Err(format!(
                    "{} still runs its program (status code {code:04X}) after the show's end",
                    net.name(drive)
                ));
            }
            tokio::time::sleep(WAIT_POLL).await;
        }
    }
    Ok(())
}

/// A console line on an SCL installation: each request resolved to its gateway entry
/// and drive (its address character names the drive; without one, the entry must
/// have one drive), checked against the latch, handed to the link. Returns why it
/// was refused, if it was.
///
/// # Errors
/// The line does not parse (with line and column), names no drive, or could move a
/// drive while the e-stop is latched.
pub fn console(
    net: &SclNet,
    line: &str,
    gateway: Option<usize>,
    latched: bool,
    generation: u64,
) -> Result<(), ServerMessage> {
    let requests = parse_script(line).map_err(|error| {
        ServerMessage::error(
            error.code(),
            format!("the line is not valid: {error}"),
            error.params(),
        )
    })?;
    if requests.is_empty() {
        return Err(ServerMessage::error(
            Code::EmptyLine,
            "the line holds no command",
            Params::new(),
        ));
    }
    let index = gateway.unwrap_or(0);
    let link = net.links().get(index).ok_or_else(|| {
        ServerMessage::from_template(
            Code::NoSuchGateway,
            params! {"gateway" => index, "last" => net.links().len().saturating_sub(1)},
        )
    })?;
    let mut targets: Vec<(usize, Request)> = Vec::with_capacity(requests.len());
    for request in requests {
        let drive = match request.address {
            Some(address) => link.drive_of(address).ok_or_else(|| {
                ServerMessage::from_template(
                    Code::NoSuchDrive,
                    params! {"drive" => address.character(), "gateway" => index},
                )
            })?,
            None if link.drives() == 1 => 0,
            None => {
                return Err(ServerMessage::from_template(
                    Code::DriveAddressNeeded,
                    params! {"request" => &request, "gateway" => index, "drives" => link.drives()},
                ));
            }
        };
        if latched && !super::is_inert(&request.command) {
            return Err(ServerMessage::error(
                Code::EstopLatched,
                "the e-stop is latched: only queries and stops can be sent until \
                        Start, Reset or Home; this line was not sent",
                Params::new(),
            ));
        }
        targets.push((drive, request));
    }
    for (drive, request) in targets {
        link.console(drive, &request, generation);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use floatball_shared::show::demo::wave;

    use super::*;

    #[test]
    fn every_ball_is_compiled_in_ball_order_as_one_at_a_time_would() {
        // 7 balls: shares of unequal length on any number of cores.
        let show = wave(1, 7, 40, 200);
        let settings = QProgramConfig {
            tolerance_mm: 1000.0,
            ..QProgramConfig::default()
        };
        let together = compile_every_ball(&show, &settings);
        assert_eq!(together.len(), 7);
        for (ball, (program, track)) in together.iter().zip(&show.tracks).enumerate() {
            let alone = compile(track, &settings);
            assert_eq!(
                program.as_ref().map(QProgram::text).ok(),
                alone.as_ref().map(QProgram::text).ok(),
                "ball u{ball}"
            );
            assert!(program.is_ok(), "ball u{ball}: {program:?}");
        }
        // Errors stay with their ball.
        let strict = QProgramConfig {
            tolerance_mm: 0.001,
            ..settings
        };
        let refused = compile_every_ball(&show, &strict);
        assert_eq!(refused.len(), 7);
        assert!(
            refused
                .iter()
                .all(|program| matches!(program, Err(QProgramError::TooFar { .. })))
        );
        assert!(compile_every_ball(&wave(1, 1, 1, 200), &settings).len() == 1);
    }
}
