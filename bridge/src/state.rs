//! What every request handler shares: the configuration, the password and tokens, the
//! show store and playlist, the gateways, and the player (which owns the live status).
//!
//! [`AppState::open`] builds it from the data directory at start; nothing in it is
//! global, so tests run many bridges side by side.

use std::path::PathBuf;
use std::sync::Arc;

use floatball_shared::api::Status;
use floatball_shared::ascii::EncodeError;
use tokio::sync::{Mutex, watch};

use crate::estop::Latch;

use crate::auth::{Clock, LoginLimiter, Password, PasswordError, Tokens};
use crate::config::Config;
use crate::gateways::Gateways;
use crate::playback::Playback;
use crate::playlist::{PlaylistError, PlaylistStore};
use crate::store::{ShowStore, StoreError};

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
    config: Config,
    paths: Paths,
    clock: Clock,
    password: Password,
    tokens: Tokens,
    login_limiter: LoginLimiter,
    shows: ShowStore,
    playlist: PlaylistStore,
    catalogue: Mutex<()>,
    gateways: Gateways,
    playback: Playback,
    stopping: watch::Sender<bool>,
}

impl AppState {
    /// Opens the data directory (creating what is missing) for a bridge with `config`,
    /// reading time from `clock`, and opens the links to the gateways. Must run inside
    /// the async runtime.
    ///
    /// # Errors
    /// [`OpenError`] naming the file or directory that cannot be used.
    pub fn open(config: Config, paths: Paths, clock: Clock) -> Result<Self, OpenError> {
        std::fs::create_dir_all(&paths.data_dir).map_err(|source| OpenError::DataDir {
            path: paths.data_dir.clone(),
            source,
        })?;
        let password = Password::open(&paths.data_dir)?;
        let shows = ShowStore::open(&paths.data_dir)?;
        let playlist = PlaylistStore::open(&paths.data_dir)?;
        let tokens = Tokens::open(&paths.data_dir, clock.now());
        let latch = Arc::new(Latch::new());
        let gateways = Gateways::open(&config, &latch)?;
        let playback = Playback::spawn(config.installation.clone(), gateways.links().to_vec());
        Ok(Self {
            inner: Arc::new(Inner {
                config,
                paths,
                clock,
                password,
                tokens,
                login_limiter: LoginLimiter::new(),
                shows,
                playlist,
                catalogue: Mutex::new(()),
                gateways,
                playback,
                stopping: watch::channel(false).0,
            }),
        })
    }

    /// The installation's configuration.
    pub fn config(&self) -> &Config {
        &self.inner.config
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

    /// The links to the gateways.
    pub fn gateways(&self) -> &Gateways {
        &self.inner.gateways
    }

    /// The player: Start, E-stop, Reset.
    pub fn playback(&self) -> &Playback {
        &self.inner.playback
    }

    /// Tells long-lived connections (WebSockets) that the server is stopping.
    pub fn stop(&self) {
        self.inner.stopping.send_replace(true);
    }

    /// A receiver that turns `true` when the server is stopping.
    pub fn stopping(&self) -> watch::Receiver<bool> {
        self.inner.stopping.subscribe()
    }

    /// A receiver that sees every status change (the playback task owns the status).
    pub fn subscribe_status(&self) -> watch::Receiver<Status> {
        self.inner.playback.status()
    }
}
