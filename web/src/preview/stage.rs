//! A show drawn on a canvas: the frame loop's work, shared by the preview and the
//! performance panel.
//!
//! A [`Stage`] keeps the show's [`Sampler`] (the same evaluator as the simulator)
//! with every per-frame buffer, the camera, and a renderer: WebGL2 ([`super::gl`]) or
//! the 2D top view ([`super::top_view`]). [`Stage::draw`] samples the show at a time
//! and draws it without allocating; balls beyond a limit are drawn red.

use floatball_shared::show::{DEFAULT_TRAVEL_MM, Layout, Sampler, Show};
use glam::Vec2;
use wasm_bindgen::JsCast;
use web_sys::{CanvasRenderingContext2d, HtmlCanvasElement};

use super::camera::{Orbit, Viewport};
use super::gestures::Gesture;
use super::gl::{FrameView, GlView, pack_colour};
use super::scene::Scene;
use super::top_view;

/// The colour of a ball beyond a limit (the app's danger red).
pub const BEYOND_COLOUR: [u8; 3] = [229, 52, 44];
/// The largest device pixel ratio drawn at (sharper costs more than it shows).
const MAX_PIXEL_RATIO: f64 = 2.0;
/// The size used while the canvas has no layout yet, CSS pixels.
const UNLAID_SIZE: (f64, f64) = (320.0, 240.0);

/// Which renderer draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RendererKind {
    /// 3D through WebGL2.
    WebGl2,
    /// The 2D top view (the fallback without WebGL2, or the user's choice).
    TopView,
}

impl RendererKind {
    /// The name used in `data-renderer`.
    pub fn name(self) -> &'static str {
        match self {
            RendererKind::WebGl2 => "webgl2",
            RendererKind::TopView => "2d",
        }
    }
}

#[derive(Debug)]
enum Renderer {
    Gl(Box<GlView>),
    Top(CanvasRenderingContext2d),
}

/// A show, its buffers, the camera and a renderer on one canvas.
#[derive(Debug)]
pub struct Stage {
    canvas: HtmlCanvasElement,
    renderer: Renderer,
    layout: Layout,
    scene: Scene,
    sampler: Sampler,
    positions_mm: Vec<f32>,
    colours: Vec<[u8; 3]>,
    /// Per ball: the centre's height and the packed colour, as the GPU reads them.
    balls: Vec<f32>,
    beyond: Vec<usize>,
    selected: Option<usize>,
    camera: Orbit,
    camera_moved: bool,
    viewport: Viewport,
    /// The show time last drawn; `None` when the next frame must be drawn anyway.
    drawn_ms: Option<f64>,
    /// The installation's travel and pitch, when known (else the defaults' and the
    /// show's).
    matrix: Option<Matrix>,
}

/// What the installation says about the picture: how far balls travel and how far
/// apart they hang.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Matrix {
    /// Lowest position, mm below the top.
    pub travel_mm: f64,
    /// Distance between neighbouring balls, mm.
    pub pitch_mm: f64,
}

/// The scene of `layout`, on the installation `matrix` when it is known.
fn scene_of(layout: Layout, matrix: Option<Matrix>) -> Scene {
    match matrix {
        Some(matrix) => Scene::new(
            Layout {
                pitch_mm: matrix.pitch_mm,
                ..layout
            },
            matrix.travel_mm,
        ),
        None => Scene::new(layout, DEFAULT_TRAVEL_MM),
    }
}

/// `performance.now()`, ms.
pub fn now_ms() -> f64 {
    web_sys::window()
        .and_then(|window| window.performance())
        .map_or_else(js_sys::Date::now, |performance| performance.now())
}

impl Stage {
    /// `show` on `canvas` drawn by `kind`; `beyond` lists the balls that break a
    /// limit. An error says why that renderer cannot draw on this canvas.
    pub fn new(
        canvas: HtmlCanvasElement,
        show: &Show,
        beyond: Vec<usize>,
        kind: RendererKind,
    ) -> Result<Self, String> {
        let scene = scene_of(show.layout, None);
        let renderer = match kind {
            RendererKind::WebGl2 => Renderer::Gl(Box::new(GlView::new(&canvas)?)),
            RendererKind::TopView => Renderer::Top(
                canvas
                    .get_context("2d")
                    .ok()
                    .flatten()
                    .and_then(|context| context.dyn_into().ok())
                    .ok_or("this canvas has no 2D context")?,
            ),
        };
        let (min, max) = scene.bounds();
        let mut stage = Self {
            canvas,
            renderer,
            layout: show.layout,
            scene,
            sampler: Sampler::new(show),
            positions_mm: Vec::new(),
            colours: Vec::new(),
            balls: Vec::new(),
            beyond: Vec::new(),
            selected: None,
            camera: Orbit::fit(min, max, 1.0),
            camera_moved: false,
            viewport: Viewport {
                width: 0.0,
                height: 0.0,
            },
            drawn_ms: None,
            matrix: None,
        };
        stage.set_show(show, beyond)?;
        Ok(stage)
    }

    /// Shows another show on the same canvas. The view is framed anew for another
    /// layout; on the same one (a show regenerated while its parameters change) a
    /// view the user moved stays.
    pub fn set_show(&mut self, show: &Show, beyond: Vec<usize>) -> Result<(), String> {
        let units = show.tracks.len();
        let same_layout = self.layout == show.layout && self.positions_mm.len() == units;
        self.layout = show.layout;
        self.scene = scene_of(show.layout, self.matrix);
        // The last show's layout is let go first, so the new one reuses its memory
        // instead of growing the page's (and, on the first change, waiting for it).
        drop(std::mem::take(&mut self.sampler));
        self.sampler = Sampler::new(show);
        self.positions_mm = vec![0.0; units];
        self.colours = vec![[0; 3]; units];
        self.balls = vec![0.0; units * 2];
        self.beyond = beyond;
        self.selected = None;
        if !(same_layout && self.camera_moved) {
            self.camera_moved = false;
            self.fit_camera();
        }
        self.drawn_ms = None;
        if let Renderer::Gl(gl) = &mut self.renderer {
            gl.set_scene(&self.scene, units)?;
        }
        Ok(())
    }

    /// Marks the balls of `beyond` as breaking a limit (drawn red), from the next
    /// frame.
    pub fn set_beyond(&mut self, beyond: Vec<usize>) {
        self.beyond = beyond;
        self.drawn_ms = None;
    }

    /// Draws on the installation `matrix` (its travel and pitch), or on the defaults
    /// and the show's pitch (`None`); the view is framed anew when that changes.
    pub fn set_matrix(&mut self, matrix: Option<Matrix>) -> Result<(), String> {
        if matrix == self.matrix {
            return Ok(());
        }
        self.matrix = matrix;
        self.scene = scene_of(self.layout, matrix);
        if !self.camera_moved {
            self.fit_camera();
        }
        self.drawn_ms = None;
        if let Renderer::Gl(gl) = &mut self.renderer {
            gl.set_scene(&self.scene, self.positions_mm.len())?;
        }
        Ok(())
    }

    /// Which renderer draws.
    pub fn kind(&self) -> RendererKind {
        match self.renderer {
            Renderer::Gl(_) => RendererKind::WebGl2,
            Renderer::Top(_) => RendererKind::TopView,
        }
    }

    /// The canvas drawn on.
    pub fn canvas(&self) -> &HtmlCanvasElement {
        &self.canvas
    }

    /// The camera of the 3D view.
    pub fn camera(&self) -> Orbit {
        self.camera
    }

    /// The scene of the 3D view.
    pub fn scene(&self) -> Scene {
        self.scene
    }

    /// The canvas's size as last drawn, pixels.
    pub fn viewport(&self) -> Viewport {
        self.viewport
    }

    /// Every ball's position in the last frame drawn, mm below the top.
    pub fn positions_mm(&self) -> &[f32] {
        &self.positions_mm
    }

    /// Marks `unit` (the ball whose plot is shown), or none.
    pub fn select(&mut self, unit: Option<usize>) {
        if self.selected != unit {
            self.selected = unit;
            self.drawn_ms = None;
        }
    }

    /// Back to the default view.
    pub fn reset_view(&mut self) {
        self.camera_moved = false;
        self.fit_camera();
        self.drawn_ms = None;
    }

    /// Moves the camera by a gesture in CSS pixels (taps are for [`Self::pick`]).
    pub fn apply(&mut self, gesture: Gesture) {
        let scale = self.device_pixels_per_css_pixel();
        match gesture {
            Gesture::Rotate(delta) => self.camera.rotate(delta),
            Gesture::Pan(delta) => self.camera.pan(delta * scale, self.viewport),
            Gesture::Zoom(factor) => self.camera.zoom(factor),
            Gesture::Tap(_) => return,
        }
        self.camera_moved = true;
        self.drawn_ms = None;
    }

    /// The ball under `css` (CSS pixels from the canvas's top-left corner), as drawn
    /// in the last frame.
    pub fn pick(&self, css: Vec2) -> Option<usize> {
        let pixel = css * self.device_pixels_per_css_pixel();
        match self.renderer {
            Renderer::Gl(_) => self.scene.pick(
                self.camera.ray_through(pixel, self.viewport),
                &self.positions_mm,
            ),
            Renderer::Top(_) => top_view::Geometry::fit(
                self.layout,
                f64::from(self.viewport.width),
                f64::from(self.viewport.height),
            )
            .hit(f64::from(pixel.x), f64::from(pixel.y), &self.positions_mm),
        }
    }

    /// Samples every ball at `t_ms` into the stage's buffers (what [`Self::draw`]
    /// does first); balls beyond a limit turn red.
    pub fn sample(&mut self, t_ms: f64) {
        self.sampler
            .sample(t_ms, &mut self.positions_mm, Some(&mut self.colours));
        for unit in &self.beyond {
            if let Some(colour) = self.colours.get_mut(*unit) {
                *colour = BEYOND_COLOUR;
            }
        }
    }

    /// Samples and draws the show at `t_ms` unless that very frame is on screen
    /// already (`force` draws anyway); whether it drew. The GPU may still be drawing
    /// on return (see [`Self::finish`]).
    pub fn draw(&mut self, t_ms: f64, force: bool) -> bool {
        let resized = self.fit_canvas();
        if !force && !resized && self.drawn_ms == Some(t_ms) {
            return false;
        }
        self.sample(t_ms);
        match &mut self.renderer {
            Renderer::Gl(gl) => {
                for (unit, (ball, (position_mm, colour))) in self
                    .balls
                    .chunks_exact_mut(2)
                    .zip(self.positions_mm.iter().zip(&self.colours))
                    .enumerate()
                {
                    let centre = self.scene.ball_centre(unit, *position_mm);
                    ball.copy_from_slice(&[centre.y, pack_colour(*colour)]);
                }
                let aspect = self.viewport.aspect();
                gl.draw(&FrameView {
                    clip_from_world: self.camera.clip_from_world(aspect),
                    eye: self.camera.eye(),
                    light: self.camera.light(),
                    viewport: self.viewport,
                    balls: &self.balls,
                    selected: self.selected,
                });
            }
            Renderer::Top(context) => top_view::draw(
                context,
                self.layout,
                (
                    f64::from(self.viewport.width),
                    f64::from(self.viewport.height),
                ),
                &self.positions_mm,
                &self.colours,
                self.selected,
            ),
        }
        self.drawn_ms = Some(t_ms);
        true
    }

    /// Waits until the GPU has finished the frames drawn so far (the 2D canvas draws
    /// at once).
    pub fn finish(&self) {
        if let Renderer::Gl(gl) = &self.renderer {
            gl.finish();
        }
    }

    fn device_pixels_per_css_pixel(&self) -> f32 {
        let css_width = self.canvas.client_width();
        if css_width > 0 {
            self.viewport.width / css_width as f32
        } else {
            1.0
        }
    }

    /// Sizes the canvas to its box at the screen's pixel ratio; whether it changed.
    fn fit_canvas(&mut self) -> bool {
        let ratio = web_sys::window()
            .map_or(1.0, |window| window.device_pixel_ratio())
            .clamp(1.0, MAX_PIXEL_RATIO);
        let (css_width, css_height) = (
            f64::from(self.canvas.client_width()),
            f64::from(self.canvas.client_height()),
        );
        let (css_width, css_height) = if css_width < 1.0 || css_height < 1.0 {
            UNLAID_SIZE
        } else {
            (css_width, css_height)
        };
        let width = (css_width * ratio).round() as u32;
        let height = (css_height * ratio).round() as u32;
        let viewport = Viewport {
            width: width as f32,
            height: height as f32,
        };
        if self.canvas.width() != width || self.canvas.height() != height {
            self.canvas.set_width(width);
            self.canvas.set_height(height);
        }
        if viewport == self.viewport {
            return false;
        }
        self.viewport = viewport;
        if !self.camera_moved {
            self.fit_camera();
        }
        true
    }

    fn fit_camera(&mut self) {
        let (min, max) = self.scene.bounds();
        self.camera = Orbit::fit(min, max, self.viewport.aspect());
    }
}
