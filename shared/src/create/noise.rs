//! The smooth noise field: a slowly changing, drifting landscape of hills and
//! hollows, the same for the same seed.
//!
//! Three-dimensional gradient (Perlin) noise with the quintic fade, so it is C2 in
//! space and time, sampled at (x + drift · t, y) / `scale_m` and time `change_hz` · t;
//! the gradients come from a permutation shuffled by `seed`.

use super::catalogue::PatternSpec;
use super::params::{ParamKind, ParamSpec, Reader};
use super::{CreateError, Field, Grid};

/// The noise field's parameters.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "scale_m",
        label: "Size of hills",
        help: "About how far apart the hills are.",
        kind: ParamKind::number(0.5, 30.0, 0.1, 3.0, "m"),
    },
    ParamSpec {
        key: "amplitude_mm",
        label: "Height of hills",
        help: "How far the surface reaches above and below the middle.",
        kind: ParamKind::number(0.0, 3000.0, 10.0, 1500.0, "mm"),
    },
    ParamSpec {
        key: "change_hz",
        label: "Change",
        help: "How quickly the landscape changes shape (0: it only drifts).",
        kind: ParamKind::number(0.0, 1.0, 0.01, 0.12, "Hz"),
    },
    ParamSpec {
        key: "drift_m_s",
        label: "Drift",
        help: "How fast the landscape drifts to the right.",
        kind: ParamKind::number(0.0, 3.0, 0.05, 0.3, "m/s"),
    },
    ParamSpec {
        key: "centre_mm",
        label: "Middle height",
        help: "The height the hills rise and fall around, below the top.",
        kind: ParamKind::height_mm(3000.0),
    },
    ParamSpec {
        key: "seed",
        label: "Seed",
        help: "Another number gives another landscape; the same number the same one.",
        kind: ParamKind::number(0.0, 9999.0, 1.0, 1.0, ""),
    },
];

/// The catalogue's entry.
pub const PATTERN: PatternSpec = PatternSpec {
    name: "noise",
    label: "Noise field",
    help: "A smooth landscape of hills and hollows that drifts and changes.",
    params: PARAMS,
    build,
};

/// The noise field with its parameters fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct Noise {
    /// Each ball's (x, y) in noise cells.
    xy: Vec<(f64, f64)>,
    /// Noise cells drifted per second.
    drift_per_s: f64,
    change_hz: f64,
    amplitude_mm: f64,
    centre_mm: f64,
    /// The shuffled permutation of 0..=255, twice.
    perm: Vec<u8>,
}

fn build(reader: &mut Reader<'_>, grid: &Grid) -> Result<Box<dyn Field>, CreateError> {
    let scale_mm = reader.number("scale_m") * 1000.0;
    let amplitude_mm = reader.number("amplitude_mm");
    let change_hz = reader.number("change_hz");
    let drift_mm_s = reader.number("drift_m_s") * 1000.0;
    let centre_mm = reader.number("centre_mm");
    let seed = reader.number("seed").round() as u64;
    // Fisher–Yates with a 64-bit LCG seeded by `seed`.
    let mut perm: Vec<u8> = (0..=255).collect();
    let mut state = seed.wrapping_mul(6_364_136_223_846_793_005) ^ 0x2545_F491_4F6C_DD1D;
    for i in (1..256usize).rev() {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        let j = ((state >> 33) % (i as u64 + 1)) as usize;
        perm.swap(i, j);
    }
    perm.extend_from_within(..);
    Ok(Box::new(Noise {
        xy: (0..grid.unit_count())
            .map(|unit| {
                let (x, y) = grid.xy_mm(unit);
                (x / scale_mm, y / scale_mm)
            })
            .collect(),
        drift_per_s: drift_mm_s / scale_mm,
        change_hz,
        // Perlin noise stays within about ±0.7 in practice; scale so the hills reach
        // about the amplitude.
        amplitude_mm: amplitude_mm * 1.4,
        centre_mm,
        perm,
    }))
}

/// Quintic fade 6t⁵ − 15t⁴ + 10t³.
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

/// Dot product of one of 12 edge gradients (chosen by `hash`) with (x, y, z).
fn grad(hash: u8, x: f64, y: f64, z: f64) -> f64 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

impl Noise {
    /// Gradient noise at (x, y, z), about −1 to 1.
    fn at(&self, x: f64, y: f64, z: f64) -> f64 {
        let p = &self.perm;
        let (xf, yf, zf) = (x.floor(), y.floor(), z.floor());
        let (x, y, z) = (x - xf, y - yf, z - zf);
        // Cells wrap every 256 (the permutation's period).
        let xi = (xf.rem_euclid(256.0)) as usize;
        let yi = (yf.rem_euclid(256.0)) as usize;
        let zi = (zf.rem_euclid(256.0)) as usize;
        let (u, v, w) = (fade(x), fade(y), fade(z));
        let a = usize::from(p[xi]) + yi;
        let (aa, ab) = (usize::from(p[a]) + zi, usize::from(p[a + 1]) + zi);
        let b = usize::from(p[xi + 1]) + yi;
        let (ba, bb) = (usize::from(p[b]) + zi, usize::from(p[b + 1]) + zi);
        lerp(
            w,
            lerp(
                v,
                lerp(u, grad(p[aa], x, y, z), grad(p[ba], x - 1.0, y, z)),
                lerp(
                    u,
                    grad(p[ab], x, y - 1.0, z),
                    grad(p[bb], x - 1.0, y - 1.0, z),
                ),
            ),
            lerp(
                v,
                lerp(
                    u,
                    grad(p[aa + 1], x, y, z - 1.0),
                    grad(p[ba + 1], x - 1.0, y, z - 1.0),
                ),
                lerp(
                    u,
                    grad(p[ab + 1], x, y - 1.0, z - 1.0),
                    grad(p[bb + 1], x - 1.0, y - 1.0, z - 1.0),
                ),
            ),
        )
    }
}

impl Field for Noise {
    fn sample(&self, _grid: &Grid, t_s: f64, out_mm: &mut [f64]) {
        let shift = self.drift_per_s * t_s;
        // Offset the time axis off the lattice so time 0 is not a flat plane.
        let z = self.change_hz * t_s + 0.5;
        for (out, &(x, y)) in out_mm.iter_mut().zip(&self.xy) {
            *out = self.centre_mm + self.amplitude_mm * self.at(x - shift + 0.37, y + 0.61, z);
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::params::{Params, Value};
    use super::*;

    fn noise(seed: f64, grid: &Grid) -> Box<dyn Field> {
        let params: Params = [("seed".to_owned(), Value::Number(seed))]
            .into_iter()
            .collect();
        PATTERN.field(&params, 0, grid).unwrap().0
    }

    #[test]
    fn the_landscape_is_smooth_varied_and_seeded() {
        let grid = Grid::new(8, 8, 500.0, 7500.0);
        let (mut a, mut b, mut c) = (vec![0.0; 64], vec![0.0; 64], vec![0.0; 64]);
        noise(3.0, &grid).sample(&grid, 1.5, &mut a);
        noise(3.0, &grid).sample(&grid, 1.5, &mut b);
        noise(4.0, &grid).sample(&grid, 1.5, &mut c);
        assert_eq!(a, b);
        assert_ne!(a, c);
        let (lo, hi) = a.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &mm| {
            (lo.min(mm), hi.max(mm))
        });
        assert!(hi - lo > 200.0, "{lo}..{hi}");
        // Neighbouring instants are close (smooth in time).
        noise(3.0, &grid).sample(&grid, 1.501, &mut b);
        assert!(a.iter().zip(&b).all(|(a, b)| (a - b).abs() < 5.0));
    }

    #[test]
    fn gradient_noise_is_zero_on_the_lattice_and_bounded() {
        let probe = Noise {
            xy: vec![],
            drift_per_s: 0.0,
            change_hz: 0.0,
            amplitude_mm: 1.0,
            centre_mm: 0.0,
            perm: (0..=255).chain(0..=255).collect(),
        };
        assert_eq!(probe.at(3.0, 4.0, 5.0), 0.0);
        for i in 0..1000 {
            let f = f64::from(i);
            let value = probe.at(f * 0.137, f * 0.071, f * 0.013);
            assert!(value.abs() <= 1.05, "{value}");
        }
    }
}
