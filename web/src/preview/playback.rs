//! The preview's transport controls as a plain type: the vendor app's restart, step
//! back, pause / play and step forward (`docs/uim2503.md` §4), plus a time slider and the
//! playback speed.

/// How far one step back or forward moves, ms.
pub const STEP_MS: f64 = 500.0;

/// The speeds offered, as multiples of real time.
pub const SPEEDS: [f64; 5] = [0.25, 0.5, 1.0, 2.0, 4.0];

/// Where the preview is in a show, and whether it runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Playback {
    t_ms: f64,
    duration_ms: f64,
    playing: bool,
    speed: f64,
}

impl Playback {
    /// At the start of a show of `duration_ms`, playing in real time.
    pub fn new(duration_ms: u64) -> Self {
        Self {
            t_ms: 0.0,
            duration_ms: duration_ms as f64,
            playing: true,
            speed: 1.0,
        }
    }

    /// The same place and speed in another show of `duration_ms`, from its start.
    pub fn for_show(self, duration_ms: u64) -> Self {
        Self {
            speed: self.speed,
            ..Self::new(duration_ms)
        }
    }

    /// The show time, ms.
    pub fn t_ms(&self) -> f64 {
        self.t_ms
    }

    /// The show's length, ms.
    pub fn duration_ms(&self) -> f64 {
        self.duration_ms
    }

    /// Whether time runs.
    pub fn playing(&self) -> bool {
        self.playing
    }

    /// How many show ms pass in one ms of real time.
    pub fn speed(&self) -> f64 {
        self.speed
    }

    /// Plays at `speed` times real time (ignored unless positive and finite).
    pub fn set_speed(&mut self, speed: f64) {
        if speed.is_finite() && speed > 0.0 {
            self.speed = speed;
        }
    }

    /// Lets `elapsed_ms` of real time pass (at the speed set); at the end the preview
    /// stops there.
    pub fn advance(&mut self, elapsed_ms: f64) {
        if !self.playing || !elapsed_ms.is_finite() || elapsed_ms <= 0.0 {
            return;
        }
        self.t_ms = (self.t_ms + elapsed_ms * self.speed).min(self.duration_ms);
        if self.t_ms >= self.duration_ms {
            self.playing = false;
        }
    }

    /// Back to the start, playing.
    pub fn restart(&mut self) {
        self.t_ms = 0.0;
        self.playing = true;
    }

    /// One step back, paused.
    pub fn step_back(&mut self) {
        self.seek(self.t_ms - STEP_MS);
        self.playing = false;
    }

    /// One step forward, paused.
    pub fn step_forward(&mut self) {
        self.seek(self.t_ms + STEP_MS);
        self.playing = false;
    }

    /// Stops the clock where it is.
    pub fn pause(&mut self) {
        self.playing = false;
    }

    /// Pause, or play; at the end, play starts over.
    pub fn toggle(&mut self) {
        if self.playing {
            self.playing = false;
        } else {
            if self.t_ms >= self.duration_ms {
                self.t_ms = 0.0;
            }
            self.playing = true;
        }
    }

    /// Follows a time given from outside (the machine's, in live mode): there, and
    /// paused so that the preview's own clock does not run as well.
    pub fn follow(&mut self, t_ms: f64) {
        self.seek(t_ms);
        self.playing = false;
    }

    /// Jumps to `t_ms` (clamped to the show).
    pub fn seek(&mut self, t_ms: f64) {
        self.t_ms = if t_ms.is_finite() {
            t_ms.clamp(0.0, self.duration_ms)
        } else {
            0.0
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    #[wasm_bindgen_test(unsupported = test)]
    fn plays_to_the_end_and_stops_there() {
        let mut playback = Playback::new(1000);
        assert!(playback.playing());
        playback.advance(400.0);
        assert_eq!(playback.t_ms(), 400.0);
        playback.advance(f64::NAN);
        playback.advance(-5.0);
        assert_eq!(playback.t_ms(), 400.0);
        playback.advance(900.0);
        assert_eq!(playback.t_ms(), 1000.0);
        assert!(!playback.playing());
        playback.advance(100.0);
        assert_eq!(playback.t_ms(), 1000.0);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn steps_pause_and_stay_inside_the_show() {
        let mut playback = Playback::new(1200);
        playback.step_forward();
        assert!(!playback.playing());
        assert_eq!(playback.t_ms(), STEP_MS);
        playback.step_forward();
        playback.step_forward();
        assert_eq!(playback.t_ms(), 1200.0);
        playback.step_back();
        assert_eq!(playback.t_ms(), 1200.0 - STEP_MS);
        playback.seek(100.0);
        playback.step_back();
        assert_eq!(playback.t_ms(), 0.0);
        playback.advance(100.0);
        assert_eq!(playback.t_ms(), 0.0, "paused");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn toggle_pauses_resumes_and_starts_over_at_the_end() {
        let mut playback = Playback::new(1000);
        playback.advance(300.0);
        playback.toggle();
        assert!(!playback.playing());
        playback.toggle();
        assert!(playback.playing());
        assert_eq!(playback.t_ms(), 300.0);
        playback.pause();
        playback.pause();
        assert!(!playback.playing());
        playback.toggle();
        playback.advance(5000.0);
        playback.toggle();
        assert!(playback.playing());
        assert_eq!(playback.t_ms(), 0.0);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn speed_scales_time_and_survives_a_new_show() {
        let mut playback = Playback::new(10_000);
        playback.set_speed(4.0);
        playback.advance(250.0);
        assert_eq!(playback.t_ms(), 1000.0);
        playback.set_speed(0.0);
        playback.set_speed(f64::INFINITY);
        assert_eq!(playback.speed(), 4.0);
        playback.set_speed(0.25);
        playback.advance(400.0);
        assert_eq!(playback.t_ms(), 1100.0);
        let next = playback.for_show(2000);
        assert_eq!(
            (next.t_ms(), next.duration_ms(), next.speed()),
            (0.0, 2000.0, 0.25)
        );
        assert!(SPEEDS.contains(&1.0));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn following_pauses_the_own_clock() {
        let mut playback = Playback::new(10_000);
        playback.follow(2500.0);
        assert_eq!((playback.t_ms(), playback.playing()), (2500.0, false));
        playback.advance(100.0);
        assert_eq!(playback.t_ms(), 2500.0);
        playback.follow(1e12);
        assert_eq!(playback.t_ms(), 10_000.0);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn restart_and_seek() {
        let mut playback = Playback::new(1000);
        playback.seek(700.0);
        assert_eq!(playback.t_ms(), 700.0);
        playback.seek(5000.0);
        assert_eq!(playback.t_ms(), 1000.0);
        playback.seek(f64::NAN);
        assert_eq!(playback.t_ms(), 0.0);
        playback.seek(600.0);
        playback.toggle();
        playback.restart();
        assert_eq!((playback.t_ms(), playback.playing()), (0.0, true));
    }
}
