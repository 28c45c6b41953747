//! The preview's transport controls as a plain type: the vendor app's restart, step
//! back, pause / play and step forward (PROTOCOL §1.7), plus a time slider.

/// How far one step back or forward moves, ms.
pub const STEP_MS: f64 = 500.0;

/// Where the preview is in a show, and whether it runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Playback {
    t_ms: f64,
    duration_ms: f64,
    playing: bool,
}

impl Playback {
    /// At the start of a show of `duration_ms`, playing.
    pub fn new(duration_ms: u64) -> Self {
        Self {
            t_ms: 0.0,
            duration_ms: duration_ms as f64,
            playing: true,
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

    /// Lets `elapsed_ms` of real time pass; at the end the preview stops there.
    pub fn advance(&mut self, elapsed_ms: f64) {
        if !self.playing || !elapsed_ms.is_finite() || elapsed_ms <= 0.0 {
            return;
        }
        self.t_ms = (self.t_ms + elapsed_ms).min(self.duration_ms);
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

    #[test]
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

    #[test]
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

    #[test]
    fn toggle_pauses_resumes_and_starts_over_at_the_end() {
        let mut playback = Playback::new(1000);
        playback.advance(300.0);
        playback.toggle();
        assert!(!playback.playing());
        playback.toggle();
        assert!(playback.playing());
        assert_eq!(playback.t_ms(), 300.0);
        playback.advance(5000.0);
        playback.toggle();
        assert!(playback.playing());
        assert_eq!(playback.t_ms(), 0.0);
    }

    #[test]
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
