//! What the bridge asks of MOONS' drives beside the player
//! ([`floatball_shared::scl::drive`], carried out by `crate::playback`): a console
//! line resolved to its drives ([`console`]); every unit's drive
//! ([`drives_of`]) and how errors name it ([`SclNet::name`]); every ball's Q program
//! compiled on every core ([`compile_every_ball`]) with the installation's settings
//! ([`qprogram_config`]).

use floatball_shared::api::ServerMessage;
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::params;
use floatball_shared::plan::Installation;
use floatball_shared::plan::verdict::{Fix, Why};
use floatball_shared::scl::qprogram::{
    QProgram, QProgramConfig, QProgramError, Streaming, compile_for_drive,
};
use floatball_shared::scl::{Request, parse_script};
use floatball_shared::show::Show;

use super::SclNet;
use crate::config::SclConfig;

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
/// uses ([`crate::config::scl::qprogram_config`]), so a program downloaded for Q
/// Programmer is the one Start would upload.
pub fn qprogram_config(installation: &Installation, scl: &SclConfig) -> QProgramConfig {
    crate::config::scl::qprogram_config(installation, &crate::config::scl::scl_overrides(scl))
}

/// Compiles every ball's track of `show` with `settings`, in ball order, on as many
/// threads as the machine has cores (each ball is independent; a 10-minute show takes
/// about 0.1–0.3 s a ball), stored or streamed as `streaming` allows. Blocking: call
/// it from a blocking thread.
pub fn compile_every_ball(
    show: &Show,
    settings: &QProgramConfig,
    streaming: Streaming,
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
                        .map(|track| compile_for_drive(track, settings, streaming))
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

/// Why a show cannot be compiled for MOONS' drives: the first ball that cannot, and
/// what would make every ball compile.
#[derive(Debug)]
pub struct Uncompilable {
    /// The first ball's reason.
    pub why: Why,
    /// When balls stray too far from the show: the tolerance that would take them.
    pub fixes: Vec<Fix>,
}

/// Every ball of `show` compiled with `settings` ([`compile_every_ball`]), or why
/// not: the one judgement the plan report and Start share. Blocking.
///
/// # Errors
/// [`Uncompilable`]: the first ball that cannot be compiled, and the tolerance that
/// would take the ball that strays furthest.
pub fn compile_show(
    show: &Show,
    settings: &QProgramConfig,
    streaming: Streaming,
) -> Result<Vec<QProgram>, Uncompilable> {
    let mut programs = Vec::with_capacity(show.tracks.len());
    let mut largest_mm: Option<f64> = None;
    let mut first = None;
    for (ball, program) in compile_every_ball(show, settings, streaming)
        .into_iter()
        .enumerate()
    {
        match program {
            Ok(program) => programs.push(program),
            Err(error) => {
                if let QProgramError::TooFar { deviation_mm, .. } = error {
                    largest_mm = Some(largest_mm.map_or(deviation_mm, |mm| mm.max(deviation_mm)));
                }
                first.get_or_insert(Why::Program { ball, error });
            }
        }
    }
    match first {
        None => Ok(programs),
        Some(why) => Err(Uncompilable {
            why,
            fixes: largest_mm
                .map(|mm| Fix::Tolerance {
                    tolerance_mm: mm.ceil(),
                    deviation_mm: mm,
                })
                .into_iter()
                .collect(),
        }),
    }
}

impl SclNet {
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
        let together = compile_every_ball(&show, &settings, Streaming::Never);
        assert_eq!(together.len(), 7);
        for (ball, (program, track)) in together.iter().zip(&show.tracks).enumerate() {
            let alone = floatball_shared::scl::qprogram::compile(track, &settings);
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
        let refused = compile_every_ball(&show, &strict, Streaming::Never);
        assert_eq!(refused.len(), 7);
        assert!(
            refused
                .iter()
                .all(|program| matches!(program, Err(QProgramError::TooFar { .. })))
        );
        assert!(compile_every_ball(&wave(1, 1, 1, 200), &settings, Streaming::Never).len() == 1);
    }
}
