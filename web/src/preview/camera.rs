//! The 3D view's camera: an orbit around a target point, and the maths between the
//! world and the canvas (projection of a point to a pixel, the ray under a pixel).
//!
//! World frame (metres): `x` to the right along a row, `y` up, `z` towards the front
//! (row numbers grow along `+z`); the ceiling grid is the plane `y = 0` and balls hang
//! below it (see [`super::scene`]). Pixels are canvas pixels with the origin at the
//! top-left corner, `y` growing downwards, as the browser's events and `readPixels`
//! (after flipping) count them.

use glam::camera::rh::{proj, view};
use glam::{Mat4, Vec2, Vec3, Vec4Swizzles};

/// The size of the canvas being drawn, pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Viewport {
    /// Width, pixels.
    pub width: f32,
    /// Height, pixels.
    pub height: f32,
}

impl Viewport {
    /// Width over height (1 for an empty viewport).
    pub fn aspect(&self) -> f32 {
        if self.width > 0.0 && self.height > 0.0 {
            self.width / self.height
        } else {
            1.0
        }
    }
}

/// A half-line in the world: where a tap looks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// The start (on the near plane), metres.
    pub origin: Vec3,
    /// The direction, of length 1.
    pub direction: Vec3,
}

/// How far a drag of one pixel turns the view, radians.
const RADIANS_PER_PIXEL: f32 = 0.006;
/// The steepest view, above or below the horizon, radians (just short of straight
/// up or down, where "up" on screen would be undefined).
const MAX_PITCH: f32 = 1.50;
/// The default view: from the front-right, a little above the grid's middle.
const DEFAULT_YAW: f32 = 0.55;
const DEFAULT_PITCH: f32 = 0.30;
/// The vertical field of view, radians (45°).
const FOV_Y: f32 = std::f32::consts::FRAC_PI_4;
/// How far out a fitted view lets the scene reach, as a share of the half width and
/// height.
const FIT_MARGIN: f32 = 0.92;

/// A camera that looks at `target` from `distance` away, turned `yaw` around the
/// vertical axis and raised `pitch` above the horizon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orbit {
    /// The point looked at, metres.
    pub target: Vec3,
    /// Turn around the vertical axis, radians; 0 looks from the front (`+z`).
    pub yaw: f32,
    /// Height of the eye above the horizon through the target, radians.
    pub pitch: f32,
    /// From the eye to the target, metres.
    pub distance: f32,
    /// Closest and farthest the camera may come, metres.
    pub distance_range: (f32, f32),
}

impl Orbit {
    /// The default view of a scene within `min`..`max` (metres), framed to fit a
    /// viewport of `aspect` (width / height).
    pub fn fit(min: Vec3, max: Vec3, aspect: f32) -> Self {
        let radius = ((max - min).length() / 2.0).max(0.1);
        // The narrower of the two fields of view must hold the scene's sphere...
        let half_fov_x = ((FOV_Y / 2.0).tan() * aspect.max(0.1)).atan();
        let half_fov = half_fov_x.min(FOV_Y / 2.0);
        let sphere_distance = radius / half_fov.sin();
        let mut orbit = Self {
            target: (min + max) / 2.0,
            yaw: DEFAULT_YAW,
            pitch: DEFAULT_PITCH,
            distance: sphere_distance,
            distance_range: (radius * 0.05, sphere_distance * 6.0),
        };
        // ...but a box fills less of it: come as close as keeps every corner in view,
        // with a margin.
        let viewport = Viewport {
            width: aspect.max(0.1),
            height: 1.0,
        };
        let corners = (0..8).map(|corner: u32| {
            Vec3::new(
                if corner & 1 == 0 { min.x } else { max.x },
                if corner & 2 == 0 { min.y } else { max.y },
                if corner & 4 == 0 { min.z } else { max.z },
            )
        });
        let fits = |orbit: &Self| {
            corners.clone().all(|corner| {
                orbit.pixel_of(corner, viewport).is_some_and(|pixel| {
                    let ndc = Vec2::new(pixel.x / viewport.width, pixel.y) * 2.0 - Vec2::ONE;
                    ndc.abs().max_element() <= FIT_MARGIN
                })
            })
        };
        let (mut inside, mut outside) = (sphere_distance * 1.2, sphere_distance * 0.2);
        for _ in 0..24 {
            orbit.distance = (inside + outside) / 2.0;
            if fits(&orbit) {
                inside = orbit.distance;
            } else {
                outside = orbit.distance;
            }
        }
        orbit.distance = inside;
        orbit
    }

    /// Where the eye is, metres.
    pub fn eye(&self) -> Vec3 {
        let (sin_yaw, cos_yaw) = self.yaw.sin_cos();
        let (sin_pitch, cos_pitch) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(cos_pitch * sin_yaw, sin_pitch, cos_pitch * cos_yaw)
    }

    /// World to camera.
    pub fn view_from_world(&self) -> Mat4 {
        view::look_at_mat4(self.eye(), self.target, Vec3::Y)
    }

    /// Camera to clip space (WebGL's: depth from −1 to 1).
    pub fn clip_from_view(&self, aspect: f32) -> Mat4 {
        let near = (self.distance * 0.01).max(0.01);
        let far = self.distance * 20.0 + 100.0;
        proj::opengl::perspective(FOV_Y, aspect, near, far)
    }

    /// World to clip space, for a viewport of `aspect`.
    pub fn clip_from_world(&self, aspect: f32) -> Mat4 {
        self.clip_from_view(aspect) * self.view_from_world()
    }

    /// The direction towards the light, of length 1: a lamp above and to the right of
    /// the eye, so whatever is seen is lit from the front.
    pub fn light(&self) -> Vec3 {
        let view = self.view_from_world().inverse();
        let right = view.x_axis.xyz();
        let up = view.y_axis.xyz();
        let back = view.z_axis.xyz();
        (back + 0.6 * up + 0.3 * right).normalize()
    }

    /// The pixel where `world` appears, or `None` behind the eye.
    pub fn pixel_of(&self, world: Vec3, viewport: Viewport) -> Option<Vec2> {
        let clip = self.clip_from_world(viewport.aspect()) * world.extend(1.0);
        if clip.w <= 0.0 {
            return None;
        }
        let ndc = clip.xyz() / clip.w;
        Some(Vec2::new(
            (ndc.x + 1.0) / 2.0 * viewport.width,
            (1.0 - ndc.y) / 2.0 * viewport.height,
        ))
    }

    /// The ray from the eye through `pixel`.
    pub fn ray_through(&self, pixel: Vec2, viewport: Viewport) -> Ray {
        let world_from_clip = self.clip_from_world(viewport.aspect()).inverse();
        let ndc = Vec2::new(
            pixel.x / viewport.width.max(1.0) * 2.0 - 1.0,
            1.0 - pixel.y / viewport.height.max(1.0) * 2.0,
        );
        let near = world_from_clip.project_point3(ndc.extend(-1.0));
        let far = world_from_clip.project_point3(ndc.extend(1.0));
        Ray {
            origin: near,
            direction: (far - near).normalize_or(Vec3::NEG_Z),
        }
    }

    /// Turns the view by a drag of `delta` pixels: sideways turns around the
    /// vertical axis, up and down raises or lowers the eye.
    pub fn rotate(&mut self, delta: Vec2) {
        self.yaw = (self.yaw - delta.x * RADIANS_PER_PIXEL) % std::f32::consts::TAU;
        self.pitch = (self.pitch + delta.y * RADIANS_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Comes closer by `factor` (> 1 zooms in, < 1 out), within the distance range.
    pub fn zoom(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            let (near, far) = self.distance_range;
            self.distance = (self.distance / factor).clamp(near, far);
        }
    }

    /// Slides the view so that what was under the fingers follows a move of `delta`
    /// pixels.
    pub fn pan(&mut self, delta: Vec2, viewport: Viewport) {
        let metres_per_pixel = 2.0 * self.distance * (FOV_Y / 2.0).tan() / viewport.height.max(1.0);
        let view = self.view_from_world().inverse();
        let right = view.x_axis.xyz();
        let up = view.y_axis.xyz();
        self.target += (-delta.x * right + delta.y * up) * metres_per_pixel;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    const VIEWPORT: Viewport = Viewport {
        width: 800.0,
        height: 600.0,
    };

    fn close(a: Vec2, b: Vec2) -> bool {
        (a - b).length() < 0.01
    }

    fn front_view() -> Orbit {
        Orbit {
            target: Vec3::ZERO,
            yaw: 0.0,
            pitch: 0.0,
            distance: 10.0,
            distance_range: (1.0, 100.0),
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_target_lands_in_the_middle() {
        let camera = Orbit::fit(
            Vec3::new(-2.0, -7.5, -2.0),
            Vec3::new(2.0, 0.0, 2.0),
            4.0 / 3.0,
        );
        let middle = camera.pixel_of(camera.target, VIEWPORT).unwrap();
        assert!(close(middle, Vec2::new(400.0, 300.0)), "{middle}");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_known_point_lands_on_the_expected_pixel() {
        // Seen from the front at 10 m with a 45° field of view, the visible half
        // height at the target is 10 tan(22.5°) m = 4.142 m: a point 1 m up and 1 m to
        // the right is 300 / 4.142 = 72.43 px up and right of the centre.
        let camera = front_view();
        let pixel = camera.pixel_of(Vec3::new(1.0, 1.0, 0.0), VIEWPORT).unwrap();
        let px = 300.0 / (10.0 * (FOV_Y / 2.0).tan());
        assert!(close(pixel, Vec2::new(400.0 + px, 300.0 - px)), "{pixel}");
        assert_eq!(
            camera.pixel_of(Vec3::new(0.0, 0.0, 20.0), VIEWPORT),
            None,
            "behind"
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_ray_under_a_pixel_goes_through_the_point_there() {
        let mut camera = front_view();
        camera.yaw = 0.7;
        camera.pitch = -0.4;
        let point = Vec3::new(0.5, -1.2, 0.3);
        let pixel = camera.pixel_of(point, VIEWPORT).unwrap();
        let ray = camera.ray_through(pixel, VIEWPORT);
        let along = (point - ray.origin).dot(ray.direction);
        let miss = (ray.origin + along * ray.direction - point).length();
        assert!(miss < 1e-4, "{miss}");
        assert!((ray.direction.length() - 1.0).abs() < 1e-6);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_fitted_view_holds_the_whole_scene() {
        let (min, max) = (Vec3::new(-5.0, -8.0, -5.0), Vec3::new(5.0, 0.0, 5.0));
        for aspect in [9.0 / 16.0, 1.0, 16.0 / 9.0] {
            let viewport = Viewport {
                width: 600.0 * aspect,
                height: 600.0,
            };
            let camera = Orbit::fit(min, max, aspect);
            let mut widest = 0.0f32;
            for corner in 0..8 {
                let pick = |bit: u32, lo: f32, hi: f32| if corner & bit == 0 { lo } else { hi };
                let point = Vec3::new(
                    pick(1, min.x, max.x),
                    pick(2, min.y, max.y),
                    pick(4, min.z, max.z),
                );
                let pixel = camera.pixel_of(point, viewport).unwrap();
                assert!(
                    (0.0..=viewport.width).contains(&pixel.x)
                        && (0.0..=viewport.height).contains(&pixel.y),
                    "corner {point} at {pixel} with aspect {aspect}"
                );
                let half = Vec2::new(viewport.width, viewport.height) / 2.0;
                widest = widest.max(((pixel - half) / half).abs().max_element());
            }
            // Tight: the scene reaches the margin on some side.
            assert!(widest > FIT_MARGIN - 0.01, "{widest} with aspect {aspect}");
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn drags_turn_zoom_and_pan() {
        let mut camera = front_view();
        camera.rotate(Vec2::new(0.0, 10_000.0));
        assert_eq!(camera.pitch, MAX_PITCH, "never over the top");
        camera.rotate(Vec2::new(-100.0, 0.0));
        assert!((camera.yaw - 0.6).abs() < 1e-6);

        camera.zoom(2.0);
        assert_eq!(camera.distance, 5.0);
        camera.zoom(1e9);
        assert_eq!(camera.distance, 1.0);
        camera.zoom(0.0);
        camera.zoom(f32::NAN);
        assert_eq!(camera.distance, 1.0);

        // What was under the fingers follows them.
        let mut camera = front_view();
        let point = Vec3::new(0.3, 0.2, 0.0);
        let before = camera.pixel_of(point, VIEWPORT).unwrap();
        camera.pan(Vec2::new(40.0, -25.0), VIEWPORT);
        let after = camera.pixel_of(point, VIEWPORT).unwrap();
        assert!(
            close(after - before, Vec2::new(40.0, -25.0)),
            "{}",
            after - before
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_light_comes_from_the_eye_side() {
        let camera = front_view();
        let light = camera.light();
        assert!((light.length() - 1.0).abs() < 1e-6);
        assert!(light.z > 0.5 && light.y > 0.0 && light.x > 0.0, "{light}");
    }
}
