//! The travelling wave: every ball bobs around a middle height as a sine wave of a
//! given wavelength travels across the matrix in one of four directions.
//!
//! Position `centre_mm + amplitude_mm · sin(2π (d − speed · t) / wavelength)`, `d` the
//! ball's distance along the direction of travel. A ball's peak speed is
//! `amplitude · 2π · speed / wavelength`.

use std::f64::consts::TAU;

use super::catalogue::PatternSpec;
use super::params::{ParamKind, ParamSpec, Reader};
use super::{CreateError, Field, Grid};

/// The directions a wave travels in, seen from below with the front row nearest.
pub const DIRECTIONS: &[&str] = &["right", "left", "back", "front"];

/// The wave's parameters.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "direction",
        label: "Direction",
        help: "Which way the wave travels.",
        kind: ParamKind::Choice {
            options: DIRECTIONS,
            default: "right",
        },
    },
    ParamSpec {
        key: "wavelength_m",
        label: "Wavelength",
        help: "Distance from one crest to the next.",
        kind: ParamKind::number(0.5, 50.0, 0.1, 4.0, "m"),
    },
    ParamSpec {
        key: "amplitude_mm",
        label: "Amplitude",
        help: "How far each ball moves above and below the middle.",
        kind: ParamKind::number(0.0, 3000.0, 10.0, 800.0, "mm"),
    },
    ParamSpec {
        key: "speed_m_s",
        label: "Speed",
        help: "How fast the crests travel across the matrix.",
        kind: ParamKind::number(0.0, 5.0, 0.05, 0.5, "m/s"),
    },
    ParamSpec {
        key: "centre_mm",
        label: "Middle height",
        help: "The middle of the swing, below the top.",
        kind: ParamKind::height_mm(3000.0),
    },
];

/// The catalogue's entry.
pub const PATTERN: PatternSpec = PatternSpec {
    name: "wave",
    label: "Wave",
    help: "A sine wave travelling across the matrix.",
    params: PARAMS,
    build,
};

/// The wave with its parameters fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct Wave {
    /// Each ball's phase at time 0, radians: its sine and cosine, so a sample is two
    /// multiplications a ball (sin(φ − ωt) = sin φ cos ωt − cos φ sin ωt).
    phase: Vec<(f64, f64)>,
    /// Phase change per second, radians.
    omega: f64,
    centre_mm: f64,
    amplitude_mm: f64,
}

fn build(reader: &mut Reader<'_>, grid: &Grid) -> Result<Box<dyn Field>, CreateError> {
    let direction = reader.choice("direction");
    let (dx, dy) = match direction {
        "left" => (-1.0, 0.0),
        "back" => (0.0, 1.0),
        "front" => (0.0, -1.0),
        _ => (1.0, 0.0),
    };
    let wavelength_mm = reader.number("wavelength_m") * 1000.0;
    let amplitude_mm = reader.number("amplitude_mm");
    let speed_mm_s = reader.number("speed_m_s") * 1000.0;
    let centre_mm = reader.number("centre_mm");
    let phase = (0..grid.unit_count())
        .map(|unit| {
            let (x, y) = grid.xy_mm(unit);
            (TAU * (x * dx + y * dy) / wavelength_mm).sin_cos()
        })
        .collect();
    Ok(Box::new(Wave {
        phase,
        omega: TAU * speed_mm_s / wavelength_mm,
        centre_mm,
        amplitude_mm,
    }))
}

impl Field for Wave {
    fn sample(&self, _grid: &Grid, t_s: f64, out_mm: &mut [f64]) {
        let (sin, cos) = (self.omega * t_s).sin_cos();
        let (sin, cos) = (self.amplitude_mm * sin, self.amplitude_mm * cos);
        for (out, (sin_phase, cos_phase)) in out_mm.iter_mut().zip(&self.phase) {
            *out = self.centre_mm + sin_phase * cos - cos_phase * sin;
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::params::{Params, Value};
    use super::*;

    fn field(pairs: &[(&str, Value)], grid: &Grid) -> Box<dyn Field> {
        let params: Params = pairs
            .iter()
            .map(|(key, value)| ((*key).to_owned(), value.clone()))
            .collect();
        PATTERN.field(&params, 0, grid).unwrap().0
    }

    #[test]
    fn the_crest_travels_in_its_direction_at_its_speed() {
        let grid = Grid::new(1, 9, 500.0, 7500.0);
        let wave = field(
            &[
                ("wavelength_m", Value::Number(2.0)),
                ("speed_m_s", Value::Number(1.0)),
                ("amplitude_mm", Value::Number(1000.0)),
            ],
            &grid,
        );
        let mut now = vec![0.0; 9];
        let mut later = vec![0.0; 9];
        wave.sample(&grid, 0.0, &mut now);
        wave.sample(&grid, 0.5, &mut later);
        // After 0.5 s at 1 m/s the wave has moved one ball (500 mm) to the right.
        for col in 1..9 {
            assert!((later[col] - now[col - 1]).abs() < 1e-9, "{col}");
        }
        assert!((now[4] - 3000.0).abs() < 1e-9); // the centre ball starts at the middle
        let left = field(
            &[
                ("direction", Value::Text("left".into())),
                ("wavelength_m", Value::Number(2.0)),
                ("speed_m_s", Value::Number(1.0)),
            ],
            &grid,
        );
        left.sample(&grid, 0.0, &mut now);
        left.sample(&grid, 0.5, &mut later);
        for col in 0..8 {
            assert!((later[col] - now[col + 1]).abs() < 1e-9, "{col}");
        }
    }

    #[test]
    fn the_same_parameters_give_the_same_positions() {
        let grid = Grid::new(4, 5, 400.0, 5000.0);
        let (mut a, mut b) = (vec![0.0; 20], vec![0.0; 20]);
        field(&[], &grid).sample(&grid, 3.21, &mut a);
        field(&[], &grid).sample(&grid, 3.21, &mut b);
        assert_eq!(a, b);
    }
}
