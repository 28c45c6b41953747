//! What every request handler shares: the live status and where the app's files are.

use std::path::PathBuf;
use std::sync::Arc;

use floatball_shared::api::Status;
use tokio::sync::watch;

/// Shared state of the running bridge; cheap to clone.
#[derive(Debug, Clone)]
pub struct AppState {
    inner: Arc<Inner>,
}

#[derive(Debug)]
struct Inner {
    static_dir: PathBuf,
    status: watch::Sender<Status>,
}

impl AppState {
    /// A bridge serving the app from `static_dir`, with an idle player.
    pub fn new(static_dir: PathBuf) -> Self {
        let (status, _) = watch::channel(Status::default());
        Self {
            inner: Arc::new(Inner { static_dir, status }),
        }
    }

    /// Where the web app's files are.
    pub fn static_dir(&self) -> &PathBuf {
        &self.inner.static_dir
    }

    /// A receiver that sees every status change.
    pub fn subscribe_status(&self) -> watch::Receiver<Status> {
        self.inner.status.subscribe()
    }

    /// Changes the status; every connected client is told.
    pub fn update_status(&self, change: impl FnOnce(&mut Status)) {
        self.inner.status.send_modify(change);
    }
}
