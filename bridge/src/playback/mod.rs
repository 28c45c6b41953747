//! Playback: the show sequencer (`floatball_shared::player`) driven by the bridge's
//! clock, the links' state and the units' answers, for every drive family, in one
//! task ([`sequenced::run`]); each family is a port under it: UIM2503 gateways on
//! their links (`uim2503.rs`), MBOX boxes (`mbox.rs`), MOONS' drives (`scl.rs`).
//!
//! **One owner.** The playback task owns the sequencer and the status: it is the only
//! writer of the [`Status`] every client sees (the sequencer's part and each
//! gateway's, read from the links as snapshots), published on a watch channel
//! whenever it changes (the WebSocket layer limits how often clients hear of it). It
//! is built at once after a request, an e-stop or a new state, otherwise at most every
//! 20 ms; the answers waiting are handled together in one turn (a hundred gateways
//! send thousands a second). Beside it, every gateway in full
//! ([`Playback::gateway_list`], `GET /api/status/gateways`): a status with more than
//! [`floatball_shared::api::GATEWAY_DETAIL_LIMIT`] gateways details only those with a
//! problem.
//!
//! **The e-stop waits on nothing.** [`Playback::estop`] presses the latch and wakes
//! every port itself ([`crate::estop::press`]: the links' writers, the boxes' sender,
//! the drives' owners); the task only learns of it, on its next turn, from the
//! latch's generation, and stops the sequencer. Start, Reset and Home are tagged with
//! the generation they were issued at; they are prepared away from the task (a
//! blocking thread), and the task accepts them only if no e-stop came since
//! ([`admit`]: no e-stop since, every gateway up). Everything a run sends carries the
//! generation of the request that started it, so nothing prepared before an e-stop
//! reaches a unit after it.
//!
//! **A new installation while idle.** [`Playback::reconfigure`] hands the task a new
//! installation: UIM2503 with its links (`crate::gateways::Gateways::reopen`), MBOX
//! with its boxes' configuration, SCL alone (the same boxes and drives: only the
//! matrix's limits change there). The task takes it only while the sequencer is idle
//! (a new drive, the new links, their feedback relayed) and refuses it otherwise.
//! The handle's installation and links are a snapshot the task's acceptance replaces.
//!
//! **Arming** (UIM2503 gateways): while the matrix is idle, [`crate::arming`] hands
//! the task the playlist prepared as Start would prepare it ([`Playback::arm`]); the
//! drive loads the first entry's tables without moving anything and the status says
//! `armed`. [`Playback::disarm`] drops it (a console line, a new playlist or
//! installation, a commissioning command) and keeps arming away for [`ARM_QUIET`]; the
//! e-stop, Reset, Home and a lost link drop it in the drive.
//!
//! **One plan per playlist.** The UIM2503 playlist prepared last is kept with its key
//! (each show's name and file SHA-256, delays, cycles, loop flag) and the
//! installation ([`Playback::prepared_for`]): the armer, Start and Reset take it
//! instead of reading and planning the shows again, and its plans (`Arc`) are the
//! drive's own.
//!
//! **Play from anywhere.** A Start or Reset may name an entry and a time inside it
//! ([`At`]): the entry's show cut there ([`floatball_shared::show::Show::from_time`])
//! is prepared by the family as any one-entry playlist is (UIM2503 plans it, MBOX
//! samples it, MOONS' drives compile it) and handed to the sequencer as the entry's
//! first cycle ([`floatball_shared::player::Lead`]). It is never kept: the playlist
//! prepared last stays the full one.
//!
//! **A stalled link is a fault.** While a playlist runs, a link that has bytes queued
//! and writes nothing for [`stall_limit`] stops the show on every gateway and sets the
//! state `error`, naming the gateway.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use floatball_shared::api::{GatewayStatus, GatewaySummary, Status, summarise_gateways};
use floatball_shared::mbox::drive::MboxDrive;
use floatball_shared::mbox::player::MboxPlayerConfig;
use floatball_shared::plan::Installation;
use floatball_shared::player::{Entry, LinkView, Sequencer, StartError};
use floatball_shared::show::Cut;
use floatball_shared::uim2503::player::{PlayerConfig, Prepared, Uim2503Drive, prepare, runs};
use tokio::sync::{mpsc, oneshot, watch};

use crate::commission::health::HealthView;
use crate::config::SclConfig;
use crate::estop::{self, Latch, StopPort};
use crate::ports::mbox::MboxNet;
use crate::ports::scl::SclNet;
use crate::ports::uim2503::Link;

mod live;
mod mbox;
mod scl;
mod sequenced;
mod uim2503;

pub use live::{LiveError, LiveWatch, PositionsWatch};

use sequenced::{Prepare, PreparedRuns};
use uim2503::link_views;
pub use uim2503::stall_limit;

type Reply = oneshot::Sender<Result<(), StartError>>;

/// How a playlist begins ([`Playback::play_at`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Begin {
    /// Start: only while nothing runs (homing first when the positions are unknown).
    Start,
    /// Reset: its stop was pressed; home, then play.
    Reset,
    /// A locate (a timecode jump): the run under way ends without an e-stop and
    /// the balls go from where they are to the new point
    /// ([`floatball_shared::player::Sequencer::locate_at`]); as a Start when nothing
    /// runs.
    Locate,
}

enum Request {
    /// Start, Reset or a locate (`begin`): the playlist prepared for the family's
    /// drive (UIM2503 plans, MBOX samplers, MOONS' programs: [`PreparedRuns`]).
    Play {
        generation: u64,
        prepared: Result<PreparedRuns, StartError>,
        loop_playlist: bool,
        begin: Begin,
        /// The entry it begins at (0-based), and the lead when it begins at a time
        /// inside it: the show's time at the cut's start, and the cut prepared as a
        /// one-entry playlist.
        at: (usize, Option<PreparedLead>),
        reply: Reply,
    },
    Home {
        generation: u64,
        reply: Reply,
    },
    /// Look at the latch now (the e-stop was pressed).
    Estop,
    /// A new installation, taken only while idle ([`Playback::reconfigure`]); boxed:
    /// it is much larger than the other requests.
    Reconfigure(Box<Reconfigure>),
    /// Arm the first entry of a playlist prepared while the matrix was idle, at the
    /// drive's disarm count `disarms` and e-stop `generation`.
    Arm {
        generation: u64,
        disarms: u64,
        prepared: PreparedRuns,
    },
    /// Drop what is armed.
    Disarm,
    /// Live mode: its input, Go live / Leave live, recording ([`live`]).
    Live(live::LiveRequest),
    /// A timecode chase's clock trim: entry `entry`'s (0-based) show has its time 0 at
    /// `show_start` by the timecode ([`Playback::trim_clock`]).
    Trim {
        entry: usize,
        show_start: Instant,
    },
}

/// A lead as a request carries it: the show's time at the cut's start, and the cut
/// prepared as a one-entry playlist.
type PreparedLead = (u64, Result<PreparedRuns, StartError>);

/// A new installation for the player, with its links (UIM2503) or its boxes'
/// calibration (MBOX).
struct Reconfigure {
    installation: Installation,
    /// The MBOX player's configuration, for an installation of MBOX boxes.
    mbox: Option<MboxPlayerConfig>,
    links: Arc<Vec<Link>>,
    /// The units' health of each link (UIM2503; same order), from the new monitors.
    health: Vec<HealthView>,
    /// The gateways whose link is new (its feedback is not relayed yet).
    opened: Vec<usize>,
    reply: oneshot::Sender<Result<(), ReconfigureError>>,
}

/// Why the player did not take a new installation.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ReconfigureError {
    /// The player is not idle (`state`: what it is doing).
    #[error("the player is {state}; a new installation is applied only while it is idle")]
    NotIdle {
        /// The player's state, as the status names it.
        state: String,
    },
    /// The task does not take this installation live (an MBOX player without its
    /// boxes' configuration).
    #[error("this installation is applied at the next start")]
    NotLive,
    /// The playback task is gone (the bridge is shutting down).
    #[error("the player is not running")]
    Gone,
}

impl std::fmt::Debug for Request {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Request::Play { begin, .. } => match begin {
                Begin::Start => "Start",
                Begin::Reset => "Reset",
                Begin::Locate => "Locate",
            },
            Request::Home { .. } => "Home",
            Request::Estop => "Estop",
            Request::Reconfigure(_) => "Reconfigure",
            Request::Arm { .. } => "Arm",
            Request::Disarm => "Disarm",
            Request::Live(_) => "Live",
            Request::Trim { .. } => "Trim",
        })
    }
}

/// A handle to the playback task; cheap to clone.
#[derive(Debug, Clone)]
pub struct Playback {
    requests: mpsc::UnboundedSender<Request>,
    status: watch::Receiver<Status>,
    /// The balls' live positions ([`live::Positions`]).
    live_positions: live::PositionsWatch,
    /// Every gateway in full, in installation order, as the status was last built.
    gateway_list: watch::Receiver<Listed>,
    /// The installation and the links now: a snapshot, replaced when the task takes a
    /// new installation ([`Playback::reconfigure`]).
    live: Arc<std::sync::RwLock<Live>>,
    latch: Arc<Latch>,
    /// The MBOX boxes, when the installation's gateways are MBOX boxes.
    boxes: Option<MboxNet>,
    /// The MOONS' drives, when the installation's gateways are SCL gateway entries.
    scl: Option<SclNet>,
    /// How the family under the sequencer prepares a playlist (MBOX boxes, MOONS'
    /// drives); `None`: UIM2503 gateways, planned for their lines.
    sequenced: Option<Arc<dyn Prepare>>,
    /// Arming's side: the player's disarm count and the quiet time.
    arming: Arc<ArmingShared>,
    /// The playlist prepared last (armed or started), kept for the next Arm or Start
    /// of the same playlist on the same installation: planned once, its plans shared
    /// by the armer, the player and Start.
    kept: Arc<Mutex<Option<Kept>>>,
}

/// What a playlist was prepared from, as far as planning goes: each entry's show (its
/// name and the SHA-256 of its stored file), delay and cycles, and the loop flag. The
/// same key on the same installation plans to the same [`Prepared`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlaylistKey {
    /// Per entry: show name, SHA-256 of its file, delay (ms), cycles.
    entries: Vec<(String, String, u64, u32)>,
    loop_playlist: bool,
}

impl PlaylistKey {
    /// The key of a playlist whose entries are `(show name, SHA-256 of its stored
    /// file, delay_ms, cycles)`.
    pub fn new(entries: Vec<(String, String, u64, u32)>, loop_playlist: bool) -> Self {
        Self {
            entries,
            loop_playlist,
        }
    }
}

/// A playlist prepared, with what it was prepared from.
#[derive(Debug)]
struct Kept {
    key: PlaylistKey,
    installation: Arc<Installation>,
    prepared: Prepared,
}

/// A playlist for Start, Reset or Arm.
#[derive(Debug)]
pub enum Playlist {
    /// Prepared already ([`Playback::prepared_for`]): not read nor planned again.
    Prepared(Prepared),
    /// Read and planned on one blocking thread ([`Playback::prepare_blocking`]), so
    /// that the show is freed as it is planned where it was allocated (a show read on
    /// one thread and planned on another stays in the first one's malloc arena beside
    /// its plan: 72 MB more at the peak for a 10,000-ball minute).
    Planned(Result<Prepared, StartError>),
    /// Read from the store: planned now, and kept under `key` when it has one (the
    /// key of what was read: taken before reading and found the same after).
    Read {
        /// The entries with their shows.
        entries: Vec<Entry>,
        /// Whether the playlist starts over after its last entry.
        loop_playlist: bool,
        /// What was read, for [`Playback::prepared_for`].
        key: Option<PlaylistKey>,
    },
}

impl Playlist {
    /// A playlist read from the store, kept under no key.
    fn read(entries: Vec<Entry>, loop_playlist: bool) -> Self {
        Self::Read {
            entries,
            loop_playlist,
            key: None,
        }
    }
}

/// Where a Start or Reset begins: an entry (0-based) from its start, or the entry's
/// show cut at a time ([`floatball_shared::show::Cut`], made by the caller from the
/// entry's show).
#[derive(Debug, Default)]
pub struct At {
    /// The entry, 0-based.
    pub entry: usize,
    /// The entry's show cut at the time asked for; `None`: from its start.
    pub cut: Option<Cut>,
}

/// How long after [`Playback::disarm`] nothing is armed: a console session or a
/// commissioning walk of several steps is not interleaved with loading tables.
pub const ARM_QUIET: Duration = Duration::from_secs(3);

/// What the handles and the playback task share about arming.
#[derive(Debug)]
struct ArmingShared {
    /// The drive's disarm count, as the task last saw it.
    disarms: AtomicU64,
    /// No arming before this.
    quiet_until: Mutex<Instant>,
    /// The balls' positions are unknown (the next Start homes first), as the task
    /// last saw it.
    needs_home: AtomicBool,
}

impl Default for ArmingShared {
    fn default() -> Self {
        Self {
            disarms: AtomicU64::new(0),
            quiet_until: Mutex::new(Instant::now() + ARM_QUIET),
            needs_home: AtomicBool::new(true),
        }
    }
}

/// The installation the player runs and its links.
#[derive(Debug, Clone)]
struct Live {
    installation: Arc<Installation>,
    links: Arc<Vec<Link>>,
}

/// Why a request could not be handled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlaybackError {
    /// The player refused (nothing moved).
    #[error(transparent)]
    Refused(#[from] StartError),
    /// The playback task is gone (the bridge is shutting down).
    #[error("the player is not running")]
    Gone,
}

impl Playback {
    /// Starts the playback task for `installation` on `links` (one per gateway, in
    /// order, all obeying the same e-stop latch). Must run inside the async runtime.
    pub fn spawn(installation: Installation, links: Vec<Link>) -> Self {
        Self::spawn_with_health(installation, links, Vec::new())
    }

    /// As [`Playback::spawn`], with each link's unit health (same order) copied into
    /// its gateway's status ([`crate::commission::health`]).
    pub fn spawn_with_health(
        installation: Installation,
        links: Vec<Link>,
        health: Vec<HealthView>,
    ) -> Self {
        let latch = links
            .first()
            .map_or_else(|| Arc::new(Latch::new()), |link| Arc::clone(link.latch()));
        let links = Arc::new(links);
        let sequencer = Sequencer::new(Uim2503Drive::new(PlayerConfig {
            installation: installation.clone(),
        }));
        let family = uim2503::Uim2503Family::new(Arc::clone(&links), health);
        let started = Self::spawn_sequenced(sequencer, family, Arc::new(installation), latch, None);
        started.set_live(None, Some(links));
        started
    }

    /// The handle of a task just spawned, with its inbox and status: no links, boxes or
    /// drives until the caller names its own.
    fn started(
        requests: mpsc::UnboundedSender<Request>,
        (status, gateway_list): (watch::Receiver<Status>, watch::Receiver<Listed>),
        live_positions: live::PositionsWatch,
        installation: Arc<Installation>,
        latch: Arc<Latch>,
    ) -> Self {
        Self {
            requests,
            status,
            live_positions,
            gateway_list,
            live: Arc::new(std::sync::RwLock::new(Live {
                installation,
                links: Arc::new(Vec::new()),
            })),
            latch,
            boxes: None,
            scl: None,
            sequenced: None,
            arming: Arc::new(ArmingShared::default()),
            kept: Arc::new(Mutex::new(None)),
        }
    }

    /// Starts the playback task for an installation of MBOX boxes: `config` for the
    /// player, `boxes` on their socket, obeying `latch` (the one the boxes' sender
    /// obeys). Must run inside the async runtime.
    pub fn spawn_mbox(config: MboxPlayerConfig, boxes: MboxNet, latch: Arc<Latch>) -> Self {
        let installation = Arc::new(config.installation.clone());
        let sequencer = Sequencer::new(MboxDrive::new(config));
        let family = mbox::MboxFamily {
            boxes: boxes.clone(),
        };
        Self {
            boxes: Some(boxes),
            ..Self::spawn_sequenced(
                sequencer,
                family,
                installation,
                latch,
                Some(Arc::new(mbox::MboxPrepare)),
            )
        }
    }

    /// Starts the playback task for an installation of MOONS' drives: `drives` on
    /// their links with their settings `scl`, obeying `latch` (the one their owners
    /// obey). Must run inside the async runtime.
    pub fn spawn_scl(
        installation: Installation,
        scl: SclConfig,
        drives: SclNet,
        latch: Arc<Latch>,
    ) -> Self {
        let scl = Arc::new(scl);
        let sequencer = Sequencer::new(scl::drive(&installation, &scl, &drives));
        let family = scl::SclFamily {
            net: drives.clone(),
            scl: Arc::clone(&scl),
        };
        let prepare = scl::SclPrepare {
            net: drives.clone(),
            scl,
        };
        Self {
            scl: Some(drives),
            ..Self::spawn_sequenced(
                sequencer,
                family,
                Arc::new(installation),
                latch,
                Some(Arc::new(prepare)),
            )
        }
    }

    /// Starts the playback task of a family under the sequencer; `prepare`: how the
    /// family prepares a playlist (`None`: planned for UIM2503 lines).
    fn spawn_sequenced<F: sequenced::Family>(
        sequencer: Sequencer<F::Drive>,
        family: F,
        installation: Arc<Installation>,
        latch: Arc<Latch>,
        prepare: Option<Arc<dyn Prepare>>,
    ) -> Self {
        let (requests, inbox) = mpsc::unbounded_channel();
        let (list_tx, list) = watch::channel(Listed::default());
        let (status_tx, status) =
            watch::channel(sequenced::status(&sequencer, 0, &family, &list_tx));
        let (positions_tx, positions) = live::Positions::new();
        let started = Self {
            sequenced: prepare,
            ..Self::started(requests, (status, list), positions, installation, latch)
        };
        tokio::spawn(sequenced::run(
            sequencer,
            family,
            (Arc::clone(&started.latch), Arc::clone(&started.arming)),
            inbox,
            (status_tx, list_tx, positions_tx),
        ));
        started
    }

    /// The status, on every change.
    pub fn status(&self) -> watch::Receiver<Status> {
        self.status.clone()
    }

    /// Every gateway in full, in installation order, as the status was last built
    /// (the status itself details only the gateways with a problem beyond
    /// [`floatball_shared::api::GATEWAY_DETAIL_LIMIT`]).
    pub fn gateway_list(&self) -> Vec<GatewayStatus> {
        self.gateway_list.borrow().gateways.clone()
    }

    /// The links now, in gateway order.
    pub fn links(&self) -> Arc<Vec<Link>> {
        Arc::clone(&self.live().links)
    }

    /// The installation the player runs now.
    pub fn installation(&self) -> Arc<Installation> {
        Arc::clone(&self.live().installation)
    }

    /// The e-stop latch.
    pub fn latch(&self) -> &Arc<Latch> {
        &self.latch
    }

    /// E-stop: presses the latch — every link writes its stop ahead of anything
    /// queued (which is dropped) — then tells the player. Takes no lock and waits for
    /// nothing. Returns the gateways the stop cannot reach now, each with the reason.
    pub fn estop(&self) -> Vec<String> {
        let links = self.links();
        let mut ports: Vec<&dyn StopPort> = links.iter().map(|link| link as _).collect();
        if let Some(boxes) = &self.boxes {
            ports.push(boxes);
        }
        if let Some(drives) = &self.scl {
            ports.push(drives);
        }
        let failures = estop::press(&self.latch, &ports);
        let _ = self.requests.send(Request::Estop);
        failures
    }

    /// The MBOX boxes, when the installation's gateways are MBOX boxes.
    pub fn boxes(&self) -> Option<&MboxNet> {
        self.boxes.as_ref()
    }

    /// The MOONS' drives, when the installation's gateways are SCL gateway entries.
    pub fn scl(&self) -> Option<&SclNet> {
        self.scl.as_ref()
    }

    /// Start the playlist, as a request issued now.
    ///
    /// # Errors
    /// [`PlaybackError::Refused`] with the player's reason; nothing moved.
    pub async fn start(
        &self,
        entries: Vec<Entry>,
        loop_playlist: bool,
    ) -> Result<(), PlaybackError> {
        let generation = self.latch.generation();
        self.start_issued(entries, loop_playlist, generation).await
    }

    /// Start the playlist, as a request issued at e-stop `generation`: refused with
    /// [`StartError::Superseded`] if the e-stop was pressed since.
    ///
    /// # Errors
    /// As [`Playback::start`].
    pub async fn start_issued(
        &self,
        entries: Vec<Entry>,
        loop_playlist: bool,
        generation: u64,
    ) -> Result<(), PlaybackError> {
        self.play(
            Playlist::read(entries, loop_playlist),
            generation,
            Begin::Start,
        )
        .await
    }

    /// Reset: stop now, home, and play the playlist from its first entry.
    ///
    /// # Errors
    /// [`PlaybackError::Refused`]: the matrix is stopped, and stays so.
    pub async fn reset(
        &self,
        entries: Vec<Entry>,
        loop_playlist: bool,
    ) -> Result<(), PlaybackError> {
        self.estop();
        let generation = self.latch.generation();
        self.reset_issued(entries, loop_playlist, generation).await
    }

    /// The rest of a Reset whose stop was pressed already, at e-stop `generation`.
    ///
    /// # Errors
    /// As [`Playback::reset`].
    pub async fn reset_issued(
        &self,
        entries: Vec<Entry>,
        loop_playlist: bool,
        generation: u64,
    ) -> Result<(), PlaybackError> {
        self.play(
            Playlist::read(entries, loop_playlist),
            generation,
            Begin::Reset,
        )
        .await
    }

    /// Plans the playlist (unless it is [prepared](Playlist::Prepared) already), then
    /// hands it to the task as a Start, Reset or locate (`begin`), as a request issued
    /// at e-stop `generation`.
    ///
    /// # Errors
    /// As [`Playback::start`].
    pub async fn play(
        &self,
        playlist: Playlist,
        generation: u64,
        begin: Begin,
    ) -> Result<(), PlaybackError> {
        self.play_at(playlist, At::default(), generation, begin)
            .await
    }

    /// As [`Playback::play`], beginning where `at` says: at an entry, from its start
    /// or from a time inside its show (the cut prepared here, as a one-entry
    /// playlist, and not kept).
    ///
    /// # Errors
    /// As [`Playback::start`]; a cut that cannot run is refused as its entry would be.
    pub async fn play_at(
        &self,
        playlist: Playlist,
        at: At,
        generation: u64,
        begin: Begin,
    ) -> Result<(), PlaybackError> {
        let entry = at.entry;
        let lead = match at.cut {
            Some(cut) => Some((cut.start_ms, self.prepare_lead(entry, cut.show).await?)),
            None => None,
        };
        let at = (entry, lead);
        if let Some(prepare) = &self.sequenced {
            let Playlist::Read {
                entries,
                loop_playlist,
                ..
            } = playlist
            else {
                // Planned for serial lines: never made here (`plans_lines` is false).
                return Err(PlaybackError::Refused(StartError::Empty));
            };
            let installation = self.installation();
            let prepare = Arc::clone(prepare);
            let prepared =
                tokio::task::spawn_blocking(move || prepare.prepare(&installation, entries))
                    .await
                    .map_err(|_| PlaybackError::Gone)?;
            return self
                .ask(|reply| Request::Play {
                    generation,
                    prepared,
                    loop_playlist,
                    begin,
                    at,
                    reply,
                })
                .await;
        }
        let prepared = self.prepared(playlist).await?.map(runs);
        let loop_playlist = prepared.as_ref().is_ok_and(|(_, looping)| *looping);
        self.ask(|reply| Request::Play {
            generation,
            prepared: prepared.map(|(runs, _)| Box::new(runs) as PreparedRuns),
            loop_playlist,
            begin,
            at,
            reply,
        })
        .await
    }

    /// The cut `show` of entry `entry` (0-based) prepared as the family prepares a
    /// one-entry playlist, on a blocking thread; a refusal names the entry.
    async fn prepare_lead(
        &self,
        entry: usize,
        show: floatball_shared::show::Show,
    ) -> Result<Result<PreparedRuns, StartError>, PlaybackError> {
        let installation = self.installation();
        let entries = vec![Entry {
            show,
            delay_ms: 0,
            cycles: 1,
        }];
        let sequenced = self.sequenced.clone();
        let views = link_views(&self.links());
        let prepared = tokio::task::spawn_blocking(move || match sequenced {
            Some(prepare) => prepare.prepare(&installation, entries),
            None => prepare(&installation, entries, false, &views)
                .map(|prepared| Box::new(runs(prepared).0) as PreparedRuns),
        })
        .await
        .map_err(|_| PlaybackError::Gone)?;
        Ok(prepared.map_err(|error| match error {
            StartError::Invalid { show, reason, .. } => StartError::Invalid {
                entry: entry + 1,
                show,
                reason,
            },
            StartError::Infeasible {
                show,
                reason,
                fixes,
                ..
            } => StartError::Infeasible {
                entry: entry + 1,
                show,
                reason,
                fixes,
            },
            other => other,
        }))
    }

    /// Home: stop now, bring every ball home, and stay idle there.
    ///
    /// # Errors
    /// [`PlaybackError::Refused`]: the matrix is stopped, and stays so.
    pub async fn home(&self) -> Result<(), PlaybackError> {
        self.estop();
        let generation = self.latch.generation();
        self.home_issued(generation).await
    }

    /// The rest of a Home whose stop was pressed already, at e-stop `generation`.
    ///
    /// # Errors
    /// As [`Playback::home`].
    pub async fn home_issued(&self, generation: u64) -> Result<(), PlaybackError> {
        self.ask(|reply| Request::Home { generation, reply }).await
    }

    /// The playlist prepared last (armed or started) if it was prepared from `key` on
    /// the installation now: its plans are shared, nothing is read or planned again
    /// (UIM2503 gateways; `None` for MBOX boxes and MOONS' drives).
    pub fn prepared_for(&self, key: &PlaylistKey) -> Option<Prepared> {
        if self.sequenced.is_some() {
            return None;
        }
        let installation = self.installation();
        let kept = self.kept.lock().unwrap_or_else(PoisonError::into_inner);
        kept.as_ref()
            .filter(|kept| kept.key == *key && Arc::ptr_eq(&kept.installation, &installation))
            .map(|kept| kept.prepared.clone())
    }

    /// `playlist` prepared: as it is, or planned now (and kept under its key).
    async fn prepared(
        &self,
        playlist: Playlist,
    ) -> Result<Result<Prepared, StartError>, PlaybackError> {
        match playlist {
            Playlist::Prepared(prepared) => Ok(Ok(prepared)),
            Playlist::Planned(prepared) => Ok(prepared),
            Playlist::Read {
                entries,
                loop_playlist,
                key,
            } => {
                let installation = self.installation();
                let prepared = self.prepare(entries, loop_playlist).await?;
                self.keep(key, installation, &prepared);
                Ok(prepared)
            }
        }
    }

    /// Keeps `prepared` (when it was prepared, from `key` on `installation`) for
    /// [`Playback::prepared_for`]. The one kept replaces the last: at most one
    /// playlist's plans besides what the player holds.
    fn keep(
        &self,
        key: Option<PlaylistKey>,
        installation: Arc<Installation>,
        prepared: &Result<Prepared, StartError>,
    ) {
        if let (Some(key), Ok(prepared)) = (key, prepared) {
            *self.kept.lock().unwrap_or_else(PoisonError::into_inner) = Some(Kept {
                key,
                installation,
                prepared: prepared.clone(),
            });
        }
    }

    /// Whether a Start may begin inside a show here: every family cuts a show, except
    /// MOONS' drives that play the programs stored on them.
    pub fn cuts(&self) -> bool {
        self.sequenced.as_ref().is_none_or(|prepare| prepare.cuts())
    }

    /// Whether a playlist is planned for serial lines here ([`Playback::prepare_blocking`]):
    /// UIM2503 gateways, not MBOX boxes or MOONS' drives.
    pub fn plans_lines(&self) -> bool {
        self.sequenced.is_none()
    }

    /// Plans the playlist `entries` now, on the calling thread (a blocking one: the
    /// thread that read the shows, see [`Playlist::Planned`]), and keeps it under
    /// `key` (the key of what was read).
    ///
    /// # Errors
    /// The player's refusal, as Start would give it.
    pub fn prepare_blocking(
        &self,
        entries: Vec<Entry>,
        loop_playlist: bool,
        key: Option<PlaylistKey>,
    ) -> Result<Prepared, StartError> {
        let installation = self.installation();
        let views = link_views(&self.links());
        let prepared = prepare(&installation, entries, loop_playlist, &views);
        self.keep(key, installation, &prepared);
        prepared
    }

    /// Plans the playlist on a blocking thread: planning a long show takes a while, and
    /// neither the playback task nor the runtime's workers may wait for it.
    async fn prepare(
        &self,
        entries: Vec<Entry>,
        loop_playlist: bool,
    ) -> Result<Result<Prepared, StartError>, PlaybackError> {
        let installation = self.installation();
        let views = link_views(&self.links());
        tokio::task::spawn_blocking(move || prepare(&installation, entries, loop_playlist, &views))
            .await
            .map_err(|_| PlaybackError::Gone)
    }

    /// Sends the player a request and waits for its answer.
    async fn ask(&self, request: impl FnOnce(Reply) -> Request) -> Result<(), PlaybackError> {
        let (reply, answer) = oneshot::channel();
        self.requests
            .send(request(reply))
            .map_err(|_| PlaybackError::Gone)?;
        answer
            .await
            .map_err(|_| PlaybackError::Gone)?
            .map_err(PlaybackError::from)
    }
}

impl Playback {
    /// The installation and links now (a copy of two pointers).
    fn live(&self) -> Live {
        match self.live.read() {
            Ok(live) => live.clone(),
            Err(poisoned) => poisoned.into_inner().clone(),
        }
    }

    /// Replaces the installation and/or the links of the snapshot.
    fn set_live(&self, installation: Option<Arc<Installation>>, links: Option<Arc<Vec<Link>>>) {
        let mut live = match self.live.write() {
            Ok(live) => live,
            Err(poisoned) => poisoned.into_inner(),
        };
        if let Some(installation) = installation {
            live.installation = installation;
        }
        if let Some(links) = links {
            live.links = links;
        }
    }

    /// Hands the player a new `installation` and its `links` (UIM2503: those of the
    /// gateways in `opened` are new; the others: the same empty list) with the units'
    /// `health` of each link (the new monitors' views), and, for MBOX
    /// boxes, the MBOX player's configuration `mbox`: taken only while the player is
    /// idle, when the player starts anew on it.
    ///
    /// # Errors
    /// [`ReconfigureError`]: not idle, an MBOX installation without `mbox`, or the
    /// task gone; nothing changed.
    pub async fn reconfigure(
        &self,
        installation: Installation,
        mbox: Option<MboxPlayerConfig>,
        links: Arc<Vec<Link>>,
        health: Vec<HealthView>,
        opened: Vec<usize>,
    ) -> Result<(), ReconfigureError> {
        let (reply, answer) = oneshot::channel();
        self.requests
            .send(Request::Reconfigure(Box::new(Reconfigure {
                installation: installation.clone(),
                mbox,
                links: Arc::clone(&links),
                health,
                opened,
                reply,
            })))
            .map_err(|_| ReconfigureError::Gone)?;
        answer.await.map_err(|_| ReconfigureError::Gone)??;
        self.set_live(Some(Arc::new(installation)), Some(links));
        Ok(())
    }
}

/// The answer while the player is `state` (`running`: a run is under way): idle or
/// not.
fn idle_for_reconfigure(
    state: floatball_shared::api::PlayerState,
    running: bool,
) -> Result<(), ReconfigureError> {
    if running || state != floatball_shared::api::PlayerState::Idle {
        Err(ReconfigureError::NotIdle {
            state: state.as_str().to_owned(),
        })
    } else {
        Ok(())
    }
}

// ---- arm ----

impl Playback {
    /// Whether this installation arms shows while idle (UIM2503 gateways; MBOX boxes
    /// take positions frame by frame, MOONS' drives load their programs at Start).
    pub fn arms(&self) -> bool {
        self.sequenced.is_none() && !self.live().links.is_empty()
    }

    /// The player's disarm count as last published: an arming prepared at this count
    /// is accepted only if no disarm came since.
    pub fn disarms(&self) -> u64 {
        self.arming.disarms.load(Ordering::Acquire)
    }

    /// Whether the balls' positions are unknown (the next Start homes first), as the
    /// player last said (a timecode chase's lead estimate, `crate::timecode::lead`).
    pub fn needs_home(&self) -> bool {
        self.arming.needs_home.load(Ordering::Acquire)
    }

    /// Whether the quiet time after the last [`Playback::disarm`] is over.
    pub fn arming_allowed(&self) -> bool {
        Instant::now()
            >= *self
                .arming
                .quiet_until
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
    }

    /// Drops what is armed (or being armed): the next Start loads every table again,
    /// and nothing is armed for [`ARM_QUIET`]. Call it before anything that could change
    /// what the units hold or what the first entry is: a console line to a gateway, a
    /// A timecode chase's clock trim (`docs/show-control.md`, drift): the show of
    /// entry `entry` (0-based) has its time 0 at `show_start` by the timecode; the
    /// drive pulls the units' clock toward it where its family can (MBOX exactly,
    /// UIM2503 streamed rows ±1 ms each, MOONS' drives not at all). Ignored unless
    /// that entry plays. Takes no lock and waits for nothing.
    pub fn trim_clock(&self, entry: usize, show_start: Instant) {
        let _ = self.requests.send(Request::Trim { entry, show_start });
    }

    /// new playlist, a changed show of the playlist, a new installation, a
    /// commissioning command. Takes no lock the task holds and waits for nothing.
    pub fn disarm(&self) {
        *self
            .arming
            .quiet_until
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = Instant::now() + ARM_QUIET;
        let _ = self.requests.send(Request::Disarm);
    }

    /// Arms the first entry of `playlist` (prepared as Start would prepare it, on a
    /// blocking thread, unless it is prepared already) if the player is still idle and nothing disarmed it
    /// since `disarms` ([`Playback::disarms`] read before the playlist was). Returns
    /// whether the request went to the player; a playlist Start would refuse is not
    /// armed.
    pub async fn arm(&self, playlist: Playlist, disarms: u64) -> bool {
        if !self.arms() {
            return false;
        }
        let generation = self.latch.generation();
        let Ok(Ok(prepared)) = self.prepared(playlist).await else {
            return false;
        };
        self.requests
            .send(Request::Arm {
                generation,
                disarms,
                prepared: Box::new(runs(prepared).0),
            })
            .is_ok()
    }
}

/// How often at most the full list of gateways is published: the status is built on
/// every turn of the task (many a second while a show streams), the list is read
/// every 2 s by an app that shows it.
pub const LIST_EVERY: Duration = Duration::from_millis(250);

/// Every gateway in full as last published ([`Playback::gateway_list`]), and when.
#[derive(Debug, Default)]
struct Listed {
    at: Option<Instant>,
    gateways: Vec<GatewayStatus>,
}

/// Publishes `all` (every gateway) on `list` if it changed and the last publication
/// is [`LIST_EVERY`] old, and summarises it for the status ([`summarise_gateways`]).
/// Every task builds its status at least ten times a second, so the list is never
/// more than about a third of a second behind.
fn summarise(
    all: Vec<GatewayStatus>,
    list: &watch::Sender<Listed>,
) -> (Vec<GatewayStatus>, GatewaySummary) {
    list.send_if_modified(|published| {
        let due = published.at.is_none_or(|at| at.elapsed() >= LIST_EVERY);
        let changed = due && published.gateways != all;
        if changed {
            published.gateways.clone_from(&all);
            published.at = Some(Instant::now());
        }
        changed
    });
    summarise_gateways(all)
}

/// Whether a request issued at `generation` may run now: no e-stop since, every
/// gateway up; then the latch is released for it.
fn admit(
    latch: &Latch,
    generation: u64,
    views: &[LinkView],
    gateways: usize,
) -> Result<(), StartError> {
    if generation != latch.generation() {
        return Err(StartError::Superseded);
    }
    if let Some(gateway) = (0..gateways).find(|&gateway| !views.get(gateway).is_some_and(|v| v.up))
    {
        return Err(StartError::NotConnected { gateway });
    }
    if !latch.release(generation) {
        return Err(StartError::Superseded);
    }
    Ok(())
}

/// Publishes `current` if it differs from what the clients saw last.
fn publish(status: &watch::Sender<Status>, current: Status) {
    status.send_if_modified(|published| {
        let changed = *published != current;
        if changed {
            *published = current;
        }
        changed
    });
}
