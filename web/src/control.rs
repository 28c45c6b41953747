//! The Control and Settings pages' logic as plain types, so the pages only wire it:
//!
//! - [`PlanVerdicts`]: the bandwidth verdict of each show in the playlist, fetched
//!   again in rounds; an answer from an older round (the playlist or the link changed
//!   meanwhile) is dropped;
//! - [`Panel`]: which panel under the icons is open, and what an edit of the checked
//!   entries needs first ([`needs_checks`]);
//! - [`TimingForm`]: the delay and cycles typed in the edit and settings forms;
//! - [`begin_save`] / [`settle_save`]: an edit is applied to the playlist, stored on
//!   the bridge, and the bridge's answer taken; a refusal leaves the edit to be rolled
//!   back by fetching the bridge's playlist again;
//! - what the matrix's state allows: the playlist is locked while it runs
//!   ([`edit_lock`], as the bridge refuses such edits with `playlist_locked`), Start
//!   says why it cannot be pressed ([`start_block`]), and Reset, Home and a Start
//!   after an E-stop ask for a one-tap confirmation that says what will move
//!   ([`Action`]); the E-stop never asks;
//! - where Start and Reset begin ([`start_from`]): an entry and a time inside its
//!   show, typed beside Start ("play from anywhere").

use floatball_shared::api::{
    ApiError, ClientMessage, PlayerState, Playlist, PlaylistEntry, StartFrom,
};
use floatball_shared::codes::Code;

use crate::client::Failure;
use crate::i18n::Text;
use crate::playlist::{
    InputError, PlaylistEditor, Verdict, can_start, format_delay_s, parse_cycles, parse_delay_s,
};

/// One round of plan fetches: answers carry it back so that late ones are known.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Round(u32);

/// The verdict of each show of the playlist, as fetched in the latest round.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlanVerdicts {
    round: u32,
    verdicts: Vec<(String, Verdict)>,
}

impl PlanVerdicts {
    /// Starts a new round for `shows`: each pending, or none at all while the bridge
    /// cannot be asked. Returns the round to fetch in, if any.
    pub fn begin(&mut self, shows: &[String], can_ask: bool) -> Option<Round> {
        self.round = self.round.wrapping_add(1);
        if !can_ask {
            self.verdicts.clear();
            return None;
        }
        self.verdicts = shows
            .iter()
            .map(|show| (show.clone(), Verdict::Pending))
            .collect();
        Some(Round(self.round))
    }

    /// Takes the answer for `show` fetched in `round`; returns whether it was used
    /// (not when a later round has begun since).
    pub fn answer(&mut self, round: Round, show: &str, verdict: Verdict) -> bool {
        if round != Round(self.round) {
            return false;
        }
        match self.verdicts.iter_mut().find(|(name, _)| name == show) {
            Some(slot) => {
                slot.1 = verdict;
                true
            }
            None => false,
        }
    }

    /// Each show with its verdict, in playlist order.
    pub fn verdicts(&self) -> &[(String, Verdict)] {
        &self.verdicts
    }

    /// Whether there is nothing to show.
    pub fn is_empty(&self) -> bool {
        self.verdicts.is_empty()
    }

    /// Whether Start may be pressed for `editor`'s playlist (see [`can_start`]).
    pub fn allow_start(&self, editor: &PlaylistEditor) -> bool {
        can_start(editor, &self.verdicts)
    }
}

/// Which panel under the icons is open.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Panel {
    /// None.
    None,
    /// Pick a controller file to append.
    Add,
    /// Delay and cycles of the checked entries.
    Edit,
}

impl Panel {
    /// The panel open after `which`'s icon is pressed with `checked` entries checked:
    /// pressed again it closes; Edit wants a checked entry first.
    ///
    /// # Errors
    /// [`Text::CheckFirst`] for Edit with nothing checked (the panel stays).
    pub fn pressed(self, which: Panel, checked: usize) -> Result<Panel, Text> {
        if which == Panel::Edit {
            needs_checks(checked)?;
        }
        Ok(if self == which { Panel::None } else { which })
    }
}

/// Whether an edit of the checked entries (move, delete, edit) may go.
///
/// # Errors
/// [`Text::CheckFirst`] when no entry is checked.
pub fn needs_checks(checked: usize) -> Result<(), Text> {
    if checked == 0 {
        Err(Text::CheckFirst)
    } else {
        Ok(())
    }
}

/// A delay and a number of cycles, read from a form.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// The delay before the show, ms.
    pub delay_ms: u64,
    /// How many times it plays.
    pub cycles: u32,
}

/// The delay (in seconds) and cycles as typed in a form.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TimingForm {
    /// The delay, seconds, as typed.
    pub delay_s: String,
    /// The cycles, as typed.
    pub cycles: String,
}

impl TimingForm {
    /// The edit form for the first checked entry (0 s, once without one).
    pub fn of_entry(entry: Option<&PlaylistEntry>) -> Self {
        Self {
            delay_s: entry.map_or_else(|| "0".to_owned(), |entry| format_delay_s(entry.delay_ms)),
            cycles: entry.map_or_else(|| "1".to_owned(), |entry| entry.cycles.to_string()),
        }
    }

    /// The settings form for `playlist`'s defaults.
    pub fn defaults_of(playlist: &Playlist) -> Self {
        Self {
            delay_s: format_delay_s(playlist.default_delay_ms),
            cycles: playlist.default_cycles.to_string(),
        }
    }

    /// Reads the form; the delay is checked first.
    ///
    /// # Errors
    /// The first field that cannot be used.
    pub fn parse(delay_s: &str, cycles: &str) -> Result<Timing, InputError> {
        Ok(Timing {
            delay_ms: parse_delay_s(delay_s)?,
            cycles: parse_cycles(cycles)?,
        })
    }
}

/// Applies `edit` (which says whether it changed anything) to `editor`; returns the
/// playlist to store on the bridge, or `None` when nothing changed.
pub fn begin_save(
    editor: &mut PlaylistEditor,
    edit: impl FnOnce(&mut PlaylistEditor) -> bool,
) -> Option<Playlist> {
    edit(editor).then(|| editor.playlist().clone())
}

/// Takes the bridge's answer to a save: the playlist it stored replaces the edited
/// one.
///
/// # Errors
/// The failure, unchanged, when the bridge did not store it: the editor keeps the
/// edit until the caller fetches the bridge's playlist again (the roll-back).
pub fn settle_save(
    editor: &mut PlaylistEditor,
    answer: Result<Playlist, Failure>,
) -> Result<(), Failure> {
    editor.replace(answer?);
    Ok(())
}

/// Whether `failure` is the bridge's `playlist_locked` refusal (409): the matrix
/// started running meanwhile; the page then says so in its own words.
pub fn is_locked_refusal(failure: &Failure) -> bool {
    let code = Code::PlaylistLocked.as_str();
    match failure {
        Failure::Rejected(error) => error.code == code,
        Failure::Unexpected { status: 409, body } => {
            crate::json::from_str::<ApiError>(body).is_ok_and(|error| error.code == code)
        }
        _ => false,
    }
}

/// Whether the matrix runs the playlist or moves its balls in `state`: a show waits,
/// approaches, loads or plays, or the balls home. The bridge locks the playlist's
/// entries then.
pub fn is_running(state: Option<PlayerState>) -> bool {
    matches!(
        state,
        Some(
            PlayerState::Waiting
                | PlayerState::Approaching
                | PlayerState::Loading
                | PlayerState::Playing
                | PlayerState::Homing
        )
    )
}

/// Why the playlist's entries cannot be edited (add, move, delete, edit) in `state`,
/// if they cannot: while the matrix runs. Checking entries stays possible.
pub fn edit_lock(state: Option<PlayerState>) -> Option<Text> {
    is_running(state).then_some(Text::PlaylistLocked)
}

/// Why Start cannot be pressed, if it cannot: no link to the bridge, the matrix runs,
/// the playlist is empty, or a show cannot run (`allowed` is
/// [`PlanVerdicts::allow_start`]'s answer).
pub fn start_block(connected: bool, state: Option<PlayerState>, allowed: bool) -> Option<Text> {
    if !connected {
        Some(Text::StartNeedsConnection)
    } else if is_running(state) {
        Some(Text::StartWhileRunning)
    } else if !allowed {
        Some(Text::StartNeedsPlayableList)
    } else {
        None
    }
}

/// The name of a [`start_block`] reason in the page's `data-reason` (the variant's
/// name), spelled out so that the app carries no `Debug` names of every [`Text`].
pub fn start_reason_key(why: Text) -> &'static str {
    match why {
        Text::StartNeedsConnection => "StartNeedsConnection",
        Text::StartWhileRunning => "StartWhileRunning",
        Text::StartNeedsPlayableList => "StartNeedsPlayableList",
        _ => "Other",
    }
}

/// Where Start and Reset begin, as typed beside Start: `entry` 1-based (empty: the
/// first), `time` inside the entry's show as `m:ss`, `m:ss.s` or seconds (`90`,
/// `90.5`; empty: its start), to the millisecond. Nothing typed: the playlist's
/// start, as before.
///
/// # Errors
/// [`Text::BadStartFrom`]: an entry that is not a whole number from 1, or a time
/// that is not one of those forms.
pub fn start_from(entry: &str, time: &str) -> Result<StartFrom, Text> {
    let entry = entry.trim();
    let entry = if entry.is_empty() {
        None
    } else {
        match entry.parse::<usize>() {
            Ok(entry) if entry >= 1 => Some(entry),
            _ => return Err(Text::BadStartFrom),
        }
    };
    let time = time.trim();
    let time_ms = if time.is_empty() {
        None
    } else {
        let (minutes, seconds) = match time.split_once(':') {
            Some((minutes, seconds)) => (
                minutes
                    .trim()
                    .parse::<u64>()
                    .map_err(|_| Text::BadStartFrom)?,
                seconds.trim(),
            ),
            None => (0, time),
        };
        let seconds: f64 = seconds.parse().map_err(|_| Text::BadStartFrom)?;
        if !seconds.is_finite() || seconds < 0.0 || (time.contains(':') && seconds >= 60.0) {
            return Err(Text::BadStartFrom);
        }
        // Within a u64 of ms for any time a show can have.
        let ms = (seconds * 1000.0).round() as u64;
        Some(minutes.saturating_mul(60_000).saturating_add(ms)).filter(|&ms| ms > 0)
    };
    Ok(StartFrom { entry, time_ms })
}

/// A control button that moves the balls (the E-stop is not one: it never asks).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Play the playlist from its first entry.
    Start,
    /// Stop, home every ball, and play the playlist again.
    Reset,
    /// Stop, home every ball, and stay idle.
    Home,
}

impl Action {
    /// What the button sends.
    pub fn message(self) -> ClientMessage {
        self.message_from(StartFrom::default())
    }

    /// What the button sends when Start and Reset begin `from` (Home goes home).
    pub fn message_from(self, from: StartFrom) -> ClientMessage {
        match self {
            Action::Start => ClientMessage::Start(from),
            Action::Reset => ClientMessage::Reset(from),
            Action::Home => ClientMessage::Home,
        }
    }

    /// A word for tests and styling.
    pub fn key(self) -> &'static str {
        match self {
            Action::Start => "start",
            Action::Reset => "reset",
            Action::Home => "home",
        }
    }

    /// What the confirmation says will move, if this press needs one in `state`:
    /// Reset and Home always; Start only after an E-stop or an error (the balls home
    /// first, from wherever they stopped).
    pub fn confirmation(self, state: Option<PlayerState>) -> Option<Text> {
        match self {
            Action::Reset => Some(Text::ConfirmReset),
            Action::Home => Some(Text::ConfirmHome),
            Action::Start => matches!(state, Some(PlayerState::Stopped | PlayerState::Error))
                .then_some(Text::ConfirmStartAfterStop),
        }
    }
}

#[cfg(test)]
mod tests {
    use floatball_shared::api::PlanReport;
    use wasm_bindgen_test::wasm_bindgen_test;

    use super::*;

    fn report(feasible: bool) -> PlanReport {
        PlanReport {
            show: "a".into(),
            feasible,
            reason: None,
            fixes: Vec::new(),
            reason_problem: None,
            fix_problems: Vec::new(),
            preload_ms: 0,
            advice: Vec::new(),
            gateways: Vec::new(),
        }
    }

    fn shows(names: &[&str]) -> Vec<String> {
        names.iter().map(|name| (*name).to_owned()).collect()
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_round_starts_pending_and_takes_its_answers() {
        let mut plans = PlanVerdicts::default();
        let round = plans.begin(&shows(&["a", "b"]), true).expect("connected");
        assert_eq!(plans.verdicts().len(), 2);
        assert!(plans.verdicts().iter().all(|(_, v)| *v == Verdict::Pending));
        assert!(plans.answer(round, "b", Verdict::of(Some(report(false)))));
        assert!(!plans.answer(round, "unknown", Verdict::Unavailable));
        assert_eq!(plans.verdicts()[0], ("a".to_owned(), Verdict::Pending));
        assert_eq!(plans.verdicts()[1].1.key(), "infeasible");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_late_answer_of_an_older_round_is_dropped() {
        let mut plans = PlanVerdicts::default();
        let old = plans.begin(&shows(&["a"]), true).expect("connected");
        let new = plans.begin(&shows(&["a"]), true).expect("connected");
        assert_ne!(old, new);
        assert!(!plans.answer(old, "a", Verdict::Failed(Failure::NotFound)));
        assert_eq!(plans.verdicts()[0].1, Verdict::Pending);
        assert!(plans.answer(new, "a", Verdict::Unavailable));
        assert_eq!(plans.verdicts()[0].1, Verdict::Unavailable);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn without_the_bridge_there_are_no_verdicts_and_old_answers_stay_out() {
        let mut plans = PlanVerdicts::default();
        let round = plans.begin(&shows(&["a"]), true).expect("connected");
        assert_eq!(plans.begin(&shows(&["a"]), false), None);
        assert!(plans.is_empty());
        assert!(!plans.answer(round, "a", Verdict::Unavailable));
        assert!(plans.is_empty());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn start_waits_for_entries_and_is_blocked_by_an_infeasible_show() {
        let mut editor = PlaylistEditor::default();
        let mut plans = PlanVerdicts::default();
        assert!(!plans.allow_start(&editor), "empty playlist");
        editor.add("a");
        let round = plans.begin(&editor.shows(), true).expect("connected");
        assert!(plans.allow_start(&editor), "pending does not block");
        plans.answer(round, "a", Verdict::of(Some(report(false))));
        assert!(!plans.allow_start(&editor));
        let round = plans.begin(&editor.shows(), true).expect("connected");
        plans.answer(round, "a", Verdict::of(Some(report(true))));
        assert!(plans.allow_start(&editor));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn panels_toggle_and_edit_wants_a_checked_entry() {
        assert_eq!(Panel::None.pressed(Panel::Add, 0), Ok(Panel::Add));
        assert_eq!(Panel::Add.pressed(Panel::Add, 0), Ok(Panel::None));
        assert_eq!(Panel::Add.pressed(Panel::Edit, 0), Err(Text::CheckFirst));
        assert_eq!(Panel::Add.pressed(Panel::Edit, 2), Ok(Panel::Edit));
        assert_eq!(Panel::Edit.pressed(Panel::Edit, 1), Ok(Panel::None));
        assert_eq!(needs_checks(0), Err(Text::CheckFirst));
        assert_eq!(needs_checks(1), Ok(()));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_playlist_is_locked_and_start_blocked_while_the_matrix_runs() {
        let running = [
            PlayerState::Waiting,
            PlayerState::Approaching,
            PlayerState::Loading,
            PlayerState::Playing,
            PlayerState::Homing,
        ];
        for state in running {
            assert_eq!(edit_lock(Some(state)), Some(Text::PlaylistLocked));
            assert_eq!(
                start_block(true, Some(state), true),
                Some(Text::StartWhileRunning)
            );
        }
        for state in [PlayerState::Idle, PlayerState::Stopped, PlayerState::Error] {
            assert_eq!(edit_lock(Some(state)), None, "{state:?}");
            assert_eq!(start_block(true, Some(state), true), None, "{state:?}");
        }
        assert_eq!(edit_lock(None), None);
        assert_eq!(
            start_block(false, Some(PlayerState::Idle), true),
            Some(Text::StartNeedsConnection)
        );
        assert_eq!(
            start_block(true, Some(PlayerState::Idle), false),
            Some(Text::StartNeedsPlayableList)
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_bridges_lock_refusal_is_recognised() {
        let body = serde_json::to_string(&ApiError::coded(
            Code::PlaylistLocked,
            "the playlist cannot change while the matrix is playing",
        ))
        .unwrap();
        assert!(is_locked_refusal(&Failure::Unexpected {
            status: 409,
            body: body.clone()
        }));
        let error: ApiError = serde_json::from_str(&body).unwrap();
        assert!(is_locked_refusal(&Failure::Rejected(error)));
        assert!(!is_locked_refusal(&Failure::Unexpected {
            status: 409,
            body: r#"{"error":"\"a\" is in the playlist"}"#.into()
        }));
        assert!(!is_locked_refusal(&Failure::NotFound));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn reset_and_home_always_ask_and_start_only_after_a_stop() {
        for state in [None, Some(PlayerState::Idle), Some(PlayerState::Playing)] {
            assert_eq!(Action::Start.confirmation(state), None);
            assert_eq!(Action::Reset.confirmation(state), Some(Text::ConfirmReset));
            assert_eq!(Action::Home.confirmation(state), Some(Text::ConfirmHome));
        }
        for state in [PlayerState::Stopped, PlayerState::Error] {
            assert_eq!(
                Action::Start.confirmation(Some(state)),
                Some(Text::ConfirmStartAfterStop)
            );
        }
        assert_eq!(Action::Home.message(), ClientMessage::Home);
        assert_eq!(Action::Reset.message(), ClientMessage::reset());
        assert_eq!(Action::Start.message(), ClientMessage::start());
        assert_eq!(Action::Home.key(), "home");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn start_and_reset_begin_where_typed() {
        let from = |entry: &str, time: &str| start_from(entry, time);
        assert_eq!(from("", ""), Ok(StartFrom::default()));
        assert_eq!(from(" ", "0"), Ok(StartFrom::default()));
        assert_eq!(
            from("2", "1:30"),
            Ok(StartFrom {
                entry: Some(2),
                time_ms: Some(90_000)
            })
        );
        assert_eq!(from("", "90.25").unwrap().time_ms, Some(90_250));
        assert_eq!(from("", "0:02.5").unwrap().time_ms, Some(2_500));
        assert_eq!(from("1", "").unwrap().entry, Some(1));
        for (entry, time) in [
            ("0", ""),
            ("x", ""),
            ("", "1:75"),
            ("", "-3"),
            ("", "a:10"),
            ("", "1:"),
        ] {
            assert_eq!(
                from(entry, time),
                Err(Text::BadStartFrom),
                "{entry:?} {time:?}"
            );
        }
        let at = from("3", "12").unwrap();
        assert_eq!(Action::Start.message_from(at), ClientMessage::Start(at));
        assert_eq!(Action::Reset.message_from(at), ClientMessage::Reset(at));
        assert_eq!(Action::Home.message_from(at), ClientMessage::Home);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn forms_start_from_the_entry_or_the_defaults_and_read_back() {
        assert_eq!(
            TimingForm::of_entry(None),
            TimingForm {
                delay_s: "0".into(),
                cycles: "1".into()
            }
        );
        let entry = PlaylistEntry {
            show: "a".into(),
            delay_ms: 1500,
            cycles: 3,
            timecode_start: None,
        };
        let form = TimingForm::of_entry(Some(&entry));
        assert_eq!((form.delay_s.as_str(), form.cycles.as_str()), ("1.5", "3"));
        assert_eq!(
            TimingForm::parse(&form.delay_s, &form.cycles),
            Ok(Timing {
                delay_ms: 1500,
                cycles: 3
            })
        );
        let playlist = Playlist {
            default_delay_ms: 250,
            default_cycles: 2,
            ..Playlist::default()
        };
        let form = TimingForm::defaults_of(&playlist);
        assert_eq!((form.delay_s.as_str(), form.cycles.as_str()), ("0.25", "2"));
        assert_eq!(TimingForm::parse("x", "0"), Err(InputError::Delay));
        assert_eq!(TimingForm::parse("1,5", "0"), Err(InputError::Cycles));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_save_sends_only_a_change_and_takes_the_bridges_answer() {
        let mut editor = PlaylistEditor::default();
        assert_eq!(begin_save(&mut editor, PlaylistEditor::move_up), None);
        let sent = begin_save(&mut editor, |editor| {
            editor.add("a");
            true
        })
        .expect("changed");
        assert_eq!(sent.entries.len(), 1);
        assert_eq!(editor.playlist(), &sent);

        let mut stored = sent.clone();
        stored.entries[0].cycles = 7;
        assert_eq!(settle_save(&mut editor, Ok(stored.clone())), Ok(()));
        assert_eq!(editor.playlist(), &stored);

        begin_save(&mut editor, |editor| editor.delete_checked() > 0);
        editor.set_checked(0, true);
        begin_save(&mut editor, |editor| editor.delete_checked() > 0).expect("changed");
        assert_eq!(
            settle_save(&mut editor, Err(Failure::NotFound)),
            Err(Failure::NotFound)
        );
        assert!(editor.entries().is_empty(), "kept until fetched again");
    }
}
