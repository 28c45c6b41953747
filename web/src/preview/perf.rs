//! The performance panel: how long this device takes to evaluate and to draw one
//! frame of synthetic shows of 100, 2,500 and 10,000 balls, with the preview's own
//! [`Stage`] (the same sampler and renderer).
//!
//! Each size plays from [`START_MS`] (the ripple in full swing): drawn for
//! [`WARM_UP_FRAMES`] frames, then measured for [`MEASURED_FRAMES`], one per animation
//! frame. The frame time runs from the sampling to the GPU having drawn the frame (a
//! one-pixel read-back waits for it), its median shown so that a garbage collection
//! or a busy moment does not decide the figure; the frame rate counts the animation
//! frames the browser gave meanwhile. The evaluation time is `Sampler::sample` alone,
//! the mean over [`EVAL_FRAMES`] successive frames sampled in a row (browsers round
//! `performance.now()` to 0.1 ms, too coarse for one call).

use std::f64::consts::TAU;

use floatball_shared::show::{ColourKey, Layout, Show, Track, TrackRow};
use leptos::html::Canvas;
use leptos::prelude::*;

use crate::context::tr_in;
use leptos::task::spawn_local;
use wasm_bindgen_futures::JsFuture;

use super::stage::{RendererKind, Stage, now_ms};
use crate::i18n::{Lang, Text};

/// The show sizes measured, balls.
pub const SIZES: [usize; 3] = [100, 2_500, 10_000];
/// Frames drawn before measuring (shaders compiled, caches warm).
pub const WARM_UP_FRAMES: usize = 5;
/// Frames measured per size.
pub const MEASURED_FRAMES: usize = 30;
/// Frames sampled in a row for the evaluation time.
pub const EVAL_FRAMES: usize = 120;
/// Where in the synthetic shows the measurements start, ms.
pub const START_MS: f64 = 3000.0;
/// One frame at 60 frames a second, ms.
const FRAME_MS: f64 = 1000.0 / 60.0;

/// A synthetic show's length and rows, ms.
const SHOW_MS: u32 = 10_000;
const ROW_MS: u32 = 200;
/// The ripple: around mid travel, this far up and down, with this period, swelling
/// from rest and calming back to rest over this long at each end.
const MIDDLE_MM: f64 = 3750.0;
const AMPLITUDE_MM: f64 = 1500.0;
const PERIOD_MS: f64 = 8000.0;
const RAMP_MS: f64 = 3000.0;

/// How far the ripple has swelled at `t_ms` (0 at both ends, 1 in the middle) and
/// how fast that changes, per ms.
fn swell(t_ms: f64) -> (f64, f64) {
    // Smoothstep and its derivative, rising at the start and falling at the end.
    let step = |x: f64| {
        let x = x.clamp(0.0, 1.0);
        (x * x * (3.0 - 2.0 * x), 6.0 * x * (1.0 - x))
    };
    let (rise, rise_rate) = step(t_ms / RAMP_MS);
    let (fall, fall_rate) = step((f64::from(SHOW_MS) - t_ms) / RAMP_MS);
    (rise * fall, (rise_rate * fall - rise * fall_rate) / RAMP_MS)
}

/// A ripple spreading from the middle of a square-ish grid of at least `balls` balls
/// (exactly `balls` for squares such as 100, 2,500 and 10,000), each ball with colour
/// keyframes: 200 ms rows from rest to rest within the default limits, as a real
/// show would be.
pub fn synthetic_show(balls: usize) -> Show {
    let cols = (balls.max(1) as f64).sqrt().ceil() as u32;
    let rows = balls.max(1).div_ceil(cols as usize) as u32;
    let layout = Layout {
        rows,
        cols,
        pitch_mm: 500.0,
    };
    let omega = TAU / PERIOD_MS;
    let centre = (f64::from(cols - 1) / 2.0, f64::from(rows - 1) / 2.0);
    let tracks = (0..layout.unit_count())
        .map(|unit| {
            let (row, col) = layout.cell(unit);
            let distance = (f64::from(col) - centre.0).hypot(f64::from(row) - centre.1);
            let phase = distance * 0.6;
            let row_at = |t_ms: f64| {
                let (swell, swell_rate) = swell(t_ms);
                let (sin, cos) = (omega * t_ms - phase).sin_cos();
                let position_mm = MIDDLE_MM + AMPLITUDE_MM * swell * sin;
                let per_ms = AMPLITUDE_MM * (swell_rate * sin + swell * omega * cos);
                TrackRow::new(position_mm, per_ms * 1000.0, ROW_MS)
            };
            let hue = (distance / 10.0).fract();
            Track {
                start_mm: MIDDLE_MM,
                rows: (1..=SHOW_MS / ROW_MS)
                    .map(|k| row_at(f64::from(k * ROW_MS)))
                    .collect(),
                colours: [0, SHOW_MS / 2, SHOW_MS]
                    .iter()
                    .enumerate()
                    .map(|(i, time_ms)| ColourKey {
                        time_ms: u64::from(*time_ms),
                        rgb: rainbow(hue + i as f64 / 3.0),
                    })
                    .collect(),
            }
        })
        .collect();
    Show {
        outputs: Vec::new(),
        name: format!("synthetic {balls}"),
        layout,
        tracks,
    }
}

/// A bright colour around the colour wheel (`hue` in turns).
fn rainbow(hue: f64) -> [u8; 3] {
    [0.0, 1.0 / 3.0, 2.0 / 3.0].map(|offset| {
        let c = 0.5 + 0.5 * (TAU * (hue + offset)).cos();
        (c * 255.0).round() as u8
    })
}

/// The middle value (the mean of the two middle ones for an even count); 0 for none.
pub fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    match values.len() {
        0 => 0.0,
        n if n % 2 == 1 => values[n / 2],
        n => (values[n / 2 - 1] + values[n / 2]) / 2.0,
    }
}

/// The figures of one size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PerfResult {
    /// Balls in the show.
    pub balls: usize,
    /// Mean time to sample every ball, ms.
    pub eval_ms: f64,
    /// Median time to sample and draw a frame, to the GPU's end, ms.
    pub frame_ms: f64,
    /// Animation frames per second while measuring.
    pub fps: f64,
}

/// Waits for the next animation frame; its time stamp, ms.
async fn next_frame() -> f64 {
    let promise = js_sys::Promise::new(&mut |resolve, _| {
        // Without a window there is no frame to wait for; the promise never settles.
        let _ = window().request_animation_frame(&resolve);
    });
    JsFuture::from(promise)
        .await
        .ok()
        .and_then(|stamp| stamp.as_f64())
        .unwrap_or_else(now_ms)
}

/// Measures `stage` (showing a synthetic show of `balls`).
async fn measure(stage: &mut Stage, balls: usize) -> PerfResult {
    let mut frames = Vec::with_capacity(MEASURED_FRAMES);
    let mut stamps = Vec::with_capacity(MEASURED_FRAMES);
    let mut t_ms = START_MS;
    for frame in 0..WARM_UP_FRAMES + MEASURED_FRAMES {
        let stamp = next_frame().await;
        let started = now_ms();
        stage.draw(t_ms, true);
        stage.finish();
        if frame >= WARM_UP_FRAMES {
            frames.push(now_ms() - started);
            stamps.push(stamp);
        }
        t_ms += FRAME_MS;
    }
    let started = now_ms();
    for _ in 0..EVAL_FRAMES {
        stage.sample(t_ms);
        t_ms += FRAME_MS;
    }
    let eval_ms = (now_ms() - started) / EVAL_FRAMES as f64;
    let span_ms = stamps.last().copied().unwrap_or(0.0) - stamps.first().copied().unwrap_or(0.0);
    PerfResult {
        balls,
        eval_ms,
        frame_ms: median(&mut frames),
        fps: if span_ms > 0.0 {
            (stamps.len() - 1) as f64 * 1000.0 / span_ms
        } else {
            0.0
        },
    }
}

/// The panel: a canvas, a button that measures every size in turn, and the figures.
#[component]
pub fn PerfPanel(
    /// The language of the labels.
    #[prop(into)]
    lang: Signal<Lang>,
) -> impl IntoView {
    let canvas = NodeRef::<Canvas>::new();
    let results = RwSignal::new(Vec::<PerfResult>::new());
    let running = RwSignal::new(None::<usize>);
    let renderer = RwSignal::new(None::<(RendererKind, u32, u32)>);
    let failure = RwSignal::new(None::<String>);

    let run = move |_| {
        let Some(canvas) = canvas.get_untracked() else {
            return;
        };
        results.set(Vec::new());
        failure.set(None);
        spawn_local(async move {
            let mut stage: Option<Stage> = None;
            for balls in SIZES {
                if running.try_set(Some(balls)).is_some() {
                    // The panel has gone (the value came back unset).
                    return;
                }
                // Let the status show before the show is built.
                next_frame().await;
                let show = synthetic_show(balls);
                let ready = match &mut stage {
                    Some(stage) => stage.set_show(&show, Vec::new()),
                    None => Stage::new(canvas.clone(), &show, Vec::new(), RendererKind::WebGl2)
                        .or_else(|_| {
                            Stage::new(canvas.clone(), &show, Vec::new(), RendererKind::TopView)
                        })
                        .map(|new| stage = Some(new)),
                };
                let stage = match (ready, stage.as_mut()) {
                    (Ok(()), Some(stage)) => stage,
                    (Err(why), _) => {
                        failure.try_set(Some(why));
                        break;
                    }
                    (Ok(()), None) => break,
                };
                drop(show);
                let result = measure(stage, balls).await;
                let viewport = stage.viewport();
                renderer.try_set(Some((
                    stage.kind(),
                    viewport.width as u32,
                    viewport.height as u32,
                )));
                if results.try_update(|list| list.push(result)).is_none() {
                    return;
                }
            }
            running.try_set(None);
        });
    };

    let rows = move || {
        results
            .get()
            .into_iter()
            .map(|result| {
                view! {
                    <tr
                        data-testid="perf-row"
                        data-balls=result.balls
                        data-eval-ms=format!("{:.3}", result.eval_ms)
                        data-frame-ms=format!("{:.3}", result.frame_ms)
                        data-fps=format!("{:.1}", result.fps)
                    >
                        <td class="mono">{result.balls}</td>
                        <td class="mono">{format!("{:.3}", result.eval_ms)}</td>
                        <td class="mono">{format!("{:.1}", result.frame_ms)}</td>
                        <td class="mono">{format!("{:.0}", result.fps)}</td>
                    </tr>
                }
            })
            .collect_view()
    };
    view! {
        <section class="perf card" data-testid="perf">
            <h3>{tr_in(lang, Text::Performance)}</h3>
            <p class="muted">{tr_in(lang, Text::PerfExplain)}</p>
            <button
                class="primary"
                data-testid="perf-run"
                data-done=move || {
                    let finished = !results.with(Vec::is_empty) || failure.with(Option::is_some);
                    (running.get().is_none() && finished).to_string()
                }
                disabled=move || running.get().is_some()
                on:click=run
            >
                {tr_in(lang, Text::PerfRun)}
            </button>
            <p class="muted" data-testid="perf-status">
                {move || running.get().map(|balls| lang.get().measuring(balls))}
                {move || failure.get()}
            </p>
            // Sized here, not by the stylesheet, so the figures are for the same canvas
            // wherever the panel is (and in the tests, which have no stylesheet).
            <canvas
                node_ref=canvas
                class="perf-stage"
                data-testid="perf-canvas"
                style="width: 100%; max-width: 640px; aspect-ratio: 4 / 3"
            ></canvas>
            <p class="muted" data-testid="perf-renderer">
                {move || renderer.get().map(|(kind, width, height)| lang.get().drawn_by(kind == RendererKind::WebGl2, width, height))}
            </p>
            <table class="list perf-results" data-testid="perf-results">
                <thead>
                    <tr>
                        <th>{tr_in(lang, Text::Units)}</th>
                        <th>{tr_in(lang, Text::PerfEvalMs)}</th>
                        <th>{tr_in(lang, Text::PerfFrameMs)}</th>
                        <th>{tr_in(lang, Text::PerfFps)}</th>
                    </tr>
                </thead>
                <tbody>{rows}</tbody>
            </table>
        </section>
    }
}

#[cfg(test)]
mod tests {
    use floatball_shared::show::{Limits, Sampler, validate};
    use wasm_bindgen_test::wasm_bindgen_test;

    use super::*;

    #[wasm_bindgen_test(unsupported = test)]
    fn synthetic_shows_have_the_sizes_asked_and_keep_the_limits() {
        for balls in SIZES {
            let show = synthetic_show(balls);
            assert_eq!(show.tracks.len(), balls);
            assert_eq!(show.duration_ms(), u64::from(SHOW_MS));
            if balls <= 100 {
                let limits = Limits::for_layout(show.layout.rows, show.layout.cols);
                assert_eq!(validate(&show, &limits), Vec::new());
            }
        }
        let show = synthetic_show(7);
        assert_eq!((show.layout.rows, show.layout.cols), (3, 3));
        assert_eq!(show.tracks.len(), 9);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn synthetic_shows_move_and_change_colour() {
        let show = synthetic_show(100);
        let mut sampler = Sampler::new(&show);
        let mut positions = vec![0.0f32; 100];
        let mut colours = vec![[0u8; 3]; 100];
        sampler.sample(0.0, &mut positions, Some(&mut colours));
        assert!(
            positions.iter().all(|p| *p == MIDDLE_MM as f32),
            "from rest"
        );
        let (first, first_colour) = (positions[0], colours[0]);
        sampler.sample(4000.0, &mut positions, Some(&mut colours));
        assert!((positions[0] - first).abs() > 100.0);
        assert_ne!(colours[0], first_colour);
        assert!(positions.iter().all(|p| (0.0..=7500.0).contains(p)));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_median_is_the_middle() {
        assert_eq!(median(&mut []), 0.0);
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
    }
}
