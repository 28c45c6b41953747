//! The 2D top view: every ball seen from above at its place in the grid, as a disc
//! that is larger and brighter the higher the ball hangs (closer to the viewer) and
//! smaller and darker the lower it is. It is what the preview draws where WebGL2 is
//! missing, or when the user asks for it. Geometry and shading are plain functions;
//! only [`draw`] touches the canvas.

use floatball_shared::show::{DEFAULT_TRAVEL_MM, Layout};
use web_sys::CanvasRenderingContext2d;

/// The canvas background.
pub const BACKGROUND: &str = "#0b1117";
/// The ring around the ball whose plot is shown (the app's accent colour).
const SELECTED: &str = "#3fa7f5";

/// Where the grid sits on a canvas.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// The side of one cell, canvas pixels.
    pub cell: f64,
    /// The grid's top-left corner, canvas pixels.
    pub origin: (f64, f64),
    /// Columns in the grid.
    pub cols: u32,
}

impl Geometry {
    /// The largest square cells that fit `layout` into `width` × `height`, centred.
    pub fn fit(layout: Layout, width: f64, height: f64) -> Self {
        let cols = layout.cols.max(1);
        let rows = layout.rows.max(1);
        let cell = (width / f64::from(cols))
            .min(height / f64::from(rows))
            .max(0.0);
        let origin = (
            (width - cell * f64::from(cols)) / 2.0,
            (height - cell * f64::from(rows)) / 2.0,
        );
        Self { cell, origin, cols }
    }

    /// The centre of ball `unit` (row-major).
    pub fn centre(&self, unit: usize) -> (f64, f64) {
        let cols = self.cols as usize;
        let (row, col) = (unit / cols, unit % cols);
        (
            self.origin.0 + (col as f64 + 0.5) * self.cell,
            self.origin.1 + (row as f64 + 0.5) * self.cell,
        )
    }

    /// The radius of a ball `position_mm` below the top.
    pub fn radius(&self, position_mm: f32) -> f64 {
        self.cell * 0.45 * (1.0 - 0.5 * depth(position_mm))
    }

    /// The ball drawn under the point (`x`, `y`): the one whose cell holds it, if the
    /// point is within the disc's largest size (a tap need not hit a small disc).
    pub fn hit(&self, x: f64, y: f64, positions_mm: &[f32]) -> Option<usize> {
        if self.cell <= 0.0 || self.cols == 0 {
            return None;
        }
        let col = ((x - self.origin.0) / self.cell).floor();
        let row = ((y - self.origin.1) / self.cell).floor();
        if col < 0.0 || row < 0.0 || col >= f64::from(self.cols) {
            return None;
        }
        let unit = row as usize * self.cols as usize + col as usize;
        let (cx, cy) = self.centre(unit);
        let reach = self.radius(0.0);
        (unit < positions_mm.len() && (x - cx).hypot(y - cy) <= reach).then_some(unit)
    }
}

/// How low a ball hangs, 0.0 (top) to 1.0 (end of travel).
pub fn depth(position_mm: f32) -> f64 {
    if position_mm.is_finite() {
        (f64::from(position_mm) / DEFAULT_TRAVEL_MM).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The ball's colour darkened with its depth, as a CSS colour.
pub fn shade(rgb: [u8; 3], position_mm: f32) -> String {
    let light = 1.0 - 0.7 * depth(position_mm);
    let [r, g, b] = rgb.map(|c| (f64::from(c) * light).round() as u8);
    format!("rgb({r},{g},{b})")
}

/// Draws every ball on a `width` × `height` canvas, with a ring around `selected`.
pub fn draw(
    context: &CanvasRenderingContext2d,
    layout: Layout,
    (width, height): (f64, f64),
    positions_mm: &[f32],
    colours: &[[u8; 3]],
    selected: Option<usize>,
) {
    context.set_fill_style_str(BACKGROUND);
    context.fill_rect(0.0, 0.0, width, height);
    let geometry = Geometry::fit(layout, width, height);
    for (unit, (position_mm, rgb)) in positions_mm.iter().zip(colours).enumerate() {
        let (x, y) = geometry.centre(unit);
        context.begin_path();
        // Cannot fail for a finite, non-negative radius and these angles.
        let _ = context.arc(
            x,
            y,
            geometry.radius(*position_mm),
            0.0,
            std::f64::consts::TAU,
        );
        context.set_fill_style_str(&shade(*rgb, *position_mm));
        context.fill();
    }
    if let Some(unit) = selected.filter(|unit| *unit < positions_mm.len()) {
        let (x, y) = geometry.centre(unit);
        context.begin_path();
        // As above.
        let _ = context.arc(
            x,
            y,
            geometry.radius(0.0) * 1.05,
            0.0,
            std::f64::consts::TAU,
        );
        context.set_stroke_style_str(SELECTED);
        context.set_line_width((geometry.cell * 0.06).max(2.0));
        context.stroke();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    fn layout(rows: u32, cols: u32) -> Layout {
        Layout {
            rows,
            cols,
            pitch_mm: 500.0,
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_grid_is_centred_in_square_cells() {
        let geometry = Geometry::fit(layout(2, 4), 400.0, 400.0);
        assert_eq!(geometry.cell, 100.0);
        assert_eq!(geometry.origin, (0.0, 100.0));
        assert_eq!(geometry.centre(0), (50.0, 150.0));
        assert_eq!(geometry.centre(5), (150.0, 250.0));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_tap_hits_the_ball_of_its_cell() {
        let geometry = Geometry::fit(layout(2, 4), 400.0, 400.0);
        let positions = [0.0; 8];
        assert_eq!(geometry.hit(150.0, 250.0, &positions), Some(5));
        assert_eq!(
            geometry.hit(190.0, 250.0, &positions),
            Some(5),
            "within reach"
        );
        assert_eq!(
            geometry.hit(199.0, 201.0, &positions),
            None,
            "a cell's corner"
        );
        assert_eq!(
            geometry.hit(150.0, 50.0, &positions),
            None,
            "above the grid"
        );
        assert_eq!(
            geometry.hit(150.0, 350.0, &positions),
            None,
            "below the grid"
        );
        assert_eq!(
            geometry.hit(150.0, 250.0, &positions[..5]),
            None,
            "no such ball"
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn higher_balls_are_bigger_and_brighter() {
        let geometry = Geometry::fit(layout(1, 1), 100.0, 100.0);
        assert!(geometry.radius(0.0) > geometry.radius(7500.0));
        assert_eq!(geometry.radius(0.0), 45.0);
        assert_eq!(geometry.radius(-10.0), 45.0);
        assert_eq!(shade([200, 100, 0], 0.0), "rgb(200,100,0)");
        assert_eq!(shade([200, 100, 0], 7500.0), "rgb(60,30,0)");
        assert_eq!(depth(f32::NAN), 0.0);
        assert_eq!(depth(3750.0), 0.5);
    }
}
