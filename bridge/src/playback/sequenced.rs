//! The playback loop over the show sequencer ([`floatball_shared::player`]): one task
//! for every drive family (UIM2503 gateways, MBOX boxes, MOONS' drives), the family's
//! port ([`Family`]) carrying out what its drive queued and handing back what the
//! units answered.
//!
//! **One owner.** The task owns the sequencer and the status: Start, Reset and Home
//! are admitted as for every family ([`super::admit`]: no e-stop since they were
//! issued, every link up, then the latch released for them); an e-stop is learnt
//! from the latch's generation on the next turn and stops the sequencer (the stop
//! itself went out from [`super::Playback::estop`] without the task); a lost or
//! stalled link or a drive's failure stops the matrix through the same latch. Every
//! request a run sends carries the generation of the request that began it, so
//! nothing of a run reaches a unit after an e-stop.
//!
//! **Many inputs, few polls.** The units' answers waiting are handed to the drive
//! together in one turn (at most [`INPUTS_PER_TURN`]: a hundred UIM2503 gateways
//! acknowledge thousands of instructions a second); answers alone poll the sequencer
//! at most once a [`Family::POLL_PERIOD`], and the status is built at once after a
//! request, an e-stop or a new state, otherwise at most once a [`STATUS_PERIOD`]
//! ([`Publisher`]).

use std::any::Any;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use floatball_shared::api::{GatewayStatus, PlayerState, Status};
use floatball_shared::plan::Installation;
use floatball_shared::player::{Drive, Lead, Run, Sequencer, StartAt};
use floatball_shared::player::{Entry, LinkView, StartError};
use tokio::sync::{mpsc, watch};

use super::{
    ArmingShared, Begin, Listed, Reconfigure, ReconfigureError, Reply, Request, admit,
    idle_for_reconfigure, publish, summarise,
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

    /// Whether a show cut at a time plays as it is prepared (not on drives that play
    /// their stored programs).
    fn cuts(&self) -> bool {
        true
    }
}

/// A drive family in the bridge: its drive under the sequencer, and the port that
/// carries out what the drive queued.
pub(super) trait Family: Send + 'static {
    /// The family's drive.
    type Drive: Drive<Entry: Send> + Send + 'static;
    /// What the units answer, for the drive.
    type Input: Send + 'static;

    /// How often at most answers alone poll the sequencer (a request, the e-stop or
    /// the sequencer's own wake-up poll at once).
    const POLL_PERIOD: Duration = Duration::ZERO;

    /// The task began: where the units' answers go, for a family whose links send
    /// them on their own (UIM2503 feedback).
    fn attach(&mut self, _inputs: &mpsc::UnboundedSender<Self::Input>) {}

    /// Each link as Start's admission sees it, in gateway order.
    fn views(&self) -> Vec<LinkView>;

    /// Each gateway's status, in gateway order (`drive`: what the drive knows of
    /// them).
    fn statuses(&self, drive: &Self::Drive) -> Vec<GatewayStatus>;

    /// A link lost or stalled while a run is under way (`running`): why the matrix
    /// stops. Asked at every poll.
    fn lost(&mut self, running: bool) -> Option<String>;

    /// Where the family's stop goes ([`estop::press`]).
    fn ports(&self) -> Vec<&dyn StopPort>;

    /// How long ahead of its time the task polls the sequencer, µs (frames are handed
    /// to a sender that sends them at their slot).
    fn lead_us(&self) -> u64 {
        0
    }

    /// Before each poll: what the drive must know of the links now.
    fn before_poll(&self, _drive: &mut Self::Drive) {}

    /// Carries out what `drive` queued, for a run admitted at `generation`, its
    /// times on the clock whose zero is `epoch`; answers go to `inputs`.
    fn carry_out(
        &mut self,
        drive: &mut Self::Drive,
        epoch: Instant,
        generation: u64,
        inputs: &mpsc::UnboundedSender<Self::Input>,
    );

    /// Hands `input` to the drive under `sequencer` at `now_us`.
    fn apply(sequencer: &mut Sequencer<Self::Drive>, now_us: u64, input: Self::Input);

    /// A new installation, taken while idle: the drive for it (answers of new links
    /// go to `inputs`).
    ///
    /// # Errors
    /// [`ReconfigureError::NotLive`]: this change is not taken live.
    fn reconfigure(
        &mut self,
        change: &Reconfigure,
        inputs: &mpsc::UnboundedSender<Self::Input>,
    ) -> Result<Self::Drive, ReconfigureError>;
}

/// The most answers one turn of the task hands to the drive before it looks at its
/// requests, the clock and the links again.
pub(super) const INPUTS_PER_TURN: usize = 1024;

/// How long the status may lag what the sequencer and the links know while nothing
/// urgent happened: a status describes every gateway, and building it on each of the
/// thousands of answers a second a hundred gateways send costs more than the rest of
/// the task. The clients read it ten times a second at most.
pub(super) const STATUS_PERIOD: Duration = Duration::from_millis(20);

/// The status at `now_us`: the sequencer's (a show's time on the units' clock at that
/// instant), with every gateway's.
pub(super) fn status<F: Family>(
    sequencer: &Sequencer<F::Drive>,
    now_us: u64,
    family: &F,
    list: &watch::Sender<Listed>,
) -> Status {
    let mut status = sequencer.status_at(now_us);
    (status.gateways, status.gateway_summary) = summarise(family.statuses(sequencer.drive()), list);
    status
}

/// The playlist a request carries, as the drive runs it.
fn runs_of<D: Drive + 'static>(
    prepared: Result<PreparedRuns, StartError>,
) -> Result<Vec<Run<D::Entry>>, StartError> {
    prepared.and_then(|prepared| {
        prepared
            .downcast::<Vec<Run<D::Entry>>>()
            .map(|runs| *runs)
            // Prepared for another family: the installation changed since.
            .map_err(|_| StartError::Superseded)
    })
}

/// Where a request's run begins: at `entry`, with the lead it carries (the show's
/// time at the cut's start, and the cut prepared as a one-entry playlist).
fn start_at<D: Drive + 'static>(
    entry: usize,
    lead: Option<super::PreparedLead>,
) -> Result<StartAt<D::Entry>, StartError> {
    let lead = match lead {
        None => None,
        Some((from_ms, prepared)) => {
            let run = runs_of::<D>(prepared)?
                .into_iter()
                .next()
                .ok_or(StartError::Empty)?;
            Some(Lead {
                from_ms,
                prepared: run.prepared,
            })
        }
    };
    Ok(StartAt { entry, lead })
}

/// Carries out a Start, Reset or Home on the sequencer, if no e-stop came since it was
/// issued and every link is up; returns its generation, where to answer, and the
/// answer. Arming requests are carried out here too (they answer nothing).
fn handle<D: Drive + 'static>(
    sequencer: &mut Sequencer<D>,
    latch: &Latch,
    request: Request,
    (now_us, run_generation): (u64, u64),
    views: &[LinkView],
) -> Option<(u64, Reply, Result<(), StartError>)> {
    let gateways = views.len();
    Some(match request {
        Request::Play {
            generation,
            prepared,
            loop_playlist,
            begin,
            at: (entry, lead),
            reply,
        } => {
            let runs =
                runs_of::<D>(prepared).and_then(|runs| Ok((runs, start_at::<D>(entry, lead)?)));
            let result = if begin == Begin::Reset {
                let admitted =
                    runs.and_then(|runs| admit(latch, generation, views, gateways).map(|()| runs));
                sequencer.reset_at(now_us, admitted, loop_playlist)
            } else if begin == Begin::Locate {
                // No stop was pressed: refused, the show under way plays on.
                let admitted =
                    runs.and_then(|runs| admit(latch, generation, views, gateways).map(|()| runs));
                sequencer.locate_at(now_us, admitted, loop_playlist)
            } else if sequencer.is_running() {
                Err(StartError::Busy)
            } else {
                runs.and_then(|(runs, at)| {
                    admit(latch, generation, views, gateways)?;
                    sequencer.start_at(now_us, runs, loop_playlist, at)
                })
            };
            (generation, reply, result)
        }
        Request::Home { generation, reply } => {
            let result = admit(latch, generation, views, gateways);
            match &result {
                Ok(()) => sequencer.home(now_us),
                // The stop went out: the matrix stays stopped, saying why.
                Err(error) => sequencer.stop_with(Some(error.to_string())),
            }
            (generation, reply, result)
        }
        Request::Arm {
            generation,
            disarms,
            prepared,
        } => {
            // Only with no e-stop in force or since it was issued, the run's batches
            // tagged with the generation now, and every link up.
            if generation == latch.generation()
                && generation == run_generation
                && !latch.is_latched()
                && views.iter().all(|view| view.up)
                && let Ok(runs) = runs_of::<D>(Ok(prepared))
                && let Some(first) = runs.first()
            {
                sequencer.arm(&first.prepared, disarms);
            }
            return None;
        }
        Request::Disarm => {
            sequencer.drive_mut().disarm();
            return None;
        }
        Request::Estop | Request::Reconfigure(_) | Request::Live(_) | Request::Trim { .. } => {
            return None;
        }
    })
}

/// The task: the sequencer on the clock, the family's port carrying out its drive's
/// work, the status from both.
pub(super) async fn run<F: Family>(
    mut sequencer: Sequencer<F::Drive>,
    mut family: F,
    (latch, arming): (Arc<Latch>, Arc<ArmingShared>),
    mut inbox: mpsc::UnboundedReceiver<Request>,
    (status_tx, list, mut positions): (
        watch::Sender<Status>,
        watch::Sender<Listed>,
        super::live::Positions,
    ),
) {
    let epoch = Instant::now();
    let now_us = || u64::try_from(epoch.elapsed().as_micros()).unwrap_or(u64::MAX);
    let (inputs_tx, mut inputs) = mpsc::unbounded_channel::<F::Input>();
    family.attach(&inputs_tx);
    let mut seen_generation = latch.generation();
    let mut run_generation = seen_generation;
    let mut publisher = Publisher::new();
    let mut polled = Instant::now();
    let mut poll_owed = false;
    let mut live_feed = super::live::Feed::default();
    loop {
        let now = now_us();
        let lead_us = family.lead_us();
        // Idle, it still looks at the links ten times a second for the status; a
        // status held back is published within its period, a poll held back within
        // its own.
        let wake_us = sequencer
            .next_wakeup_us(now)
            .unwrap_or(now + 100_000)
            .min(now + 100_000);
        let mut sleep_until = epoch + Duration::from_micros(wake_us.saturating_sub(lead_us));
        // A show's given start turns the state `playing` on the clock alone: the
        // status goes out at that instant (not ahead by the lead).
        if let Some(change_us) = sequencer.next_state_change_us(now) {
            sleep_until = sleep_until.min(epoch + Duration::from_micros(change_us));
        }
        if let Some(due) = Instant::now().checked_add(publisher.due_in()) {
            sleep_until = sleep_until.min(due);
        }
        if poll_owed {
            sleep_until = sleep_until.min(polled + F::POLL_PERIOD);
        }
        let mut request = None;
        let mut input = None;
        tokio::select! {
            received = inbox.recv() => {
                let Some(received) = received else { return };
                request = Some(received);
            }
            Some(received) = inputs.recv() => input = Some(received),
            // Live input changed after a quiet period: its step may go now.
            () = live_feed.changed(), if sequencer.live_awaits_change() => {}
            () = tokio::time::sleep_until(sleep_until.into()) => {}
        }
        // A clock trim is not news: applied at once, it wakes nothing else.
        if let Some(Request::Trim { entry, show_start }) = request {
            // Signed: a show located into may have its time 0 before the task began.
            let start_us = match show_start.checked_duration_since(epoch) {
                Some(after) => i64::try_from(after.as_micros()).unwrap_or(i64::MAX),
                None => {
                    -i64::try_from(epoch.duration_since(show_start).as_micros()).unwrap_or(i64::MAX)
                }
            };
            sequencer.trim_clock(now_us(), entry, start_us);
            request = None;
        }
        let by_input = input.is_some();
        // The answers waiting, in the order they came.
        let mut handed = 0;
        while handed < INPUTS_PER_TURN
            && let Some(received) = input.take().or_else(|| inputs.try_recv().ok())
        {
            F::apply(&mut sequencer, now_us(), received);
            handed += 1;
        }
        let mut urgent = request.is_some();
        // An e-stop pressed since the last turn: the ports have acted on it already.
        let generation = latch.generation();
        if generation != seen_generation {
            seen_generation = generation;
            sequencer.estop();
            urgent = true;
        }
        if let Some(Request::Reconfigure(change)) = request {
            let state = sequencer.state_at(now_us());
            let result = idle_for_reconfigure(state, sequencer.is_running())
                .and_then(|()| family.reconfigure(&change, &inputs_tx))
                .map(|drive| sequencer = Sequencer::new(drive));
            let _ = change.reply.send(result);
            request = None;
        }
        if let Some(Request::Live(live)) = request {
            let now = now_us();
            if let Some(generation) = live_feed.handle(&mut sequencer, &latch, live, now) {
                run_generation = generation;
            }
            request = None;
        }
        if let Some(request) = request
            && let Some((generation, reply, result)) = handle(
                &mut sequencer,
                &latch,
                request,
                (now_us(), run_generation),
                &family.views(),
            )
        {
            if result.is_ok() {
                run_generation = generation;
            }
            let _ = reply.send(result);
        }
        // Answers alone move the sequencer on at most once a POLL_PERIOD.
        poll_owed = by_input && !urgent && polled.elapsed() < F::POLL_PERIOD;
        if !poll_owed {
            polled = Instant::now();
            if let Some(reason) = family.lost(sequencer.is_running()) {
                tracing::error!("{reason}");
                estop::press(&latch, &family.ports());
                seen_generation = latch.generation();
                sequencer.fail_with(reason);
                urgent = true;
            }
            family.before_poll(sequencer.drive_mut());
            if sequencer.is_live() {
                live_feed.feed(&mut sequencer);
            }
            sequencer.poll(now_us() + lead_us);
        }
        if sequencer.take_estop() {
            // The drive failed: whatever the units were doing, they stop.
            if let Some(reason) = sequencer.status().last_error {
                tracing::error!("{reason}");
            }
            let failures = estop::press(&latch, &family.ports());
            if !failures.is_empty() {
                tracing::error!("the stop did not reach {}", failures.join("; "));
            }
            // A stop the sequencer asked for is not news to it (it failed, and stays
            // so).
            seen_generation = latch.generation();
            urgent = true;
        }
        family.carry_out(sequencer.drive_mut(), epoch, run_generation, &inputs_tx);
        arming
            .disarms
            .store(sequencer.drive().disarms(), Ordering::Release);
        arming
            .needs_home
            .store(sequencer.needs_home(), Ordering::Release);
        let now = now_us();
        if publisher.due(urgent, sequencer.state_at(now)) {
            publish(&status_tx, status(&sequencer, now, &family, &list));
        }
        positions.publish(&sequencer);
    }
}

/// When the playback task next builds the status: at once after a request, an e-stop
/// or a change of the sequencer's state; otherwise once a [`STATUS_PERIOD`].
#[derive(Debug)]
struct Publisher {
    built: Instant,
    state: PlayerState,
    /// A turn did not build it: what changed since waits for the period's end.
    held_back: bool,
}

impl Publisher {
    fn new() -> Self {
        Self {
            built: Instant::now()
                .checked_sub(STATUS_PERIOD)
                .unwrap_or_else(Instant::now),
            state: PlayerState::Idle,
            held_back: false,
        }
    }

    /// How long until a held-back status is due (`Duration::MAX`: none is).
    fn due_in(&self) -> Duration {
        if self.held_back {
            STATUS_PERIOD.saturating_sub(self.built.elapsed())
        } else {
            Duration::MAX
        }
    }

    /// Whether to build the status now; if so, counts it as built.
    fn due(&mut self, urgent: bool, state: PlayerState) -> bool {
        let due = urgent || state != self.state || self.built.elapsed() >= STATUS_PERIOD;
        if due {
            self.built = Instant::now();
            self.state = state;
        }
        self.held_back = !due;
        due
    }
}
