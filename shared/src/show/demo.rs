//! The demo show: a travelling sine wave across the matrix, the one generated show the
//! tests, benches and examples share. [`wave`] gives the standard one; [`Wave`] sets
//! its depth, swing, period and how the phase travels.
//!
//! Every ball starts at rest where its wave starts, moves in rows of a fixed length and
//! ends its last row at rest. Positions and velocities are rounded to 0.1 mm (mm/s), as a
//! show file would hold them, unless [`Wave::tenths`] is off.
//!
//! ```
//! use floatball_shared::show::demo::{Wave, wave};
//!
//! let show = wave(2, 3, 20, 200); // 2 × 3 balls, 20 rows of 200 ms
//! assert_eq!(show.tracks.len(), 6);
//! assert_eq!(show.duration_ms(), 4000);
//! let deep = Wave { amplitude_mm: 1500.0, period_s: 8.0, ..Wave::new(2, 3, 20, 200) }.show();
//! assert_ne!(deep, show);
//! ```

use std::f64::consts::TAU;

use super::{Layout, Show, Track, TrackRow};

/// A travelling sine wave: every ball bobs `amplitude_mm` around `centre_mm` once every
/// `period_s`, its phase `col_phase` radians on from the ball to its left and
/// `row_phase` from the ball above.
#[derive(Debug, Clone, PartialEq)]
pub struct Wave {
    /// Rows of balls.
    pub rows: u32,
    /// Columns of balls.
    pub cols: u32,
    /// PVT rows per ball.
    pub rows_per_ball: usize,
    /// Every PVT row's length, ms.
    pub row_ms: u32,
    /// The middle of the swing, mm below the top.
    pub centre_mm: f64,
    /// Half the swing, mm.
    pub amplitude_mm: f64,
    /// One wave every `period_s` seconds.
    pub period_s: f64,
    /// Phase from one column to the next, radians.
    pub col_phase: f64,
    /// Phase from one row to the next, radians.
    pub row_phase: f64,
    /// Round positions (mm) and velocities (mm/s) to a tenth, as a show file written
    /// with one decimal holds them; off, the exact sine.
    pub tenths: bool,
}

impl Wave {
    /// The standard wave on a `rows` × `cols` matrix, `rows_per_ball` rows of `row_ms`:
    /// 0.5 m around 3 m, one wave every 4 s, 0.6 rad a column and 0.2 rad a row
    /// (within 40 000 mm/s² from rest for rows of 100 ms or more), rounded to tenths.
    pub fn new(rows: u32, cols: u32, rows_per_ball: usize, row_ms: u32) -> Self {
        Self {
            rows,
            cols,
            rows_per_ball,
            row_ms,
            centre_mm: 3000.0,
            amplitude_mm: 500.0,
            period_s: 4.0,
            col_phase: 0.6,
            row_phase: 0.2,
            tenths: true,
        }
    }

    /// The show, named `wave`.
    pub fn show(&self) -> Show {
        let omega = TAU / self.period_s;
        let mut tracks = Vec::with_capacity(self.rows as usize * self.cols as usize);
        for row in 0..self.rows {
            for col in 0..self.cols {
                let phase = f64::from(col) * self.col_phase + f64::from(row) * self.row_phase;
                let at =
                    |t_s: f64| self.centre_mm + self.amplitude_mm * (omega * t_s + phase).sin();
                let speed = |t_s: f64| self.amplitude_mm * omega * (omega * t_s + phase).cos();
                let round = |value: f64| if self.tenths { tenth(value) } else { value };
                let rows = (1..=self.rows_per_ball)
                    .map(|i| {
                        let t_s = (i as f64) * f64::from(self.row_ms) / 1000.0;
                        let velocity = if i == self.rows_per_ball {
                            0.0
                        } else {
                            round(speed(t_s))
                        };
                        TrackRow::new(round(at(t_s)), velocity, self.row_ms)
                    })
                    .collect();
                tracks.push(Track {
                    start_mm: round(at(0.0)),
                    rows,
                    colours: Vec::new(),
                });
            }
        }
        Show {
            outputs: Vec::new(),
            name: "wave".into(),
            layout: Layout {
                rows: self.rows,
                cols: self.cols,
                pitch_mm: 500.0,
            },
            tracks,
        }
    }
}

/// The standard [`Wave`] on a `rows` × `cols` matrix: `rows_per_ball` rows of `row_ms`.
pub fn wave(rows: u32, cols: u32, rows_per_ball: usize, row_ms: u32) -> Show {
    Wave::new(rows, cols, rows_per_ball, row_ms).show()
}

/// `value` rounded to a tenth.
fn tenth(value: f64) -> f64 {
    (value * 10.0).round() / 10.0
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::show::{Limits, validate};

    #[test]
    fn the_wave_starts_and_ends_at_rest_and_is_valid() {
        let show = wave(3, 4, 40, 100);
        assert_eq!(show.layout.rows * show.layout.cols, 12);
        assert_eq!(show.duration_ms(), 4000);
        let mut limits = Limits::for_layout(3, 4);
        limits.max_accel_mm_s2 = 40_000.0;
        assert_eq!(validate(&show, &limits), Vec::new());
        for track in &show.tracks {
            let last = track.rows.last().unwrap();
            assert_eq!(last.velocity_mm_s, 0.0);
            // One full period: back where it started, to the rounding.
            assert!((last.position_mm - track.start_mm).abs() <= 0.1);
            assert!((2500.0..=3500.0).contains(&track.start_mm));
        }
        // The phase travels: neighbours differ.
        assert_ne!(show.tracks[0].start_mm, show.tracks[1].start_mm);
        assert_ne!(show.tracks[0].start_mm, show.tracks[4].start_mm);
    }

    #[test]
    fn every_figure_of_the_wave_can_be_set() {
        let wave = Wave {
            centre_mm: 2000.0,
            amplitude_mm: 25.0,
            col_phase: 0.0,
            row_phase: 0.0,
            ..Wave::new(1, 2, 10, 250)
        };
        let show = wave.show();
        assert_eq!(show.tracks[0], show.tracks[1]);
        for row in &show.tracks[0].rows {
            assert!((1975.0..=2025.0).contains(&row.position_mm), "{row:?}");
        }
        let rounded = &show.tracks[0].rows[0];
        assert_eq!(
            rounded.position_mm,
            (rounded.position_mm * 10.0).round() / 10.0
        );
        let exact = Wave {
            tenths: false,
            ..wave
        }
        .show();
        let row = &exact.tracks[0].rows[0];
        assert_eq!(row.position_mm, 2000.0 + 25.0 * (TAU / 4.0 * 0.25).sin());
    }
}
