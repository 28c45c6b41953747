//! Start, Reset and Home as the WebSocket asks for them: the stored playlist, its shows
//! read from the store (on a blocking thread), handed to the player with the e-stop
//! generation the request was issued at. Every refusal comes back as a coded
//! [`ServerMessage::Error`]: its code and parameters (which entry, why, and what would
//! make it run — why and the fixes also as coded problems) and the same as an English
//! sentence.

use floatball_shared::api::{ServerMessage, StartFrom};
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::params;
use floatball_shared::player::{Entry, StartError};

use crate::playback::{At, Begin, PlaybackError, Playlist, PlaylistKey};
use crate::playlist;
use crate::state::AppState;
use crate::store::ShowName;

/// How long a taken Start or Reset keeps the playlist locked while waiting for the
/// status to show the run (it is published within a player turn, 10 ms, normally).
const RUN_SHOWN_WITHIN: std::time::Duration = std::time::Duration::from_secs(2);

/// What the operator asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// Play the playlist from its first entry, or from where [`StartFrom`] says
    /// (homing first after an e-stop).
    Start(StartFrom),
    /// Stop, home, and play the playlist from its first entry, or from where
    /// [`StartFrom`] says.
    Reset(StartFrom),
    /// Stop, home, and stay idle.
    Home,
    /// A locate (the timecode jumped): the show under way ends without an e-stop,
    /// and the balls go from where they are to where [`StartFrom`] says, and play on
    /// from there; as a Start when nothing runs.
    Locate(StartFrom),
}

/// The stored playlist with its shows, and its loop flag.
///
/// # Errors
/// A show the playlist names cannot be read.
pub fn playlist_entries(state: &AppState) -> Result<(Vec<Entry>, bool), ServerMessage> {
    let playlist = state.playlist().get();
    let mut entries = Vec::with_capacity(playlist.entries.len());
    for (index, entry) in playlist.entries.iter().enumerate() {
        let show = ShowName::parse(&entry.show)
            .map_err(|error| error.to_string())
            .and_then(|name| state.shows().load(&name).map_err(|error| error.to_string()))
            .map_err(|reason| {
                ServerMessage::from_template(
                    Code::EntryUnreadable,
                    params! {"entry" => index + 1, "show" => entry.show, "reason" => reason},
                )
            })?;
        entries.push(Entry {
            show,
            delay_ms: entry.delay_ms,
            cycles: entry.cycles.max(1),
        });
    }
    Ok((entries, playlist.loop_playlist))
}

/// The key of the stored playlist ([`PlaylistKey`]: its shows by name and the SHA-256
/// of their files, delays, cycles, loop flag); `None` when a show it names is not
/// stored. Cheap: the store keeps every show's summary in memory.
pub fn playlist_key(state: &AppState) -> Option<PlaylistKey> {
    let playlist = state.playlist().get();
    let shows = state.shows().list();
    let entries = playlist
        .entries
        .iter()
        .map(|entry| {
            let summary = shows.iter().find(|summary| summary.name == entry.show)?;
            Some((
                entry.show.clone(),
                summary.sha256.clone(),
                entry.delay_ms,
                entry.cycles.max(1),
            ))
        })
        .collect::<Option<Vec<_>>>()?;
    Some(PlaylistKey::new(entries, playlist.loop_playlist))
}

/// The stored playlist for Start, Reset or the armer: the one prepared last when it is
/// what is stored now (nothing read nor planned again), else read from the store on
/// a blocking thread and, for UIM2503 gateways, planned on the same thread and kept
/// under its key, taken before reading and kept only if the same after (a show
/// replaced meanwhile is planned again next time).
///
/// # Errors
/// A show the playlist names cannot be read.
pub async fn playlist(state: &AppState) -> Result<Playlist, ServerMessage> {
    let key = playlist_key(state);
    if let Some(prepared) = key
        .as_ref()
        .and_then(|key| state.playback().prepared_for(key))
    {
        return Ok(Playlist::Prepared(prepared));
    }
    let reading = state.clone();
    tokio::task::spawn_blocking(move || {
        let (entries, loop_playlist) = playlist_entries(&reading)?;
        let key = key.filter(|key| playlist_key(&reading).as_ref() == Some(key));
        let playback = reading.playback();
        Ok(if playback.plans_lines() {
            // Planned here, on the thread that read the shows (see `Playlist::Planned`).
            Playlist::Planned(playback.prepare_blocking(entries, loop_playlist, key))
        } else {
            Playlist::Read {
                entries,
                loop_playlist,
                key,
            }
        })
    })
    .await
    .map_err(|error| {
        ServerMessage::error(
            Code::Internal,
            format!("the playlist cannot be read: {error}"),
            params! {"what" => "the playlist cannot be read"},
        )
    })?
}

/// Takes `control` as it arrives, from any client (the WebSocket, OSC): checked first
/// ([`check`]: a request that will be refused has no effect at all), then Reset and
/// Home press the e-stop at once ([`crate::playback::Playback::estop`]), and every
/// request is tagged now with the e-stop generation, so that an e-stop arriving after
/// it voids it even while it is being prepared. Returns the rest of the work, for the
/// caller to spawn: [`run`] at that generation.
///
/// A Reset to a time inside a show is the one request whose check needs the show
/// itself (where its cut can start): its stop is pressed once the cut is known to
/// start, unless an e-stop came meanwhile (then it is refused as superseded).
///
/// # Errors
/// The refusal [`check`] found: nothing was stopped, latched or homed.
pub fn issue(
    state: &AppState,
    control: Control,
) -> Result<
    impl std::future::Future<Output = Result<(), ServerMessage>> + Send + 'static,
    ServerMessage,
> {
    check(state, control)?;
    let cut_first = reset_inside_a_show(control);
    if stops_first(control) && cut_first.is_none() {
        state.playback().estop();
    }
    let generation = state.playback().latch().generation();
    let state = state.clone();
    Ok(async move {
        let generation = match cut_first {
            None => generation,
            Some(from) => {
                begin_at(&state, from).await?;
                let playback = state.playback();
                if playback.latch().generation() != generation {
                    return Err(refusal(&PlaybackError::Refused(StartError::Superseded)));
                }
                playback.estop();
                playback.latch().generation()
            }
        };
        run(&state, control, generation).await
    })
}

/// Whether `control` stops the matrix before it does anything else (Reset, Home).
fn stops_first(control: Control) -> bool {
    matches!(control, Control::Reset(_) | Control::Home)
}

/// Where a Reset begins when that is a time inside a show: its stop waits for the
/// cut to be known to start ([`issue`]).
fn reset_inside_a_show(control: Control) -> Option<StartFrom> {
    match control {
        Control::Reset(from) if from.time_ms.is_some_and(|time_ms| time_ms > 0) => Some(from),
        _ => None,
    }
}

/// Checks `control` against the stored playlist before it has any effect (issue 52):
/// a Start, Reset, goto or locate at an entry the playlist lacks, at a time at or past
/// its show's end (by the show's stored length), from a time on drives that cannot
/// start inside a show, or on an empty playlist is refused here, so that its Reset
/// never stops the matrix nor latches the e-stop. Home has nothing to check. Cheap: the
/// playlist and the shows' summaries are in memory.
///
/// # Errors
/// The refusal, coded as [`run`] would have refused it.
pub fn check(state: &AppState, control: Control) -> Result<(), ServerMessage> {
    let (Control::Start(from) | Control::Reset(from) | Control::Locate(from)) = control else {
        return Ok(());
    };
    let (entry, show) = named_entry(state, from)?;
    let time_ms = from.time_ms.unwrap_or(0);
    if time_ms == 0 {
        return Ok(());
    }
    let shows = state.shows().list();
    let Some(summary) = shows.iter().find(|summary| summary.name == show) else {
        return Err(ServerMessage::from_template(
            Code::EntryUnreadable,
            params! {"entry" => entry, "show" => show, "reason" => "the show is not stored"},
        ));
    };
    if time_ms >= summary.duration_ms {
        return Err(refusal(&PlaybackError::Refused(StartError::PastTheEnd {
            entry,
            time_ms,
            duration_ms: summary.duration_ms,
        })));
    }
    Ok(())
}

/// The entry `from` names (1-based) and its show's name, from the stored playlist;
/// for a start from a time inside it, the family must be able to start there.
///
/// # Errors
/// An empty playlist, an entry it lacks, a family that cannot start inside a show.
fn named_entry(state: &AppState, from: StartFrom) -> Result<(usize, String), ServerMessage> {
    let refused = |error: StartError| refusal(&PlaybackError::Refused(error));
    let playlist = state.playlist().get();
    let entries = playlist.entries.len();
    let entry = from.entry.unwrap_or(1);
    let Some(named) = entry
        .checked_sub(1)
        .and_then(|index| playlist.entries.get(index))
    else {
        return Err(refused(if entries == 0 {
            StartError::Empty
        } else {
            StartError::NoSuchEntry { entry, entries }
        }));
    };
    if from.time_ms.unwrap_or(0) > 0 && !state.playback().cuts() {
        return Err(refused(StartError::NoCut { entry }));
    }
    Ok((entry, named.show.clone()))
}

/// Why a request from a source that may not release an e-stop was not issued
/// ([`issue_unless_latched`]); nothing was stopped, latched or homed.
#[derive(Debug, Clone, PartialEq)]
pub enum NotIssued {
    /// The e-stop is latched, or was pressed as the request was issued.
    Latched,
    /// The request will be refused ([`check`]): the refusal.
    Refused(Box<ServerMessage>),
}

impl std::fmt::Display for NotIssued {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Latched => Latched.fmt(f),
            Self::Refused(refusal) => f.write_str(&reason((**refusal).clone())),
        }
    }
}

/// An e-stop is latched (or was pressed as the request was issued): a source other
/// than an operator in the app may not release it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Latched;

impl std::fmt::Display for Latched {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(
            "the e-stop is latched: only an operator's Start, Reset or Home in the app \
             releases it",
        )
    }
}

/// [`issue`] for a source that must never release an e-stop — OSC, the schedule,
/// timecode: refused while one is latched, refused when [`check`] refuses it, and void
/// when one is pressed before the request is accepted
/// ([`crate::estop::unreleasing_generation`]: the generation is read before the latch
/// is looked at, and an e-stop pressed with a Reset's or Home's own stop is seen).
///
/// # Errors
/// [`NotIssued`]: nothing was issued, stopped, latched or homed.
pub fn issue_unless_latched(
    state: &AppState,
    control: Control,
) -> Result<impl std::future::Future<Output = Result<(), ServerMessage>> + Send + 'static, NotIssued>
{
    let playback = state.playback();
    if playback.latch().is_latched() {
        return Err(NotIssued::Latched);
    }
    check(state, control).map_err(|refusal| NotIssued::Refused(Box::new(refusal)))?;
    let cut_first = reset_inside_a_show(control);
    let stop = || {
        playback.estop();
    };
    let own_stop: Option<&dyn Fn()> = if stops_first(control) && cut_first.is_none() {
        Some(&stop)
    } else {
        None
    };
    let generation = crate::estop::unreleasing_generation(playback.latch(), own_stop)
        .ok_or(NotIssued::Latched)?;
    let state = state.clone();
    Ok(async move {
        let generation = match cut_first {
            None => generation,
            Some(from) => {
                begin_at(&state, from).await?;
                let playback = state.playback();
                let superseded = || refusal(&PlaybackError::Refused(StartError::Superseded));
                if playback.latch().generation() != generation {
                    return Err(superseded());
                }
                let stop = || {
                    playback.estop();
                };
                crate::estop::unreleasing_generation(playback.latch(), Some(&stop))
                    .ok_or_else(superseded)?
            }
        };
        run(&state, control, generation).await
    })
}

/// Why a request was refused, in English, for a source's log or outcome (the
/// schedule, timecode): the error's message, or the answer itself when it is not an
/// error.
#[must_use]
pub fn reason(refusal: ServerMessage) -> String {
    match refusal {
        ServerMessage::Error { message, .. } => message,
        other => format!("{other:?}"),
    }
}

/// Carries out `control`, a request issued at e-stop `generation` (for Reset and
/// Home, after their own stop was pressed).
///
/// # Errors
/// Why the matrix did not start, as the [`ServerMessage::Error`] to send: a code, its
/// parameters and the English words (it did not move; after a refused Reset or Home it
/// stays stopped).
pub async fn run(state: &AppState, control: Control, generation: u64) -> Result<(), ServerMessage> {
    let playback = state.playback();
    let result = match control {
        Control::Home => playback.home_issued(generation).await,
        Control::Start(from) | Control::Reset(from) | Control::Locate(from) => {
            // The playlist is locked from this read on (PUT /api/playlist).
            let _pending = state.start_pending().await;
            let at = begin_at(state, from).await?;
            let playlist = playlist(state).await?;
            let mut status = state.subscribe_status();
            let begin = match control {
                Control::Reset(_) => Begin::Reset,
                Control::Locate(_) => Begin::Locate,
                _ => Begin::Start,
            };
            let taken = playback.play_at(playlist, at, generation, begin).await;
            if taken.is_ok() {
                // The player answers before its next status is out (MOONS' drives
                // report through their own task): the playlist stays locked until
                // the status shows the run, or a moment has passed.
                let _ = tokio::time::timeout(
                    RUN_SHOWN_WITHIN,
                    status.wait_for(|status| playlist::locked(status.state)),
                )
                .await;
            }
            taken
        }
    };
    result.map_err(|error| refusal(&error))
}

/// The acceleration of a start's run-ups from inside an entry (the cut the player
/// plays, [`floatball_shared::show::Show::from_time`]): half the installation's top
/// acceleration, mm/s². The timecode lead's estimate of a table's preload cuts the
/// show with it too, so it plans the rows the player will send.
pub fn run_up_accel_mm_s2(installation: &floatball_shared::plan::Installation) -> f64 {
    installation.limits.max_accel_mm_s2 / 2.0
}

/// Where a Start or Reset begins ([`StartFrom`], its entry 1-based): the entry
/// (0-based) and, for a time inside it, its show cut there (read from the store and
/// cut on a blocking thread; the run-ups at half the installation's top
/// acceleration), for [`crate::playback::Playback::play_at`]. The one way any
/// request names a start inside the playlist (the WebSocket's Start and Reset now;
/// a timecode locate or an OSC start later).
///
/// # Errors
/// An entry the playlist lacks, a time at or past its show's end, a show that cannot
/// be read, a family that cannot start inside a show.
pub async fn begin_at(state: &AppState, from: StartFrom) -> Result<At, ServerMessage> {
    let refused = |error: StartError| refusal(&PlaybackError::Refused(error));
    let (entry, name) = named_entry(state, from)?;
    let time_ms = from.time_ms.unwrap_or(0);
    if time_ms == 0 {
        return Ok(At {
            entry: entry - 1,
            cut: None,
        });
    }
    let reading = state.clone();
    let accel_mm_s2 = run_up_accel_mm_s2(&state.playback().installation());
    let cut = tokio::task::spawn_blocking(move || {
        let show = ShowName::parse(&name)
            .map_err(|error| error.to_string())
            .and_then(|parsed| {
                reading
                    .shows()
                    .load(&parsed)
                    .map_err(|error| error.to_string())
            })
            .map_err(|reason| {
                ServerMessage::from_template(
                    Code::EntryUnreadable,
                    params! {"entry" => entry, "show" => name, "reason" => reason},
                )
            })?;
        show.from_time(time_ms, accel_mm_s2).ok_or_else(|| {
            refused(StartError::PastTheEnd {
                entry,
                time_ms,
                duration_ms: show.duration_ms(),
            })
        })
    })
    .await
    .map_err(|error| {
        ServerMessage::error(
            Code::Internal,
            format!("the show cannot be read: {error}"),
            params! {"what" => "the show cannot be read"},
        )
    })??;
    Ok(At {
        entry: entry - 1,
        cut: Some(cut),
    })
}

fn describe(error: &PlaybackError) -> String {
    match error {
        PlaybackError::Refused(refused @ StartError::Infeasible { fixes, .. })
            if !fixes.is_empty() =>
        {
            format!(
                "{error}. To make it run: {}",
                refused.fix_sentences().join("; ")
            )
        }
        other => other.to_string(),
    }
}

/// The refusal of a request the player did not carry out, with why an entry cannot
/// run and what would make it run also as coded problems.
fn refusal(error: &PlaybackError) -> ServerMessage {
    match error {
        PlaybackError::Refused(refused) => {
            ServerMessage::error(refused.code(), describe(error), refused.params())
                .with_problems(refused.reason_problem(), refused.fix_problems())
        }
        PlaybackError::Gone => {
            ServerMessage::error(Code::PlayerGone, describe(error), Params::new())
        }
    }
}
