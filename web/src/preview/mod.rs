//! The show preview: a parsed [`Show`] played back with the vendor app's four buttons
//! (restart, step back, pause / play, step forward) and a time slider.
//!
//! [`PreviewPage`] takes the show as a signal and draws it; pages only hand it a show.
//! Until the 3D renderer (WebGL2) lands, it draws the 2D [`top_view`]; the renderer
//! replaces that canvas here without touching the pages.
//!
//! - [`playback`]: the controls as a plain type;
//! - [`top_view`]: geometry, shading and drawing of the top view.

pub mod playback;
pub mod top_view;

use std::time::Duration;

use floatball_shared::show::{Layout, Limits, Sampler, Show, validate};
use leptos::html::Canvas;
use leptos::prelude::*;
use wasm_bindgen::JsCast;

use crate::files::format_duration_ms;
use crate::i18n::{Lang, Text};
use playback::Playback;

/// How often the clock advances while playing (about 30 frames a second).
const FRAME: Duration = Duration::from_millis(33);

/// How many validation problems are listed.
const PROBLEMS_SHOWN: usize = 10;

/// A show being sampled, with its buffers.
struct Frame {
    sampler: Sampler,
    layout: Layout,
    positions_mm: Vec<f32>,
    colours: Vec<[u8; 3]>,
}

/// The preview of `show`: canvas, controls, time, and the show's problems against
/// the default limits.
#[component]
pub fn PreviewPage(
    /// The show to play; `None` shows a hint.
    #[prop(into)]
    show: Signal<Option<Show>>,
    /// The language of the labels.
    #[prop(into)]
    lang: Signal<Lang>,
) -> impl IntoView {
    let playback = RwSignal::new(Playback::new(0));
    let frame = StoredValue::new_local(None::<Frame>);
    let problems = RwSignal::new((0usize, Vec::<String>::new()));
    let canvas = NodeRef::<Canvas>::new();
    let generation = RwSignal::new(0u32);

    Effect::new(move |_| {
        show.with(|show| match show {
            Some(show) => {
                let units = show.tracks.len();
                frame.set_value(Some(Frame {
                    sampler: Sampler::new(show),
                    layout: show.layout,
                    positions_mm: vec![0.0; units],
                    colours: vec![[0; 3]; units],
                }));
                let limits = Limits::for_layout(show.layout.rows, show.layout.cols);
                let violations = validate(show, &limits);
                problems.set((
                    violations.len(),
                    violations
                        .iter()
                        .take(PROBLEMS_SHOWN)
                        .map(ToString::to_string)
                        .collect(),
                ));
                playback.set(Playback::new(show.duration_ms()));
            }
            None => {
                frame.set_value(None);
                problems.set((0, Vec::new()));
            }
        });
        generation.update(|n| *n += 1);
    });

    // Draw whenever the time, the show or the canvas changes.
    Effect::new(move |_| {
        let t_ms = playback.with(Playback::t_ms);
        generation.track();
        let Some(canvas) = canvas.get() else { return };
        frame.update_value(|frame| {
            if let Some(frame) = frame {
                draw(&canvas, frame, t_ms);
            }
        });
    });

    // The clock.
    let last_ms = StoredValue::new(js_sys::Date::now());
    let clock = set_interval_with_handle(
        move || {
            let now = js_sys::Date::now();
            let elapsed = now - last_ms.get_value();
            last_ms.set_value(now);
            if playback.with_untracked(Playback::playing) {
                playback.update(|p| p.advance(elapsed));
            }
        },
        FRAME,
    );
    if let Ok(clock) = clock {
        on_cleanup(move || clock.clear());
    }

    let button = move |test_id: &'static str,
                       symbol: &'static str,
                       text: Text,
                       action: fn(&mut Playback)| {
        view! {
            <button
                class="icon"
                data-testid=test_id
                title=move || lang.get().t(text)
                aria-label=move || lang.get().t(text)
                disabled=move || show.with(Option::is_none)
                on:click=move |_| playback.update(action)
            >
                <span class="symbol" aria-hidden="true">
                    {symbol}
                </span>
                <span class="caption">{move || lang.get().t(text)}</span>
            </button>
        }
    };
    let toggle_text = move || {
        if playback.with(Playback::playing) {
            Text::Pause
        } else {
            Text::Play
        }
    };
    let aspect = move || {
        show.with(|show| {
            show.as_ref().map_or_else(
                || "aspect-ratio: 1".to_owned(),
                |show| {
                    format!(
                        "aspect-ratio: {} / {}",
                        show.layout.cols.max(1),
                        show.layout.rows.max(1)
                    )
                },
            )
        })
    };
    view! {
        <div class="preview" data-testid="preview">
            <Show
                when=move || show.with(Option::is_some)
                fallback=move || view! { <p class="muted" data-testid="preview-empty">{move || lang.get().t(Text::NoShowSelected)}</p> }
            >
                <p class="muted" data-testid="preview-facts">
                    {move || {
                        show.with(|show| {
                            show.as_ref()
                                .map(|show| {
                                    lang.get()
                                        .show_facts(show.tracks.len(), &format_duration_ms(show.duration_ms()))
                                })
                        })
                    }}
                </p>
            </Show>
            <canvas node_ref=canvas class="stage" data-testid="preview-canvas" style=aspect></canvas>
            <div class="transport">
                {button("preview-restart", "|◀", Text::Restart, Playback::restart)}
                {button("preview-back", "◀◀", Text::StepBack, Playback::step_back)}
                <button
                    class="icon"
                    data-testid="preview-toggle"
                    data-playing=move || playback.with(Playback::playing).to_string()
                    title=move || lang.get().t(toggle_text())
                    aria-label=move || lang.get().t(toggle_text())
                    disabled=move || show.with(Option::is_none)
                    on:click=move |_| playback.update(Playback::toggle)
                >
                    <span class="symbol" aria-hidden="true">
                        {move || if playback.with(Playback::playing) { "II" } else { "▶" }}
                    </span>
                    <span class="caption">{move || lang.get().t(toggle_text())}</span>
                </button>
                {button("preview-forward", "▶▶", Text::StepForward, Playback::step_forward)}
                <span class="time mono" data-testid="preview-time">
                    {move || {
                        playback.with(|p| {
                            format!(
                                "{} / {}",
                                format_duration_ms(p.t_ms() as u64),
                                format_duration_ms(p.duration_ms() as u64),
                            )
                        })
                    }}
                </span>
            </div>
            <input
                type="range"
                class="slider"
                min="0"
                step="10"
                aria-label=move || lang.get().t(Text::ShowTime)
                data-testid="preview-slider"
                prop:max=move || playback.with(Playback::duration_ms)
                prop:value=move || playback.with(Playback::t_ms)
                on:input=move |ev| {
                    if let Ok(t_ms) = event_target_value(&ev).parse::<f64>() {
                        playback.update(|p| p.seek(t_ms));
                    }
                }
            />
            <Show when=move || show.with(Option::is_some)>
                {move || {
                    let (count, shown) = problems.get();
                    if count == 0 {
                        view! { <p class="note done" data-testid="preview-valid">{move || lang.get().t(Text::WithinLimits)}</p> }
                            .into_any()
                    } else {
                        let more = count.saturating_sub(shown.len());
                        view! {
                            <div class="note error" data-testid="preview-problems">
                                <p>{move || lang.get().t(Text::BeyondLimits)} " " {count}</p>
                                <ul>
                                    {shown.into_iter().map(|problem| view! { <li>{problem}</li> }).collect_view()}
                                    {(more > 0).then(|| view! { <li>"…"</li> })}
                                </ul>
                            </div>
                        }
                            .into_any()
                    }
                }}
            </Show>
        </div>
    }
}

/// Samples the show at `t_ms` and draws it, sizing the canvas to its box.
fn draw(canvas: &web_sys::HtmlCanvasElement, frame: &mut Frame, t_ms: f64) {
    let ratio = window().device_pixel_ratio().max(1.0);
    let css_width = f64::from(canvas.client_width().max(0));
    let css_height = f64::from(canvas.client_height().max(0));
    let (css_width, css_height) = if css_width < 1.0 || css_height < 1.0 {
        (320.0, 320.0)
    } else {
        (css_width, css_height)
    };
    let width = (css_width * ratio).round() as u32;
    let height = (css_height * ratio).round() as u32;
    if canvas.width() != width || canvas.height() != height {
        canvas.set_width(width);
        canvas.set_height(height);
    }
    let Some(context) = canvas
        .get_context("2d")
        .ok()
        .flatten()
        .and_then(|context| context.dyn_into::<web_sys::CanvasRenderingContext2d>().ok())
    else {
        return;
    };
    frame
        .sampler
        .sample(t_ms, &mut frame.positions_mm, Some(&mut frame.colours));
    top_view::draw(
        &context,
        frame.layout,
        (f64::from(width), f64::from(height)),
        &frame.positions_mm,
        &frame.colours,
    );
}
