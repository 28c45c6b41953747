//! MOONS' drives as a family under the sequencer ([`super::sequenced`]): the drives'
//! sans-IO drive ([`floatball_shared::scl::drive`]) asks, and each request goes to
//! its link ([`crate::ports::scl::SclNet`]) as a task of its own whose answer comes back to
//! the playback task; a lane of the drive sends its next request only when the one
//! before was answered, so every drive hears its lines in order.
//!
//! A playlist is prepared before Start: every show checked against the installation
//! and, when programs are uploaded, every ball's Q program compiled — a show that
//! cannot be compiled is refused before anything moves, with the ball and why.

use std::sync::Arc;
use std::time::Instant;

use floatball_shared::api::GatewayStatus;
use floatball_shared::plan::Installation;
use floatball_shared::player::{Entry, LinkView, Run, Sequencer, StartError};
use floatball_shared::scl::drive::{
    DriveSlot, SclDrive, SclDriveConfig, SclEntry, SclLine, SclLiveConfig, Trigger,
};
use tokio::sync::mpsc;

use super::sequenced::{Family, Prepare, PreparedRuns};
use super::{Reconfigure, ReconfigureError};
use crate::config::{SclConfig, SclGateway, SclPrograms};
use crate::estop::StopPort;
use crate::ports::scl::SclNet;
use crate::ports::scl::program::{
    DriveRef, Uncompilable, compile_show, drives_of, qprogram_config,
};

/// An answer: the request's id, its lines or why there are none, and when the request
/// reached its drive (µs on the task's clock), if it was sent.
pub type Answer = (u64, Result<Vec<String>, String>, Option<u64>);

/// The drives of an installation, as a family.
#[derive(Debug)]
pub struct SclFamily {
    /// The drives on their links.
    pub net: SclNet,
    /// The `[scl]` settings.
    pub scl: Arc<SclConfig>,
}

/// The drive for `installation` on `net` with `scl`, live mode on its lines
/// included (each RS-485 line at its baud; eSCL and simulated drives over UDP).
pub fn drive(installation: &Installation, scl: &SclConfig, net: &SclNet) -> SclDrive {
    let lines = scl
        .gateways
        .iter()
        .map(|gateway| match gateway {
            SclGateway::Serial { baud, .. } => SclLine::Rs485 { baud: *baud },
            SclGateway::Escl(_) | SclGateway::Sim { .. } => SclLine::Escl,
        })
        .collect();
    SclDrive::new(drive_config(installation, scl, net)).with_live(SclLiveConfig {
        lines,
        max_speed_mm_s: installation.limits.max_speed_mm_s,
        layout: installation.layout(),
    })
}

/// What the drive needs of `installation` on `net` with `scl`.
pub fn drive_config(installation: &Installation, scl: &SclConfig, net: &SclNet) -> SclDriveConfig {
    let units = drives_of(installation)
        .into_iter()
        .map(|drive| DriveSlot {
            gateway: drive.gateway,
            drive: drive.drive,
            name: net.name(drive),
        })
        .collect();
    let trigger = scl.trigger.map(|(address, output)| {
        let drive = net
            .links()
            .first()
            .and_then(|link| link.drive_of(address))
            .ok_or_else(|| format!("the trigger drive {address} is not on SCL gateway 0"));
        let name = drive
            .as_ref()
            .map(|&drive| net.name(DriveRef { gateway: 0, drive }))
            .unwrap_or_default();
        Trigger {
            drive,
            name,
            output,
        }
    });
    SclDriveConfig {
        units,
        gateways: net.links().len(),
        counts_per_mm: installation.counts_per_mm,
        steps_per_rev: scl.steps_per_rev,
        approach_speed_mm_s: installation.approach_speed_mm_s,
        max_accel_mm_s2: installation.limits.max_accel_mm_s2,
        home_mm: installation.home_mm,
        travel_mm: installation.limits.travel_mm,
        trigger,
    }
}

impl Family for SclFamily {
    type Drive = SclDrive;
    type Input = Answer;

    fn views(&self) -> Vec<LinkView> {
        self.net
            .links()
            .iter()
            .map(|link| LinkView {
                up: link.is_up(),
                queued_bytes: 0,
            })
            .collect()
    }

    fn statuses(&self, _drive: &SclDrive) -> Vec<GatewayStatus> {
        self.net.statuses()
    }

    fn lost(&mut self, _running: bool) -> Option<String> {
        // A drive that does not answer fails the request that waited for it.
        None
    }

    fn ports(&self) -> Vec<&dyn StopPort> {
        vec![&self.net]
    }

    fn carry_out(
        &mut self,
        drive: &mut SclDrive,
        epoch: Instant,
        generation: u64,
        inputs: &mpsc::UnboundedSender<Answer>,
    ) {
        for ask in drive.take_asks() {
            let net = self.net.clone();
            let inputs = inputs.clone();
            tokio::spawn(async move {
                let (answer, delivered) = match net.links().get(ask.gateway) {
                    Some(link) => {
                        let (answer, delivered) = link
                            .request_delivered(ask.drive, ask.text, ask.expect, generation)
                            .await;
                        (answer.map_err(|error| error.to_string()), delivered)
                    }
                    None => (
                        Err(format!("there is no SCL gateway {}", ask.gateway)),
                        None,
                    ),
                };
                let delivered_us = delivered.map(|at| {
                    u64::try_from(at.saturating_duration_since(epoch).as_micros())
                        .unwrap_or(u64::MAX)
                });
                let _ = inputs.send((ask.id, answer, delivered_us));
            });
        }
    }

    fn apply(sequencer: &mut Sequencer<SclDrive>, now_us: u64, (id, answer, delivered_us): Answer) {
        let drive = sequencer.drive_mut();
        if let Some(delivered_us) = delivered_us {
            drive.delivered(id, delivered_us);
        }
        drive.answer(now_us, id, answer);
    }

    fn reconfigure(
        &mut self,
        change: &Reconfigure,
        _inputs: &mpsc::UnboundedSender<Answer>,
    ) -> Result<SclDrive, ReconfigureError> {
        // The drives stay (their gateway entries did not change); the drive takes the
        // matrix's new calibration and limits.
        Ok(drive(&change.installation, &self.scl, &self.net))
    }
}

/// A playlist for the drives: checked, and compiled when programs are uploaded.
#[derive(Debug)]
pub struct SclPrepare {
    /// The drives (they name the balls in errors).
    pub net: SclNet,
    /// The `[scl]` settings.
    pub scl: Arc<SclConfig>,
}

impl Prepare for SclPrepare {
    fn cuts(&self) -> bool {
        self.scl.programs.compiled()
    }

    fn prepare(
        &self,
        installation: &Installation,
        entries: Vec<Entry>,
    ) -> Result<PreparedRuns, StartError> {
        check(installation, &entries)?;
        let config = drive_config(installation, &self.scl, &self.net);
        let settings = qprogram_config(installation, &self.scl);
        let mut runs = Vec::with_capacity(entries.len());
        for (index, entry) in entries.into_iter().enumerate() {
            let show = &entry.show;
            let programs = match self.scl.programs {
                SclPrograms::Upload | SclPrograms::Stream => Some(
                    compile_show(show, &settings, self.scl.programs.streaming()).map_err(
                        |Uncompilable { why, fixes }| StartError::Infeasible {
                            entry: index + 1,
                            show: show.name.clone(),
                            reason: Box::new(why),
                            fixes,
                        },
                    )?,
                ),
                SclPrograms::Stored => None,
            };
            let duration_ms = show.duration_ms();
            runs.push(Run {
                name: show.name.clone(),
                duration_ms,
                timing: entry.timing(),
                prepared: SclEntry::new(
                    &config,
                    show.tracks.iter().map(|track| track.start_mm),
                    programs,
                    duration_ms,
                ),
            });
        }
        Ok(Box::new(runs))
    }
}

/// Whether `entries` can play on MOONS' drives: a playlist, every show valid for the
/// installation with a track per drive.
fn check(installation: &Installation, entries: &[Entry]) -> Result<(), StartError> {
    if entries.is_empty() {
        return Err(StartError::Empty);
    }
    for (index, entry) in entries.iter().enumerate() {
        if let Some(reason) =
            floatball_shared::plan::report::unfit_verdict(installation, &entry.show)
        {
            return Err(StartError::Invalid {
                entry: index + 1,
                show: entry.show.name.clone(),
                reason: Box::new(reason),
            });
        }
    }
    Ok(())
}
