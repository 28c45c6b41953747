//! Rain: drops falling on the matrix at random places and times, each pushing the
//! ball it hits (and its neighbours within `radius_m`) down and letting it rise again.
//!
//! Deterministic: time is cut in slots of `1 / drops_per_s`; slot k holds one drop, at
//! a place and a moment within the slot drawn from a hash of (`seed`, k), so any time
//! can be sampled without the drops before it and the same seed always gives the same
//! rain. Each drop is the bump `64 s³ (1 − s)³` over `drop_s` seconds (zero slope and
//! curvature at both ends), `depth_mm` deep at its centre and smaller towards
//! `radius_m` (a smooth step).

use super::catalogue::PatternSpec;
use super::params::{ParamKind, ParamSpec, Reader};
use super::{CreateError, Field, Grid, smooth_step};

/// The rain's parameters.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "drops_per_s",
        label: "Drops",
        help: "How many drops fall per second on the whole matrix.",
        kind: ParamKind::number(0.1, 50.0, 0.1, 2.0, "/s"),
    },
    ParamSpec {
        key: "depth_mm",
        label: "Depth",
        help: "How far a drop pushes the ball it hits down.",
        kind: ParamKind::number(0.0, 3000.0, 10.0, 500.0, "mm"),
    },
    ParamSpec {
        key: "drop_s",
        label: "Drop time",
        help: "Seconds from a drop's hit until the ball is back.",
        kind: ParamKind::number(0.5, 10.0, 0.1, 3.0, "s"),
    },
    ParamSpec {
        key: "radius_m",
        label: "Splash",
        help: "How far from the ball hit its neighbours move too (0: only that ball).",
        kind: ParamKind::number(0.0, 5.0, 0.1, 0.8, "m"),
    },
    ParamSpec {
        key: "base_mm",
        label: "Surface",
        help: "The height of the still surface, below the top.",
        kind: ParamKind::height_mm(2500.0),
    },
    ParamSpec {
        key: "seed",
        label: "Seed",
        help: "Another number gives other drops; the same number the same drops.",
        kind: ParamKind::number(0.0, 9999.0, 1.0, 1.0, ""),
    },
];

/// The catalogue's entry.
pub const PATTERN: PatternSpec = PatternSpec {
    name: "rain",
    label: "Rain",
    help: "Drops falling at random places, each pushing balls down for a moment.",
    params: PARAMS,
    build,
};

/// The rain with its parameters fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct Rain {
    slot_s: f64,
    drop_s: f64,
    depth_mm: f64,
    /// Splash radius in balls (pitches).
    radius_balls: f64,
    base_mm: f64,
    seed: u64,
    rows: u32,
    cols: u32,
}

fn build(reader: &mut Reader<'_>, grid: &Grid) -> Result<Box<dyn Field>, CreateError> {
    let drops_per_s = reader.number("drops_per_s");
    let radius_mm = reader.number("radius_m") * 1000.0;
    // The seed is a whole number from 0 to 9999 (clamped by the reader).
    let seed = reader.number("seed").round() as u64;
    Ok(Box::new(Rain {
        slot_s: 1.0 / drops_per_s,
        drop_s: reader.number("drop_s"),
        depth_mm: reader.number("depth_mm"),
        radius_balls: radius_mm / grid.pitch_mm,
        base_mm: reader.number("base_mm"),
        seed,
        rows: grid.rows,
        cols: grid.cols,
    }))
}

/// SplitMix64: a well-mixed 64-bit hash of `x`.
fn mix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A number in [0, 1) from the top 53 bits of `x`.
fn unit_interval(x: u64) -> f64 {
    (x >> 11) as f64 / (1u64 << 53) as f64
}

impl Rain {
    /// Drop `slot`'s start time (s) and the ball it hits (row, column).
    fn drop(&self, slot: u64) -> (f64, u32, u32) {
        let h = mix(self.seed.wrapping_mul(0x1000_0000_01B3) ^ mix(slot));
        let at_s = (slot as f64 + unit_interval(h)) * self.slot_s;
        let h2 = mix(h);
        let ball = h2 % (u64::from(self.rows) * u64::from(self.cols)).max(1);
        let cols = u64::from(self.cols.max(1));
        let (row, col) = (ball / cols, ball % cols);
        (
            at_s,
            u32::try_from(row).unwrap_or(0),
            u32::try_from(col).unwrap_or(0),
        )
    }
}

impl Field for Rain {
    fn sample(&self, _grid: &Grid, t_s: f64, out_mm: &mut [f64]) {
        out_mm.fill(self.base_mm);
        if t_s <= 0.0 || self.depth_mm == 0.0 {
            return;
        }
        // Drops that started within the last drop_s seconds (a slot's drop falls
        // within the slot).
        let first = ((t_s - self.drop_s) / self.slot_s).floor().max(0.0) as u64;
        let last = (t_s / self.slot_s).floor().max(0.0) as u64;
        let reach = self.radius_balls.floor() as i64;
        let cols = i64::from(self.cols);
        let rows = i64::from(self.rows);
        for slot in first..=last {
            let (at_s, row, col) = self.drop(slot);
            let s = (t_s - at_s) / self.drop_s;
            if !(0.0..1.0).contains(&s) || s <= 0.0 {
                continue;
            }
            let bump = 64.0 * (s * (1.0 - s)).powi(3) * self.depth_mm;
            let (row, col) = (i64::from(row), i64::from(col));
            for r in (row - reach).max(0)..=(row + reach).min(rows - 1) {
                for c in (col - reach).max(0)..=(col + reach).min(cols - 1) {
                    let d = ((r - row) as f64).hypot((c - col) as f64);
                    let weight = if d == 0.0 {
                        1.0
                    } else if d < self.radius_balls {
                        smooth_step(1.0 - d / self.radius_balls)
                    } else {
                        continue;
                    };
                    if let Some(out) = usize::try_from(r * cols + c)
                        .ok()
                        .and_then(|unit| out_mm.get_mut(unit))
                    {
                        *out += bump * weight;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::params::{Params, Value};
    use super::*;

    fn rain(pairs: &[(&str, f64)], grid: &Grid) -> Box<dyn Field> {
        let params: Params = pairs
            .iter()
            .map(|(key, value)| ((*key).to_owned(), Value::Number(*value)))
            .collect();
        PATTERN.field(&params, 0, grid).unwrap().0
    }

    #[test]
    fn drops_push_balls_down_and_let_them_back() {
        let grid = Grid::new(6, 6, 500.0, 7500.0);
        let field = rain(&[("radius_m", 0.0)], &grid);
        let mut out = vec![0.0; 36];
        field.sample(&grid, 0.0, &mut out);
        assert!(out.iter().all(|&mm| mm == 2500.0));
        let mut moved = 0;
        let mut deepest = 0.0f64;
        for step in 1..200 {
            field.sample(&grid, f64::from(step) * 0.1, &mut out);
            moved += out.iter().filter(|&&mm| mm > 2500.0).count();
            deepest = deepest.max(out.iter().fold(0.0, |a, &b| a.max(b)));
            assert!(out.iter().all(|&mm| mm >= 2500.0));
        }
        assert!(moved > 100, "{moved}");
        assert!(deepest > 2500.0 + 450.0, "{deepest}");
    }

    #[test]
    fn the_seed_decides_the_drops() {
        let grid = Grid::new(5, 5, 500.0, 7500.0);
        let (mut a, mut b, mut c) = (vec![0.0; 25], vec![0.0; 25], vec![0.0; 25]);
        let mut differ = false;
        for step in 1..50 {
            let t_s = f64::from(step) * 0.37;
            rain(&[("seed", 7.0)], &grid).sample(&grid, t_s, &mut a);
            rain(&[("seed", 7.0)], &grid).sample(&grid, t_s, &mut b);
            rain(&[("seed", 8.0)], &grid).sample(&grid, t_s, &mut c);
            assert_eq!(a, b);
            differ |= a != c;
        }
        assert!(differ);
    }

    #[test]
    fn a_splash_moves_the_neighbours_less() {
        let grid = Grid::new(9, 9, 500.0, 7500.0);
        let field = rain(&[("radius_m", 1.0), ("drops_per_s", 0.1)], &grid);
        let probe = Rain {
            slot_s: 10.0,
            drop_s: 3.0,
            depth_mm: 500.0,
            radius_balls: 2.0,
            base_mm: 2500.0,
            seed: 1,
            rows: 9,
            cols: 9,
        };
        let (at_s, row, col) = probe.drop(0);
        let mut out = vec![0.0; 81];
        field.sample(&grid, at_s + 1.5, &mut out); // the bump's middle
        let centre = out[(row * 9 + col) as usize];
        assert!((centre - 3000.0).abs() < 1e-6, "{centre}");
        let moved: Vec<f64> = out.iter().copied().filter(|&mm| mm > 2500.0).collect();
        assert!(moved.len() > 1 && moved.iter().all(|&mm| mm <= centre));
    }
}
