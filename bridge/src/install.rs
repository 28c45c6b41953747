//! A new installation applied without a restart: `PUT /api/installation` and a
//! gateway's new line speed (`POST /api/gateways/{g}/baud`).
//!
//! The one path that changes the configuration while the bridge runs, under the
//! catalogue lock (so no Start can begin meanwhile):
//! 1. refused while the player is not idle or a Start is pending
//!    ([`InstallError::Busy`]), and a change to the gateways of MBOX boxes or MOONS'
//!    drives ([`InstallError::NotLive`]: their tables hold more than the API says);
//! 2. `floatball.toml` edited ([`crate::config::edit`], comments and other keys kept)
//!    and checked as `floatball check` checks it, every problem listed
//!    ([`InstallError::Invalid`]); nothing is written unless it passes;
//! 3. written atomically ([`crate::durable`]);
//! 4. applied: the links whose port or baud changed and the added gateways opened,
//!    the removed ones closed ([`crate::gateways::Gateways::reopen`]), the player
//!    restarted idle on the new installation ([`crate::playback::Playback::reconfigure`]),
//!    and the configuration snapshot replaced ([`AppState::replace_config`]). Should
//!    the player refuse (it left idle in between), the old links and file are put
//!    back.
//!
//! A line-speed change is checked and marked under the lock
//! ([`AppState::line_speed_change`]), then releases it while the link waits (up to
//! [`BAUD_RESTART_WAIT`]) for the gateway's power cycle — shows and the playlist stay
//! editable, a Start waits for the mark, other installation changes are refused as
//! busy — and takes it again to save and apply the new speed (or, when the gateway
//! stays silent, ends with the line back at its old speed and nothing saved).
//!
//! What is live: the matrix (rows, cols, pitch, travel, limits, calibration, home,
//! approach speed; for MBOX boxes and MOONS' drives too, as long as their gateways'
//! stations stay the same) and the UIM2503 gateways (port, baud, stations, how many).
//! What is not: everything else in the file (listen, origins, uploads, the e-stop,
//! `[mbox]`, `[scl]`), which `PUT` does not change, and the gateways of MBOX boxes
//! and MOONS' drives (refused: edit the file and restart).

use std::sync::Arc;
use std::time::Duration;

use floatball_shared::api::{
    BaudChanged, GatewayKind, InstallationGateway, InstallationInfo, PlayerState,
};
use floatball_shared::codes::{Code, Coded, Params, english_text};
use floatball_shared::params;
use floatball_shared::plan::report::GATEWAY_BAUDS;
use floatball_shared::plan::{DriveKind, Installation};

use crate::config::{self, Config, ConfigError, Family, Overrides, edit};
use crate::playback::ReconfigureError;
use crate::ports::uim2503::BaudError;
use crate::state::AppState;

/// How long a baud change waits for the gateway to answer at the new speed (a real
/// gateway takes its new speed when the installer power-cycles it).
pub const BAUD_RESTART_WAIT: Duration = Duration::from_secs(60);

/// Why a new installation was not applied; nothing changed. Its text is its code's
/// English template, but for [`InstallError::NoSuchGateway`] and
/// [`InstallError::Baud`], which say more.
#[derive(Debug)]
pub enum InstallError {
    /// The checks of `floatball check` found these problems.
    Invalid(Vec<ConfigError>),
    /// The player is not idle, or a Start is pending (`state` says which).
    Busy {
        /// The player's state, or `starting`.
        state: String,
    },
    /// An installation of MBOX boxes or MOONS' drives.
    NotLive,
    /// The file could not be read, edited or written.
    NotSaved(String),
    /// The gateway has no link (no such gateway, or not a UIM2503).
    NoSuchGateway {
        /// The gateway asked for.
        gateway: usize,
        /// How many links there are.
        links: usize,
    },
    /// The gateway does not take that speed.
    BaudNotAllowed {
        /// The gateway.
        gateway: usize,
        /// The speed asked for.
        baud: u32,
    },
    /// The link did not change its speed ([`Link::change_baud`]'s reason); the line
    /// runs at its old speed.
    Baud {
        /// The gateway.
        gateway: usize,
        /// The speed asked for.
        baud: u32,
        /// Why.
        error: BaudError,
    },
}

impl std::fmt::Display for InstallError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NoSuchGateway { gateway, .. } => {
                write!(f, "there is no UIM2503 gateway {gateway}")
            }
            Self::Baud { gateway, error, .. } => write!(f, "gateway {gateway}: {error}"),
            _ => f.write_str(&english_text(self.code(), &self.params())),
        }
    }
}

impl std::error::Error for InstallError {}

impl Coded for InstallError {
    fn code(&self) -> Code {
        match self {
            Self::Invalid(_) => Code::InstallationInvalid,
            Self::Busy { .. } => Code::InstallationBusy,
            Self::NotLive => Code::InstallationNotLive,
            Self::NotSaved(_) => Code::InstallationNotSaved,
            Self::NoSuchGateway { .. } => Code::NoSuchGateway,
            Self::BaudNotAllowed { .. } => Code::BaudNotAllowed,
            Self::Baud { error, .. } => error.code(),
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::Invalid(problems) => params! {"problems" => problems.len()},
            Self::Busy { state } => params! {"state" => state},
            Self::NotLive => Params::new(),
            Self::NotSaved(reason) => params! {"reason" => reason},
            Self::NoSuchGateway { gateway, links } => {
                params! {"gateway" => gateway, "last" => links.saturating_sub(1)}
            }
            Self::BaudNotAllowed { baud, .. } => {
                let allowed: Vec<String> = GATEWAY_BAUDS.iter().map(u32::to_string).collect();
                params! {"baud" => baud, "allowed" => allowed.join(", ")}
            }
            Self::Baud {
                gateway,
                baud,
                error,
            } => {
                let mut params = error.params();
                params.insert("gateway".into(), gateway.to_string());
                params.insert("baud".into(), baud.to_string());
                params
            }
        }
    }
}

/// What `GET /api/installation` says about `installation`.
pub fn info(installation: &Installation) -> InstallationInfo {
    let gateways = installation
        .gateways
        .iter()
        .enumerate()
        .map(|(index, gateway)| InstallationGateway {
            kind: match gateway.kind {
                DriveKind::Uim2503 => GatewayKind::Uim2503,
                DriveKind::Mbox => GatewayKind::Mbox,
                DriveKind::Scl => GatewayKind::Scl,
            },
            port: gateway.port.clone(),
            baud: (gateway.kind != DriveKind::Mbox).then_some(gateway.baud),
            stations: installation.stations_on(index),
        })
        .collect();
    let limits = &installation.limits;
    InstallationInfo {
        rows: limits.rows,
        cols: limits.cols,
        pitch_mm: installation.pitch_mm,
        travel_mm: limits.travel_mm,
        max_speed_mm_s: limits.max_speed_mm_s,
        max_accel_mm_s2: limits.max_accel_mm_s2,
        home_mm: installation.home_mm,
        approach_speed_mm_s: installation.approach_speed_mm_s,
        counts_per_mm: installation.counts_per_mm,
        gateways,
    }
}

/// `PUT /api/installation`: checks `new`, saves it and applies it (see the module).
///
/// # Errors
/// [`InstallError`]; nothing changed.
pub async fn put(
    state: &AppState,
    new: InstallationInfo,
) -> Result<InstallationInfo, InstallError> {
    commissioning_done(state).await?;
    let _catalogue = state.lock_catalogue().await;
    idle(state)?;
    // What the units hold may no longer fit the installation or the line.
    crate::arming::disarm(state);
    let current = state.config();
    let current_info = info(&current.installation);
    if new.gateways.is_empty() {
        // The file would fall back to the one simulated gateway of a file without any.
        return Err(InstallError::Invalid(vec![ConfigError::File {
            path: state.data_dir().join(config::FILE_NAME),
            reason: "there is no gateway: an installation needs at least one".to_owned(),
        }]));
    }
    if edit::gateways_changed(&current_info, &new) {
        return Err(InstallError::NotLive);
    }
    save_and_apply(state, &current, &new, |text| {
        edit::installation(text, &current_info, &new)
    })
    .await
}

/// `POST /api/gateways/{gateway}/baud`: the gateway's line to `baud` (the link sends
/// `BDR`, waits for the gateway's restart and greets it at the new speed), then the
/// new speed saved in `floatball.toml` and the configuration.
///
/// # Errors
/// [`InstallError`]: not idle, no such UIM2503 gateway, a speed it does not take, the
/// gateway silent at the new speed (the line is back at the old one), or the file.
pub async fn change_baud(
    state: &AppState,
    gateway: usize,
    baud: u32,
) -> Result<BaudChanged, InstallError> {
    commissioning_done(state).await?;
    // Checked and marked under the catalogue lock; the lock is not held while the
    // link waits (up to BAUD_RESTART_WAIT) for the gateway's power cycle: a Start
    // waits for the mark instead, and other installation changes are refused.
    let (link, _changing) = {
        let _catalogue = state.lock_catalogue().await;
        idle(state)?;
        let links = state.gateways().links();
        let link = links
            .get(gateway)
            .cloned()
            .ok_or(InstallError::NoSuchGateway {
                gateway,
                links: links.len(),
            })?;
        if !floatball_shared::plan::report::GATEWAY_BAUDS.contains(&baud) {
            return Err(InstallError::BaudNotAllowed { gateway, baud });
        }
        // What the units hold may no longer fit the installation or the line.
        crate::arming::disarm(state);
        (link, state.line_speed_change())
    };
    let changed = link
        .change_baud(baud, BAUD_RESTART_WAIT)
        .await
        .map_err(|error| InstallError::Baud {
            gateway,
            baud,
            error,
        })?;
    // The gateway answers at the new speed: saved and applied under the lock.
    let _catalogue = state.lock_catalogue().await;
    let current = state.config();
    let current_info = info(&current.installation);
    let mut new = current_info.clone();
    if let Some(one) = new.gateways.get_mut(gateway) {
        one.baud = Some(baud);
    }
    save_and_apply(state, &current, &new, |text| {
        edit::baud(text, &current_info, gateway, baud)
    })
    .await?;
    Ok(changed)
}

/// The longest a new installation or line speed waits for a commissioning call to end
/// (an identified ball on its way back: a few seconds) before it is refused.
const COMMISSIONING_WAIT: Duration = Duration::from_secs(15);

/// Waits, at most [`COMMISSIONING_WAIT`], until no commissioning call uses a gateway:
/// the installer may tap Save while the last identified ball is still coming back.
async fn commissioning_done(state: &AppState) -> Result<(), InstallError> {
    let deadline = tokio::time::Instant::now() + COMMISSIONING_WAIT;
    while state.commission().busy() {
        if tokio::time::Instant::now() >= deadline {
            return Err(InstallError::Busy {
                state: "commissioning".to_owned(),
            });
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    Ok(())
}

/// Refused unless the player is idle and no Start is pending.
pub(crate) fn idle(state: &AppState) -> Result<(), InstallError> {
    if state.line_speed_changing() {
        return Err(InstallError::Busy {
            state: "changing a line speed".to_owned(),
        });
    }
    if state.starts_pending() {
        return Err(InstallError::Busy {
            state: "starting".to_owned(),
        });
    }
    let playing = state.subscribe_status().borrow().state;
    if playing != PlayerState::Idle {
        return Err(InstallError::Busy {
            state: playing.as_str().to_owned(),
        });
    }
    if state.commission().busy() {
        // A roll call or an identified ball on its way back uses the links.
        return Err(InstallError::Busy {
            state: "commissioning".to_owned(),
        });
    }
    Ok(())
}

/// Steps 2 to 4 of the module: `edited` makes the new file's text from the file's.
async fn save_and_apply(
    state: &AppState,
    current: &Config,
    new: &InstallationInfo,
    edited: impl FnOnce(&str) -> Result<String, edit::EditError>,
) -> Result<InstallationInfo, InstallError> {
    let dir = state.data_dir().to_owned();
    let path = dir.join(config::FILE_NAME);
    let reading = path.clone();
    let old_text = tokio::task::spawn_blocking(move || std::fs::read_to_string(reading))
        .await
        .map_err(|error| InstallError::NotSaved(error.to_string()))?
        .map_err(|error| InstallError::NotSaved(format!("{}: {error}", path.display())))?;
    let text = edited(&old_text).map_err(|error| InstallError::NotSaved(error.to_string()))?;
    // The command line's listen stays; the ports are the ones asked for.
    let overrides = Overrides {
        listen: Some(current.listen),
        gateway_ports: Vec::new(),
    };
    let config = Config::parse_all(&path, &text, &overrides).map_err(InstallError::Invalid)?;
    let applied = info(&config.installation);
    let mut asked = new.clone();
    for (gateway, now) in asked.gateways.iter_mut().zip(&applied.gateways) {
        if gateway.baud.is_none() {
            gateway.baud = now.baud;
        }
    }
    if applied != asked {
        // The file says something else than asked (a key the edit cannot write).
        return Err(InstallError::NotSaved(
            "the edited file does not say what was asked; edit floatball.toml by hand".to_owned(),
        ));
    }
    write(&dir, text).await?;
    let before = state.gateways().links();
    // MBOX boxes and MOONS' drives keep their sockets and links: their gateways did
    // not change (`put` refuses that).
    let fixed = config.family != Family::Uim2503;
    let (links, opened) = if fixed {
        (Arc::clone(&before), Vec::new())
    } else {
        let (links, reopened) = state
            .gateways()
            .reopen(&current.installation, &config.installation);
        (links, reopened.opened)
    };
    let mbox = config
        .mbox()
        .map(|mbox| crate::state::mbox_player_config(&config.installation, mbox));
    // The units' health of the new links: new monitors, which know the new stations.
    let (health, health_views) = crate::commission::health_channels(links.len());
    if let Err(error) = state
        .playback()
        .reconfigure(
            config.installation.clone(),
            mbox,
            Arc::clone(&links),
            health_views,
            opened,
        )
        .await
    {
        state.gateways().restore(before);
        // Best effort: the file said the new installation for a moment.
        if let Err(restore) = write(&dir, old_text).await {
            tracing::error!("cannot put floatball.toml back: {restore}");
        }
        return Err(match error {
            ReconfigureError::NotIdle { state } => InstallError::Busy { state },
            ReconfigureError::NotLive => InstallError::NotLive,
            ReconfigureError::Gone => InstallError::NotSaved(error.to_string()),
        });
    }
    tracing::info!(
        "applied a new installation: {} × {} balls on {} gateway(s)",
        config.installation.limits.rows,
        config.installation.limits.cols,
        config.installation.gateways.len()
    );
    state
        .commission()
        .reopen(&links, &config.installation, health);
    state.replace_config(config);
    Ok(applied)
}

/// Writes `floatball.toml` in `dir` atomically.
async fn write(dir: &std::path::Path, text: String) -> Result<(), InstallError> {
    let dir = dir.to_owned();
    tokio::task::spawn_blocking(move || {
        crate::durable::write_atomic(&dir, config::FILE_NAME, text.as_bytes())
    })
    .await
    .map_err(|error| InstallError::NotSaved(error.to_string()))?
    .map_err(|error| InstallError::NotSaved(error.to_string()))
}

#[cfg(test)]
mod tests {
    use floatball_shared::plan::{DriveKind, Installation};

    use super::info;

    /// The app plans a show in the browser from `GET /api/installation`: what the
    /// bridge describes must read back as the installation the bridge plans with.
    #[test]
    fn the_description_reads_back_as_the_installation() {
        let uim2503 = Installation::demo(10, 12, &[115_200, 9600, 57_600]).unwrap();
        assert_eq!(info(&uim2503).installation(), uim2503);

        let mut mbox = Installation::demo(2, 3, &[0]).unwrap();
        mbox.gateways[0].kind = DriveKind::Mbox;
        mbox.approach_speed_mm_s = 321.0;
        mbox.home_mm = 12.5;
        assert_eq!(info(&mbox).installation(), mbox);
    }

    /// A refusal is worded by its code's English template, but where it says more.
    #[test]
    fn refusals_read_as_their_codes_templates() {
        use floatball_shared::codes::{Code, Coded};

        use super::InstallError;

        let busy = InstallError::Busy {
            state: "playing".into(),
        };
        assert_eq!(busy.code(), Code::InstallationBusy);
        assert_eq!(
            busy.to_string(),
            "The matrix is playing: the installation and line speeds change only while it is idle"
        );
        let not_allowed = InstallError::BaudNotAllowed {
            gateway: 0,
            baud: 1200,
        };
        assert!(
            not_allowed
                .to_string()
                .starts_with("The gateway does not take 1200 baud; it takes 9600, "),
            "{not_allowed}"
        );
        let missing = InstallError::NoSuchGateway {
            gateway: 3,
            links: 2,
        };
        assert_eq!(missing.to_string(), "there is no UIM2503 gateway 3");
        assert_eq!(missing.params()["last"], "1");
    }
}
