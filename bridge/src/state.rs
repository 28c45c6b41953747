//! What every request handler shares: the configuration, the password and tokens, the
//! show store and playlist, the gateways, and the player (which owns the live status
//! and the full list of gateways beside it).
//!
//! [`AppState::open`] builds it from the data directory at start; nothing in it is
//! global, so tests run many bridges side by side.
//!
//! The configuration is a snapshot with one owner: readers get an `Arc<Config>`
//! ([`AppState::config`]) and keep it as long as they like; a new installation
//! (`crate::install`) replaces it whole ([`AppState::replace_config`]). The watch it
//! lives in is only borrowed to copy the pointer, never across an await.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use floatball_shared::api::{GatewayStatus, Status};
use floatball_shared::uim2503::ascii::EncodeError;
use tokio::sync::{Mutex, watch};

use crate::commission::Commission;
use crate::commission::sim_units::SimUnits;
use crate::estop::Latch;

use crate::auth::{Clock, LoginLimiter, Password, PasswordError, Tokens};
use crate::config::{Config, Family, MboxConfig, MboxTarget, SclConfig, SclGateway};
use crate::gateways::Gateways;
use crate::playback::Playback;
use crate::playlist::{PlaylistError, PlaylistStore};
use crate::ports::mbox::MboxNet;
use crate::ports::scl::SclNet;
use crate::simulate::mbox::{MboxBoxes, MboxOptions};
use crate::simulate::scl::{DEFAULT_START_WIRE, SimDrives, parse_start_wire};
use crate::store::{ShowStore, StoreError};
use floatball_shared::mbox::player::MboxPlayerConfig;
use floatball_shared::plan::Installation;
use std::net::SocketAddr;

/// Why the bridge cannot start with this data directory.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The data directory cannot be created.
    #[error("cannot create the data directory {}: {source}", path.display())]
    DataDir {
        /// The directory.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The password file.
    #[error(transparent)]
    Password(#[from] PasswordError),
    /// The show store.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The playlist.
    #[error(transparent)]
    Playlist(#[from] PlaylistError),
    /// The e-stop instruction cannot be encoded.
    #[error("the e-stop instruction cannot be sent: {0}")]
    Estop(#[from] EncodeError),
    /// The MBOX boxes' socket, or a simulated box, cannot be opened.
    #[error("{0}")]
    Mbox(String),
    /// An SCL link cannot start.
    #[error("{0}")]
    Scl(String),
    /// The schedule file cannot be read.
    #[error("{0}")]
    Schedule(String),
}

/// Where the bridge keeps and finds its files.
#[derive(Debug, Clone)]
pub struct Paths {
    /// Configuration, password, shows and playlist.
    pub data_dir: PathBuf,
    /// The web app (`index.html` and the built `pkg/`).
    pub static_dir: PathBuf,
}

/// Shared state of the running bridge; cheap to clone.
#[derive(Debug, Clone)]
pub struct AppState {
    inner: Arc<Inner>,
}

#[derive(Debug)]
struct Inner {
    /// The configuration now; replaced whole, never changed in place.
    config: watch::Sender<Arc<Config>>,
    paths: Paths,
    clock: Clock,
    password: Password,
    tokens: Tokens,
    login_limiter: LoginLimiter,
    shows: ShowStore,
    playlist: PlaylistStore,
    catalogue: Mutex<()>,
    /// Starts and Resets that read the playlist and are being planned ([`StartPending`]).
    starts_pending: Arc<AtomicUsize>,
    /// Line-speed changes under way ([`LineSpeedChange`]): a Start waits for them.
    line_speed_changes: watch::Sender<usize>,
    gateways: Gateways,
    /// Roll calls, assignments, identify moves and the units' health.
    commission: Commission,
    playback: Playback,
    /// The simulated MBOX boxes (`port = "sim"`), one per such gateway, in order.
    mbox_sims: Vec<MboxBoxes>,
    /// The simulated MOONS' drives of every `kind = "scl"`, `port = "sim"` entry.
    scl_sims: Option<SimDrives>,
    stopping: watch::Sender<bool>,
    /// The weekly schedule and its scheduler's state.
    schedules: crate::schedule::Schedules,
    /// The timecode chase's status (`crate::timecode`); `None` while it is off.
    timecode: watch::Sender<Option<floatball_shared::timecode::chase::TimecodeStatus>>,
    /// The live input as received (`crate::live`; its one writer is the live task).
    live: watch::Sender<Arc<crate::live::LiveInput>>,
}

/// Opens the MBOX boxes' socket, starting a simulated box on loopback for each
/// `port = "sim"` gateway first; returns the boxes and the simulated ones.
fn open_boxes(
    mbox: &MboxConfig,
    latch: &Arc<Latch>,
) -> Result<(MboxNet, Vec<MboxBoxes>), OpenError> {
    let mut sims = Vec::new();
    let mut addresses = Vec::with_capacity(mbox.boxes.len());
    for (index, one) in mbox.boxes.iter().enumerate() {
        match one.target {
            MboxTarget::Address(address) => addresses.push(address),
            MboxTarget::Sim => {
                let ip = u32::from(floatball_shared::mbox::FACTORY_IP)
                    .wrapping_add(u32::try_from(index).unwrap_or(0));
                let sim = MboxBoxes::spawn(MboxOptions {
                    listen: SocketAddr::from(([127, 0, 0, 1], 0)),
                    boxes: 1,
                    axes: one.axes,
                    ip: ip.into(),
                    drop_percent: 0,
                    seed: 0,
                })
                .map_err(OpenError::Mbox)?;
                let socket = sim.boxes().first().map(|running| running.socket);
                addresses.push(socket.ok_or_else(|| {
                    OpenError::Mbox(format!("simulated MBOX box {index} did not start"))
                })?);
                sims.push(sim);
            }
        }
    }
    let boxes = MboxNet::open(
        mbox.host_port,
        &addresses,
        mbox.frame_period,
        mbox.time,
        Arc::clone(latch),
    )
    .map_err(OpenError::Mbox)?;
    Ok((boxes, sims))
}

/// Starts the simulated MOONS' drives of every `port = "sim"` entry of `scl` (one bus,
/// one start wire) and returns the configuration the links and the player use: each
/// such entry an eSCL entry with its drives' loopback sockets.
///
/// The wire runs from the configured trigger (`[scl] trigger`, to `start_input`) when
/// the first gateway entry is simulated, else from the simulator's default
/// ([`DEFAULT_START_WIRE`], the same as `trigger = "0:2"` with the default start input
/// 3). Without a trigger the programs wait for no input and the wire is unused. When
/// every entry is simulated the bridge sends from any free port (no drive remembers
/// an earlier host).
fn open_drives(scl: &SclConfig) -> Result<(SclConfig, Option<SimDrives>), OpenError> {
    let entries: Vec<(usize, usize)> = scl
        .gateways
        .iter()
        .enumerate()
        .filter_map(|(index, gateway)| match gateway {
            SclGateway::Sim { drives } => Some((index, *drives)),
            _ => None,
        })
        .collect();
    if entries.is_empty() {
        return Ok((scl.clone(), None));
    }
    let first_simulated = matches!(scl.gateways.first(), Some(SclGateway::Sim { .. }));
    let wire = match (scl.trigger, scl.start) {
        (Some((from, output)), Some((input, _))) if first_simulated => {
            floatball_shared::scl::twin::StartWire {
                from,
                output,
                input,
            }
        }
        _ => parse_start_wire(DEFAULT_START_WIRE).map_err(OpenError::Scl)?,
    };
    let sims = SimDrives::spawn(&entries, scl.steps_per_rev, wire).map_err(OpenError::Scl)?;
    let mut resolved = scl.clone();
    for (index, gateway) in resolved.gateways.iter_mut().enumerate() {
        if matches!(gateway, SclGateway::Sim { .. }) {
            *gateway = SclGateway::Escl(sims.sockets(index));
        }
    }
    if entries.len() == scl.gateways.len() {
        resolved.host_port = 0;
    }
    Ok((resolved, Some(sims)))
}

/// The MBOX player's configuration for `installation` on the boxes of `mbox`.
pub fn mbox_player_config(installation: &Installation, mbox: &MboxConfig) -> MboxPlayerConfig {
    MboxPlayerConfig {
        installation: installation.clone(),
        boxes: mbox.boxes.iter().map(|one| one.calibration).collect(),
        period_us: u64::try_from(mbox.frame_period.as_micros()).unwrap_or(20_000),
    }
}

impl AppState {
    /// Opens the data directory (creating what is missing) for a bridge with `config`,
    /// reading time from `clock`, and opens the links to the gateways. Must run inside
    /// the async runtime.
    ///
    /// # Errors
    /// [`OpenError`] naming the file or directory that cannot be used.
    pub fn open(config: Config, paths: Paths, clock: Clock) -> Result<Self, OpenError> {
        Self::open_with(config, paths, clock, SimUnits::default())
    }

    /// As [`AppState::open`], with simulated gateways whose new units leave the factory
    /// as `sim` says (`floatball --sim-factory-fresh`).
    ///
    /// # Errors
    /// As [`AppState::open`].
    pub fn open_with(
        config: Config,
        paths: Paths,
        clock: Clock,
        sim: SimUnits,
    ) -> Result<Self, OpenError> {
        std::fs::create_dir_all(&paths.data_dir).map_err(|source| OpenError::DataDir {
            path: paths.data_dir.clone(),
            source,
        })?;
        let password = Password::open(&paths.data_dir)?;
        // No show is read here: the index is completed once the bridge listens
        // (`server::run`).
        let shows = ShowStore::open_deferred(&paths.data_dir)?;
        let playlist = PlaylistStore::open(&paths.data_dir)?;
        let schedules =
            crate::schedule::Schedules::open(&paths.data_dir).map_err(OpenError::Schedule)?;
        let tokens = Tokens::open(&paths.data_dir, clock.now());
        let latch = Arc::new(Latch::new());
        let gateways = Gateways::open(&config, &latch, &paths.data_dir, sim)?;
        let (health, health_views) = crate::commission::health_channels(gateways.links().len());
        let mut scl_sims = None;
        let (playback, mbox_sims) = match &config.family {
            Family::Scl(scl) => {
                let (scl, sims) = open_drives(scl)?;
                scl_sims = sims;
                let drives = SclNet::open(&scl, &latch).map_err(OpenError::Scl)?;
                (
                    Playback::spawn_scl(
                        config.installation.clone(),
                        scl,
                        drives,
                        Arc::clone(&latch),
                    ),
                    Vec::new(),
                )
            }
            Family::Mbox(mbox) => {
                let (boxes, sims) = open_boxes(mbox, &latch)?;
                let player = mbox_player_config(&config.installation, mbox);
                (
                    Playback::spawn_mbox(player, boxes, Arc::clone(&latch)),
                    sims,
                )
            }
            Family::Uim2503 => (
                Playback::spawn_with_health(
                    config.installation.clone(),
                    gateways.links().to_vec(),
                    health_views,
                ),
                Vec::new(),
            ),
        };
        let starts_pending = Arc::new(AtomicUsize::new(0));
        let commission = Commission::open(
            &gateways.links(),
            &config.installation,
            paths.data_dir.clone(),
            playback.status(),
            Arc::clone(&starts_pending),
            health,
        );
        let opened = Self {
            inner: Arc::new(Inner {
                config: watch::channel(Arc::new(config)).0,
                paths,
                clock,
                password,
                tokens,
                login_limiter: LoginLimiter::new(),
                shows,
                playlist,
                catalogue: Mutex::new(()),
                starts_pending,
                line_speed_changes: watch::Sender::new(0),
                gateways,
                commission,
                playback,
                mbox_sims,
                scl_sims,
                stopping: watch::channel(false).0,
                schedules,
                timecode: watch::Sender::new(None),
                live: watch::Sender::new(Arc::new(crate::live::LiveInput::default())),
            }),
        };
        // The playback task reads live input from the receivers' snapshots.
        opened
            .inner
            .playback
            .attach_live(opened.inner.live.subscribe());
        Ok(opened)
    }

    /// The installation's configuration now: a snapshot, which a new installation
    /// replaces but never changes.
    pub fn config(&self) -> Arc<Config> {
        Arc::clone(&self.inner.config.borrow())
    }

    /// Makes `config` the configuration every reader gets from now on (the one
    /// writer: `crate::install`, under the catalogue lock).
    pub fn replace_config(&self, config: Config) {
        self.inner.config.send_replace(Arc::new(config));
    }

    /// The data directory (`floatball.toml`, the password, the shows).
    pub fn data_dir(&self) -> &std::path::Path {
        &self.inner.paths.data_dir
    }

    /// Where the web app's files are.
    pub fn static_dir(&self) -> &PathBuf {
        &self.inner.paths.static_dir
    }

    /// The clock auth decisions are made by.
    pub fn clock(&self) -> &Clock {
        &self.inner.clock
    }

    /// The operator password.
    pub fn password(&self) -> &Password {
        &self.inner.password
    }

    /// The bearer tokens.
    pub fn tokens(&self) -> &Tokens {
        &self.inner.tokens
    }

    /// The brake on password guessing.
    pub fn login_limiter(&self) -> &LoginLimiter {
        &self.inner.login_limiter
    }

    /// The stored shows.
    pub fn shows(&self) -> &ShowStore {
        &self.inner.shows
    }

    /// The stored playlist.
    pub fn playlist(&self) -> &PlaylistStore {
        &self.inner.playlist
    }

    /// Held while the shows or the playlist change, so that a playlist never names a
    /// show that is being deleted.
    pub async fn lock_catalogue(&self) -> tokio::sync::MutexGuard<'_, ()> {
        self.inner.catalogue.lock().await
    }

    /// Marks a Start or Reset as pending from the moment it reads the playlist until
    /// the player has taken or refused it (the guard's drop): planning takes a while,
    /// and all that time the status still says idle. Taken under the catalogue lock,
    /// so a playlist change either lands before the read or sees the mark.
    /// A line-speed change under way ([`AppState::line_speed_change`]) is waited out
    /// first, without holding the lock.
    pub async fn start_pending(&self) -> StartPending {
        let mut changes = self.inner.line_speed_changes.subscribe();
        loop {
            {
                let _catalogue = self.lock_catalogue().await;
                if *changes.borrow_and_update() == 0 {
                    self.inner.starts_pending.fetch_add(1, Ordering::SeqCst);
                    return StartPending {
                        state: self.clone(),
                    };
                }
            }
            let _ = changes.wait_for(|changes| *changes == 0).await;
        }
    }

    /// Marks a line-speed change as under way until the guard's drop: taken under
    /// the catalogue lock, which the change then releases while it waits for the
    /// gateway's power cycle (up to a minute), so shows and the playlist can be edited
    /// meanwhile; a Start waits for the mark to go, and another installation change is
    /// refused ([`AppState::line_speed_changing`]).
    pub fn line_speed_change(&self) -> LineSpeedChange {
        self.inner
            .line_speed_changes
            .send_modify(|changes| *changes += 1);
        LineSpeedChange {
            state: self.clone(),
        }
    }

    /// Whether a line-speed change is under way ([`AppState::line_speed_change`]).
    pub fn line_speed_changing(&self) -> bool {
        *self.inner.line_speed_changes.borrow() > 0
    }

    /// Whether a Start or Reset is being prepared ([`AppState::start_pending`]).
    pub fn starts_pending(&self) -> bool {
        self.inner.starts_pending.load(Ordering::SeqCst) > 0
    }

    /// The links to the gateways.
    pub fn gateways(&self) -> &Gateways {
        &self.inner.gateways
    }

    /// Roll calls, assignments, identify moves and the units' health.
    pub fn commission(&self) -> &Commission {
        &self.inner.commission
    }

    /// The simulated MBOX boxes (`port = "sim"`), each a box of one gateway, in
    /// configuration order.
    pub fn mbox_sims(&self) -> impl Iterator<Item = &MboxBoxes> {
        self.inner.mbox_sims.iter()
    }

    /// The simulated MOONS' drives (`kind = "scl"`, `port = "sim"`), if any.
    pub fn scl_sims(&self) -> Option<&SimDrives> {
        self.inner.scl_sims.as_ref()
    }

    /// The player: Start, E-stop, Reset.
    pub fn playback(&self) -> &Playback {
        &self.inner.playback
    }

    /// The weekly schedule and its scheduler's state.
    pub fn schedules(&self) -> &crate::schedule::Schedules {
        &self.inner.schedules
    }

    /// Tells long-lived connections (WebSockets) that the server is stopping.
    pub fn stop(&self) {
        self.inner.stopping.send_replace(true);
    }

    /// A receiver that turns `true` when the server is stopping.
    pub fn stopping(&self) -> watch::Receiver<bool> {
        self.inner.stopping.subscribe()
    }

    /// A receiver that sees every change of the timecode chase's status.
    pub fn subscribe_timecode(
        &self,
    ) -> watch::Receiver<Option<floatball_shared::timecode::chase::TimecodeStatus>> {
        self.inner.timecode.subscribe()
    }

    /// Publishes the timecode chase's status (its one writer: `crate::timecode`).
    pub fn publish_timecode(&self, status: floatball_shared::timecode::chase::TimecodeStatus) {
        self.inner.timecode.send_if_modified(|now| {
            let changed = now.as_ref() != Some(&status);
            if changed {
                *now = Some(status);
            }
            changed
        });
    }

    /// A receiver that sees every change of the configuration (it is replaced whole).
    pub fn subscribe_config(&self) -> watch::Receiver<Arc<Config>> {
        self.inner.config.subscribe()
    }

    /// A receiver of the live input as received ([`crate::live::LiveInput`], a new
    /// snapshot whenever input changes or is lost; the live mode reads it each step).
    pub fn subscribe_live(&self) -> watch::Receiver<Arc<crate::live::LiveInput>> {
        self.inner.live.subscribe()
    }

    /// The live input now.
    pub fn live_input(&self) -> Arc<crate::live::LiveInput> {
        Arc::clone(&self.inner.live.borrow())
    }

    /// Publishes the live input (its one writer: the live task, `crate::live`).
    pub fn publish_live(&self, input: Arc<crate::live::LiveInput>) {
        self.inner.live.send_replace(input);
    }

    /// A receiver that sees every status change (the playback task owns the status).
    pub fn subscribe_status(&self) -> watch::Receiver<Status> {
        self.inner.playback.status()
    }

    /// Every gateway's status in full, in installation order (the status details only
    /// those with a problem when there are many; `GET /api/status/gateways`).
    pub fn gateway_list(&self) -> Vec<GatewayStatus> {
        self.inner.playback.gateway_list()
    }
}

/// A Start or Reset being prepared; see [`AppState::start_pending`].
#[derive(Debug)]
pub struct StartPending {
    state: AppState,
}

/// A line-speed change under way ([`AppState::line_speed_change`]); ends when dropped.
#[derive(Debug)]
pub struct LineSpeedChange {
    state: AppState,
}

impl Drop for LineSpeedChange {
    fn drop(&mut self) {
        self.state
            .inner
            .line_speed_changes
            .send_modify(|changes| *changes = changes.saturating_sub(1));
    }
}

impl Drop for StartPending {
    fn drop(&mut self) {
        self.state
            .inner
            .starts_pending
            .fetch_sub(1, Ordering::SeqCst);
    }
}
