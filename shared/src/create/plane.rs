//! The tilted, rotating plane: the balls form a flat surface tilted by `slope_mm_m`
//! whose direction of tilt turns around the matrix's centre.
//!
//! Position `centre_mm + slope · (x cos θ + y sin θ)`, θ = `angle_deg` + 360° ·
//! `turns_per_min` · t / 60. A ball `r` metres from the centre moves at most
//! `slope · r · 2π · turns_per_min / 60`.

use std::f64::consts::TAU;

use super::catalogue::PatternSpec;
use super::params::{ParamKind, ParamSpec, Reader};
use super::{CreateError, Field, Grid};

/// The plane's parameters.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "slope_mm_m",
        label: "Tilt",
        help: "How much lower the surface is one metre further along its tilt.",
        kind: ParamKind::number(0.0, 2000.0, 10.0, 400.0, "mm/m"),
    },
    ParamSpec {
        key: "turns_per_min",
        label: "Turning",
        help: "Turns of the tilt's direction per minute (negative: the other way; 0: still).",
        kind: ParamKind::number(-20.0, 20.0, 0.1, 3.0, "/min"),
    },
    ParamSpec {
        key: "angle_deg",
        label: "Start angle",
        help: "Direction the surface falls towards at the start: 0° right, 90° back.",
        kind: ParamKind::number(0.0, 360.0, 1.0, 0.0, "deg"),
    },
    ParamSpec {
        key: "centre_mm",
        label: "Middle height",
        help: "The height at the matrix's centre, below the top.",
        kind: ParamKind::height_mm(3000.0),
    },
];

/// The catalogue's entry.
pub const PATTERN: PatternSpec = PatternSpec {
    name: "plane",
    label: "Tilted plane",
    help: "A flat surface, tilted, its tilt turning around the centre.",
    params: PARAMS,
    build,
};

/// The plane with its parameters fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct Plane {
    /// Each ball's (x, y) in metres from the centre.
    xy_m: Vec<(f64, f64)>,
    slope_mm_m: f64,
    angle_rad: f64,
    omega: f64,
    centre_mm: f64,
}

fn build(reader: &mut Reader<'_>, grid: &Grid) -> Result<Box<dyn Field>, CreateError> {
    let slope_mm_m = reader.number("slope_mm_m");
    let turns_per_min = reader.number("turns_per_min");
    let angle_deg = reader.number("angle_deg");
    let centre_mm = reader.number("centre_mm");
    Ok(Box::new(Plane {
        xy_m: (0..grid.unit_count())
            .map(|unit| {
                let (x, y) = grid.xy_mm(unit);
                (x / 1000.0, y / 1000.0)
            })
            .collect(),
        slope_mm_m,
        angle_rad: angle_deg.to_radians(),
        omega: TAU * turns_per_min / 60.0,
        centre_mm,
    }))
}

impl Field for Plane {
    fn sample(&self, _grid: &Grid, t_s: f64, out_mm: &mut [f64]) {
        let (sin, cos) = (self.angle_rad + self.omega * t_s).sin_cos();
        let (dx, dy) = (self.slope_mm_m * cos, self.slope_mm_m * sin);
        for (out, (x, y)) in out_mm.iter_mut().zip(&self.xy_m) {
            *out = self.centre_mm + x * dx + y * dy;
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
    fn the_tilt_turns_a_quarter_in_a_quarter_turn() {
        let grid = Grid::new(3, 3, 1000.0, 7500.0);
        let plane = PATTERN.field(&Params::new(), 0, &grid).unwrap().0;
        let mut out = vec![0.0; 9];
        plane.sample(&grid, 0.0, &mut out);
        // Falls towards the right: the right column 400 mm lower than the centre.
        assert!((out[5] - 3400.0).abs() < 1e-9 && (out[3] - 2600.0).abs() < 1e-9);
        assert!((out[7] - 3000.0).abs() < 1e-9);
        plane.sample(&grid, 5.0, &mut out); // 3 turns a minute: a quarter in 5 s
        assert!(
            (out[7] - 3400.0).abs() < 1e-9 && (out[5] - 3000.0).abs() < 1e-9,
            "{out:?}"
        );
    }
}
