//! The preview in a real browser (`wasm-pack test --headless --chrome web`): the
//! WebGL2 renderer read back pixel by pixel against the camera maths and the
//! lighting model, the controls, taps and gestures, the plot, live mode, the 2D
//! fallback, and the performance figures.
//!
//! Headless Chromium draws WebGL2 with SwiftShader (`web/webdriver.json`). Tests mount
//! components without the app's stylesheet, so canvases have the browser's default
//! size (300 × 150 CSS pixels) unless a test sets one.

use std::sync::Arc;

use floatball_shared::api::{PlayerState, Status};
use floatball_shared::show::{
    ColourKey, DEFAULT_TRAVEL_MM, Layout, Limits, Sampler, Show, Track, TrackRow, validate,
};
use floatball_web::i18n::Lang;
use floatball_web::preview::camera::{Orbit, Viewport};
use floatball_web::preview::gestures::Gesture;
use floatball_web::preview::gl::stride_for;
use floatball_web::preview::perf::{PerfPanel, SIZES};
use floatball_web::preview::plot::{BallPlot, Panel};
use floatball_web::preview::scene::{Scene, lit};
use floatball_web::preview::stage::{BEYOND_COLOUR, RendererKind, Stage};
use floatball_web::preview::{PreviewPage, show_changed};
use glam::Vec2;
use leptos::mount::mount_to;
use leptos::prelude::*;
use leptos::task::tick;
use wasm_bindgen::{JsCast, JsValue};
use wasm_bindgen_test::*;
use web_sys::{HtmlCanvasElement, WebGl2RenderingContext as Gl};

use crate::dom::*;

// ----------------------------------------------------------------------------------
// Shows
// ----------------------------------------------------------------------------------

/// A track that stays at `position_mm` for a second, in `rgb` (white if `None`).
fn still(position_mm: f64, rgb: Option<[u8; 3]>) -> Track {
    Track {
        start_mm: position_mm,
        rows: vec![TrackRow::new(position_mm, 0.0, 250); 4],
        colours: rgb
            .map(|rgb| vec![ColourKey { time_ms: 0, rgb }])
            .unwrap_or_default(),
    }
}

fn layout(rows: u32, cols: u32) -> Layout {
    Layout {
        rows,
        cols,
        pitch_mm: 500.0,
    }
}

/// Six balls, each its own colour and height.
fn coloured_show() -> Show {
    let colours = [
        [230, 40, 40],
        [40, 200, 60],
        [50, 90, 240],
        [240, 200, 40],
        [200, 60, 220],
        [40, 220, 220],
    ];
    Show {
        outputs: Vec::new(),
        name: "colours".into(),
        layout: layout(2, 3),
        tracks: colours
            .iter()
            .enumerate()
            .map(|(unit, rgb)| still(800.0 + 900.0 * unit as f64, Some(*rgb)))
            .collect(),
    }
}

/// Ball 0 hangs high, ball 1 low, both white.
fn high_and_low_show() -> Show {
    Show {
        outputs: Vec::new(),
        name: "two".into(),
        layout: layout(1, 2),
        tracks: vec![still(100.0, None), still(7000.0, None)],
    }
}

/// Ball 0 stays (green); ball 1 (blue) drops 2 m in a quarter of a second: too fast.
fn speeding_show() -> Show {
    let mut fast = still(1000.0, Some([40, 90, 240]));
    fast.rows[1] = TrackRow::new(3000.0, 0.0, 250);
    fast.rows[2] = TrackRow::new(3000.0, 0.0, 250);
    fast.rows[3] = TrackRow::new(3000.0, 0.0, 250);
    Show {
        outputs: Vec::new(),
        name: "speeding".into(),
        layout: layout(1, 2),
        tracks: vec![still(1000.0, Some([40, 200, 60])), fast],
    }
}

// ----------------------------------------------------------------------------------
// Helpers
// ----------------------------------------------------------------------------------

fn stage_canvas(container: &web_sys::HtmlElement) -> HtmlCanvasElement {
    element(container, "preview-canvas").unchecked_into()
}

/// The show time on screen, ms.
fn shown_ms(container: &web_sys::HtmlElement) -> f64 {
    attribute(container, "preview-time", "data-t-ms")
        .parse()
        .unwrap()
}

/// A pointer event at `at` (CSS pixels from the canvas's top-left corner).
fn pointer(canvas: &HtmlCanvasElement, kind: &str, id: i32, at: Vec2, button: i16) {
    let rect = canvas.get_bounding_client_rect();
    let init = web_sys::PointerEventInit::new();
    init.set_bubbles(true);
    init.set_pointer_id(id);
    init.set_is_primary(id == 1);
    init.set_button(button);
    init.set_client_x((rect.left() + f64::from(at.x)).round() as i32);
    init.set_client_y((rect.top() + f64::from(at.y)).round() as i32);
    let event = web_sys::PointerEvent::new_with_event_init_dict(kind, &init).unwrap();
    canvas.dispatch_event(&event).unwrap();
}

fn tap(canvas: &HtmlCanvasElement, at: Vec2) {
    pointer(canvas, "pointerdown", 1, at, 0);
    pointer(canvas, "pointerup", 1, at, 0);
}

fn gl_of(canvas: &HtmlCanvasElement) -> Gl {
    canvas
        .get_context("webgl2")
        .unwrap()
        .expect("the canvas has a WebGL2 context")
        .unchecked_into()
}

/// Every pixel of a WebGL2 canvas, RGBA rows from the bottom.
fn gl_pixels(canvas: &HtmlCanvasElement) -> Vec<u8> {
    let (width, height) = (canvas.width() as i32, canvas.height() as i32);
    let mut pixels = vec![0u8; (width * height * 4) as usize];
    gl_of(canvas)
        .read_pixels_with_opt_u8_array(
            0,
            0,
            width,
            height,
            Gl::RGBA,
            Gl::UNSIGNED_BYTE,
            Some(&mut pixels),
        )
        .unwrap();
    pixels
}

/// The WebGL2 canvas pixel at `at` (pixels from the top-left corner).
fn gl_pixel(canvas: &HtmlCanvasElement, at: Vec2) -> [u8; 3] {
    let mut pixel = [0u8; 4];
    let y = canvas.height() as i32 - 1 - at.y.floor() as i32;
    gl_of(canvas)
        .read_pixels_with_opt_u8_array(
            at.x.floor() as i32,
            y,
            1,
            1,
            Gl::RGBA,
            Gl::UNSIGNED_BYTE,
            Some(&mut pixel),
        )
        .unwrap();
    [pixel[0], pixel[1], pixel[2]]
}

/// The 2D canvas pixel at `at` (pixels from the top-left corner).
fn pixel_2d(canvas: &HtmlCanvasElement, at: Vec2) -> [u8; 3] {
    let context = canvas
        .get_context("2d")
        .unwrap()
        .unwrap()
        .unchecked_into::<web_sys::CanvasRenderingContext2d>();
    let data = context
        .get_image_data(f64::from(at.x.floor()), f64::from(at.y.floor()), 1.0, 1.0)
        .unwrap()
        .data();
    [data[0], data[1], data[2]]
}

fn near(got: [u8; 3], want: [u8; 3], tolerance: u8) -> bool {
    got.iter()
        .zip(want)
        .all(|(g, w)| g.abs_diff(w) <= tolerance)
}

/// Where the preview's default camera shows ball `unit` of `show` at `t_ms`, in canvas
/// pixels, and the camera.
fn default_view_of(canvas: &HtmlCanvasElement, show: &Show, unit: usize, t_ms: f64) -> Vec2 {
    let scene = Scene::new(show.layout, DEFAULT_TRAVEL_MM);
    let viewport = Viewport {
        width: canvas.width() as f32,
        height: canvas.height() as f32,
    };
    let (min, max) = scene.bounds();
    let camera = Orbit::fit(min, max, viewport.aspect());
    let mut positions = vec![0.0f32; show.tracks.len()];
    Sampler::new(show).sample(t_ms, &mut positions, None);
    camera
        .pixel_of(scene.ball_centre(unit, positions[unit]), viewport)
        .unwrap()
}

/// Mounts a preview of `show`, waits for its 3D stage, and pauses it at `t_ms`.
async fn mount_paused(
    show: Show,
    t_ms: f64,
) -> (web_sys::HtmlElement, impl Sized, HtmlCanvasElement) {
    let container = fresh_container();
    let show = RwSignal::new(Some(Arc::new(show)));
    let mounted = mount_to(container.clone(), move || {
        view! { <PreviewPage show=show lang=Lang::En /> }
    });
    until("the 3D stage", || {
        attribute(&container, "preview-canvas", "data-renderer") == "webgl2"
    })
    .await;
    element(&container, "preview-toggle").click();
    set_value(&container, "preview-slider", &t_ms.to_string(), "input");
    // Two animation frames: the paused frame is on screen.
    sleep(100).await;
    let canvas = stage_canvas(&container);
    (container, mounted, canvas)
}

// ----------------------------------------------------------------------------------
// The renderer
// ----------------------------------------------------------------------------------

/// Shows are compared by identity: the same `Arc` is no change (no row-by-row
/// comparison of a large show), another one is, even with the same rows.
#[wasm_bindgen_test]
fn a_show_signal_changes_when_the_show_is_another_one() {
    let show = Some(Arc::new(high_and_low_show()));
    let copy = Some(Arc::new(high_and_low_show()));
    assert!(!show_changed(Some(&show), Some(&show.clone())));
    assert!(show_changed(Some(&show), Some(&copy)));
    assert!(show_changed(None, Some(&show)));
    assert!(show_changed(Some(&show), Some(&None)));
    assert!(show_changed(Some(&None), Some(&show)));
    assert!(!show_changed(Some(&None), Some(&None)));
    assert!(show_changed(None, Some(&None)));
}

#[wasm_bindgen_test]
async fn every_ball_lands_on_its_pixel_in_its_lit_colour() {
    let canvas = fresh_canvas(480, 360);
    let show = coloured_show();
    let mut stage = Stage::new(canvas.clone(), &show, Vec::new(), RendererKind::WebGl2)
        .expect("WebGL2 in headless Chromium");
    assert_eq!(stage.kind(), RendererKind::WebGl2);
    assert!(stage.draw(500.0, true), "a frame");
    assert_eq!((canvas.width(), canvas.height()), (480, 360));

    let camera = stage.camera();
    let scene = stage.scene();
    let viewport = stage.viewport();
    let light = camera.light();
    for (unit, track) in show.tracks.iter().enumerate() {
        let centre = scene.ball_centre(unit, track.start_mm as f32);
        let pixel = camera.pixel_of(centre, viewport).unwrap();
        assert!(
            pixel.x > 0.0 && pixel.y > 0.0 && pixel.x < 480.0 && pixel.y < 360.0,
            "ball {unit} at {pixel}"
        );
        // At the middle of a ball, its surface faces the eye.
        let normal = (camera.eye() - centre).normalize();
        let want = lit(track.colours[0].rgb, normal, light);
        let got = gl_pixel(&canvas, pixel);
        assert!(
            near(got, want, 8),
            "ball {unit} at {pixel}: {got:?}, want {want:?}"
        );
    }

    // Not blank: most of the picture is background, but balls, cables and the grid
    // cover a good part of it in many colours.
    let pixels = gl_pixels(&canvas);
    let background = [11u8, 17, 23];
    let drawn = pixels
        .chunks_exact(4)
        .filter(|px| !near([px[0], px[1], px[2]], background, 2))
        .count();
    let mut colours: Vec<[u8; 3]> = pixels
        .chunks_exact(4)
        .map(|px| [px[0], px[1], px[2]])
        .collect();
    colours.sort_unstable();
    colours.dedup();
    let total = pixels.len() / 4;
    assert!(drawn * 100 > total, "{drawn} of {total} pixels drawn");
    assert!(drawn * 2 < total, "{drawn} of {total} pixels drawn");
    assert!(colours.len() > 50, "{} colours", colours.len());
}

/// The cables' colour in the picture (`CABLE_COLOUR` in `preview::gl`).
const CABLE_RGB: [u8; 3] = [115, 128, 140];

/// A `rows` × `cols` show, every ball still at `position_mm`.
fn still_matrix(rows: u32, cols: u32, position_mm: f64) -> Show {
    Show {
        outputs: Vec::new(),
        name: "matrix".into(),
        layout: layout(rows, cols),
        tracks: (0..rows * cols)
            .map(|_| still(position_mm, Some([240, 200, 40])))
            .collect(),
    }
}

/// Draws `show` on a 640 × 480 canvas with the default view; the stage, the canvas,
/// its pixels and every how many rows and columns a cable is drawn.
fn draw_matrix(show: &Show) -> (Stage, HtmlCanvasElement, Vec<u8>, usize) {
    let canvas = fresh_canvas(640, 480);
    let mut stage = Stage::new(canvas.clone(), show, Vec::new(), RendererKind::WebGl2)
        .expect("WebGL2 in headless Chromium");
    assert!(stage.draw(500.0, true), "a frame");
    let (camera, scene, viewport) = (stage.camera(), stage.scene(), stage.viewport());
    // As the renderer decides: from how far apart the nearest balls are on screen.
    let nearest = stage
        .positions_mm()
        .iter()
        .enumerate()
        .map(|(unit, position_mm)| scene.ball_centre(unit, *position_mm).distance(camera.eye()))
        .fold(f32::INFINITY, f32::min);
    let focal_px = viewport.height / 2.0 / std::f32::consts::FRAC_PI_8.tan();
    let stride = stride_for(scene.grid().2 * focal_px / nearest);
    let pixels = gl_pixels(&canvas);
    (stage, canvas, pixels, stride)
}

/// Of nine points along the cable of `unit` (between its ball and the grid), how
/// many show the cable's colour (within a pixel).
fn cable_points_shown(stage: &Stage, pixels: &[u8], unit: usize) -> usize {
    let (camera, scene, viewport) = (stage.camera(), stage.scene(), stage.viewport());
    let (width, height) = (viewport.width as i32, viewport.height as i32);
    let anchor = scene.anchor(unit);
    let top =
        scene.ball_centre(unit, stage.positions_mm()[unit]) + glam::Vec3::Y * scene.ball_radius_m;
    (1..=9)
        .filter(|k| {
            let at = camera
                .pixel_of(top.lerp(anchor, *k as f32 / 10.0), viewport)
                .unwrap();
            let (x, y) = (at.x.floor() as i32, height - 1 - at.y.floor() as i32);
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (x, y) = (x + dx, y + dy);
                    if x < 0 || y < 0 || x >= width || y >= height {
                        return false;
                    }
                    let i = ((y * width + x) * 4) as usize;
                    near([pixels[i], pixels[i + 1], pixels[i + 2]], CABLE_RGB, 4)
                })
            })
        })
        .count()
}

/// A sparse view draws every ball's cable, up to the grid; a dense one (10,000
/// balls seen whole) draws only every k-th, but those still hang from the grid down
/// to their ball, visible above it.
#[wasm_bindgen_test]
async fn cables_hang_above_the_balls_in_sparse_and_dense_views() {
    let show = still_matrix(4, 4, 5000.0);
    let (stage, _canvas, pixels, stride) = draw_matrix(&show);
    assert_eq!(stride, 1, "a sparse view");
    for unit in 0..16 {
        let shown = cable_points_shown(&stage, &pixels, unit);
        assert!(shown >= 8, "the cable of ball {unit}: {shown} of 9 points");
    }

    let show = still_matrix(100, 100, 5000.0);
    let (stage, _canvas, pixels, stride) = draw_matrix(&show);
    assert!(stride > 1, "a dense view");
    // The front corner's nearest ball with a cable drawn.
    let row = (99 / stride) * stride;
    let unit = row * 100 + row;
    let shown = cable_points_shown(&stage, &pixels, unit);
    assert!(shown >= 7, "the cable of ball {unit}: {shown} of 9 points");
    // The ball itself is drawn (lit yellow, not the background nor a cable).
    let centre = stage
        .camera()
        .pixel_of(
            stage.scene().ball_centre(unit, stage.positions_mm()[unit]),
            stage.viewport(),
        )
        .unwrap();
    let (x, y) = (
        centre.x.floor() as i32,
        stage.viewport().height as i32 - 1 - centre.y.floor() as i32,
    );
    let i = ((y * stage.viewport().width as i32 + x) * 4) as usize;
    let [r, g, b] = [pixels[i], pixels[i + 1], pixels[i + 2]];
    assert!(r > 100 && g > 80 && b < 60, "ball {unit}: {:?}", [r, g, b]);
}

/// From very close a ball is too big for a point sprite: it is drawn as a quad, still
/// lit as the model says, and its neighbours (sprites) keep theirs.
#[wasm_bindgen_test]
async fn a_ball_too_big_for_a_sprite_is_still_drawn_lit() {
    let canvas = fresh_canvas(480, 360);
    // One ball at the middle of the scene's box, where the camera looks.
    let rgb = [200, 120, 60];
    let show = Show {
        outputs: Vec::new(),
        name: "one".into(),
        layout: layout(1, 1),
        // (the box reaches from the grid to the floor, travel and two radii below).
        tracks: vec![still(DEFAULT_TRAVEL_MM / 2.0, Some(rgb))],
    };
    let mut stage = Stage::new(canvas.clone(), &show, Vec::new(), RendererKind::WebGl2).unwrap();
    stage.draw(0.0, true);
    for factor in [1.0, 4.0, 1000.0] {
        stage.apply(Gesture::Zoom(factor));
        assert!(stage.draw(0.0, true));
        let camera = stage.camera();
        let centre = stage.scene().ball_centre(0, stage.positions_mm()[0]);
        let pixel = camera.pixel_of(centre, stage.viewport()).unwrap();
        let want = lit(rgb, (camera.eye() - centre).normalize(), camera.light());
        let got = gl_pixel(&canvas, pixel);
        assert!(near(got, want, 8), "zoom {factor}: {got:?}, want {want:?}");
        // The ball's width on screen: from its middle outwards to the background.
        let background = [11u8, 17, 23];
        let width = (0..480)
            .take_while(|dx| {
                let x = pixel.x + *dx as f32;
                x < 479.0 && !near(gl_pixel(&canvas, Vec2::new(x, pixel.y)), background, 2)
            })
            .count();
        console_log!("zoom {factor}: half width {width} px");
        if factor == 1000.0 {
            assert!(width > 200, "{width} px");
        }
    }
}

#[wasm_bindgen_test]
async fn a_ball_beyond_a_limit_is_red_and_a_tap_plots_it_with_the_violation() {
    let show = speeding_show();
    let (container, _mounted, canvas) = mount_paused(show.clone(), 0.0).await;
    // The check follows the show's first frame.
    until("the check", || {
        all(&container, "preview-problems").len() == 1
    })
    .await;

    let fine = default_view_of(&canvas, &show, 0, 0.0);
    let beyond = default_view_of(&canvas, &show, 1, 0.0);
    until("ball 1 drawn red", || {
        let [r, g, b] = gl_pixel(&canvas, beyond);
        r > g + 60 && r > b + 60
    })
    .await;
    let [r, g, b] = gl_pixel(&canvas, fine);
    assert!(
        g > r + 60 && g > b + 60,
        "ball 0 stays green: {:?}",
        [r, g, b]
    );
    let [r, g, b] = gl_pixel(&canvas, beyond);
    assert!(
        r > g + 60 && r > b + 60,
        "ball 1 is drawn red ({BEYOND_COLOUR:?} lit): {:?}",
        [r, g, b]
    );

    // Tap the red ball: its plot, with its problems.
    assert!(all(&container, "preview-plot").is_empty());
    tap(&canvas, beyond);
    until("the plot", || !all(&container, "preview-plot").is_empty()).await;
    assert_eq!(attribute(&container, "preview-plot", "data-unit"), "1");
    assert_eq!(
        text(&container, "preview-plot-title"),
        "Ball u1 (row 1, col 2)"
    );
    let limits = Limits::for_layout(1, 2);
    let violations = validate(&show, &limits);
    let own = violations
        .iter()
        .filter(|v| v.unit.is_some_and(|u| u.index == 1))
        .count();
    assert!(own > 0);
    assert_eq!(
        attribute(&container, "preview-plot", "data-violations"),
        own.to_string()
    );
    assert!(text(&container, "preview-plot-problems").contains("exceeds the limit"));

    // The violation is a red band across the velocity panel at its time; elsewhere the
    // panel's top is background.
    sleep(50).await;
    let plot_canvas: HtmlCanvasElement =
        element(&container, "preview-plot-canvas").unchecked_into();
    let plot = BallPlot::new(&show, 1, &limits, &violations).unwrap();
    let layout = plot.layout(
        f64::from(plot_canvas.width()),
        f64::from(plot_canvas.height()),
    );
    let mark = plot
        .marks()
        .into_iter()
        .find(|mark| mark.panel == Panel::Velocity)
        .expect("a speed mark");
    let (top, _) = layout.rows(Panel::Velocity);
    let at = |t_ms: f64| Vec2::new(layout.time.px(t_ms) as f32, (top + 3.0) as f32);
    let [r, g, b] = pixel_2d(&plot_canvas, at(mark.t_ms));
    assert!(
        r > g + 30 && r > b + 30,
        "a red band at the violation: {:?}",
        [r, g, b]
    );
    let calm = pixel_2d(&plot_canvas, at(950.0));
    assert!(near(calm, [11, 17, 23], 4), "no band later: {calm:?}");

    // The time on screen is marked, and moves with it.
    let cursor_left = || {
        let style = attribute(&container, "preview-plot-cursor", "style");
        style
            .split("left: ")
            .nth(1)
            .and_then(|rest| rest.split('%').next())
            .and_then(|left| left.parse::<f64>().ok())
            .unwrap_or_else(|| panic!("{style}"))
    };
    let at_start = cursor_left();
    let want = layout.time.px(0.0) / f64::from(plot_canvas.width()) * 100.0;
    assert!((at_start - want).abs() < 0.01, "{at_start} vs {want}");
    element(&container, "preview-forward").click();
    tick().await;
    assert!(cursor_left() > at_start);

    // The other ball: no problems. Close: no plot.
    tap(&canvas, fine);
    until("ball 0's plot", || {
        attribute(&container, "preview-plot", "data-unit") == "0"
    })
    .await;
    assert_eq!(
        attribute(&container, "preview-plot", "data-violations"),
        "0"
    );
    element(&container, "preview-plot-close").click();
    until("the plot closes", || {
        all(&container, "preview-plot").is_empty()
    })
    .await;
    // A tap on nothing chooses nothing.
    tap(&canvas, Vec2::new(2.0, 2.0));
    sleep(50).await;
    assert!(all(&container, "preview-plot").is_empty());
}

#[wasm_bindgen_test]
async fn drags_and_the_wheel_move_the_view_and_reset_brings_it_back() {
    let (container, _mounted, canvas) = mount_paused(coloured_show(), 500.0).await;
    let container = &container;
    let original = gl_pixels(&canvas);

    // Orbit by a drag.
    let from = Vec2::new(150.0, 75.0);
    pointer(&canvas, "pointerdown", 1, from, 0);
    for step in 1..=5 {
        pointer(
            &canvas,
            "pointermove",
            1,
            from + Vec2::new(12.0 * step as f32, 0.0),
            0,
        );
    }
    pointer(&canvas, "pointerup", 1, from + Vec2::new(60.0, 0.0), 0);
    sleep(100).await;
    let turned = gl_pixels(&canvas);
    assert_ne!(turned, original, "the drag turned the view");
    assert!(
        all(container, "preview-plot").is_empty(),
        "a drag is no tap"
    );

    // Zoom by the wheel.
    let init = web_sys::WheelEventInit::new();
    init.set_bubbles(true);
    init.set_cancelable(true);
    init.set_delta_y(-300.0);
    let wheel = web_sys::WheelEvent::new_with_event_init_dict("wheel", &init).unwrap();
    canvas.dispatch_event(&wheel).unwrap();
    assert!(wheel.default_prevented(), "the page does not scroll");
    sleep(100).await;
    assert_ne!(gl_pixels(&canvas), turned, "the wheel zoomed");

    // Two fingers pan and pinch.
    let zoomed = gl_pixels(&canvas);
    pointer(&canvas, "pointerdown", 1, Vec2::new(100.0, 70.0), 0);
    pointer(&canvas, "pointerdown", 2, Vec2::new(200.0, 70.0), 0);
    pointer(&canvas, "pointermove", 2, Vec2::new(230.0, 90.0), 0);
    pointer(&canvas, "pointerup", 2, Vec2::new(230.0, 90.0), 0);
    pointer(&canvas, "pointerup", 1, Vec2::new(100.0, 70.0), 0);
    sleep(100).await;
    assert_ne!(gl_pixels(&canvas), zoomed, "two fingers moved the view");

    element(container, "preview-reset-view").click();
    sleep(100).await;
    assert!(
        gl_pixels(&canvas) == original,
        "reset brings the default view back"
    );
}

// ----------------------------------------------------------------------------------
// The controls
// ----------------------------------------------------------------------------------

#[wasm_bindgen_test]
async fn the_controls_change_the_time_as_the_vendor_app_does() {
    let container = fresh_container();
    let show = RwSignal::new(None::<Arc<Show>>);
    let _mounted = mount_to(container.clone(), move || {
        view! { <PreviewPage show=show lang=Lang::En /> }
    });
    assert_eq!(all(&container, "preview-empty").len(), 1);
    assert!(element(&container, "preview-forward").has_attribute("disabled"));

    // A 10 s show.
    let mut long = high_and_low_show();
    for track in &mut long.tracks {
        track.rows = vec![track.rows[0]; 40];
    }
    show.set(Some(Arc::new(long)));
    tick().await;
    let playing = || attribute(&container, "preview-toggle", "data-playing");
    assert_eq!(playing(), "true", "a new show plays");

    // Pause, restart (plays from 0), pause: at 0, and stays there.
    element(&container, "preview-toggle").click();
    element(&container, "preview-restart").click();
    tick().await;
    assert_eq!(playing(), "true");
    element(&container, "preview-toggle").click();
    tick().await;
    assert_eq!(playing(), "false");
    set_value(&container, "preview-slider", "0", "input");
    tick().await;
    assert_eq!(text(&container, "preview-time"), "0:00.0 / 0:10.0");

    // Steps of half a second, paused; never before 0.
    element(&container, "preview-forward").click();
    tick().await;
    assert_eq!(text(&container, "preview-time"), "0:00.5 / 0:10.0");
    sleep(100).await;
    assert_eq!(shown_ms(&container), 500.0, "paused");
    element(&container, "preview-back").click();
    element(&container, "preview-back").click();
    tick().await;
    assert_eq!(shown_ms(&container), 0.0);

    // The slider jumps; a step from there; the slider follows the time.
    set_value(&container, "preview-slider", "9800", "input");
    tick().await;
    assert_eq!(shown_ms(&container), 9800.0);
    element(&container, "preview-forward").click();
    tick().await;
    assert_eq!(shown_ms(&container), 10_000.0, "not past the end");
    let slider: web_sys::HtmlInputElement = element(&container, "preview-slider").unchecked_into();
    assert_eq!(slider.value(), "10000");

    // Play at the end starts over; at 4× the show runs four times as fast as the clock.
    set_value(&container, "preview-speed", "4", "change");
    element(&container, "preview-toggle").click();
    let started = js_sys::Date::now();
    until("a second has played", || shown_ms(&container) >= 1000.0).await;
    sleep(500).await;
    element(&container, "preview-toggle").click();
    let real_ms = js_sys::Date::now() - started;
    let show_ms = shown_ms(&container);
    assert!(
        show_ms > 2.5 * real_ms && show_ms < 4.5 * real_ms,
        "{show_ms} ms of show in {real_ms} ms"
    );

    // At 1× it is the clock's own pace; at the end it stops.
    set_value(&container, "preview-speed", "1", "change");
    set_value(&container, "preview-slider", "9700", "input");
    element(&container, "preview-toggle").click();
    until_within("the end", 3000, || playing() == "false").await;
    assert_eq!(shown_ms(&container), 10_000.0);
}

#[wasm_bindgen_test]
async fn live_mode_follows_the_machine_while_it_plays_this_show() {
    let container = fresh_container();
    let mut long = high_and_low_show();
    for track in &mut long.tracks {
        track.rows = vec![track.rows[0]; 40];
    }
    let show = RwSignal::new(Some(Arc::new(long)));
    let status = RwSignal::new(None::<Status>);
    let _mounted = mount_to(container.clone(), move || {
        view! { <PreviewPage show=show lang=Lang::En name="two.json".to_owned() status=status /> }
    });
    tick().await;
    assert!(
        all(&container, "preview-live").is_empty(),
        "offline: no live mode"
    );

    let report = |state, name: &str, show_time_ms| {
        status.set(Some(Status {
            state,
            show: Some(name.into()),
            show_time_ms,
            show_duration_ms: 10_000,
            ..Status::default()
        }));
    };
    let live = || element(&container, "preview-live");
    report(PlayerState::Loading, "two.json", 0);
    tick().await;
    assert!(live().has_attribute("disabled"));
    assert_eq!(all(&container, "preview-live-hint").len(), 1);
    report(PlayerState::Playing, "other.json", 4000);
    tick().await;
    assert!(live().has_attribute("disabled"), "another show");

    report(PlayerState::Playing, "two.json", 4000);
    tick().await;
    assert!(!live().has_attribute("disabled"));
    live().click();
    tick().await;
    assert_eq!(
        live().get_attribute("aria-pressed").as_deref(),
        Some("true")
    );
    until("the machine's time", || {
        (4000.0..4600.0).contains(&shown_ms(&container))
    })
    .await;
    // Between reports the time runs on; a new report moves it there.
    sleep(200).await;
    assert!(shown_ms(&container) > 4100.0, "{}", shown_ms(&container));
    report(PlayerState::Playing, "two.json", 7000);
    until("the next report", || {
        (7000.0..7600.0).contains(&shown_ms(&container))
    })
    .await;

    // A control of the preview's own leaves live mode.
    element(&container, "preview-restart").click();
    tick().await;
    assert_eq!(
        live().get_attribute("aria-pressed").as_deref(),
        Some("false")
    );
    assert!(shown_ms(&container) < 500.0);

    // Live again; the matrix stops: live ends, the picture stays.
    report(PlayerState::Playing, "two.json", 8000);
    tick().await;
    live().click();
    until("live", || shown_ms(&container) >= 8000.0).await;
    report(PlayerState::Stopped, "two.json", 8100);
    tick().await;
    assert_eq!(
        live().get_attribute("aria-pressed").as_deref(),
        Some("false")
    );
    assert!(live().has_attribute("disabled"));
    let stopped_at = shown_ms(&container);
    assert!(stopped_at >= 8000.0);
    assert_eq!(
        attribute(&container, "preview-toggle", "data-playing"),
        "false"
    );
}

// ----------------------------------------------------------------------------------
// The 2D top view
// ----------------------------------------------------------------------------------

/// High balls are bright, low balls dark, and between them is the background.
fn assert_top_view_drawn(canvas: &HtmlCanvasElement) {
    let (w, h) = (canvas.width() as f32, canvas.height() as f32);
    let high = pixel_2d(canvas, Vec2::new(w * 0.25, h * 0.5));
    let low = pixel_2d(canvas, Vec2::new(w * 0.75, h * 0.5));
    let gap = pixel_2d(canvas, Vec2::new(w * 0.5, h * 0.05));
    let brightness = |rgb: [u8; 3]| rgb.iter().map(|c| u32::from(*c)).sum::<u32>();
    assert!(brightness(high) > brightness(low), "{high:?} vs {low:?}");
    assert!(brightness(low) > brightness(gap), "{low:?} vs {gap:?}");
}

#[wasm_bindgen_test]
async fn the_top_view_draws_when_chosen_and_taps_pick_its_balls() {
    let (container, _mounted, _) = mount_paused(high_and_low_show(), 0.0).await;
    element(&container, "preview-mode-top").click();
    until("the top view", || {
        attribute(&container, "preview-canvas", "data-renderer") == "2d"
    })
    .await;
    assert!(all(&container, "preview-reset-view").is_empty());
    sleep(100).await;
    let canvas = stage_canvas(&container);
    assert_top_view_drawn(&canvas);
    tap(
        &canvas,
        Vec2::new(
            canvas.client_width() as f32 * 0.75,
            canvas.client_height() as f32 * 0.5,
        ),
    );
    until("the plot", || {
        attribute(&container, "preview-plot", "data-unit") == "1"
    })
    .await;

    element(&container, "preview-mode-3d").click();
    until("3D again", || {
        attribute(&container, "preview-canvas", "data-renderer") == "webgl2"
    })
    .await;
}

#[wasm_bindgen_test]
async fn without_webgl2_the_top_view_stands_in() {
    // This browser without WebGL2: `getContext("webgl2")` answers null.
    let restore: js_sys::Function = js_sys::Function::new_no_args(
        "const real = HTMLCanvasElement.prototype.getContext;
         HTMLCanvasElement.prototype.getContext = function (kind, ...rest) {
             return kind === 'webgl2' ? null : real.call(this, kind, ...rest);
         };
         return () => { HTMLCanvasElement.prototype.getContext = real; };",
    )
    .call0(&JsValue::NULL)
    .unwrap()
    .unchecked_into();

    let container = fresh_container();
    let show = RwSignal::new(Some(Arc::new(high_and_low_show())));
    let mounted = mount_to(container.clone(), move || {
        view! { <PreviewPage show=show lang=Lang::En /> }
    });
    until("the fallback", || {
        attribute(&container, "preview-canvas", "data-renderer") == "2d"
    })
    .await;
    let note = text(&container, "preview-no-webgl");
    assert!(note.contains("WebGL2"), "{note}");
    assert!(element(&container, "preview-mode-3d").has_attribute("disabled"));
    element(&container, "preview-toggle").click();
    set_value(&container, "preview-slider", "0", "input");
    sleep(100).await;
    assert_top_view_drawn(&stage_canvas(&container));
    drop(mounted);
    restore.call0(&JsValue::NULL).unwrap();
}

// ----------------------------------------------------------------------------------
// Performance
// ----------------------------------------------------------------------------------

/// The frame rate every size should reach (issue 18: 10,000 balls at ≥ 60 frames/s
/// on headless Chromium's software renderer, 640 × 480).
const FPS_GOAL: f64 = 60.0;

/// The figures of the issues' benchmarks: sampling 10,000 balls (goal ≤ 1 ms) and the
/// frame rate ([`FPS_GOAL`]). Printed, not asserted (timings vary with the machine's
/// load, and a test build is not optimised; `docs/preview.md` gives the release
/// figures); only sanity is checked.
#[wasm_bindgen_test]
async fn performance_figures_for_100_2500_and_10000_balls() {
    let container = fresh_container();
    let _mounted = mount_to(container.clone(), move || {
        view! { <div style="width: 640px"><PerfPanel lang=Lang::En /></div> }
    });
    element(&container, "perf-run").click();
    until_within("the figures", 300_000, || {
        attribute(&container, "perf-run", "data-done") == "true"
    })
    .await;
    let rows = all(&container, "perf-row");
    assert_eq!(
        rows.len(),
        SIZES.len(),
        "{}",
        text(&container, "perf-status")
    );
    let figure = |row: &web_sys::HtmlElement, name: &str| -> f64 {
        row.get_attribute(name).unwrap().parse().unwrap()
    };
    let build = if cfg!(debug_assertions) {
        "debug"
    } else {
        "release"
    };
    console_log!(
        "preview performance ({build} build, {}):",
        text(&container, "perf-renderer")
    );
    for (row, balls) in rows.iter().zip(SIZES) {
        let (eval_ms, frame_ms, fps) = (
            figure(row, "data-eval-ms"),
            figure(row, "data-frame-ms"),
            figure(row, "data-fps"),
        );
        console_log!(
            "  {balls:>6} balls: sample {eval_ms:.3} ms, frame {frame_ms:.2} ms, {fps:.1} frames/s (goal {FPS_GOAL})"
        );
        assert_eq!(figure(row, "data-balls"), balls as f64);
        assert!((0.0..1000.0).contains(&eval_ms));
        assert!(frame_ms >= eval_ms && frame_ms < 5000.0);
        assert!(fps > 0.0);
    }
    assert!(text(&container, "perf-renderer").contains("WebGL2"));
}
