//! The breathing surface: the whole matrix rises and falls slowly together, bulging
//! more in the middle than at the edges when `dome_mm` is not 0.
//!
//! Position `centre_mm + sin(2π t / period_s) · (amplitude_mm + dome_mm · (1 − (r/R)²))`,
//! `r` a ball's distance from the matrix's centre and `R` the distance to a corner.

use std::f64::consts::TAU;

use super::catalogue::PatternSpec;
use super::params::{ParamKind, ParamSpec, Reader};
use super::{CreateError, Field, Grid};

/// The breathing surface's parameters.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "amplitude_mm",
        label: "Depth of breath",
        help: "How far the whole surface rises and falls from the middle.",
        kind: ParamKind::number(0.0, 3000.0, 10.0, 900.0, "mm"),
    },
    ParamSpec {
        key: "period_s",
        label: "Breath",
        help: "Seconds for one breath, in and out.",
        kind: ParamKind::number(1.0, 120.0, 0.5, 8.0, "s"),
    },
    ParamSpec {
        key: "dome_mm",
        label: "Dome",
        help: "How much more the middle moves than the corners (negative: less).",
        kind: ParamKind::number(-3000.0, 3000.0, 10.0, 600.0, "mm"),
    },
    ParamSpec {
        key: "centre_mm",
        label: "Middle height",
        help: "The height the surface breathes around, below the top.",
        kind: ParamKind::height_mm(3000.0),
    },
];

/// The catalogue's entry.
pub const PATTERN: PatternSpec = PatternSpec {
    name: "breathe",
    label: "Breathing surface",
    help: "The whole surface rises and falls slowly, bulging in the middle.",
    params: PARAMS,
    build,
};

/// The breathing surface with its parameters fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct Breathe {
    /// Each ball's swing, mm.
    swing_mm: Vec<f64>,
    omega: f64,
    centre_mm: f64,
}

fn build(reader: &mut Reader<'_>, grid: &Grid) -> Result<Box<dyn Field>, CreateError> {
    let amplitude_mm = reader.number("amplitude_mm");
    let period_s = reader.number("period_s");
    let dome_mm = reader.number("dome_mm");
    let centre_mm = reader.number("centre_mm");
    let corner_mm = grid.half_diagonal_mm();
    let swing_mm = (0..grid.unit_count())
        .map(|unit| {
            let (x, y) = grid.xy_mm(unit);
            let inside = if corner_mm > 0.0 {
                1.0 - (x * x + y * y) / (corner_mm * corner_mm)
            } else {
                1.0
            };
            amplitude_mm + dome_mm * inside
        })
        .collect();
    Ok(Box::new(Breathe {
        swing_mm,
        omega: TAU / period_s,
        centre_mm,
    }))
}

impl Field for Breathe {
    fn sample(&self, _grid: &Grid, t_s: f64, out_mm: &mut [f64]) {
        let breath = (self.omega * t_s).sin();
        for (out, swing_mm) in out_mm.iter_mut().zip(&self.swing_mm) {
            *out = self.centre_mm + breath * swing_mm;
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::params::Params;
    use super::*;

    #[test]
    fn the_middle_breathes_deeper_than_the_corners() {
        let grid = Grid::new(3, 3, 500.0, 7500.0);
        let breathe = PATTERN.field(&Params::new(), 0, &grid).unwrap().0;
        let mut out = vec![0.0; 9];
        breathe.sample(&grid, 2.0, &mut out); // a quarter of the 8 s breath: deepest
        assert!((out[4] - (3000.0 + 900.0 + 600.0)).abs() < 1e-9, "{out:?}");
        assert!((out[0] - (3000.0 + 900.0)).abs() < 1e-9, "{out:?}");
        assert!(out[1] > out[0] && out[1] < out[4]);
        breathe.sample(&grid, 8.0, &mut out);
        assert!(out.iter().all(|&mm| (mm - 3000.0).abs() < 1e-9));
    }
}
