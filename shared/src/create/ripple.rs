//! The ripple: rings spreading from a point of the matrix, as from a stone dropped in
//! water, weaker as they go (damping).
//!
//! The front leaves the point at time 0 and travels at `speed_m_s`; behind it each
//! ball swings `amplitude_mm · e^(−damping · r)` around `centre_mm`, `r` its distance
//! from the point in metres. The front rises over one wavelength (a smooth step), so
//! every ball starts from rest.

use std::f64::consts::TAU;

use super::catalogue::PatternSpec;
use super::params::{ParamKind, ParamSpec, Reader};
use super::{CreateError, Field, Grid, smooth_step};

/// The ripple's parameters.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "x_m",
        label: "Point, across",
        help: "Where the rings start: metres right of the matrix's centre (negative: left).",
        kind: ParamKind::number(-25.0, 25.0, 0.1, 0.0, "m"),
    },
    ParamSpec {
        key: "y_m",
        label: "Point, deep",
        help: "Where the rings start: metres behind the matrix's centre (negative: in front).",
        kind: ParamKind::number(-25.0, 25.0, 0.1, 0.0, "m"),
    },
    ParamSpec {
        key: "wavelength_m",
        label: "Wavelength",
        help: "Distance from one ring to the next.",
        kind: ParamKind::number(0.5, 20.0, 0.1, 3.0, "m"),
    },
    ParamSpec {
        key: "speed_m_s",
        label: "Speed",
        help: "How fast the rings spread.",
        kind: ParamKind::number(0.1, 5.0, 0.05, 0.6, "m/s"),
    },
    ParamSpec {
        key: "amplitude_mm",
        label: "Amplitude",
        help: "How far balls swing at the point, above and below the middle.",
        kind: ParamKind::number(0.0, 3000.0, 10.0, 700.0, "mm"),
    },
    ParamSpec {
        key: "damping_per_m",
        label: "Damping",
        help: "How quickly the rings weaken: the swing falls by e (2.7 times) every 1/damping metres.",
        kind: ParamKind::number(0.0, 2.0, 0.01, 0.15, "1/m"),
    },
    ParamSpec {
        key: "centre_mm",
        label: "Middle height",
        help: "The height of the still surface, below the top.",
        kind: ParamKind::height_mm(3000.0),
    },
];

/// The catalogue's entry.
pub const PATTERN: PatternSpec = PatternSpec {
    name: "ripple",
    label: "Ripple",
    help: "Rings spreading from a point, weaker as they go.",
    params: PARAMS,
    build,
};

/// The ripple with its parameters fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct Ripple {
    /// Each ball's distance from the point, in wavelengths.
    waves: Vec<f64>,
    /// Each ball's swing, mm.
    swing_mm: Vec<f64>,
    /// Wavelengths the front travels per second.
    waves_per_s: f64,
    centre_mm: f64,
}

fn build(reader: &mut Reader<'_>, grid: &Grid) -> Result<Box<dyn Field>, CreateError> {
    let point_mm = (reader.number("x_m") * 1000.0, reader.number("y_m") * 1000.0);
    let wavelength_mm = reader.number("wavelength_m") * 1000.0;
    let speed_mm_s = reader.number("speed_m_s") * 1000.0;
    let amplitude_mm = reader.number("amplitude_mm");
    let damping_per_mm = reader.number("damping_per_m") / 1000.0;
    let centre_mm = reader.number("centre_mm");
    let distance_mm = |unit| {
        let (x, y) = grid.xy_mm(unit);
        (x - point_mm.0).hypot(y - point_mm.1)
    };
    let units = 0..grid.unit_count();
    Ok(Box::new(Ripple {
        waves: units
            .clone()
            .map(|unit| distance_mm(unit) / wavelength_mm)
            .collect(),
        swing_mm: units
            .map(|unit| amplitude_mm * (-damping_per_mm * distance_mm(unit)).exp())
            .collect(),
        waves_per_s: speed_mm_s / wavelength_mm,
        centre_mm,
    }))
}

impl Field for Ripple {
    fn sample(&self, _grid: &Grid, t_s: f64, out_mm: &mut [f64]) {
        let front = self.waves_per_s * t_s;
        for ((out, waves), swing_mm) in out_mm.iter_mut().zip(&self.waves).zip(&self.swing_mm) {
            // Wavelengths behind the front; the first one rises smoothly.
            let behind = front - waves;
            *out = if behind <= 0.0 {
                self.centre_mm
            } else {
                self.centre_mm - swing_mm * smooth_step(behind) * (TAU * behind).sin()
            };
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::params::{Params, Value};
    use super::*;

    #[test]
    fn rings_reach_farther_balls_later_and_weaker() {
        let grid = Grid::new(1, 11, 500.0, 7500.0);
        let params: Params = [
            ("x_m".to_owned(), Value::Number(-2.5)), // the leftmost ball
            ("speed_m_s".to_owned(), Value::Number(1.0)),
            ("wavelength_m".to_owned(), Value::Number(1.0)),
            ("damping_per_m".to_owned(), Value::Number(0.5)),
        ]
        .into_iter()
        .collect();
        let ripple = PATTERN.field(&params, 0, &grid).unwrap().0;
        let mut out = vec![0.0; 11];
        ripple.sample(&grid, 0.0, &mut out);
        assert!(out.iter().all(|&mm| mm == 3000.0), "still at the start");
        // After 2 s the front is 2 m out: balls 0–3 move, ball 4 (2 m) and farther not yet.
        ripple.sample(&grid, 2.0, &mut out);
        assert!(out[4..].iter().all(|&mm| mm == 3000.0), "{out:?}");
        // The largest swing each ball reaches falls with its distance.
        let mut peak = [0.0f64; 11];
        for step in 0..400 {
            ripple.sample(&grid, f64::from(step) * 0.05, &mut out);
            for (peak, mm) in peak.iter_mut().zip(&out) {
                *peak = peak.max((mm - 3000.0).abs());
            }
        }
        for ball in 2..11 {
            assert!(peak[ball] < peak[ball - 1], "{peak:?}");
        }
        assert!(peak[0] <= 700.0 + 1e-9);
    }
}
