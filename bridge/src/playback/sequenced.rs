//! The playback loop over the show sequencer ([`floatball_shared::player`]): one task
//! for every drive family that runs on it (MBOX boxes, MOONS' drives), the family's
//! port ([`Family`]) carrying out what its drive queued and handing back what the
//! units answered.
//!
//! **One owner.** The task owns the sequencer and the status, as the UIM2503 task
//! does: Start, Reset and Home are admitted as for every family ([`super::admit`]: no
//! e-stop since they were issued, every link up, then the latch released for them);
//! an e-stop is learnt from the latch's generation on the next turn and stops the
//! sequencer (the stop itself went out from [`super::Playback::estop`] without the
//! task); a lost link or a drive's failure stops the matrix through the same latch.
//! Every request a run sends carries the generation of the request that began it, so
//! nothing of a run reaches a unit after an e-stop.

use std::any::Any;
use std::sync::Arc;
use std::time::{Duration, Instant};

use floatball_shared::api::{GatewayStatus, Status};
use floatball_shared::plan::Installation;
use floatball_shared::plan::player::{Entry, LinkView, StartError};
use floatball_shared::player::{Drive, Run, Sequencer};
use tokio::sync::{mpsc, watch};

use super::{
    Listed, Reconfigure, ReconfigureError, Request, admit, idle_for_reconfigure, publish, summarise,
};
use crate::estop::{self, Latch, StopPort};

/// A playlist prepared for a family's drive (its `Vec<Run<Drive::Entry>>`), as the
/// request carries it to the task.
pub(super) type PreparedRuns = Box<dyn Any + Send>;

/// How a family prepares a playlist before Start (on a blocking thread): checks every
/// show against the installation and makes what its drive plays from.
pub(super) trait Prepare: Send + Sync + std::fmt::Debug {
    /// `entries` prepared for `installation`.
    ///
    /// # Errors
    /// Why the playlist cannot play; nothing moved.
    fn prepare(
        &self,
        installation: &Installation,
        entries: Vec<Entry>,
    ) -> Result<PreparedRuns, StartError>;
}

/// A drive family in the bridge: its drive under the sequencer, and the port that
/// carries out what the drive queued.
pub(super) trait Family: Send + 'static {
    /// The family's drive.
    type Drive: Drive<Entry: Send> + Send + 'static;
    /// What the units answer, for the drive.
    type Input: Send + 'static;

    /// Each link as Start's admission sees it, in gateway order.
    fn views(&self) -> Vec<LinkView>;

    /// Each gateway's status, in gateway order.
    fn statuses(&self) -> Vec<GatewayStatus>;

    /// A link lost while a run is under way: why the matrix stops.
    fn lost(&self) -> Option<String>;

    /// Where the family's stop goes ([`estop::press`]).
    fn port(&self) -> &dyn StopPort;

    /// How long ahead of its time the task polls the sequencer, µs (frames are handed
    /// to a sender that sends them at their slot).
    fn lead_us(&self) -> u64 {
        0
    }

    /// Carries out what `drive` queued, for a run admitted at `generation`; answers
    /// go to `inputs`.
    fn carry_out(
        &mut self,
        drive: &mut Self::Drive,
        epoch: Instant,
        generation: u64,
        inputs: &mpsc::UnboundedSender<Self::Input>,
    );

    /// Hands `input` to `drive` at `now_us`.
    fn apply(drive: &mut Self::Drive, now_us: u64, input: Self::Input);

    /// A new installation, taken while idle: the drive for it.
    ///
    /// # Errors
    /// [`ReconfigureError::NotLive`]: this change is not taken live.
    fn reconfigure(&mut self, change: &Reconfigure) -> Result<Self::Drive, ReconfigureError>;
}

/// The status: the sequencer's, with every gateway's.
pub(super) fn status<F: Family>(
    sequencer: &Sequencer<F::Drive>,
    family: &F,
    list: &watch::Sender<Listed>,
) -> Status {
    let mut status = sequencer.status();
    (status.gateways, status.gateway_summary) = summarise(family.statuses(), list);
    status
}

/// Carries out a Start, Reset or Home on the sequencer, if no e-stop came since it was
/// issued and every link is up; returns its generation, where to answer, and the
/// answer.
fn handle<D: Drive + 'static>(
    sequencer: &mut Sequencer<D>,
    latch: &Latch,
    request: Request,
    now_us: u64,
    views: &[LinkView],
) -> Option<(u64, super::Reply, Result<(), StartError>)> {
    let gateways = views.len();
    Some(match request {
        Request::Play {
            generation,
            prepared,
            loop_playlist,
            reset,
            reply,
        } => {
            let runs = prepared.and_then(|prepared| {
                prepared
                    .downcast::<Vec<Run<D::Entry>>>()
                    .map(|runs| *runs)
                    // PreparedRuns for another family: the installation changed since.
                    .map_err(|_| StartError::Superseded)
            });
            let result = if reset {
                let admitted =
                    runs.and_then(|runs| admit(latch, generation, views, gateways).map(|()| runs));
                sequencer.reset(now_us, admitted, loop_playlist)
            } else if sequencer.is_running() {
                Err(StartError::Busy)
            } else {
                runs.and_then(|runs| {
                    admit(latch, generation, views, gateways)?;
                    sequencer.start(now_us, runs, loop_playlist)
                })
            };
            (generation, reply, result)
        }
        Request::Home { generation, reply } => {
            let result = admit(latch, generation, views, gateways).map(|()| sequencer.home(now_us));
            (generation, reply, result)
        }
        Request::Start {
            generation, reply, ..
        }
        | Request::Reset {
            generation, reply, ..
        } => (generation, reply, Err(StartError::Busy)),
        Request::Estop | Request::Arm { .. } | Request::Disarm | Request::Reconfigure(_) => {
            return None;
        }
    })
}

/// The task: the sequencer on the clock, the family's port carrying out its drive's
/// work, the status from both.
pub(super) async fn run<F: Family>(
    mut sequencer: Sequencer<F::Drive>,
    mut family: F,
    latch: Arc<Latch>,
    mut inbox: mpsc::UnboundedReceiver<Request>,
    (status_tx, list): (watch::Sender<Status>, watch::Sender<Listed>),
) {
    let epoch = Instant::now();
    let now_us = || u64::try_from(epoch.elapsed().as_micros()).unwrap_or(u64::MAX);
    let (inputs_tx, mut inputs) = mpsc::unbounded_channel::<F::Input>();
    let mut seen_generation = latch.generation();
    let mut run_generation = seen_generation;
    loop {
        let now = now_us();
        let lead_us = family.lead_us();
        // Idle, it still looks at the links ten times a second for the status.
        let wake_us = sequencer
            .next_wakeup_us(now)
            .unwrap_or(now + 100_000)
            .min(now + 100_000);
        let sleep = tokio::time::sleep_until(
            (epoch + Duration::from_micros(wake_us.saturating_sub(lead_us))).into(),
        );
        let mut request = None;
        let mut input = None;
        tokio::select! {
            received = inbox.recv() => {
                let Some(received) = received else { return };
                request = Some(received);
            }
            Some(received) = inputs.recv() => input = Some(received),
            () = sleep => {}
        }
        let generation = latch.generation();
        if generation != seen_generation {
            seen_generation = generation;
            sequencer.estop();
        }
        // Every answer waiting, in the order they came.
        while let Some(received) = input.take().or_else(|| inputs.try_recv().ok()) {
            F::apply(sequencer.drive_mut(), now_us(), received);
        }
        if let Some(Request::Reconfigure(change)) = request {
            let state = sequencer.status().state;
            let result = idle_for_reconfigure(state, sequencer.is_running())
                .and_then(|()| family.reconfigure(&change))
                .map(|drive| sequencer = Sequencer::new(drive));
            let _ = change.reply.send(result);
            request = None;
        }
        if let Some(request) = request
            && let Some((generation, reply, result)) =
                handle(&mut sequencer, &latch, request, now_us(), &family.views())
        {
            if result.is_ok() {
                run_generation = generation;
            }
            let _ = reply.send(result);
        }
        if sequencer.is_running()
            && let Some(reason) = family.lost()
        {
            tracing::error!("{reason}");
            estop::press(&latch, &[family.port()]);
            seen_generation = latch.generation();
            sequencer.fail_with(reason);
        }
        sequencer.poll(now_us() + lead_us);
        if sequencer.take_estop() {
            // The drive failed: whatever the units were doing, they stop.
            if let Some(reason) = sequencer.status().last_error {
                tracing::error!("{reason}");
            }
            estop::press(&latch, &[family.port()]);
            seen_generation = latch.generation();
        }
        family.carry_out(sequencer.drive_mut(), epoch, run_generation, &inputs_tx);
        publish(&status_tx, status(&sequencer, &family, &list));
    }
}
