//! The show preview: a parsed [`Show`] played back in 3D (WebGL2) or as a 2D top
//! view, with the vendor app's four buttons (restart, step back, pause / play, step
//! forward), a time slider, the speed, a live mode that follows the matrix, a plot of
//! any ball tapped, and a performance panel.
//!
//! [`PreviewPage`] takes the show as a signal and draws it; pages only hand it a show
//! (and, for live mode, its name and the bridge's status). Every animation frame it
//! samples the show through the shared [`Sampler`] (the simulator's evaluator) into
//! buffers it keeps, and draws only when the picture changes.
//!
//! - [`playback`]: the controls as a plain type; [`live`]: the machine's clock;
//!   [`model`]: what the page shows as plain types (the clock on screen, the renderer
//!   chosen, the ball selected), so that [`PreviewPage`] only wires them;
//! - [`camera`], [`scene`], [`gestures`]: the 3D view's maths and touch handling;
//! - [`stage`]: a show on a canvas (sampling and the renderer); [`gl`]: WebGL2;
//!   [`top_view`]: the 2D fallback;
//! - [`plot`]: one ball over the whole show; [`perf`]: the performance panel;
//! - [`live_picture`]: the matrix's live positions while it is live (issue 38), in
//!   the Live card's chunk.

pub mod camera;
pub mod gestures;
pub mod gl;
pub mod live;
pub mod live_picture;
pub mod model;
pub mod perf;
pub mod playback;
pub mod plot;
pub mod scene;
pub mod stage;
pub mod top_view;

use std::rc::Rc;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use floatball_shared::api::{InstallationInfo, Status};
use floatball_shared::show::{Limits, Show, Violation};
use glam::Vec2;
use leptos::html::Canvas;
use leptos::prelude::*;

use crate::context::tr_in;
use wasm_bindgen::JsCast;

use crate::files::format_duration_ms;
use crate::i18n::{Lang, Text};
use gestures::{Gesture, Gestures};
use model::{Clock, Mode, ViewChoice};
use playback::{Playback, SPEEDS};
use plot::BallPlot;
use stage::{Matrix, RendererKind, Stage, now_ms};

/// How many validation problems are listed.
const PROBLEMS_SHOWN: usize = 10;

/// A show checked against the installation's limits, or the default limits of its
/// layout while the installation is not known.
#[derive(Debug, Clone, PartialEq)]
struct Checked {
    limits: Limits,
    /// Whether `limits` are the installation's.
    installed: bool,
    violations: Vec<Violation>,
    /// The first [`PROBLEMS_SHOWN`] violations in words, in 中文 and in English.
    words: [Vec<String>; 2],
    /// The balls with a violation, each once, in order.
    beyond: Vec<usize>,
}

impl Checked {
    /// Checks `show` with the check's code, a chunk of its own
    /// ([`crate::lazy::show_violations`]).
    async fn of(
        show: Arc<Show>,
        installation: Option<&InstallationInfo>,
    ) -> Result<Self, crate::lazy::ChunkError> {
        let limits = installation.map_or_else(
            || Limits::for_layout(show.layout.rows, show.layout.cols),
            crate::installation::limits_of,
        );
        let crate::lazy::Violations {
            all: violations,
            words_zh,
            words_en,
        } = crate::lazy::show_violations(show, limits, PROBLEMS_SHOWN).await?;
        let mut beyond: Vec<usize> = violations
            .iter()
            .filter_map(|violation| violation.unit.map(|unit| unit.index))
            .collect();
        beyond.sort_unstable();
        beyond.dedup();
        Ok(Self {
            limits,
            installed: installation.is_some(),
            violations,
            words: [words_zh, words_en],
            beyond,
        })
    }
}

/// Whether a show signal's new value is another show (a `Memo`'s comparison): shows
/// are shared ([`Arc`]) and compared by identity, never row by row.
pub fn show_changed(old: Option<&Option<Arc<Show>>>, new: Option<&Option<Arc<Show>>>) -> bool {
    match (old.map(Option::as_ref), new.map(Option::as_ref)) {
        (Some(Some(old)), Some(Some(new))) => !Arc::ptr_eq(old, new),
        (Some(None), Some(None)) => false,
        _ => true,
    }
}

/// The preview of `show`: the stage, the controls, the time, the tapped ball's plot,
/// and the show's problems against the installation's limits (the defaults while
/// it is not known); the 3D view uses its travel and pitch.
///
/// What it shows is kept in two plain models ([`model`]): the [`Clock`], which
/// moves every frame, and the [`ViewChoice`], which moves when the user asks.
#[component]
pub fn PreviewPage(
    /// The show to play; `None` shows a hint. Shared, never copied (a large show is
    /// many megabytes).
    #[prop(into)]
    show: Signal<Option<Arc<Show>>>,
    /// The language of the labels.
    #[prop(into)]
    lang: Signal<Lang>,
    /// The show's file name, to recognise it in the bridge's status (live mode).
    #[prop(optional, into)]
    name: MaybeProp<String>,
    /// The bridge's latest status; none while not connected.
    #[prop(optional, into)]
    status: MaybeProp<Status>,
    /// The installation (`GET /api/installation`) while connected: its limits, grid
    /// and pitch; the defaults and the show's pitch without it.
    #[prop(optional, into)]
    installation: MaybeProp<InstallationInfo>,
    /// Where a new show opens, paused, ms (the Control page's start time); none: from
    /// its start, playing.
    #[prop(optional, into)]
    from_ms: MaybeProp<u64>,
) -> impl IntoView {
    let clock = RwSignal::new(Clock::new(now_ms()));
    let view_choice = RwSignal::new(ViewChoice::default());
    // The check of a new show follows its first frame (two animation frames later):
    // a large show is on screen at once, and its balls beyond a limit turn red and
    // its problems are listed a moment after. The latest request wins.
    let checked = RwSignal::new(None::<Checked>);
    // The check's code could not be loaded (offline, or the app was updated).
    let check_failed = RwSignal::new(false);
    let check_due = StoredValue::new(0u32);
    Effect::new(move |_| {
        show.track();
        installation.track();
        checked.set(None);
        check_failed.set(false);
        let due = check_due.get_value().wrapping_add(1);
        check_due.set_value(due);
        request_animation_frame(move || {
            request_animation_frame(move || {
                if check_due.get_value() != due {
                    return;
                }
                let Some(show) = show.with_untracked(Clone::clone) else {
                    return;
                };
                let installation = installation.get_untracked();
                leptos::task::spawn_local(async move {
                    let result = Checked::of(show, installation.as_ref()).await;
                    // A newer show (or the page gone) makes this check void.
                    if check_due.try_get_value() != Some(due) {
                        return;
                    }
                    match result {
                        Ok(result) => {
                            checked.try_set(Some(result));
                        }
                        Err(crate::lazy::ChunkError) => {
                            check_failed.try_set(true);
                        }
                    }
                });
            });
        });
    });
    let matrix = Memo::new(move |_| {
        installation.with(|installation| {
            installation.as_ref().map(|info| Matrix {
                travel_mm: info.travel_mm,
                pitch_mm: info.pitch_mm,
            })
        })
    });
    let stage = StoredValue::new_local(None::<Stage>);
    // Counts the stages built or given a show, so the check's marks follow.
    let staged = RwSignal::new(0u32);
    let renderer = Memo::new(move |_| view_choice.with(ViewChoice::renderer));
    let selected = Memo::new(move |_| view_choice.with(ViewChoice::selected));
    let live = Memo::new(move |_| clock.with(|c| (c.live_on(), c.live_available())));
    let parts = StageParts {
        show,
        canvas: NodeRef::new(),
        stage,
        gestures: StoredValue::new(Gestures::default()),
        view_choice,
    };

    // A new show: from its start (or the start time it was opened at), nothing
    // chosen.
    Effect::new(move |_| {
        let duration_ms = show.with(|show| show.as_deref().map_or(0, Show::duration_ms));
        let from_ms = from_ms.get_untracked();
        clock.update(|clock| clock.for_show_from(duration_ms, from_ms));
        view_choice.update(|view| view.select(None));
    });

    // The stage follows the show, the canvas and the renderer asked for; where WebGL2
    // cannot draw, the canvas is replaced by a 2D one.
    Effect::new(move |_| {
        let kind = renderer.get();
        let canvas = parts.canvas.get();
        let matrix = matrix.get();
        // The balls beyond a limit are marked once the check is done (below).
        let beyond = Vec::new();
        show.with(|show| {
            let (Some(canvas), Some(show)) = (canvas, show) else {
                stage.set_value(None);
                return;
            };
            let reused = stage
                .try_update_value(|current| match current {
                    Some(current) if current.canvas() == &canvas && current.kind() == kind => {
                        Some(current.set_show(show, beyond.clone()))
                    }
                    _ => None,
                })
                .flatten();
            let outcome = match reused {
                Some(outcome) => outcome,
                None => Stage::new(canvas, show, beyond, kind).map(|new| {
                    stage.set_value(Some(new));
                }),
            }
            .and_then(|()| {
                stage
                    .try_update_value(|stage| stage.as_mut().map(|stage| stage.set_matrix(matrix)))
                    .flatten()
                    .unwrap_or(Ok(()))
            });
            match outcome {
                // The marks of the check, on this stage too (below).
                Ok(()) => staged.update(|n| *n = n.wrapping_add(1)),
                Err(why) => {
                    stage.set_value(None);
                    if kind == RendererKind::WebGl2 {
                        leptos::logging::warn!("3D preview unavailable: {why}");
                        view_choice.update(|view| view.webgl_failed(why));
                    }
                }
            }
        });
    });

    Effect::new(move |_| {
        let unit = selected.get();
        with_stage(stage, |stage| stage.select(unit));
    });

    // The balls beyond a limit, red on whatever stage draws the show: when the check
    // arrives, and when the stage is built or given the show anew (another view, a
    // resized canvas); none while the check of a new show is still to come.
    Effect::new(move |_| {
        staged.track();
        let beyond = checked.with(|checked| {
            checked
                .as_ref()
                .map(|c| c.beyond.clone())
                .unwrap_or_default()
        });
        with_stage(stage, |stage| stage.set_beyond(beyond));
    });

    // Live mode: the bridge's reports feed the clock.
    Effect::new(move |_| {
        let status = status.get();
        let name = name.get();
        let now = now_ms();
        clock.update(|clock| clock.report(status.as_ref(), name.as_deref(), now));
    });

    run_frames(clock, stage);

    let button = move |test_id: &'static str,
                       symbol: &'static str,
                       text: Text,
                       action: fn(&mut Playback)| {
        view! {
            <button
                class="icon"
                data-testid=test_id
                title=tr_in(lang, text)
                aria-label=tr_in(lang, text)
                disabled=move || show.with(Option::is_none)
                on:click=move |_| clock.update(|clock| clock.control(action))
            >
                <span class="symbol" aria-hidden="true">
                    {symbol}
                </span>
                <span class="caption">{tr_in(lang, text)}</span>
            </button>
        }
    };
    let playing = move || clock.with(|clock| clock.playback().playing());
    let t_ms = move || clock.with(Clock::t_ms);
    let toggle_text = move || if playing() { Text::Pause } else { Text::Play };

    let plot = Memo::new(move |_| {
        let unit = selected.get()?;
        show.with(|show| {
            checked.with(|checked| {
                let (show, checked) = (show.as_ref()?, checked.as_ref()?);
                BallPlot::new(show, unit, &checked.limits, &checked.violations)
            })
        })
    });

    view! {
        <div class="preview" data-testid="preview">
            <Show
                when=move || show.with(Option::is_some)
                fallback=move || view! { <p class="muted" data-testid="preview-empty">{tr_in(lang, Text::NoShowSelected)}</p> }
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
            <div class="stage-box">
                <Show
                    when=move || renderer.get() == RendererKind::WebGl2
                    fallback=move || stage_canvas(RendererKind::TopView, parts)
                >
                    {stage_canvas(RendererKind::WebGl2, parts)}
                </Show>
            </div>
            <Show when=move || view_choice.with(ViewChoice::explains_no_webgl)>
                <p class="note" data-testid="preview-no-webgl">{tr_in(lang, Text::NoWebGl)}</p>
            </Show>
            <div class="transport">
                {button("preview-restart", "|◀", Text::Restart, Playback::restart)}
                {button("preview-back", "◀◀", Text::StepBack, Playback::step_back)}
                <button
                    class="icon"
                    data-testid="preview-toggle"
                    data-playing=move || playing().to_string()
                    title=move || lang.get().t(toggle_text())
                    aria-label=move || lang.get().t(toggle_text())
                    disabled=move || show.with(Option::is_none)
                    on:click=move |_| clock.update(|clock| clock.control(Playback::toggle))
                >
                    <span class="symbol" aria-hidden="true">
                        {move || if playing() { "II" } else { "▶" }}
                    </span>
                    <span class="caption">{move || lang.get().t(toggle_text())}</span>
                </button>
                {button("preview-forward", "▶▶", Text::StepForward, Playback::step_forward)}
                <span
                    class="time mono"
                    data-testid="preview-time"
                    data-t-ms=move || format!("{:.0}", t_ms())
                >
                    {move || {
                        clock.with(|clock| {
                            format!(
                                "{} / {}",
                                format_duration_ms(clock.t_ms() as u64),
                                format_duration_ms(clock.playback().duration_ms() as u64),
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
                aria-label=tr_in(lang, Text::ShowTime)
                data-testid="preview-slider"
                prop:max=move || clock.with(|clock| clock.playback().duration_ms())
                prop:value=t_ms
                on:input=move |ev| {
                    if let Ok(t_ms) = event_target_value(&ev).parse::<f64>() {
                        clock.update(|clock| clock.control(|p| p.seek(t_ms)));
                    }
                }
            />
            <div class="tools">
                <label class="speed">
                    <span>{tr_in(lang, Text::PlaybackSpeed)}</span>
                    <select
                        data-testid="preview-speed"
                        on:change=move |ev| {
                            if let Ok(speed) = event_target_value(&ev).parse::<f64>() {
                                clock.update(|clock| clock.set_speed(speed));
                            }
                        }
                    >
                        {SPEEDS
                            .iter()
                            .map(|speed| {
                                view! {
                                    <option
                                        value=speed.to_string()
                                        selected=move || clock.with(|clock| clock.playback().speed()) == *speed
                                    >
                                        {format!("{speed}×")}
                                    </option>
                                }
                            })
                            .collect_view()}
                    </select>
                </label>
                <Show when=move || status.with(Option::is_some)>
                    <button
                        class="toggle"
                        class:on=move || live.get().0
                        data-testid="preview-live"
                        aria-pressed=move || live.get().0.to_string()
                        title=tr_in(lang, Text::LiveHint)
                        disabled=move || !live.get().1
                        on:click=move |_| clock.update(Clock::toggle_live)
                    >
                        {tr_in(lang, Text::Live)}
                    </button>
                </Show>
                <div class="segmented" role="group">
                    <button
                        data-testid="preview-mode-3d"
                        aria-pressed=move || (view_choice.with(ViewChoice::mode) == Mode::ThreeD).to_string()
                        disabled=move || !view_choice.with(ViewChoice::offers_3d)
                        on:click=move |_| view_choice.update(|view| view.choose(Mode::ThreeD))
                    >
                        {tr_in(lang, Text::View3d)}
                    </button>
                    <button
                        data-testid="preview-mode-top"
                        aria-pressed=move || (renderer.get() == RendererKind::TopView).to_string()
                        on:click=move |_| view_choice.update(|view| view.choose(Mode::Top))
                    >
                        {tr_in(lang, Text::TopView)}
                    </button>
                </div>
                <Show when=move || renderer.get() == RendererKind::WebGl2>
                    <button
                        data-testid="preview-reset-view"
                        on:click=move |_| with_stage(stage, Stage::reset_view)
                    >
                        {tr_in(lang, Text::ResetView)}
                    </button>
                </Show>
                <button
                    class="toggle"
                    class:on=move || view_choice.with(ViewChoice::perf_open)
                    data-testid="preview-perf"
                    aria-pressed=move || view_choice.with(ViewChoice::perf_open).to_string()
                    on:click=move |_| {
                        let mut opened = false;
                        view_choice.update(|view| opened = view.toggle_perf());
                        if opened {
                            clock.update(Clock::pause);
                        }
                    }
                >
                    {tr_in(lang, Text::Performance)}
                </button>
            </div>
            <Show when=move || status.with(Option::is_some) && !live.get().1>
                <p class="muted small" data-testid="preview-live-hint">{tr_in(lang, Text::LiveHint)}</p>
            </Show>
            <Show when=move || renderer.get() == RendererKind::WebGl2 && show.with(Option::is_some)>
                <p class="muted small">{tr_in(lang, Text::GestureHint)}</p>
            </Show>
            {move || {
                plot.get()
                    .map(|plot| {
                        let t_ms = Signal::derive(t_ms);
                        let on_close = Callback::new(move |()| view_choice.update(|view| view.select(None)));
                        crate::lazy::chunk_view(
                            lang,
                            Text::PartFailed,
                            crate::lazy::plot_panel,
                            move |panel: crate::lazy::PlotView| panel(plot.clone(), lang, t_ms, on_close),
                        )
                    })
            }}
            <Show when=move || view_choice.with(ViewChoice::perf_open)>
                {crate::lazy::chunk_view(
                    lang,
                    Text::PartFailed,
                    crate::lazy::perf_panel,
                    move |panel: crate::lazy::PerfView| panel(lang),
                )}
            </Show>
            <Show when=move || show.with(Option::is_some)>
                {move || {
                    if check_failed.get() {
                        return view! {
                            <p class="note error" data-testid="preview-check-failed">
                                {tr_in(lang, Text::CheckFailed)} " "
                                <button on:click=move |_| crate::lazy::reload_app()>
                                    {tr_in(lang, Text::ReloadApp)}
                                </button>
                            </p>
                        }
                        .into_any();
                    }
                    checked.with(|checked| problems_view(checked.as_ref(), lang))
                }}
            </Show>
        </div>
    }
}

/// The show's problems against the limits, or that it is within them.
fn problems_view(checked: Option<&Checked>, lang: Signal<Lang>) -> AnyView {
    // Nothing while the check is still to come.
    let Some(checked) = checked else {
        return ().into_any();
    };
    let violations = &checked.violations[..];
    let installed = checked.installed;
    let count = violations.len();
    if count == 0 {
        let within = if installed {
            Text::WithinInstallationLimits
        } else {
            Text::WithinLimits
        };
        return view! { <p class="note done" data-testid="preview-valid">{tr_in(lang, within)}</p> }
            .into_any();
    }
    let beyond = if installed {
        Text::BeyondInstallationLimits
    } else {
        Text::BeyondLimits
    };
    let shown = checked.words[usize::from(lang.get() == Lang::En)].clone();
    let more = count.saturating_sub(shown.len());
    view! {
        <div class="note error" data-testid="preview-problems" data-limits=if installed { "installation" } else { "default" }>
            <p>{tr_in(lang, beyond)} " " {count}</p>
            <ul>
                {shown.into_iter().map(|problem| view! { <li>{problem}</li> }).collect_view()}
                {(more > 0).then(|| view! { <li>"…"</li> })}
            </ul>
        </div>
    }
    .into_any()
}

/// Runs `act` on the stage, if there is one.
pub(crate) fn with_stage(
    stage: StoredValue<Option<Stage>, LocalStorage>,
    act: impl FnOnce(&mut Stage),
) {
    stage.update_value(|stage| {
        if let Some(stage) = stage {
            act(stage);
        }
    });
}

/// Starts the frame loop until the component goes: every frame the clock moves (own
/// or live), then the stage draws if its picture changed.
fn run_frames(clock: RwSignal<Clock>, stage: StoredValue<Option<Stage>, LocalStorage>) {
    let alive = Arc::new(AtomicBool::new(true));
    {
        let alive = Arc::clone(&alive);
        on_cleanup(move || alive.store(false, Ordering::Relaxed));
    }
    let step = move || {
        let now = now_ms();
        clock.maybe_update(|clock| clock.frame(now));
        let t_ms = clock.with_untracked(Clock::t_ms);
        with_stage(stage, |stage| {
            stage.draw(t_ms, false);
        });
    };
    animate(Rc::new(step), alive);
}

/// What the stage's canvas is wired to (all `Copy`, for the event handlers).
#[derive(Clone, Copy)]
pub(crate) struct StageParts {
    pub(crate) show: Signal<Option<Arc<Show>>>,
    pub(crate) canvas: NodeRef<Canvas>,
    pub(crate) stage: StoredValue<Option<Stage>, LocalStorage>,
    pub(crate) gestures: StoredValue<Gestures>,
    pub(crate) view_choice: RwSignal<ViewChoice>,
}

/// Where a pointer event is on its target, CSS pixels.
fn point(event: &web_sys::MouseEvent) -> Vec2 {
    let rect = event
        .target()
        .and_then(|target| target.dyn_into::<web_sys::Element>().ok())
        .map(|element| element.get_bounding_client_rect());
    let (left, top) = rect.map_or((0.0, 0.0), |rect| (rect.left(), rect.top()));
    Vec2::new(
        (f64::from(event.client_x()) - left) as f32,
        (f64::from(event.client_y()) - top) as f32,
    )
}

/// The canvas `kind` draws on, with the pointer gestures: drag to turn (or pan with
/// the right button or Shift), wheel to zoom, tap to select a ball. One canvas per
/// renderer: a canvas that had a WebGL2 context cannot draw in 2D, so switching
/// makes a new one.
pub(crate) fn stage_canvas(kind: RendererKind, parts: StageParts) -> impl IntoView {
    let StageParts {
        show,
        canvas,
        stage,
        gestures,
        view_choice,
    } = parts;
    let apply = move |moves: Vec<Gesture>| {
        with_stage(stage, |stage| {
            for gesture in moves {
                stage.apply(gesture);
            }
        });
    };
    let released = move |event: web_sys::PointerEvent, tap: bool| {
        let at = point(&event);
        let gesture = gestures
            .try_update_value(|g| g.up(event.pointer_id(), at, tap, now_ms()))
            .flatten();
        if let Some(Gesture::Tap(at)) = gesture {
            let picked = stage.with_value(|stage| stage.as_ref().and_then(|s| s.pick(at)));
            view_choice.update(|view| view.select(picked));
        }
    };
    let style = move || match (kind, show.with(|show| show.as_ref().map(|s| s.layout))) {
        (RendererKind::TopView, Some(layout)) => format!(
            "aspect-ratio: {} / {}",
            layout.cols.max(1),
            layout.rows.max(1)
        ),
        (RendererKind::TopView, None) => "aspect-ratio: 1".to_owned(),
        (RendererKind::WebGl2, _) => String::new(),
    };
    view! {
        <canvas
            node_ref=canvas
            class="stage"
            class:three-d=kind == RendererKind::WebGl2
            data-testid="preview-canvas"
            data-renderer=kind.name()
            style=style
            on:pointerdown=move |event| {
                let at = point(&event);
                let pan = event.button() == 2 || event.shift_key();
                gestures.update_value(|g| g.down(event.pointer_id(), at, pan, now_ms()));
                if let Some(target) = event
                    .target()
                    .and_then(|target| target.dyn_into::<web_sys::Element>().ok())
                {
                    // Synthetic pointers cannot be captured; the drag then ends at
                    // the canvas's edge.
                    let _ = target.set_pointer_capture(event.pointer_id());
                }
            }
            on:pointermove=move |event| {
                let at = point(&event);
                let moves = gestures
                    .try_update_value(|g| g.moved(event.pointer_id(), at))
                    .unwrap_or_default();
                apply(moves);
            }
            on:pointerup=move |event| released(event, true)
            on:pointercancel=move |event| released(event, false)
            on:wheel=move |event| {
                event.prevent_default();
                apply(vec![Gestures::wheel(event.delta_y())]);
            }
            on:contextmenu=move |event| event.prevent_default()
        ></canvas>
    }
}

/// Runs `step` on every animation frame while `alive`.
pub(crate) fn animate(step: Rc<dyn Fn()>, alive: Arc<AtomicBool>) {
    request_animation_frame(move || {
        if alive.load(Ordering::Relaxed) {
            step();
            animate(step, alive);
        }
    });
}

/// The tapped ball's plot, its figures and its problems, with the time on screen
/// marked.
#[component]
pub fn PlotPanel(
    plot: BallPlot,
    #[prop(into)] lang: Signal<Lang>,
    /// The show time on screen, ms.
    #[prop(into)]
    t_ms: Signal<f64>,
    on_close: impl Fn() + 'static,
) -> impl IntoView {
    let canvas = NodeRef::<Canvas>::new();
    let plot = StoredValue::new(plot);
    let resized = RwSignal::new(0u32);
    // Where the panels are on the canvas drawn, as shares of its size.
    let drawn = RwSignal::new(None::<plot::PlotLayout>);
    let size = RwSignal::new((1.0f64, 1.0f64));
    let resize = window_event_listener(leptos::ev::resize, move |_| resized.update(|n| *n += 1));
    on_cleanup(move || resize.remove());
    Effect::new(move |_| {
        resized.track();
        let lang = lang.get();
        let Some(canvas) = canvas.get() else { return };
        let Some(context) = canvas
            .get_context("2d")
            .ok()
            .flatten()
            .and_then(|context| context.dyn_into::<web_sys::CanvasRenderingContext2d>().ok())
        else {
            return;
        };
        let ratio = window().device_pixel_ratio().clamp(1.0, 2.0);
        let width = (f64::from(canvas.client_width().max(200)) * ratio).round();
        let height = (f64::from(canvas.client_height().max(120)) * ratio).round();
        canvas.set_width(width as u32);
        canvas.set_height(height as u32);
        plot.with_value(|plot| {
            let end = format_duration_ms(plot.duration_ms as u64);
            plot::draw(
                &context,
                plot,
                (width, height),
                plot::Labels {
                    position: lang.t(Text::PlotPosition),
                    velocity: lang.t(Text::PlotVelocity),
                    start: &format_duration_ms(0),
                    end: &end,
                },
            );
            drawn.set(Some(plot.layout(width, height)));
            size.set((width, height));
        });
    });
    let cursor = move || {
        let layout = drawn.get()?;
        let (width, height) = size.get();
        let x = layout.time.px(t_ms.get()) / width * 100.0;
        let top = layout.position.px_lo / height * 100.0;
        let bottom = layout.velocity.px_hi / height * 100.0;
        Some(format!(
            "left: {x:.3}%; top: {top:.3}%; height: {:.3}%",
            bottom - top
        ))
    };
    let (index, row, col, facts, problems) = plot.with_value(|plot| {
        let (highest, lowest) = plot.position_range_mm();
        (
            plot.unit.index,
            plot.unit.row,
            plot.unit.col,
            (highest, lowest, plot.peak_speed_mm_s()),
            plot.violations.clone(),
        )
    });
    let count = problems.len();
    view! {
        <section class="plot card" data-testid="preview-plot" data-unit=index data-violations=count>
            <div class="plot-head">
                <h3 data-testid="preview-plot-title">{move || lang.get().ball_name(index, row, col)}</h3>
                <button data-testid="preview-plot-close" on:click=move |_| on_close()>
                    {tr_in(lang, Text::Close)}
                </button>
            </div>
            <p class="muted small">{move || lang.get().ball_facts(facts.0, facts.1, facts.2)}</p>
            <div class="plot-wrap">
                <canvas node_ref=canvas class="plot-canvas" data-testid="preview-plot-canvas"></canvas>
                <div class="plot-cursor" data-testid="preview-plot-cursor" style=cursor></div>
            </div>
            {if count == 0 {
                view! { <p class="note done">{tr_in(lang, Text::BallWithinLimits)}</p> }.into_any()
            } else {
                view! {
                    <ul class="note error" data-testid="preview-plot-problems">
                        {problems
                            .into_iter()
                            .map(|problem| view! { <li>{move || lang.get().error_of(&problem)}</li> })
                            .collect_view()}
                    </ul>
                }
                    .into_any()
            }}
        </section>
    }
}
