//! Where things are in the 3D view: the ceiling grid, each ball on its cable, the
//! floor reference; which ball a tap hits; and how a ball is lit.
//!
//! A ball's position is the length of its cable, mm below the grid (`docs/architecture.md` §3): ball
//! `unit` (row-major) hangs from its anchor in the grid, at `position_mm` below it,
//! with the ball just under the cable's end. The floor reference is the plane the
//! balls' bottoms reach at the end of travel. Metres in the world, as in
//! [`super::camera`].

use floatball_shared::show::Layout;
use glam::Vec3;

use super::camera::Ray;

/// Light that reaches every surface, as a share of full light (the rest is Lambert).
pub const AMBIENT: f32 = 0.3;

/// A ball's radius as a share of the grid's pitch.
const RADIUS_PER_PITCH: f32 = 0.3;

/// How much larger than the ball the area that a tap hits is (fingers are wide).
const TAP_SLACK: f32 = 1.6;

/// The matrix in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scene {
    rows: u32,
    cols: u32,
    pitch_m: f32,
    travel_m: f32,
    /// Every ball's radius, metres.
    pub ball_radius_m: f32,
}

impl Scene {
    /// The scene of `layout` on an installation of `travel_mm`.
    pub fn new(layout: Layout, travel_mm: f64) -> Self {
        let pitch_m = if layout.pitch_mm.is_finite() && layout.pitch_mm > 0.0 {
            (layout.pitch_mm / 1000.0) as f32
        } else {
            0.5
        };
        Self {
            rows: layout.rows.max(1),
            cols: layout.cols.max(1),
            pitch_m,
            travel_m: (travel_mm.max(0.0) / 1000.0) as f32,
            ball_radius_m: pitch_m * RADIUS_PER_PITCH,
        }
    }

    /// Columns, rows, and the distance between neighbouring balls, metres.
    pub fn grid(&self) -> (u32, u32, f32) {
        (self.cols, self.rows, self.pitch_m)
    }

    /// Where the cable of `unit` leaves the grid (centred on the origin).
    pub fn anchor(&self, unit: usize) -> Vec3 {
        let cols = self.cols as usize;
        let (row, col) = ((unit / cols) as f32, (unit % cols) as f32);
        Vec3::new(
            (col - (self.cols as f32 - 1.0) / 2.0) * self.pitch_m,
            0.0,
            (row - (self.rows as f32 - 1.0) / 2.0) * self.pitch_m,
        )
    }

    /// The centre of `unit`'s ball when its cable is `position_mm` long.
    pub fn ball_centre(&self, unit: usize, position_mm: f32) -> Vec3 {
        let cable_m = if position_mm.is_finite() {
            position_mm / 1000.0
        } else {
            0.0
        };
        self.anchor(unit) - Vec3::Y * (cable_m + self.ball_radius_m)
    }

    /// The height of the floor reference (the balls' bottoms at the end of travel).
    pub fn floor_y(&self) -> f32 {
        -(self.travel_m + 2.0 * self.ball_radius_m)
    }

    /// The corners of the box holding the grid, the floor and every ball within
    /// travel.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let half = Vec3::new(
            self.cols as f32 * self.pitch_m / 2.0,
            0.0,
            self.rows as f32 * self.pitch_m / 2.0,
        );
        (
            Vec3::new(-half.x, self.floor_y(), -half.z),
            Vec3::new(half.x, 0.0, half.z),
        )
    }

    /// The lines of the ceiling grid (one through each row and column of anchors,
    /// half a pitch past the outer balls) and of the floor reference (its outline and
    /// the same grid), as pairs of points: `(ceiling, floor)`.
    pub fn grid_lines(&self) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
        self.grid_lines_every(1)
    }

    /// As [`Self::grid_lines`], but only through every `stride`-th row and column of
    /// anchors (the first of each included): what a dense view draws.
    pub fn grid_lines_every(&self, stride: usize) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
        let stride = stride.max(1);
        let (min, max) = self.bounds();
        let mut ceiling = Vec::new();
        let mut floor = Vec::new();
        let mut both = |a: Vec3, b: Vec3| {
            ceiling.extend([a.to_array(), b.to_array()]);
            let down = Vec3::Y * self.floor_y();
            floor.extend([(a + down).to_array(), (b + down).to_array()]);
        };
        for col in (0..self.cols as usize).step_by(stride) {
            let x = self.anchor(col).x;
            both(Vec3::new(x, 0.0, min.z), Vec3::new(x, 0.0, max.z));
        }
        for row in (0..self.rows as usize).step_by(stride) {
            let z = self.anchor(row * self.cols as usize).z;
            both(Vec3::new(min.x, 0.0, z), Vec3::new(max.x, 0.0, z));
        }
        let y = self.floor_y();
        let corners = [
            Vec3::new(min.x, y, min.z),
            Vec3::new(max.x, y, min.z),
            Vec3::new(max.x, y, max.z),
            Vec3::new(min.x, y, max.z),
        ];
        for (i, corner) in corners.iter().enumerate() {
            floor.extend([corner.to_array(), corners[(i + 1) % 4].to_array()]);
        }
        (ceiling, floor)
    }

    /// The ball a tap along `ray` hits first, with some slack around each ball;
    /// `positions_mm` as sampled for the frame on screen.
    pub fn pick(&self, ray: Ray, positions_mm: &[f32]) -> Option<usize> {
        let radius = self.ball_radius_m * TAP_SLACK;
        positions_mm
            .iter()
            .enumerate()
            .filter_map(|(unit, position_mm)| {
                let to_centre = self.ball_centre(unit, *position_mm) - ray.origin;
                let along = to_centre.dot(ray.direction);
                let miss_sq = to_centre.length_squared() - along * along;
                (along > 0.0 && miss_sq <= radius * radius).then_some((unit, along))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(unit, _)| unit)
    }
}

/// The colour of a ball's surface with normal `normal` under a light from `light`
/// (both of length 1): Lambert plus [`AMBIENT`]. The fragment shader computes the
/// same; the browser tests compare rendered pixels with this.
pub fn lit(rgb: [u8; 3], normal: Vec3, light: Vec3) -> [u8; 3] {
    let light = AMBIENT + (1.0 - AMBIENT) * normal.dot(light).max(0.0);
    rgb.map(|c| (f32::from(c) * light).round().clamp(0.0, 255.0) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    fn scene() -> Scene {
        Scene::new(
            Layout {
                rows: 2,
                cols: 3,
                pitch_mm: 500.0,
            },
            7500.0,
        )
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn balls_hang_below_their_anchor_in_the_grid() {
        let scene = scene();
        assert_eq!(scene.anchor(0), Vec3::new(-0.5, 0.0, -0.25));
        assert_eq!(scene.anchor(5), Vec3::new(0.5, 0.0, 0.25));
        assert_eq!(scene.ball_radius_m, 0.15);
        let centre = scene.ball_centre(4, 2000.0);
        assert!(
            (centre - Vec3::new(0.0, -2.15, 0.25)).length() < 1e-6,
            "{centre}"
        );
        assert_eq!(scene.ball_centre(4, f32::NAN).y, -0.15);
        assert!((scene.floor_y() + 7.8).abs() < 1e-6);
        let (min, max) = scene.bounds();
        assert_eq!(
            (min.x, min.z, max.x, max.z, max.y),
            (-0.75, -0.5, 0.75, 0.5, 0.0)
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_grid_has_a_line_per_row_and_column_and_the_floor_an_outline() {
        let (ceiling, floor) = scene().grid_lines();
        assert_eq!(ceiling.len(), 2 * (2 + 3));
        assert_eq!(floor.len(), 2 * (2 + 3) + 2 * 4);
        assert!(ceiling.iter().all(|p| p[1] == 0.0));
        assert!(floor.iter().all(|p| (p[1] + 7.8).abs() < 1e-6));
        let (every_other, floor) = scene().grid_lines_every(2);
        // Columns 0 and 2, row 0.
        assert_eq!(every_other.len(), 2 * (1 + 2));
        assert_eq!(floor.len(), 2 * (1 + 2) + 2 * 4);
        assert_eq!(every_other[0], ceiling[0]);
        assert_eq!(every_other[2], ceiling[4]);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_tap_picks_the_nearest_ball_on_its_ray() {
        let scene = scene();
        let positions = [1000.0, 1000.0, 1000.0, 1000.0, 3000.0, 1000.0];
        // Looking straight along the front row from its right end: ball 2 hides 1 and 0.
        let right_end = scene.ball_centre(2, 1000.0);
        let ray = Ray {
            origin: right_end + Vec3::X * 5.0,
            direction: Vec3::NEG_X,
        };
        assert_eq!(scene.pick(ray, &positions), Some(2));
        // From below, ball 4 (lower) comes first.
        let ray = Ray {
            origin: scene.anchor(4) - Vec3::Y * 10.0,
            direction: Vec3::Y,
        };
        assert_eq!(scene.pick(ray, &positions), Some(4));
        // A ray passing beside every ball, or pointing away, hits none.
        let ray = Ray {
            origin: Vec3::new(5.0, -1.0, 5.0),
            direction: Vec3::X,
        };
        assert_eq!(scene.pick(ray, &positions), None);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn lighting_is_lambert_with_ambient() {
        assert_eq!(lit([200, 100, 0], Vec3::Z, Vec3::Z), [200, 100, 0]);
        assert_eq!(lit([200, 100, 0], Vec3::Z, Vec3::NEG_Z), [60, 30, 0]);
        let half = Vec3::new(0.0, 0.5f32.sqrt(), 0.5f32.sqrt());
        let shade = AMBIENT + (1.0 - AMBIENT) * 0.5f32.sqrt();
        assert_eq!(
            lit([100, 100, 100], Vec3::Z, half)[0],
            (100.0 * shade).round() as u8
        );
    }
}
