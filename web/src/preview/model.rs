//! The preview's state as plain types, so that [`super::PreviewPage`] only wires it
//! to the page:
//!
//! - [`Clock`]: the time on screen: the controls' own [`Playback`], or the machine's
//!   [`LiveClock`] in live mode, advanced once per animation frame;
//! - [`ViewChoice`]: which renderer draws (3D unless the user chose the top view or
//!   WebGL2 failed), the ball selected, whether the performance panel is open.

use floatball_shared::api::Status;

use super::live::LiveClock;
use super::playback::Playback;
use super::stage::RendererKind;

/// The time on screen and what moves it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clock {
    playback: Playback,
    live: LiveClock,
    live_on: bool,
    /// When the last frame ran (local clock), ms.
    last_frame_ms: f64,
}

impl Clock {
    /// No show yet; the first frame comes after `now_ms`.
    pub fn new(now_ms: f64) -> Self {
        Self {
            playback: Playback::new(0),
            live: LiveClock::default(),
            live_on: false,
            last_frame_ms: now_ms,
        }
    }

    /// The controls' state.
    pub fn playback(&self) -> &Playback {
        &self.playback
    }

    /// The show time on screen, ms.
    pub fn t_ms(&self) -> f64 {
        self.playback.t_ms()
    }

    /// A new show of `duration_ms`: from its start, playing, at the same speed.
    pub fn for_show(&mut self, duration_ms: u64) {
        self.playback = self.playback.for_show(duration_ms);
    }

    /// A new show of `duration_ms` as [`Clock::for_show`], or, `from_ms` given,
    /// paused at that time (where a Start from there begins).
    pub fn for_show_from(&mut self, duration_ms: u64, from_ms: Option<u64>) {
        self.for_show(duration_ms);
        if let Some(from_ms) = from_ms {
            self.playback.follow(from_ms as f64);
        }
    }

    /// Takes the bridge's status (none while disconnected) that came at `now_ms` for
    /// the show named `name`: live mode is offered only while the matrix plays it, and
    /// ends when it stops.
    pub fn report(&mut self, status: Option<&Status>, name: Option<&str>, now_ms: f64) {
        self.live.report(status, name, now_ms);
        if !self.live.playing() {
            self.live_on = false;
        }
    }

    /// Whether live mode can be switched on.
    pub fn live_available(&self) -> bool {
        self.live.playing()
    }

    /// Whether the screen follows the machine.
    pub fn live_on(&self) -> bool {
        self.live_on
    }

    /// Switches live mode off, or on where it is available.
    pub fn toggle_live(&mut self) {
        self.live_on = !self.live_on && self.live_available();
    }

    /// A control pressed (restart, a step, play / pause, the slider): it acts on the
    /// own clock, which takes over from live mode.
    pub fn control(&mut self, action: impl FnOnce(&mut Playback)) {
        self.live_on = false;
        action(&mut self.playback);
    }

    /// Plays at `speed` times real time (live mode stays).
    pub fn set_speed(&mut self, speed: f64) {
        self.playback.set_speed(speed);
    }

    /// Stops the own clock (live mode stays).
    pub fn pause(&mut self) {
        self.playback.pause();
    }

    /// One animation frame at `now_ms`: in live mode the machine's time, otherwise
    /// the own clock runs on by the time since the last frame. Returns whether what
    /// the controls show changed.
    pub fn frame(&mut self, now_ms: f64) -> bool {
        let elapsed_ms = now_ms - self.last_frame_ms;
        self.last_frame_ms = now_ms;
        let before = self.playback;
        if self.live_on {
            if let Some(t_ms) = self.live.time_at(now_ms) {
                self.playback.follow(t_ms);
            }
        } else {
            self.playback.advance(elapsed_ms);
        }
        self.playback != before
    }
}

/// Which view the user asked for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// The 3D view (WebGL2).
    #[default]
    ThreeD,
    /// The 2D top view.
    Top,
}

/// How the show is looked at.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ViewChoice {
    mode: Mode,
    no_webgl: Option<String>,
    selected: Option<usize>,
    perf_open: bool,
}

impl ViewChoice {
    /// The view asked for.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Asks for `mode`.
    pub fn choose(&mut self, mode: Mode) {
        self.mode = mode;
    }

    /// The renderer that draws: 3D where asked for and WebGL2 works.
    pub fn renderer(&self) -> RendererKind {
        if self.mode == Mode::ThreeD && self.no_webgl.is_none() {
            RendererKind::WebGl2
        } else {
            RendererKind::TopView
        }
    }

    /// Takes note that WebGL2 cannot draw here (`why`): the top view draws from now on.
    pub fn webgl_failed(&mut self, why: String) {
        self.no_webgl = Some(why);
    }

    /// Whether 3D can be chosen.
    pub fn offers_3d(&self) -> bool {
        self.no_webgl.is_none()
    }

    /// Whether to say that 3D was asked for but cannot draw.
    pub fn explains_no_webgl(&self) -> bool {
        self.no_webgl.is_some() && self.mode == Mode::ThreeD
    }

    /// The ball selected (its plot is shown).
    pub fn selected(&self) -> Option<usize> {
        self.selected
    }

    /// Selects `unit` (a tap on a ball or beside the balls), or nothing.
    pub fn select(&mut self, unit: Option<usize>) {
        self.selected = unit;
    }

    /// Whether the performance panel is open.
    pub fn perf_open(&self) -> bool {
        self.perf_open
    }

    /// Opens or closes the performance panel; returns whether it is now open (then
    /// the show is paused, so that the measurements have the machine to themselves).
    pub fn toggle_perf(&mut self) -> bool {
        self.perf_open = !self.perf_open;
        self.perf_open
    }
}

#[cfg(test)]
mod tests {
    use floatball_shared::api::PlayerState;
    use wasm_bindgen_test::wasm_bindgen_test;

    use super::*;
    use crate::preview::live::tests::status;

    fn playing(show: &str, show_time_ms: u64) -> Status {
        status(PlayerState::Playing, show, show_time_ms)
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_own_clock_runs_by_the_time_between_frames() {
        let mut clock = Clock::new(1000.0);
        clock.for_show(10_000);
        assert!(clock.frame(1250.0));
        assert_eq!(clock.t_ms(), 250.0);
        clock.set_speed(2.0);
        clock.frame(1350.0);
        assert_eq!(clock.t_ms(), 450.0);
        clock.control(Playback::toggle);
        assert!(!clock.frame(2000.0), "paused: nothing changes");
        assert_eq!(clock.t_ms(), 450.0);
        clock.control(Playback::toggle);
        clock.frame(2100.0);
        assert_eq!(clock.t_ms(), 650.0, "the paused time does not count");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_new_show_starts_over_at_the_same_speed() {
        let mut clock = Clock::new(0.0);
        clock.for_show(5000);
        clock.set_speed(0.5);
        clock.frame(1000.0);
        clock.for_show(8000);
        assert_eq!(
            (clock.t_ms(), clock.playback().duration_ms()),
            (0.0, 8000.0)
        );
        assert_eq!(clock.playback().speed(), 0.5);
        assert!(clock.playback().playing());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn live_mode_follows_the_machine_until_a_control_takes_over() {
        let mut clock = Clock::new(0.0);
        clock.for_show(60_000);
        clock.toggle_live();
        assert!(!clock.live_on(), "not offered before the machine plays it");
        clock.report(Some(&playing("other", 3000)), Some("wave"), 0.0);
        assert!(!clock.live_available());
        clock.report(Some(&playing("wave", 3000)), Some("wave"), 0.0);
        assert!(clock.live_available());
        clock.toggle_live();
        assert!(clock.live_on());
        assert!(clock.frame(100.0));
        assert_eq!(clock.t_ms(), 3100.0);
        assert!(!clock.playback().playing(), "the own clock waits");
        clock.control(Playback::step_forward);
        assert!(!clock.live_on());
        assert_eq!(clock.t_ms(), 3600.0);
        clock.frame(900.0);
        assert_eq!(clock.t_ms(), 3600.0);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn live_mode_ends_when_the_machine_stops_but_speed_and_pause_keep_it() {
        let mut clock = Clock::new(0.0);
        clock.for_show(60_000);
        clock.report(Some(&playing("wave", 0)), Some("wave"), 0.0);
        clock.toggle_live();
        clock.set_speed(4.0);
        clock.pause();
        assert!(clock.live_on());
        clock.report(None, Some("wave"), 50.0);
        assert!(!clock.live_on() && !clock.live_available());
        clock.toggle_live();
        clock.toggle_live();
        assert!(!clock.live_on());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn three_d_draws_unless_the_top_view_is_chosen_or_webgl_fails() {
        let mut view = ViewChoice::default();
        assert_eq!(view.mode(), Mode::ThreeD);
        assert_eq!(view.renderer(), RendererKind::WebGl2);
        view.choose(Mode::Top);
        assert_eq!(view.renderer(), RendererKind::TopView);
        assert!(!view.explains_no_webgl());
        view.choose(Mode::ThreeD);
        view.webgl_failed("no context".into());
        assert_eq!(view.renderer(), RendererKind::TopView);
        assert!(!view.offers_3d());
        assert!(view.explains_no_webgl());
        view.choose(Mode::Top);
        assert!(!view.explains_no_webgl());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn selection_and_the_performance_panel() {
        let mut view = ViewChoice::default();
        assert_eq!(view.selected(), None);
        view.select(Some(3));
        assert_eq!(view.selected(), Some(3));
        view.select(None);
        assert_eq!(view.selected(), None);
        assert!(view.toggle_perf());
        assert!(view.perf_open());
        assert!(!view.toggle_perf());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_show_opened_from_a_start_time_waits_there() {
        let mut clock = Clock::new(0.0);
        clock.for_show_from(10_000, Some(2_500));
        assert_eq!(clock.t_ms(), 2_500.0);
        assert!(!clock.playback().playing());
        clock.for_show_from(2_000, Some(2_500));
        assert_eq!(clock.t_ms(), 2_000.0, "within the show");
        clock.for_show_from(10_000, None);
        assert_eq!(clock.t_ms(), 0.0);
        assert!(clock.playback().playing());
    }
}
