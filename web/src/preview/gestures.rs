//! Pointer gestures on the preview's canvas, as a plain type: one finger (or the
//! left mouse button) drags to orbit, two fingers pinch to zoom and move together to
//! pan, the right mouse button (or Shift) drags to pan, the wheel zooms, and a short
//! touch that barely moves is a tap (it picks a ball).
//!
//! Positions are canvas pixels; times are ms of any monotone clock.

use glam::Vec2;

/// A press shorter than this that moves less than [`TAP_SLOP_PX`] is a tap, ms.
const TAP_MS: f64 = 400.0;
/// How far a tap may wander, pixels.
const TAP_SLOP_PX: f32 = 8.0;
/// How much one wheel "line" (100 pixels of delta) zooms.
const WHEEL_ZOOM_PER_100PX: f32 = 1.15;

/// What a pointer event does to the view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Gesture {
    /// Turn the view by a drag of so many pixels.
    Rotate(Vec2),
    /// Slide the view by so many pixels.
    Pan(Vec2),
    /// Zoom by a factor (> 1 is closer).
    Zoom(f32),
    /// A tap at a pixel.
    Tap(Vec2),
}

/// One pointer on the canvas.
#[derive(Debug, Clone, Copy)]
struct Pointer {
    id: i32,
    at: Vec2,
}

/// A press that may still turn out to be a tap.
#[derive(Debug, Clone, Copy)]
struct Press {
    from: Vec2,
    since_ms: f64,
}

/// The pointers down on the canvas and what they are doing.
#[derive(Debug, Clone, Default)]
pub struct Gestures {
    pointers: Vec<Pointer>,
    press: Option<Press>,
    panning: bool,
}

impl Gestures {
    /// A pointer went down; `pan` for the right mouse button or with Shift held.
    pub fn down(&mut self, id: i32, at: Vec2, pan: bool, now_ms: f64) {
        self.pointers.retain(|pointer| pointer.id != id);
        self.pointers.push(Pointer { id, at });
        self.press = (self.pointers.len() == 1).then_some(Press {
            from: at,
            since_ms: now_ms,
        });
        self.panning = pan;
    }

    /// A pointer moved; what that does to the view.
    pub fn moved(&mut self, id: i32, at: Vec2) -> Vec<Gesture> {
        let Some(index) = self.pointers.iter().position(|pointer| pointer.id == id) else {
            return Vec::new();
        };
        if self
            .press
            .is_some_and(|press| press.from.distance(at) > TAP_SLOP_PX)
        {
            self.press = None;
        }
        let before = self.pointers.clone();
        self.pointers[index].at = at;
        match (before.as_slice(), self.pointers.as_slice()) {
            ([one], [now]) => {
                let delta = now.at - one.at;
                if self.press.is_some() || delta == Vec2::ZERO {
                    Vec::new()
                } else if self.panning {
                    vec![Gesture::Pan(delta)]
                } else {
                    vec![Gesture::Rotate(delta)]
                }
            }
            ([a, b, ..], [c, d, ..]) => {
                let spread_before = a.at.distance(b.at);
                let spread_now = c.at.distance(d.at);
                let mut gestures = Vec::new();
                if spread_before > 0.0 && spread_now > 0.0 && spread_now != spread_before {
                    gestures.push(Gesture::Zoom(spread_now / spread_before));
                }
                let pan = (c.at + d.at - a.at - b.at) / 2.0;
                if pan != Vec2::ZERO {
                    gestures.push(Gesture::Pan(pan));
                }
                gestures
            }
            _ => Vec::new(),
        }
    }

    /// A pointer went up (or was cancelled: `tap` false); a tap if it was one.
    pub fn up(&mut self, id: i32, at: Vec2, tap: bool, now_ms: f64) -> Option<Gesture> {
        let was_down = self.pointers.iter().any(|pointer| pointer.id == id);
        self.pointers.retain(|pointer| pointer.id != id);
        let press = self.press.take();
        // The finger left on the glass after a pinch drags on from where it is.
        if let [left] = self.pointers.as_slice() {
            self.press = None;
            self.pointers = vec![*left];
        }
        let press = press.filter(|press| {
            was_down
                && tap
                && now_ms - press.since_ms <= TAP_MS
                && press.from.distance(at) <= TAP_SLOP_PX
        })?;
        Some(Gesture::Tap(press.from))
    }

    /// The wheel turned by `delta_y` pixels (positive: towards the user, zooming out).
    pub fn wheel(delta_y: f64) -> Gesture {
        let lines = (delta_y / 100.0).clamp(-10.0, 10.0) as f32;
        Gesture::Zoom(WHEEL_ZOOM_PER_100PX.powf(-lines))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    #[wasm_bindgen_test(unsupported = test)]
    fn a_short_still_press_is_a_tap() {
        let mut gestures = Gestures::default();
        gestures.down(1, Vec2::new(10.0, 10.0), false, 0.0);
        assert!(gestures.moved(1, Vec2::new(12.0, 13.0)).is_empty());
        assert_eq!(
            gestures.up(1, Vec2::new(12.0, 13.0), true, 150.0),
            Some(Gesture::Tap(Vec2::new(10.0, 10.0)))
        );
        // Too long, or cancelled, is not.
        gestures.down(1, Vec2::ZERO, false, 0.0);
        assert_eq!(gestures.up(1, Vec2::ZERO, true, 900.0), None);
        gestures.down(1, Vec2::ZERO, false, 0.0);
        assert_eq!(gestures.up(1, Vec2::ZERO, false, 10.0), None);
        // An unknown pointer does nothing.
        assert_eq!(gestures.up(7, Vec2::ZERO, true, 10.0), None);
        assert!(gestures.moved(7, Vec2::ONE).is_empty());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn one_finger_orbits_once_it_has_left_the_tap_area() {
        let mut gestures = Gestures::default();
        gestures.down(1, Vec2::ZERO, false, 0.0);
        assert!(
            gestures.moved(1, Vec2::new(5.0, 0.0)).is_empty(),
            "still a tap"
        );
        assert_eq!(
            gestures.moved(1, Vec2::new(20.0, 5.0)),
            vec![Gesture::Rotate(Vec2::new(15.0, 5.0))]
        );
        assert_eq!(
            gestures.moved(1, Vec2::new(21.0, 5.0)),
            vec![Gesture::Rotate(Vec2::new(1.0, 0.0))]
        );
        assert_eq!(gestures.up(1, Vec2::new(21.0, 5.0), true, 100.0), None);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_right_button_pans() {
        let mut gestures = Gestures::default();
        gestures.down(1, Vec2::ZERO, true, 0.0);
        assert_eq!(
            gestures.moved(1, Vec2::new(30.0, 0.0)),
            vec![Gesture::Pan(Vec2::new(30.0, 0.0))]
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn two_fingers_pinch_and_pan() {
        let mut gestures = Gestures::default();
        gestures.down(1, Vec2::new(100.0, 100.0), false, 0.0);
        gestures.down(2, Vec2::new(200.0, 100.0), false, 10.0);
        // Spreading apart: zoom in by 1.5, the middle moves 25 px right.
        assert_eq!(
            gestures.moved(2, Vec2::new(250.0, 100.0)),
            vec![Gesture::Zoom(1.5), Gesture::Pan(Vec2::new(25.0, 0.0))]
        );
        // Both move down, one after the other: the middle follows by halves, and the
        // spread comes back to where it was.
        let first = gestures.moved(1, Vec2::new(100.0, 120.0));
        let second = gestures.moved(2, Vec2::new(250.0, 120.0));
        let (Gesture::Zoom(a), Gesture::Zoom(b)) = (first[0], second[0]) else {
            panic!("{first:?} {second:?}")
        };
        assert!((a * b - 1.0).abs() < 1e-6);
        assert_eq!(first[1], Gesture::Pan(Vec2::new(0.0, 10.0)));
        assert_eq!(second[1], Gesture::Pan(Vec2::new(0.0, 10.0)));
        // Lifting one is no tap; the other then orbits.
        assert_eq!(gestures.up(2, Vec2::new(250.0, 120.0), true, 50.0), None);
        assert_eq!(
            gestures.moved(1, Vec2::new(110.0, 120.0)),
            vec![Gesture::Rotate(Vec2::new(10.0, 0.0))]
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_wheel_zooms_out_towards_the_user() {
        let Gesture::Zoom(out) = Gestures::wheel(100.0) else {
            panic!("a zoom")
        };
        let Gesture::Zoom(closer) = Gestures::wheel(-100.0) else {
            panic!("a zoom")
        };
        assert!(out < 1.0 && closer > 1.0);
        assert!((out * closer - 1.0).abs() < 1e-6);
        assert_eq!(Gestures::wheel(1e9), Gestures::wheel(1000.0));
    }
}
