//! One ball over the whole show: its position and velocity drawn against time, with
//! the installation's travel and speed limits as lines and the validation's
//! violations marked in red.
//!
//! [`BallPlot::new`] evaluates the ball's track with the shared PVT evaluator
//! ([`floatball_shared::motion::Segment`], as the simulator and validation do) at a few
//! points inside every row; [`PlotLayout`] maps values to pixels; only [`draw`]
//! touches the canvas. Position is drawn growing downwards (the ball goes down on the
//! plot as it goes down in the room) and so is velocity (positive = moving down).

use floatball_shared::show::{Limits, Show, UnitRef, Violation, ViolationKind};
use web_sys::CanvasRenderingContext2d;

/// Points evaluated inside each PVT row (besides its start).
const POINTS_PER_ROW: usize = 4;

/// Colours of the plot.
const BACKGROUND: &str = "#0b1117";
const AXIS: &str = "#2c3e4f";
const LABEL: &str = "#8fa3b3";
const LIMIT: &str = "#f2b233";
const POSITION: &str = "#3fa7f5";
const VELOCITY: &str = "#3ccf7a";
const VIOLATION: &str = "#e5342c";
const VIOLATION_BAND: &str = "rgba(229, 52, 44, 0.35)";

/// The ball at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlotPoint {
    /// Show time, ms.
    pub t_ms: f64,
    /// Position, mm below the top.
    pub position_mm: f64,
    /// Velocity, mm/s (positive = down).
    pub velocity_mm_s: f64,
}

/// Which of the plot's two panels a violation belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Panel {
    /// Position (travel).
    Position,
    /// Velocity (speed, acceleration, row timing).
    Velocity,
}

/// A violation at a time, placed on a panel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mark {
    /// When, ms.
    pub t_ms: f64,
    /// Where it is drawn.
    pub panel: Panel,
}

/// One ball's motion over the show, with its limits and violations.
#[derive(Debug, Clone, PartialEq)]
pub struct BallPlot {
    /// The ball.
    pub unit: UnitRef,
    /// The motion, in time order.
    pub points: Vec<PlotPoint>,
    /// The show's length, ms.
    pub duration_ms: f64,
    /// The limits drawn.
    pub limits: Limits,
    /// This ball's violations.
    pub violations: Vec<Violation>,
}

impl BallPlot {
    /// The plot of ball `unit` of `show` against `limits`; `violations` are the
    /// show's (those of other balls are left out). `None` for a ball not in the show.
    pub fn new(
        show: &Show,
        unit: usize,
        limits: &Limits,
        violations: &[Violation],
    ) -> Option<Self> {
        let track = show.tracks.get(unit)?;
        let (row, col) = show.layout.cell(unit);
        let mut points = vec![PlotPoint {
            t_ms: 0.0,
            position_mm: track.start_mm,
            velocity_mm_s: 0.0,
        }];
        for (start_ms, segment) in track.segments() {
            let duration_ms = segment.duration_s * 1000.0;
            if duration_ms > 0.0 {
                points.extend((1..=POINTS_PER_ROW).map(|k| {
                    let s = k as f64 / POINTS_PER_ROW as f64;
                    let state = segment.kinematics_at_fraction(s);
                    PlotPoint {
                        t_ms: start_ms as f64 + s * duration_ms,
                        position_mm: state.position,
                        velocity_mm_s: state.velocity,
                    }
                }));
            } else {
                points.push(PlotPoint {
                    t_ms: start_ms as f64,
                    position_mm: segment.p1,
                    velocity_mm_s: segment.v1,
                });
            }
        }
        Some(Self {
            unit: UnitRef {
                index: unit,
                row,
                col,
            },
            points,
            duration_ms: show.duration_ms() as f64,
            limits: *limits,
            violations: violations
                .iter()
                .filter(|violation| violation.unit.is_some_and(|u| u.index == unit))
                .copied()
                .collect(),
        })
    }

    /// The highest and lowest positions reached, mm below the top.
    pub fn position_range_mm(&self) -> (f64, f64) {
        self.points
            .iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), p| {
                (lo.min(p.position_mm), hi.max(p.position_mm))
            })
    }

    /// The largest speed reached, mm/s.
    pub fn peak_speed_mm_s(&self) -> f64 {
        self.points
            .iter()
            .map(|p| p.velocity_mm_s.abs())
            .fold(0.0, f64::max)
    }

    /// The violations that happen at a moment, each on its panel.
    pub fn marks(&self) -> Vec<Mark> {
        self.violations
            .iter()
            .filter_map(|violation| {
                let panel = match violation.kind {
                    ViolationKind::AboveTop { .. } | ViolationKind::BelowTravel { .. } => {
                        Panel::Position
                    }
                    _ => Panel::Velocity,
                };
                Some(Mark {
                    t_ms: violation.time_ms?,
                    panel,
                })
            })
            .collect()
    }

    /// Where things go on a `width` × `height` canvas.
    pub fn layout(&self, width: f64, height: f64) -> PlotLayout {
        let (lowest_mm, highest_mm) = self.position_range_mm();
        let travel_mm = self.limits.travel_mm;
        let speed_mm_s = self
            .limits
            .max_speed_mm_s
            .max(self.peak_speed_mm_s())
            .max(1.0);
        let margin = Margin::for_size(width, height);
        let panel_height = (height - margin.top - margin.bottom - margin.gap) / 2.0;
        let position_top = margin.top;
        let velocity_top = margin.top + panel_height + margin.gap;
        let span = |lo: f64, hi: f64| (hi - lo).max(1.0) * 0.05;
        let (position_lo, position_hi) = (lowest_mm.min(0.0), highest_mm.max(travel_mm));
        let pad = span(position_lo, position_hi);
        PlotLayout {
            time: Axis {
                lo: 0.0,
                hi: self.duration_ms.max(1.0),
                px_lo: margin.left,
                px_hi: width - margin.right,
            },
            position: Axis {
                lo: position_lo - pad,
                hi: position_hi + pad,
                px_lo: position_top,
                px_hi: position_top + panel_height,
            },
            velocity: Axis {
                lo: -speed_mm_s * 1.1,
                hi: speed_mm_s * 1.1,
                px_lo: velocity_top,
                px_hi: velocity_top + panel_height,
            },
        }
    }
}

/// A linear map from values to pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axis {
    /// The value at `px_lo`.
    pub lo: f64,
    /// The value at `px_hi`.
    pub hi: f64,
    /// Pixel of `lo`.
    pub px_lo: f64,
    /// Pixel of `hi`.
    pub px_hi: f64,
}

impl Axis {
    /// The pixel of `value`.
    pub fn px(&self, value: f64) -> f64 {
        let span = self.hi - self.lo;
        if span == 0.0 {
            return self.px_lo;
        }
        self.px_lo + (value - self.lo) / span * (self.px_hi - self.px_lo)
    }
}

/// Where the plot's parts are: time across, position in the upper panel and velocity
/// in the lower, both growing downwards.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlotLayout {
    /// Time, ms, to x.
    pub time: Axis,
    /// Position, mm, to y in the upper panel.
    pub position: Axis,
    /// Velocity, mm/s, to y in the lower panel.
    pub velocity: Axis,
}

impl PlotLayout {
    /// The panel's top and bottom, pixels.
    pub fn rows(&self, panel: Panel) -> (f64, f64) {
        let axis = match panel {
            Panel::Position => self.position,
            Panel::Velocity => self.velocity,
        };
        (axis.px_lo, axis.px_hi)
    }
}

/// The space around and between the panels, pixels.
#[derive(Debug, Clone, Copy)]
struct Margin {
    left: f64,
    right: f64,
    top: f64,
    bottom: f64,
    gap: f64,
}

impl Margin {
    fn for_size(width: f64, height: f64) -> Self {
        let unit = (width.min(height * 2.0) / 60.0).clamp(6.0, 14.0);
        Self {
            left: unit * 5.0,
            right: unit,
            top: unit * 2.0,
            bottom: unit * 2.0,
            gap: unit * 2.5,
        }
    }
}

/// The words on the plot.
#[derive(Debug, Clone, Copy)]
pub struct Labels<'a> {
    /// Over the upper panel.
    pub position: &'a str,
    /// Over the lower panel.
    pub velocity: &'a str,
    /// Under the start of the time axis.
    pub start: &'a str,
    /// Under its end.
    pub end: &'a str,
}

/// Draws `plot` on a `width` × `height` canvas (pixels).
pub fn draw(
    context: &CanvasRenderingContext2d,
    plot: &BallPlot,
    (width, height): (f64, f64),
    labels: Labels,
) {
    let layout = plot.layout(width, height);
    let font_px = Margin::for_size(width, height).left / 5.0 * 1.6;
    context.set_fill_style_str(BACKGROUND);
    context.fill_rect(0.0, 0.0, width, height);
    context.set_font(&format!("{font_px:.0}px sans-serif"));
    context.set_text_baseline("bottom");

    let (x0, x1) = (layout.time.px_lo, layout.time.px_hi);
    let travel = plot.limits.travel_mm;
    let speed = plot.limits.max_speed_mm_s;
    let panels = [
        (
            Panel::Position,
            layout.position,
            labels.position,
            vec![0.0, travel],
        ),
        (
            Panel::Velocity,
            layout.velocity,
            labels.velocity,
            vec![-speed, speed],
        ),
    ];
    for (panel, axis, label, limits) in &panels {
        let (top, bottom) = layout.rows(*panel);
        context.set_stroke_style_str(AXIS);
        context.set_line_width(1.0);
        context.stroke_rect(x0, top, x1 - x0, bottom - top);
        context.set_fill_style_str(LABEL);
        // A failed text draw only loses the label.
        let _ = context.fill_text(label, x0, top - 2.0);
        context.set_text_align("right");
        for limit in limits {
            let y = axis.px(*limit);
            let _ = context.fill_text(&format!("{limit:.0}"), x0 - 4.0, y + font_px / 2.0);
        }
        context.set_text_align("left");

        // Violations: a band at each moment.
        context.set_fill_style_str(VIOLATION_BAND);
        for mark in plot.marks().iter().filter(|mark| mark.panel == *panel) {
            let x = layout.time.px(mark.t_ms);
            context.fill_rect(x - 3.0, top, 6.0, bottom - top);
        }

        // Limits: dashed lines.
        context.set_stroke_style_str(LIMIT);
        let _ = context.set_line_dash(&js_sys::Array::of2(&6.0.into(), &4.0.into()));
        for limit in limits {
            let y = axis.px(*limit);
            context.begin_path();
            context.move_to(x0, y);
            context.line_to(x1, y);
            context.stroke();
        }
        let _ = context.set_line_dash(&js_sys::Array::new());
    }

    // The time axis's ends.
    context.set_fill_style_str(LABEL);
    context.set_text_baseline("top");
    let below = layout.velocity.px_hi + 3.0;
    let _ = context.fill_text(labels.start, x0, below);
    context.set_text_align("right");
    let _ = context.fill_text(labels.end, x1, below);
    context.set_text_align("left");

    // The zero line of the velocity.
    context.set_stroke_style_str(AXIS);
    let zero = layout.velocity.px(0.0);
    context.begin_path();
    context.move_to(x0, zero);
    context.line_to(x1, zero);
    context.stroke();

    let position = |p: &PlotPoint| p.position_mm;
    let velocity = |p: &PlotPoint| p.velocity_mm_s;
    let within_travel = |p: &PlotPoint| (0.0..=travel).contains(&p.position_mm);
    let within_speed = |p: &PlotPoint| p.velocity_mm_s.abs() <= speed;
    curve(
        context,
        plot,
        &layout.time,
        &layout.position,
        position,
        within_travel,
        POSITION,
    );
    curve(
        context,
        plot,
        &layout.time,
        &layout.velocity,
        velocity,
        within_speed,
        VELOCITY,
    );
}

/// One series as a line, red where `within` fails.
fn curve(
    context: &CanvasRenderingContext2d,
    plot: &BallPlot,
    time: &Axis,
    axis: &Axis,
    value: impl Fn(&PlotPoint) -> f64,
    within: impl Fn(&PlotPoint) -> bool,
    colour: &str,
) {
    context.set_line_width(2.0);
    context.set_stroke_style_str(colour);
    context.begin_path();
    for (i, point) in plot.points.iter().enumerate() {
        let (x, y) = (time.px(point.t_ms), axis.px(value(point)));
        if i == 0 {
            context.move_to(x, y);
        } else {
            context.line_to(x, y);
        }
    }
    context.stroke();
    context.set_stroke_style_str(VIOLATION);
    context.set_line_width(3.0);
    for pair in plot.points.windows(2) {
        if !within(&pair[0]) || !within(&pair[1]) {
            context.begin_path();
            context.move_to(time.px(pair[0].t_ms), axis.px(value(&pair[0])));
            context.line_to(time.px(pair[1].t_ms), axis.px(value(&pair[1])));
            context.stroke();
        }
    }
}

#[cfg(test)]
mod tests {
    use floatball_shared::show::{Layout, Track, TrackRow, validate};
    use wasm_bindgen_test::wasm_bindgen_test;

    use super::*;

    /// Ball 0 goes 1000 mm down in 400 ms (too fast at the peak), ball 1 stays.
    fn show() -> Show {
        let track = |rows: Vec<TrackRow>| Track {
            start_mm: 0.0,
            rows,
            colours: Vec::new(),
        };
        Show {
            outputs: Vec::new(),
            name: "plot".into(),
            layout: Layout {
                rows: 1,
                cols: 2,
                pitch_mm: 500.0,
            },
            tracks: vec![
                track(vec![
                    TrackRow::new(500.0, 2500.0, 200),
                    TrackRow::new(1000.0, 0.0, 200),
                ]),
                track(vec![
                    TrackRow::new(0.0, 0.0, 200),
                    TrackRow::new(0.0, 0.0, 200),
                ]),
            ],
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_motion_is_the_shared_evaluator_inside_every_row() {
        let show = show();
        let limits = Limits::for_layout(1, 2);
        let plot = BallPlot::new(&show, 0, &limits, &[]).unwrap();
        assert_eq!(plot.points.len(), 1 + 2 * POINTS_PER_ROW);
        assert_eq!(plot.points[4].t_ms, 200.0);
        assert_eq!(plot.points[4].position_mm, 500.0);
        assert_eq!(plot.points[4].velocity_mm_s, 2500.0);
        assert_eq!(plot.points.last().unwrap().position_mm, 1000.0);
        let (_, segment) = show.tracks[0].segments().next().unwrap();
        assert_eq!(plot.points[1].position_mm, segment.position(0.05));
        assert_eq!(plot.position_range_mm(), (0.0, 1000.0));
        // The second row overshoots the arrival speed on its way.
        assert!(plot.peak_speed_mm_s() > 2500.0);
        assert_eq!(plot.unit.to_string(), "ball u0 (row 1, col 1)");
        assert!(BallPlot::new(&show, 2, &limits, &[]).is_none());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn only_this_balls_violations_are_marked_on_their_panel() {
        let show = show();
        let limits = Limits::for_layout(1, 2);
        let violations = validate(&show, &limits);
        assert!(!violations.is_empty());
        let fast = BallPlot::new(&show, 0, &limits, &violations).unwrap();
        let marks = fast.marks();
        assert!(!marks.is_empty());
        assert!(marks.iter().all(|mark| mark.panel == Panel::Velocity));
        let still = BallPlot::new(&show, 1, &limits, &violations).unwrap();
        assert!(still.violations.is_empty() && still.marks().is_empty());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn limits_and_times_land_inside_their_panels() {
        let show = show();
        let limits = Limits::for_layout(1, 2);
        let plot = BallPlot::new(&show, 0, &limits, &[]).unwrap();
        let layout = plot.layout(600.0, 300.0);
        assert_eq!(layout.time.px(0.0), layout.time.px_lo);
        assert_eq!(layout.time.px(400.0), 600.0 - layout.time.px_lo / 5.0);
        let (top, bottom) = layout.rows(Panel::Position);
        // The top (0 mm) is near the panel's top, the end of travel near its bottom.
        let y0 = layout.position.px(0.0);
        let y_travel = layout.position.px(limits.travel_mm);
        assert!(
            top < y0 && y0 < y_travel && y_travel < bottom,
            "{y0} {y_travel}"
        );
        let (top, bottom) = layout.rows(Panel::Velocity);
        assert!(bottom <= 300.0 && top > layout.position.px_hi);
        // The speed limit and the peak both fit; zero is in the middle.
        let zero = layout.velocity.px(0.0);
        assert!((zero - (top + bottom) / 2.0).abs() < 1e-9);
        assert!(layout.velocity.px(2500.0) < bottom && layout.velocity.px(-2500.0) > top);
        let flat = Axis {
            lo: 1.0,
            hi: 1.0,
            px_lo: 5.0,
            px_hi: 9.0,
        };
        assert_eq!(flat.px(3.0), 5.0);
    }
}
