//! The Create page: a show made from patterns on a timeline, previewed in 3D while
//! its parameters change (the preview checks it against the installation, or the
//! default limits offline), checked against the line's bandwidth, and saved to the local files, to the
//! controller or as a recipe.
//!
//! The draft lives in [`Ctx::create`] ([`crate::create::Draft`]), so it survives a
//! visit to another page. A change is generated at most once an animation frame:
//! dragging a slider regenerates the latest values, never a queue of old ones.
//! On a phone the picture comes first and stays at the top while the controls
//! scroll under it; wider screens put the controls beside it.

use std::rc::Rc;
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};

use floatball_shared::api::PlanReport;
use floatball_shared::create::recipe::{MAX_SEGMENTS, MAX_SHOW_S, MAX_TRANSITION_S, Recipe};
use floatball_shared::create::{
    self, CreateError, PATTERNS, ParamKind, ParamSpec, Value, params::encode_base64,
};
use floatball_shared::show::{Show, ShowFormat};
use leptos::prelude::*;
use leptos::task::spawn_local;
use wasm_bindgen::JsCast;
use wasm_bindgen_futures::JsFuture;

use crate::client::{OnProgress, UploadProgress};
use crate::components::files::{Message, save_text, upload_show};
use crate::components::{store, stored};
use crate::context::Ctx;
use crate::create::{Draft, Made, Target, format_number};
use crate::files::LocalFile;
use crate::i18n::{CreateText, Text, create as words};
use crate::plan_worker::PlanWorker;
use crate::preview::PreviewPage;

/// The generated show and what is said about it, kept apart so the show (large at
/// 10,000 balls) is never copied.
#[derive(Debug, Clone, PartialEq, Default)]
struct Outcome {
    /// What was changed to keep within the limits, in words.
    notes: Vec<String>,
    /// Why nothing could be made.
    error: Option<String>,
    /// How long the last generation took, ms.
    generated_ms: f64,
    /// Generations so far (tests wait for the next one).
    count: u32,
}

/// The planner's verdict in words: whether the line can carry the show, why not,
/// what would make it run, and where it was planned (`worker` or `page`).
type Verdict = (bool, Option<String>, Vec<String>, &'static str);

fn now_ms() -> f64 {
    window()
        .performance()
        .map_or_else(js_sys::Date::now, |performance| performance.now())
}

/// Where the draft is kept in the browser (as a recipe), so a reload keeps the work.
const RECIPE_KEY: &str = "floatball.recipe";
/// The draft is saved this long after its last change (or when the page is hidden
/// or left).
const DRAFT_SAVE_MS: u64 = 400;

/// The draft across reloads, for as long as the page is open: read back from the
/// browser the first time the page opens (its code is in this page's chunk, so the
/// app's first load does not carry the recipe reader), then saved a moment after
/// the last change — not on every one (a dragged slider changes it every frame, and
/// a recipe with a picture is large) — and at once when the browser hides or leaves
/// the app or the operator leaves the page. Only this page changes the draft. A
/// storage too full for a large picture only costs the draft across reloads.
fn keep_draft(ctx: Ctx) {
    if !ctx.create_restored.get_value() {
        ctx.create_restored.set_value(true);
        if let Some(draft) = stored(RECIPE_KEY)
            .and_then(|text| Recipe::from_json(&text).ok())
            .and_then(|recipe| Draft::from_recipe(recipe, crate::create::DEFAULT_GRID).ok())
        {
            ctx.create.set(draft);
        }
    }
    // Counted outside the page's reactive arena: the saves at cleanup and after the
    // pause must still see them once the page is gone.
    let changes = Arc::new(AtomicU32::new(0));
    let save = {
        let changes = Arc::clone(&changes);
        let saved = AtomicU32::new(0);
        Arc::new(move || {
            let change = changes.load(Ordering::Relaxed);
            if saved.swap(change, Ordering::Relaxed) != change {
                let text = ctx
                    .create
                    .try_with_untracked(|draft| draft.recipe().to_json().ok())
                    .flatten();
                store(RECIPE_KEY, text.as_deref());
            }
        })
    };
    {
        let save = Arc::clone(&save);
        Effect::new(move |first: Option<()>| {
            ctx.create.track();
            if first.is_none() {
                // The draft as it was read back (or the default): nothing to save.
                return;
            }
            let change = changes.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
            let (changes, save) = (Arc::clone(&changes), Arc::clone(&save));
            set_timeout(
                move || {
                    if changes.load(Ordering::Relaxed) == change {
                        save();
                    }
                },
                std::time::Duration::from_millis(DRAFT_SAVE_MS),
            );
        });
    }
    let when_hidden = {
        let save = Arc::clone(&save);
        window_event_listener_untyped("visibilitychange", move |_| {
            if document().visibility_state() == web_sys::VisibilityState::Hidden {
                save();
            }
        })
    };
    let when_left = {
        let save = Arc::clone(&save);
        window_event_listener_untyped("pagehide", move |_| save())
    };
    on_cleanup(move || {
        save();
        when_hidden.remove();
        when_left.remove();
    });
}

/// The Create page.
#[component]
pub fn CreatePage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    keep_draft(ctx);
    let draft = ctx.create;
    let target = Memo::new(move |_| {
        let installation = ctx.installation_now();
        let grid = draft.with(Draft::grid);
        Target::of(installation.as_ref(), grid)
    });
    // Shared with the preview, never copied: at 100 × 100 a minute is 70 MB of rows.
    let show = RwSignal::new(None::<Arc<Show>>);
    let outcome = RwSignal::new(Outcome::default());
    let message = RwSignal::new(None::<Message>);

    // The line's verdict plans the whole show: two frames after the picture, for the
    // latest show only (a slider being dragged plans once it rests). In a worker when
    // the page can start one (`plan_worker`), so that a large plan never holds the
    // page (and its E-STOP); else here.
    let verdict = RwSignal::new(None::<Verdict>);
    let verdict_due = StoredValue::new(0u32);
    let in_words = move |report: PlanReport, planned_in: &'static str| -> Verdict {
        let lang = ctx.lang.get_untracked();
        (
            report.feasible,
            lang.plan_reason(&report),
            lang.plan_fixes(&report),
            planned_in,
        )
    };
    let plan_here = move || {
        let report = show.with_untracked(|show| {
            show.as_ref()
                .and_then(|show| target.with_untracked(|t| t.verdict(show)))
        });
        verdict.set(report.map(|report| in_words(report, "page")));
    };
    // None: not tried yet; Some(None): no worker here.
    let worker = StoredValue::new_local(None::<Option<PlanWorker>>);
    let plan_in_worker = move |due: u32| -> bool {
        let Some(installation) = target.with_untracked(|t| t.installation.clone()) else {
            return false;
        };
        if worker.with_value(Option::is_none) {
            let started = PlanWorker::start(move |id, answer| {
                if id != verdict_due.get_value() {
                    return;
                }
                match answer {
                    Ok(report) => verdict.set(report.map(|report| in_words(report, "worker"))),
                    Err(error) => {
                        leptos::logging::warn!("planning in the worker failed: {error}");
                        plan_here();
                    }
                }
            });
            worker.set_value(Some(started));
        }
        let (Ok(recipe), Ok(installation)) = (
            draft.with_untracked(Draft::recipe).to_json(),
            serde_json::to_string(&installation),
        ) else {
            return false;
        };
        worker.with_value(|worker| {
            worker
                .as_ref()
                .and_then(Option::as_ref)
                .is_some_and(|worker| worker.plan(due, &recipe, &installation))
        })
    };
    let plan_after_the_picture = move || {
        verdict.set(None);
        let due = verdict_due.get_value().wrapping_add(1);
        verdict_due.set_value(due);
        request_animation_frame(move || {
            request_animation_frame(move || {
                if verdict_due.get_value() != due {
                    return;
                }
                if !plan_in_worker(due) {
                    plan_here();
                }
            });
        });
    };

    // Generation: at most once an animation frame, from the latest draft.
    let scheduled = StoredValue::new(false);
    let generate = move || {
        scheduled.set_value(false);
        let lang = ctx.lang.get_untracked();
        let started = now_ms();
        let result = draft.with_untracked(|draft| draft.make(&target.get_untracked()));
        let generated_ms = now_ms() - started;
        let count = outcome.with_untracked(|o| o.count.wrapping_add(1));
        match result {
            Ok(made) => {
                let Made {
                    show: made_show,
                    notes,
                } = made;
                outcome.set(Outcome {
                    notes: notes.iter().map(|note| words::note(lang, note)).collect(),
                    error: None,
                    generated_ms,
                    count,
                });
                show.set(Some(Arc::new(made_show)));
                plan_after_the_picture();
            }
            Err(error) => {
                outcome.set(Outcome {
                    error: Some(words::error(lang, &error)),
                    generated_ms,
                    count,
                    ..Outcome::default()
                });
                show.set(None);
                verdict.set(None);
            }
        }
    };
    // What the show depends on (not its name): a new name does not regenerate.
    let inputs = Memo::new(move |_| draft.with(|d| (d.segments().to_vec(), d.grid())));
    Effect::new(move |_| {
        inputs.track();
        target.track();
        ctx.lang.track();
        if !scheduled.get_value() {
            scheduled.set_value(true);
            request_animation_frame(generate);
        }
    });

    let lang = ctx.lang;
    view! {
        <section class="create-page" data-testid="create">
            <div class="create-preview">
                <PreviewPage
                    show=Signal::derive(move || show.get())
                    lang=ctx.lang
                    installation=Signal::derive(move || ctx.installation_now())
                />
            </div>
            <div class="create-controls">
                <Timeline show=show />
                <SegmentEditor />
                <Checks outcome=outcome target=target verdict=verdict />
                <Actions show=show target=target outcome=outcome message=message />
                {move || {
                    message
                        .get()
                        .map(|message| {
                            view! {
                                <div class="note" class:error=message.error data-testid="create-message">
                                    <p>{message.text}</p>
                                    <ul>{message.details.into_iter().map(|d| view! { <li>{d}</li> }).collect_view()}</ul>
                                </div>
                            }
                        })
                }}
                <p class="muted" data-testid="create-generated" data-ms=move || format!("{:.1}", outcome.with(|o| o.generated_ms))
                    data-count=move || outcome.with(|o| o.count)
                >
                    {move || {
                        format!(
                            "{} {:.0} ms",
                            lang.get().t(CreateText::GeneratedIn),
                            outcome.with(|o| o.generated_ms),
                        )
                    }}
                </p>
            </div>
        </section>
    }
}

/// The show's name, its length and the list of segments: pick, move, remove, add.
#[component]
fn Timeline(show: RwSignal<Option<Arc<Show>>>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let draft = ctx.create;
    let rows = move || {
        let lang = ctx.lang.get();
        draft.with(|now| {
            let count = now.segments().len();
            now
                .segments()
                .iter()
                .enumerate()
                .map(|(index, segment)| {
                    let label = format!(
                        "{}. {} · {} s",
                        index + 1,
                        words::pattern(lang, &segment.pattern),
                        format_number(segment.duration_s, 0.5),
                    );
                    let selected = index == now.selected();
                    // A small button acting on this segment.
                    let icon = move |test_id: &'static str,
                                     text: Text,
                                     symbol: &'static str,
                                     disabled: bool,
                                     act: fn(&mut Draft, usize) -> bool| {
                        view! {
                            <button
                                class="icon"
                                data-testid=test_id
                                title=lang.t(text)
                                aria-label=lang.t(text)
                                disabled=disabled
                                on:click=move |_| draft.update(|d| { act(d, index); })
                            >
                                {symbol}
                            </button>
                        }
                    };
                    view! {
                        <li class="segment" class:selected=selected data-testid="segment" data-pattern=segment.pattern.clone()>
                            <button
                                class="pick"
                                data-testid="segment-pick"
                                aria-pressed=selected.to_string()
                                on:click=move |_| draft.update(|d| d.select(index))
                            >
                                {label}
                            </button>
                            {icon("segment-up", Text::MoveUp, "↑", index == 0, |d, i| d.move_segment(i, true))}
                            {icon("segment-down", Text::MoveDown, "↓", index + 1 == count, |d, i| d.move_segment(i, false))}
                            {icon("segment-remove", Text::Delete, "✕", count == 1, Draft::remove)}
                        </li>
                    }
                })
                .collect_view()
        })
    };
    view! {
        <label class="show-name">
            <span>{ctx.tr(CreateText::ShowNameLabel)}</span>
            <input
                type="text"
                maxlength="100"
                data-testid="create-name"
                prop:value=move || draft.with(|d| d.name.clone())
                on:input=move |ev| {
                    let name = event_target_value(&ev);
                    draft.update(|d| d.name = name);
                }
            />
        </label>
        <h3>
            {ctx.tr(CreateText::Timeline)}
            " "
            <span class="muted" data-testid="create-total">
                {move || {
                    // The show made (its blends may have been lengthened), else the plan.
                    let total_s = show
                        .with(|show| show.as_ref().map(|s| s.duration_ms() as f64 / 1000.0))
                        .unwrap_or_else(|| draft.with(Draft::total_s));
                    format!("{} s", format_number(total_s, 0.1))
                }}
            </span>
        </h3>
        <ol class="segments" data-testid="segments">{rows}</ol>
        <button
            data-testid="segment-add"
            disabled=move || draft.with(|d| d.segments().len() >= MAX_SEGMENTS)
            on:click=move |_| {
                draft.update(|d| {
                    let pattern = d.current().pattern.clone();
                    d.add(&pattern);
                })
            }
        >
            {ctx.tr(CreateText::AddSegment)}
        </button>
    }
}

/// The edited segment: its pattern, its parameters, its length and blend.
#[component]
fn SegmentEditor() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let draft = ctx.create;
    let pattern_name = Memo::new(move |_| draft.with(|d| d.current().pattern.clone()));
    let options = move || {
        let lang = ctx.lang.get();
        let current = pattern_name.get();
        PATTERNS
            .iter()
            .map(|spec| {
                view! {
                    <option value=spec.name selected=spec.name == current>
                        {words::pattern(lang, spec.name)}
                    </option>
                }
            })
            .collect_view()
    };
    let params = move || {
        let name = pattern_name.get();
        create::pattern(&name).map(|pattern| {
            pattern
                .params
                .iter()
                .map(|spec| param_control(ctx, pattern.name, spec))
                .collect_view()
        })
    };
    let number_input =
        move |test_id: &'static str, get: fn(&Draft) -> f64, set: fn(&mut Draft, f64), max: f64| {
            view! {
                <input
                    type="number"
                    inputmode="decimal"
                    min="0"
                    max=max
                    step="0.5"
                    data-testid=test_id
                    prop:value=move || format_number(draft.with(get), 0.5)
                    on:change=move |ev| {
                        if let Ok(value) = event_target_value(&ev).trim().parse::<f64>() {
                            draft.update(|d| set(d, value));
                        } else {
                            // Back to the value kept.
                            draft.update(|_| {});
                        }
                    }
                />
            }
        };
    view! {
        <div class="card segment-editor" data-testid="segment-editor">
            <h3>
                {move || format!("{} {}", ctx.t(CreateText::Pattern), draft.with(|d| d.selected() + 1))}
            </h3>
            <select
                data-testid="create-pattern"
                aria-label=move || ctx.t(CreateText::Pattern)
                on:change=move |ev| {
                    let name = event_target_value(&ev);
                    draft.update(|d| d.set_pattern(&name));
                }
            >
                {options}
            </select>
            <p class="muted" data-testid="pattern-help">
                {move || words::pattern_help(ctx.lang.get(), &pattern_name.get())}
            </p>
            <div class="params">{params}</div>
            <div class="timing">
                <label>
                    <span>{ctx.tr(CreateText::SegmentDuration)}</span>
                    {number_input(
                        "segment-duration",
                        |d| d.current().duration_s,
                        Draft::set_duration_s,
                        MAX_SHOW_S,
                    )}
                </label>
                <label>
                    <span>{ctx.tr(CreateText::SegmentTransition)}</span>
                    {number_input(
                        "segment-transition",
                        |d| d.current().transition_s,
                        Draft::set_transition_s,
                        MAX_TRANSITION_S,
                    )}
                </label>
            </div>
        </div>
    }
}

/// The control of one parameter: a slider for a number, a list for a choice, a
/// text field (several lines for a bitmap), a file picker for a picture.
fn param_control(ctx: Ctx, pattern: &'static str, spec: &'static ParamSpec) -> AnyView {
    let draft = ctx.create;
    let label = move || words::param(ctx.lang.get(), pattern, spec);
    let value = move || draft.with(|d| d.value(spec));
    let test_id = format!("param-{}", spec.key);
    match spec.kind {
        ParamKind::Number {
            min,
            max,
            step,
            unit,
            ..
        } => {
            let number = move || match value() {
                Some(Value::Number(number)) => number,
                _ => min,
            };
            let value_id = format!("{test_id}-value");
            view! {
                <label class="param number">
                    <span>
                        {label} " "
                        <output class="mono" data-testid=value_id>
                            {move || format!("{} {unit}", format_number(number(), step))}
                        </output>
                    </span>
                    <input
                        type="range"
                        min=min
                        max=max
                        step=step
                        data-testid=test_id
                        prop:value=move || number().to_string()
                        on:input=move |ev| {
                            if let Ok(number) = event_target_value(&ev).parse::<f64>() {
                                draft.update(|d| d.set_param(spec.key, Value::Number(number)));
                            }
                        }
                    />
                </label>
            }
            .into_any()
        }
        ParamKind::Choice { options, .. } => {
            let current = move || match value() {
                Some(Value::Text(text)) => text,
                _ => String::new(),
            };
            view! {
                <label class="param choice">
                    <span>{label}</span>
                    <select
                        data-testid=test_id
                        on:change=move |ev| {
                            let word = event_target_value(&ev);
                            draft.update(|d| d.set_param(spec.key, Value::Text(word)));
                        }
                    >
                        {move || {
                            let lang = ctx.lang.get();
                            let current = current();
                            options
                                .iter()
                                .map(|option| {
                                    view! {
                                        <option value=*option selected=*option == current>
                                            {words::choice(lang, option)}
                                        </option>
                                    }
                                })
                                .collect_view()
                        }}
                    </select>
                </label>
            }
            .into_any()
        }
        ParamKind::Text { max_chars, .. } => {
            let text = move || match value() {
                Some(Value::Text(text)) => text,
                _ => String::new(),
            };
            let on_input = move |ev: leptos::ev::Event| {
                let text = event_target_value(&ev);
                draft.update(|d| d.set_param(spec.key, Value::Text(text)));
            };
            // A bitmap is lines of `#` and `.`: several lines, in a fixed-width font.
            let lines = max_chars > 200;
            view! {
                <label class="param text">
                    <span>{label}</span>
                    {if lines {
                        view! {
                            <textarea
                                class="mono"
                                rows="6"
                                maxlength=max_chars
                                data-testid=test_id
                                prop:value=text
                                on:input=on_input
                            ></textarea>
                        }
                        .into_any()
                    } else {
                        view! {
                            <input
                                type="text"
                                maxlength=max_chars
                                data-testid=test_id
                                prop:value=text
                                on:input=on_input
                            />
                        }
                        .into_any()
                    }}
                </label>
            }
            .into_any()
        }
        ParamKind::Bytes { max_bytes } => {
            let chosen = move || match value() {
                Some(Value::Text(base64)) if !base64.is_empty() => {
                    Some(base64.len() / 4 * 3 / 1024)
                }
                _ => None,
            };
            let on_pick = move |ev: leptos::ev::Event| {
                let Some(file) = ev
                    .target()
                    .and_then(|target| target.dyn_into::<web_sys::HtmlInputElement>().ok())
                    .and_then(|input| input.files())
                    .and_then(|files| files.get(0))
                else {
                    return;
                };
                spawn_local(async move {
                    let Ok(buffer) = JsFuture::from(file.array_buffer()).await else {
                        return;
                    };
                    let bytes = js_sys::Uint8Array::new(&buffer).to_vec();
                    if bytes.len() > max_bytes {
                        ctx.notify(words::error(
                            ctx.lang.get_untracked(),
                            &CreateError::TooLarge {
                                key: spec.key.to_owned(),
                                bytes: bytes.len(),
                                max_bytes,
                            },
                        ));
                        return;
                    }
                    let base64 = encode_base64(&bytes);
                    draft.update(|d| d.set_param(spec.key, Value::Text(base64)));
                });
            };
            let chosen_id = format!("{test_id}-chosen");
            view! {
                <label class="param bytes">
                    <span>{label}</span>
                    <input type="file" accept="image/png,image/jpeg" data-testid=test_id on:change=on_pick />
                    <span class="muted" data-testid=chosen_id>
                        {move || match chosen() {
                            Some(kib) => format!("{kib} KB"),
                            None => ctx.t(CreateText::NoPicture).to_owned(),
                        }}
                    </span>
                </label>
            }
            .into_any()
        }
    }
}

/// What the show is made for, what was changed, the limits and the line's verdict.
#[component]
fn Checks(
    outcome: RwSignal<Outcome>,
    target: Memo<Target>,
    verdict: RwSignal<Option<Verdict>>,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let draft = ctx.create;
    let online = move || target.with(|t| t.installation.is_some());
    let grid_input = move |test_id: &'static str, rows: bool| {
        view! {
            <input
                type="number"
                inputmode="numeric"
                min="1"
                max=crate::create::MAX_GRID
                data-testid=test_id
                prop:value=move || {
                    let (r, c) = draft.with(Draft::grid);
                    if rows { r } else { c }
                }
                on:change=move |ev| {
                    let value = event_target_value(&ev).trim().parse::<u32>().ok();
                    draft.update(|d| {
                        if let Some(value) = value {
                            let (r, c) = d.grid();
                            if rows { d.set_grid(value, c) } else { d.set_grid(r, value) }
                        }
                    });
                }
            />
        }
    };
    view! {
        <div class="card checks" data-testid="create-checks">
            <Show
                when=online
                fallback=move || {
                    view! {
                        <p class="muted">{ctx.tr(CreateText::MadeForDefaultGrid)}</p>
                        <div class="grid-size">
                            <label>
                                <span>{ctx.tr(CreateText::GridRows)}</span>
                                {grid_input("create-rows", true)}
                            </label>
                            <label>
                                <span>{ctx.tr(CreateText::GridCols)}</span>
                                {grid_input("create-cols", false)}
                            </label>
                        </div>
                    }
                }
            >
                <p class="muted" data-testid="create-for-installation">{ctx.tr(CreateText::MadeForInstallation)}</p>
            </Show>
            {move || {
                outcome
                    .with(|o| o.error.clone())
                    .map(|error| {
                        view! {
                            <p class="note error" data-testid="create-error">
                                {ctx.t(CreateText::CannotGenerate)} " " {error}
                            </p>
                        }
                    })
            }}
            {move || {
                let notes = outcome.with(|o| o.notes.clone());
                (!notes.is_empty())
                    .then(|| {
                        view! {
                            <div class="note" data-testid="create-notes">
                                <p>{ctx.t(CreateText::ClampedHeading)}</p>
                                <ul>{notes.into_iter().map(|n| view! { <li>{n}</li> }).collect_view()}</ul>
                            </div>
                        }
                    })
            }}
            {move || {
                verdict
                    .get()
                    .map(|(feasible, reason, fixes, planned_in)| {
                        let key = if feasible { "feasible" } else { "infeasible" };
                        view! {
                            <div
                                class=format!("verdict {key}")
                                data-testid="create-verdict"
                                data-verdict=key
                                data-planned=planned_in
                            >
                                <strong>{ctx.t(CreateText::BandwidthVerdict)} ": "</strong>
                                {ctx.t(if feasible { Text::PlanFeasible } else { Text::PlanInfeasible })}
                                {reason.map(|reason| view! { <p>{reason}</p> })}
                                {(!fixes.is_empty())
                                    .then(|| view! { <p class="muted">{ctx.t(Text::PlanFixes)} " " {fixes.join("; ")}</p> })}
                            </div>
                        }
                    })
            }}
        </div>
    }
}

/// Save to the local files, upload to the controller, download or open a recipe,
/// start again.
#[component]
fn Actions(
    show: RwSignal<Option<Arc<Show>>>,
    target: Memo<Target>,
    outcome: RwSignal<Outcome>,
    message: RwSignal<Option<Message>>,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let draft = ctx.create;
    let progress = RwSignal::new(None::<f64>);
    let ready = move || show.with(Option::is_some) && outcome.with(|o| o.error.is_none());
    // The show's file, under the name the draft has now (a copy, once per click: the
    // preview shares the show).
    let json = move || {
        let name = draft.with_untracked(Draft::show_name);
        show.with_untracked(|show| {
            let show = show.as_deref()?;
            if show.name == name {
                return show.to_json().ok();
            }
            Show {
                name,
                ..show.clone()
            }
            .to_json()
            .ok()
        })
    };

    let save_local = move |_| {
        let Some(text) = json() else { return };
        let name = draft.with_untracked(Draft::file_name);
        let Some(file) = LocalFile::new(&name, text, js_sys::Date::now()) else {
            return;
        };
        let store = ctx.store();
        spawn_local(async move {
            let lang = ctx.lang.get_untracked();
            match store.put(&file).await {
                Ok(()) => {
                    let text = format!("{}: {}", lang.t(CreateText::SavedToLocalFiles), file.name);
                    ctx.local_files.update(|list| list.upsert(file));
                    ctx.notify(text.clone());
                    message.set(Some(Message::done(text)));
                }
                Err(error) => message.set(Some(Message::error(format!(
                    "{}: {error}",
                    lang.t(Text::StorageFailed)
                )))),
            }
        });
    };
    let upload = move |_| {
        let (Some(text), Some(client)) = (json(), ctx.client()) else {
            return;
        };
        let name = draft.with_untracked(Draft::show_name);
        message.set(None);
        progress.set(Some(0.0));
        let on_progress: OnProgress =
            Rc::new(move |p: UploadProgress| progress.set(Some(p.fraction())));
        spawn_local(async move {
            let outcome =
                upload_show(ctx, &client, &name, ShowFormat::Json, text, on_progress).await;
            progress.set(None);
            message.set(Some(outcome));
        });
    };
    let download_recipe = move |_| {
        let (name, text) = draft.with_untracked(|d| {
            let recipe = target.with_untracked(|target| d.recipe_for(target));
            (d.recipe_file_name(), recipe.to_json())
        });
        let result = text
            .map_err(|error| error.to_string())
            .and_then(|text| save_text(&name, &text, "application/json"));
        if let Err(error) = result {
            message.set(Some(Message::error(error)));
        }
    };
    let open_recipe = move |ev: leptos::ev::Event| {
        let Some(input) = ev
            .target()
            .and_then(|target| target.dyn_into::<web_sys::HtmlInputElement>().ok())
        else {
            return;
        };
        let Some(file) = input.files().and_then(|files| files.get(0)) else {
            return;
        };
        input.set_value("");
        spawn_local(async move {
            let lang = ctx.lang.get_untracked();
            let text = JsFuture::from(file.text())
                .await
                .ok()
                .and_then(|text| text.as_string())
                .unwrap_or_default();
            let grid = draft.with_untracked(Draft::grid);
            match Recipe::from_json(&text).and_then(|recipe| Draft::from_recipe(recipe, grid)) {
                Ok(new) => {
                    draft.set(new);
                    message.set(None);
                }
                Err(error) => message.set(Some(Message::error(format!(
                    "{} {}",
                    lang.t(CreateText::RecipeUnreadable),
                    words::error(lang, &error)
                )))),
            }
        });
    };
    let online = move || ctx.logged_in() && ctx.connected();
    view! {
        <div class="actions create-actions">
            <button data-testid="create-save-local" disabled=move || !ready() on:click=save_local>
                {ctx.tr(CreateText::SaveToLocalFiles)}
            </button>
            <button
                data-testid="create-upload"
                disabled=move || !ready() || !online() || progress.with(Option::is_some)
                on:click=upload
            >
                {move || match progress.get() {
                    Some(fraction) => ctx.lang.get().uploading((fraction * 100.0).round() as u32),
                    None => ctx.t(CreateText::UploadToController).to_owned(),
                }}
            </button>
            <button data-testid="create-download-recipe" on:click=download_recipe>
                {ctx.tr(CreateText::DownloadRecipe)}
            </button>
            <label class="button">
                {ctx.tr(CreateText::OpenRecipe)}
                <input type="file" accept=".json,application/json" data-testid="create-open-recipe" on:change=open_recipe />
            </label>
            <button
                data-testid="create-new"
                on:click=move |_| {
                    let grid = draft.with_untracked(Draft::grid);
                    draft.update(|d| {
                        *d = Draft::new();
                        d.set_grid(grid.0, grid.1);
                    });
                }
            >
                {ctx.tr(CreateText::NewRecipe)}
            </button>
        </div>
    }
}
