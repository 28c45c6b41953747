//! MBOX boxes as a family under the sequencer ([`super::sequenced`]): the boxes'
//! drive ([`floatball_shared::mbox::drive`]) queues one frame per period, and the
//! boxes' sender ([`crate::ports::mbox::MboxNet`]) sends each at its slot, one datagram
//! a box (a live frame paced, for each box, at the instant it leaves). Before each poll
//! the drive learns the frame lead and the send lateness the sender measured lately,
//! which the live status's latency counts.

use std::time::{Duration, Instant};

use floatball_shared::api::{GatewayStatus, LinkState};
use floatball_shared::mbox::drive::MboxDrive;
use floatball_shared::mbox::player::{MboxPlayer, runs};
use floatball_shared::plan::Installation;
use floatball_shared::player::Sequencer;
use floatball_shared::player::{Entry, LinkView, StartError};
use tokio::sync::mpsc;

use super::sequenced::{Family, Prepare, PreparedRuns};
use super::{Reconfigure, ReconfigureError};
use crate::estop::StopPort;
use crate::ports::mbox::{FRAME_LEAD, MboxNet};

/// The boxes of an installation, as a family.
#[derive(Debug)]
pub struct MboxFamily {
    /// The boxes on their socket.
    pub boxes: MboxNet,
}

impl Family for MboxFamily {
    type Drive = MboxDrive;
    /// Boxes answer nothing the drive waits for.
    type Input = ();

    fn views(&self) -> Vec<LinkView> {
        (0..self.boxes.len())
            .map(|index| LinkView {
                up: self.boxes.state(index) == LinkState::Up,
                queued_bytes: 0,
            })
            .collect()
    }

    fn statuses(&self, _drive: &MboxDrive) -> Vec<GatewayStatus> {
        self.boxes.statuses()
    }

    fn lost(&mut self, running: bool) -> Option<String> {
        if !running {
            return None;
        }
        (0..self.boxes.len())
            .find(|&index| self.boxes.state(index) == LinkState::Down)
            .map(|down| {
                format!("MBOX box {down} stopped answering; the show was stopped on every box")
            })
    }

    fn ports(&self) -> Vec<&dyn StopPort> {
        vec![&self.boxes]
    }

    fn lead_us(&self) -> u64 {
        // Frames are handed to the sender FRAME_LEAD ahead of their slot; it sends
        // them at their slot.
        u64::try_from(FRAME_LEAD.as_micros()).unwrap_or(0)
    }

    fn before_poll(&self, drive: &mut MboxDrive) {
        // The live latency counts the lead and the lateness the sender measured.
        drive.set_send_timing(self.lead_us(), self.boxes.recent_lateness_us());
    }

    fn carry_out(
        &mut self,
        drive: &mut MboxDrive,
        epoch: Instant,
        generation: u64,
        _inputs: &mpsc::UnboundedSender<()>,
    ) {
        for frame in drive.take_frames() {
            let slot = epoch + Duration::from_micros(frame.slot_us);
            self.boxes.send(frame, slot, generation);
        }
    }

    fn apply(_sequencer: &mut Sequencer<MboxDrive>, _now_us: u64, (): ()) {}

    fn reconfigure(
        &mut self,
        change: &Reconfigure,
        _inputs: &mpsc::UnboundedSender<()>,
    ) -> Result<MboxDrive, ReconfigureError> {
        // The boxes stay (their gateways did not change); the drive takes the new
        // calibration and installation.
        change
            .mbox
            .clone()
            .map(MboxDrive::new)
            .ok_or(ReconfigureError::NotLive)
    }
}

/// A playlist for the boxes: checked against the installation (layout, limits,
/// outputs), each show with its sampler.
#[derive(Debug)]
pub struct MboxPrepare;

impl Prepare for MboxPrepare {
    fn prepare(
        &self,
        installation: &Installation,
        entries: Vec<Entry>,
    ) -> Result<PreparedRuns, StartError> {
        MboxPlayer::check(installation, &entries)?;
        Ok(Box::new(runs(entries)))
    }
}
