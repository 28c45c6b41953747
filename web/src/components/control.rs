//! The Control and Settings pages: the playlist with its checkboxes and icons (add,
//! move up, move down, delete, edit), Start / E-stop / Reset / Home, the bandwidth
//! verdict and the live status (`docs/uim2503.md` §4).
//!
//! With many gateways (a status that summarises them, [`crate::status::summarised`])
//! the status shows how many are up, the lowest buffer and where, and the gateways
//! with a problem in words; "Show all" opens every gateway's compact row in a
//! scrolling box, fetched from the bridge (`GET /api/status/gateways`) at once and
//! every [`LIST_REFRESH_MS`] while it is open.
//!
//! While the matrix runs, the icons are disabled with the reason beside them (the
//! bridge refuses such edits too) and Start says why it cannot be pressed. Reset,
//! Home and a Start after an E-stop turn into a one-tap confirmation that says what
//! will move, with Cancel beside it; the E-stop never asks. Beside Start, an entry
//! and a time say where Start and Reset begin ([`crate::control::start_from`]:
//! nothing typed, the playlist's start); "Preview from there" opens the entry's show
//! in the Preview, paused at that time.
//!
//! Every edit is applied to [`crate::playlist::PlaylistEditor`] and then stored on
//! the bridge (`PUT /api/playlist`); what the bridge answers is what the page shows.
//! The decisions (plan rounds, panels, forms, saving) are [`crate::control`]'s; this
//! module wires them to the page.

use std::time::Duration;

use floatball_shared::api::{ClientMessage, GatewayStatus, Status};
use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::components::topbar::EstopButton;
use crate::components::widgets::{
    BridgeError, EmptyItem, ErrorNote, RowButton, TabButton, TextField,
};
use crate::context::Ctx;
use crate::control::{
    Action, Panel, PlanVerdicts, TimingForm, begin_save, edit_lock, is_locked_refusal, is_running,
    needs_checks, settle_save, start_block, start_from, start_reason_key,
};
use crate::files::format_duration_ms;
use crate::i18n::{Lang, Text};
use crate::installation::health_warnings;
use crate::page::Page;
use crate::playlist::{PlaylistEditor, Verdict, format_delay_s};
use crate::status::{
    PROBLEMS_LISTED, gateway_text, homing_text, link_key, lowest_text, problem_text, progress,
    shows_progress, starting_text, state_key, streams, summarised, time_text,
};

/// How often the open list of every gateway is fetched again, ms.
pub const LIST_REFRESH_MS: u64 = 2000;

/// Applies `edit` to the playlist and stores the result on the bridge; `note` gets
/// the bridge's refusal, if any (then the bridge's playlist is fetched again).
fn edit_and_save(
    ctx: Ctx,
    note: RwSignal<Option<String>>,
    edit: impl FnOnce(&mut PlaylistEditor) -> bool,
) {
    let mut playlist = None;
    ctx.playlist
        .update(|editor| playlist = begin_save(editor, edit));
    let (Some(playlist), Some(client)) = (playlist, ctx.client()) else {
        return;
    };
    note.set(None);
    spawn_local(async move {
        let answer = client.put_playlist(&playlist).await;
        let mut settled = Ok(());
        ctx.playlist.maybe_update(|editor| {
            settled = settle_save(editor, answer);
            settled.is_ok()
        });
        match settled {
            Ok(()) => ctx.notify(ctx.lang.get_untracked().t(Text::PlaylistSaved)),
            Err(failure) => {
                let said = if is_locked_refusal(&failure) {
                    ctx.lang.get_untracked().t(Text::PlaylistLocked).to_owned()
                } else {
                    ctx.failed(&failure)
                };
                note.set(Some(said));
                ctx.refresh();
            }
        }
    });
}

/// The Control / Settings / Commissioning switch (the vendor app's left-hand
/// buttons).
#[component]
pub fn ControlTabs() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let tab = move |page: Page, text: Text| {
        view! {
            <TabButton
                text
                test_id=format!("subtab-{}", page.key())
                active=Signal::derive(move || ctx.page.get() == page)
                on_click=Callback::new(move |()| ctx.page.set(page))
            />
        }
    };
    view! {
        <div class="subtabs">
            {tab(Page::Control, Text::NavControl)} {tab(Page::Settings, Text::NavSettings)}
            {tab(Page::Commission, Text::NavCommission)}
            {tab(Page::Schedule, Text::NavSchedule)}
            {tab(Page::Patch, Text::NavPatch)}
        </div>
    }
}

/// The Control page.
#[component]
pub fn ControlPage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let panel = RwSignal::new(Panel::None);
    let note = RwSignal::new(None::<String>);
    let plans = RwSignal::new(PlanVerdicts::default());

    // The bandwidth report of each show, fetched again when the shows change.
    let shows = Memo::new(move |_| ctx.playlist.with(PlaylistEditor::shows));
    Effect::new(move |_| {
        let shows = shows.get();
        let connected = ctx.connected();
        let client = ctx.client().filter(|_| connected);
        let mut round = None;
        plans.update(|plans| round = plans.begin(&shows, client.is_some()));
        let (Some(client), Some(round)) = (client, round) else {
            return;
        };
        for show in shows {
            let client = client.clone();
            spawn_local(async move {
                let verdict = match client.plan(&show).await {
                    Ok(report) => Verdict::of(report),
                    Err(failure) => Verdict::Failed(failure),
                };
                plans.maybe_update(|plans| plans.answer(round, &show, verdict));
            });
        }
    });

    // The matrix state, a Memo so that only a change of it (not every status)
    // reaches what depends on it.
    let state = Memo::new(move |_| ctx.status.with(|status| status.as_ref().map(|s| s.state)));
    let locked_reason = Memo::new(move |_| {
        if ctx.connected() {
            edit_lock(state.get())
        } else {
            None
        }
    });
    let locked = move || locked_reason.with(Option::is_some);
    // An open panel closes when the playlist locks (its edit would be refused).
    Effect::new(move |_| {
        if locked() && panel.get_untracked() != Panel::None {
            panel.set(Panel::None);
        }
    });
    let icon = move |test_id: &'static str,
                     symbol: &'static str,
                     text: Text,
                     action: Box<dyn Fn() + Send + Sync>| {
        view! {
            <button
                class="icon"
                data-testid=test_id
                title=ctx.tr(text)
                disabled=locked
                on:click=move |_| action()
            >
                <span class="symbol" aria-hidden="true">
                    {symbol}
                </span>
                <span class="caption">{ctx.tr(text)}</span>
            </button>
        }
    };
    let checked = move || ctx.playlist.with_untracked(PlaylistEditor::checked_count);
    let refuse = move |why: Text| note.set(Some(ctx.lang.get_untracked().t(why).into()));
    let needs_checks = move |edit: fn(&mut PlaylistEditor) -> bool| {
        move || match needs_checks(checked()) {
            Ok(()) => edit_and_save(ctx, note, edit),
            Err(why) => refuse(why),
        }
    };
    let toggle_panel = move |which: Panel| {
        move || match panel.get_untracked().pressed(which, checked()) {
            Ok(open) => {
                note.set(None);
                panel.set(open);
            }
            Err(why) => refuse(why),
        }
    };
    let start_reason = Memo::new(move |_| {
        let allowed = plans.with(|plans| ctx.playlist.with(|editor| plans.allow_start(editor)));
        start_block(ctx.connected(), state.get(), allowed)
    });
    let send = move |message: ClientMessage| {
        ctx.bridge_error.set(None);
        ctx.send(&message);
    };
    // Where Start and Reset begin, as typed beside Start.
    let from_entry = RwSignal::new(String::new());
    let from_time = RwSignal::new(String::new());
    // The action's message with where it begins; `None` (and why, in the note) when
    // what is typed cannot be read.
    let message = move |action: Action| match start_from(
        &from_entry.get_untracked(),
        &from_time.get_untracked(),
    ) {
        Ok(from) => Some(action.message_from(from)),
        Err(why) => {
            refuse(why);
            None
        }
    };
    // The Preview, paused where a Start from what is typed begins.
    let preview_from = move || {
        let from = match start_from(&from_entry.get_untracked(), &from_time.get_untracked()) {
            Ok(from) => from,
            Err(why) => return refuse(why),
        };
        let index = from.entry.unwrap_or(1) - 1;
        let Some(show) = ctx
            .playlist
            .with_untracked(|editor| editor.entries().get(index).map(|entry| entry.show.clone()))
        else {
            return refuse(Text::BadStartFrom);
        };
        ctx.preview_controller(&show);
        ctx.preview_from_ms.set(Some(from.time_ms.unwrap_or(0)));
    };
    // The action waiting for its confirmation, if any.
    let asking = RwSignal::new(None::<Action>);
    let press = move |action: Action| match action.confirmation(state.get_untracked()) {
        Some(_) => asking.set(Some(action)),
        None => {
            asking.set(None);
            if let Some(message) = message(action) {
                send(message);
            }
        }
    };
    // A confirmation that no longer applies (Start once the matrix is idle again)
    // is dropped, so it cannot come back later by itself.
    Effect::new(move |_| {
        if let Some(action) = asking.get()
            && action.confirmation(state.get()).is_none()
        {
            asking.set(None);
        }
    });
    let enabled = move |action: Action| match action {
        Action::Start => start_reason.with(Option::is_none),
        Action::Reset | Action::Home => ctx.connected(),
    };
    let action_button = move |action: Action, class: &'static str, text: Text| {
        view! {
            <button
                class=class
                data-testid=action.key()
                disabled=move || !enabled(action)
                on:click=move |_| press(action)
            >
                {ctx.tr(text)}
            </button>
        }
    };
    // The confirmation shown: rebuilt only when it changes, not on every status.
    let confirming = Memo::new(move |_| {
        asking
            .get()
            .and_then(|action| Some((action, action.confirmation(state.get())?)))
    });
    view! {
        <section class="control">
            <ControlTabs />
            <div class="control-layout">
            <div class="control-main">
            <div class="toolbar icons">
                {icon("add", "＋", Text::Add, Box::new(toggle_panel(Panel::Add)))}
                {icon("move-up", "↑", Text::MoveUp, Box::new(needs_checks(PlaylistEditor::move_up)))}
                {icon(
                    "move-down",
                    "↓",
                    Text::MoveDown,
                    Box::new(needs_checks(PlaylistEditor::move_down)),
                )}
                {icon(
                    "delete",
                    "✕",
                    Text::Delete,
                    Box::new(needs_checks(|editor| editor.delete_checked() > 0)),
                )}
                {icon("edit", "✎", Text::Edit, Box::new(toggle_panel(Panel::Edit)))}
            </div>
            <ErrorNote text=note test_id="control-note" />
            {move || {
                locked_reason
                    .get()
                    .map(|why| {
                        view! {
                            <p class="note locked" data-testid="playlist-locked">
                                {ctx.tr(why)}
                            </p>
                        }
                    })
            }}
            {move || match panel.get() {
                Panel::None => ().into_any(),
                Panel::Add => view! { <AddPanel panel=panel note=note /> }.into_any(),
                Panel::Edit => view! { <EditPanel panel=panel note=note /> }.into_any(),
            }}
            <PlaylistView />
            <UnitsWarning />
            <div class="start-from">
                <TextField
                    label=Text::StartEntry
                    value=from_entry
                    test_id="start-entry"
                    inputmode="numeric"
                />
                <TextField
                    label=Text::StartTime
                    value=from_time
                    test_id="start-time"
                    inputmode="decimal"
                />
                <button data-testid="start-preview" on:click=move |_| preview_from()>
                    {ctx.tr(Text::PreviewFrom)}
                </button>
            </div>
            <div class="actions">
                {action_button(Action::Start, "start primary", Text::Start)}
                <EstopButton />
                {action_button(Action::Reset, "reset", Text::Reset)}
                {action_button(Action::Home, "home", Text::Home)}
            </div>
            {move || {
                confirming
                    .get()
                    .map(|(action, text)| {
                        view! {
                            <div class="confirm" data-testid="confirm" data-action=action.key()>
                                <button
                                    class="confirm-yes primary"
                                    data-testid="confirm-yes"
                                    disabled=move || !enabled(action)
                                    on:click=move |_| {
                                        asking.set(None);
                                        if let Some(message) = message(action) {
                                            send(message);
                                        }
                                    }
                                >
                                    {ctx.tr(text)}
                                </button>
                                <button
                                    class="confirm-cancel"
                                    data-testid="confirm-cancel"
                                    on:click=move |_| asking.set(None)
                                >
                                    {ctx.tr(Text::Cancel)}
                                </button>
                            </div>
                        }
                    })
            }}
            {move || {
                start_reason
                    .get()
                    .map(|why| {
                        view! {
                            <p class="note muted" data-testid="start-reason" data-reason=start_reason_key(why)>
                                {ctx.tr(why)}
                            </p>
                        }
                    })
            }}
            <BridgeError />
            </div>
            <div class="control-side">
                <PlanView plans=plans />
                <StatusView />
                <ScheduleLine />
                <TimecodeView />
                <LiveSlot />
            </div>
            </div>
        </section>
    }
}

/// The warning before Start when units are missing, share a station or reported an
/// error (the bridge's unit health per gateway); nothing while all is well or not
/// yet known.
#[component]
fn UnitsWarning() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let warnings = Memo::new(move |_| {
        ctx.status.with(|status| {
            status
                .as_ref()
                .filter(|_| ctx.connected())
                .map(|status| health_warnings(&status.gateways))
                .unwrap_or_default()
        })
    });
    move || {
        let warnings = warnings.get();
        (!warnings.is_empty()).then(|| {
            let lang = ctx.lang.get();
            view! {
                <div class="note warn units-warning" data-testid="units-warning" role="status">
                    <p>{lang.t(Text::UnitsWarning)}</p>
                    <ul>
                        {warnings
                            .iter()
                            .take(PROBLEMS_LISTED)
                            .map(|warning| view! { <li data-testid="units-warning-gateway">{lang.health_warning(warning)}</li> })
                            .collect_view()}
                        {(warnings.len() > PROBLEMS_LISTED)
                            .then(|| view! { <li class="muted">{lang.more_gateways(warnings.len() - PROBLEMS_LISTED)}</li> })}
                    </ul>
                </div>
            }
        })
    }
}

/// The playlist with a checkbox per entry.
#[component]
fn PlaylistView() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    // The entry that plays, only while the matrix runs and only if it is the show
    // the status names. A Memo, so a status that leaves it alone changes nothing;
    // the list itself is rebuilt only when the playlist changes.
    let playing = Memo::new(move |_| {
        ctx.playlist.with(|editor| {
            ctx.status.with(|status| {
                status
                    .as_ref()
                    .filter(|status| is_running(Some(status.state)))
                    .and_then(|status| editor.playing_entry(status))
            })
        })
    });
    view! {
        <h3>{ctx.tr(Text::Playlist)}</h3>
        <ol class="list playlist" data-testid="playlist">
            {move || {
                let editor = ctx.playlist.get();
                if editor.entries().is_empty() {
                    return view! { <EmptyItem text=Text::EmptyPlaylist /> }.into_any();
                }
                editor
                    .entries()
                    .iter()
                    .enumerate()
                    .map(|(index, entry)| {
                        let checked = editor.is_checked(index);
                        let facts = format!(
                            "{} s · ×{}",
                            format_delay_s(entry.delay_ms),
                            entry.cycles,
                        );
                        view! {
                            <li
                                class="entry"
                                class:playing=move || playing.get() == Some(index)
                                data-testid="entry"
                                data-show=entry.show.clone()
                            >
                                <label class="row">
                                    <input
                                        type="checkbox"
                                        data-testid="entry-check"
                                        prop:checked=checked
                                        on:change=move |ev| {
                                            let on = event_target_checked(&ev);
                                            ctx.playlist.update(|editor| editor.set_checked(index, on));
                                        }
                                    />
                                    <span class="index">{index + 1}</span>
                                    <span class="name">{entry.show.clone()}</span>
                                    <span class="facts muted" data-testid="entry-facts">
                                        {facts}
                                    </span>
                                </label>
                            </li>
                        }
                    })
                    .collect_view()
                    .into_any()
            }}
        </ol>
    }
}

/// Pick a controller file to append.
#[component]
fn AddPanel(panel: RwSignal<Panel>, note: RwSignal<Option<String>>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! {
        <div class="card panel" data-testid="add-panel">
            <h3>{ctx.tr(Text::PickShow)}</h3>
            <ul class="list">
                {move || {
                    let files = ctx.controller_files.get();
                    if files.items().is_empty() {
                        return view! { <EmptyItem text=Text::NoControllerFiles /> }.into_any();
                    }
                    files
                        .items()
                        .iter()
                        .map(|show| {
                            let name = show.name.clone();
                            let facts = format!(
                                "{} · {}",
                                show.units,
                                format_duration_ms(show.duration_ms),
                            );
                            let pick = Callback::new(move |()| {
                                let name = name.clone();
                                edit_and_save(ctx, note, move |editor| {
                                    editor.add(&name);
                                    true
                                });
                                panel.set(Panel::None);
                            });
                            view! {
                                <RowButton name=show.name.clone() test_id="pick-show" facts on_click=pick />
                            }
                        })
                        .collect_view()
                        .into_any()
                }}
            </ul>
            <button on:click=move |_| panel.set(Panel::None)>{ctx.tr(Text::Cancel)}</button>
        </div>
    }
}

/// Delay and cycles of the checked entries.
#[component]
fn EditPanel(panel: RwSignal<Panel>, note: RwSignal<Option<String>>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let form = ctx
        .playlist
        .with_untracked(|editor| TimingForm::of_entry(editor.first_checked()));
    let delay = RwSignal::new(form.delay_s);
    let cycles = RwSignal::new(form.cycles);
    // The first checked entry's timecode start (chased with `[timecode]`).
    let timecode = RwSignal::new(ctx.playlist.with_untracked(|editor| {
        editor
            .first_checked()
            .and_then(|entry| entry.timecode_start.clone())
            .unwrap_or_default()
    }));
    let error = RwSignal::new(None::<String>);
    let apply = move |event: leptos::ev::SubmitEvent| {
        event.prevent_default();
        let lang = ctx.lang.get_untracked();
        // Checked by the bridge (`entry_timecode`, shown in both languages): its
        // reader of timecodes stays out of the app's first load.
        let start = timecode.get_untracked().trim().to_owned();
        match TimingForm::parse(&delay.get_untracked(), &cycles.get_untracked()) {
            Err(input) => error.set(Some(lang.input_error(input).into())),
            Ok(timing) => {
                error.set(None);
                edit_and_save(ctx, note, move |editor| {
                    let timed = editor.edit_checked(timing.delay_ms, timing.cycles) > 0;
                    let started =
                        editor.set_timecode_checked(Some(start.as_str()).filter(|s| !s.is_empty()));
                    timed || started > 0
                });
                panel.set(Panel::None);
            }
        }
    };
    view! {
        <form class="card panel form" data-testid="edit-panel" on:submit=apply>
            <TextField label=Text::DelayS value=delay test_id="edit-delay" inputmode="decimal" />
            <TextField label=Text::Cycles value=cycles test_id="edit-cycles" inputmode="numeric" />
            <TextField label=Text::TimecodeStart value=timecode test_id="edit-timecode" />
            <ErrorNote text=error test_id="edit-error" />
            <div class="row-buttons">
                <button type="submit" class="primary" data-testid="edit-apply">
                    {ctx.tr(Text::Apply)}
                </button>
                <button type="button" on:click=move |_| panel.set(Panel::None)>
                    {ctx.tr(Text::Cancel)}
                </button>
            </div>
        </form>
    }
}

/// The bandwidth verdict of each show before Start.
#[component]
fn PlanView(plans: RwSignal<PlanVerdicts>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! {
        <Show when=move || plans.with(|plans| !plans.is_empty())>
            <div class="card" data-testid="plan">
                <h3>{ctx.tr(Text::PlanTitle)}</h3>
                <ul class="verdicts">
                    {move || {
                        plans
                            .with(|plans| plans.verdicts().to_vec())
                            .into_iter()
                            .map(|(show, verdict)| {
                                let key = verdict.key();
                                let lang = ctx.lang.get();
                                // The preload and the advice of a show that runs.
                                let (preload, advice) = match &verdict {
                                    Verdict::Feasible(report) => (
                                        (report.preload_ms > 0).then(|| lang.preload(report.preload_ms)),
                                        lang.plan_advice(report),
                                    ),
                                    _ => (None, Vec::new()),
                                };
                                let (word, reason, fixes) = match verdict {
                                    Verdict::Pending => (Text::PlanPending, None, Vec::new()),
                                    Verdict::Feasible(_) => (Text::PlanFeasible, None, Vec::new()),
                                    Verdict::Infeasible(report) => {
                                        (
                                            Text::PlanInfeasible,
                                            lang.plan_reason(&report),
                                            lang.plan_fixes(&report),
                                        )
                                    }
                                    Verdict::Unavailable => (Text::PlanUnavailable, None, Vec::new()),
                                    Verdict::Failed(failure) => {
                                        (Text::PlanUnavailable, Some(lang.failure(&failure)), Vec::new())
                                    }
                                };
                                view! {
                                    <li class=format!("verdict {key}") data-testid="verdict" data-verdict=key>
                                        <strong>{show}</strong>
                                        ": "
                                        {ctx.tr(word)}
                                        {preload
                                            .map(|preload| {
                                                view! { <span class="muted" data-testid="verdict-preload">" · " {preload}</span> }
                                            })}
                                        {reason.map(|reason| view! { <p>{reason}</p> })}
                                        {(!advice.is_empty())
                                            .then(|| {
                                                view! {
                                                    <p class="advice" data-testid="verdict-advice">
                                                        {ctx.tr(Text::PlanAdvice)} " " {advice.join("; ")}
                                                    </p>
                                                }
                                            })}
                                        {(!fixes.is_empty())
                                            .then(|| {
                                                view! {
                                                    <p class="muted">
                                                        {ctx.tr(Text::PlanFixes)} " "
                                                        {fixes.join("; ")}
                                                    </p>
                                                }
                                            })}
                                    </li>
                                }
                            })
                            .collect_view()
                    }}
                </ul>
            </div>
        </Show>
    }
}

/// The timecode chase, when the bridge has it on: the timecode, the chase's state,
/// the offset of the show from the timecode, the lead and the drift.
#[component]
fn TimecodeView() -> impl IntoView {
    use floatball_shared::timecode::chase::ChaseState;
    let ctx = expect_context::<Ctx>();
    move || {
        let chase = ctx.timecode.get().filter(|_| ctx.connected())?;
        let state = match chase.state {
            ChaseState::NoTimecode => Text::ChaseNoTimecode,
            ChaseState::Waiting => Text::ChaseWaiting,
            ChaseState::Cued => Text::ChaseCued,
            ChaseState::Chasing => Text::ChaseChasing,
            ChaseState::Locating => Text::ChaseLocating,
            ChaseState::Holding => Text::ChaseHolding,
            ChaseState::Stopped => Text::ChaseStopped,
            ChaseState::Lost => Text::ChaseLost,
        };
        let signed = |ms: i64| format!("{ms:+} ms");
        let drift = chase
            .drift_ms
            .map(|drift| format!("{} / {} s", signed(drift), chase.drift_over_ms / 1000));
        Some(view! {
            <div class="card status" data-testid="timecode">
                <h3>{ctx.tr(Text::TimecodeTitle)} " · " {chase.source.clone()}</h3>
                <p data-testid="timecode-now">
                    <strong>{chase.timecode.clone().unwrap_or_else(|| "--:--:--:--".into())}</strong>
                    {chase.rate.map(|rate| format!(" @ {rate}"))}
                    " · "
                    <span data-testid="timecode-state">{ctx.tr(state)}</span>
                </p>
                <p>
                    {ctx.tr(Text::TimecodeOffset)} ": "
                    <span data-testid="timecode-offset">
                        {chase.offset_ms.map_or_else(|| "–".to_owned(), signed)}
                    </span>
                    " · " {ctx.tr(Text::TimecodeLead)} ": " {format!("{} ms", chase.lead_ms)}
                    {drift.map(|drift| view! { " · " {ctx.tr(Text::TimecodeDrift)} ": " {drift} })}
                </p>
                {chase.refused.clone().map(|why| view! { <p class="muted">{why}</p> })}
            </div>
        })
    }
}

/// The live status from the bridge.
#[component]
fn StatusView() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    // With many gateways: how many, for the full list's button (a Memo, so that the
    // list is not rebuilt with every status).
    let listed_total = Memo::new(move |_| {
        ctx.status.with(|status| {
            status
                .as_ref()
                .filter(|status| ctx.connected() && summarised(status))
                .map(|status| status.gateway_summary.total)
        })
    });
    view! {
        <div class="card status" data-testid="status">
            <h3>{ctx.tr(Text::StatusTitle)}</h3>
            {move || {
                let status = ctx.status.get().filter(|_| ctx.connected());
                match status {
                    None => {
                        view! {
                            <p class="muted" data-testid="status-state" data-state="unknown">
                                {ctx.tr(Text::StatusUnavailable)}
                            </p>
                        }
                            .into_any()
                    }
                    Some(status) => status_details(ctx, status).into_any(),
                }
            }}
            {move || listed_total.get().map(|total| view! { <GatewayList total=total /> })}
        </div>
    }
}

/// Many gateways in a few lines: how many are up and the bytes they carry, the
/// lowest buffer and where while a show streams, and the gateways with a problem in
/// words (at most [`PROBLEMS_LISTED`], the rest counted).
fn gateway_summary(ctx: Ctx, lang: Lang, status: &Status) -> impl IntoView + use<> {
    let summary = &status.gateway_summary;
    let lowest = ctx
        .installation
        .with(|installation| lowest_text(lang, status, installation.as_ref()));
    let more = status.gateways.len().saturating_sub(PROBLEMS_LISTED);
    let problems = status
        .gateways
        .iter()
        .take(PROBLEMS_LISTED)
        .map(|gateway| {
            let link = link_key(gateway.link);
            view! {
                <li
                    class=format!("link {link}")
                    data-testid="gateway-problem"
                    data-index=gateway.index.to_string()
                    data-link=link
                >
                    <span class="gw-index">{gateway.index}</span>
                    {problem_text(lang, gateway)}
                </li>
            }
        })
        .collect_view();
    let problems = if status.gateways.is_empty() {
        view! { <p class="muted" data-testid="gateway-no-problems">{lang.t(Text::NoGatewayProblems)}</p> }
            .into_any()
    } else {
        view! {
            <p class="gateway-problems-title">{lang.t(Text::GatewayProblems)}</p>
            <ul class="gateways problems" data-testid="gateway-problems">
                {problems}
                {(more > 0)
                    .then(|| {
                        view! { <li class="muted" data-testid="gateway-problems-more">{lang.more_gateways(more)}</li> }
                    })}
            </ul>
        }
            .into_any()
    };
    view! {
        <dl class="facts-grid gateway-summary" data-testid="gateway-summary">
            <dt>{lang.t(Text::GatewaysUp)}</dt>
            <dd data-testid="gateways-up" data-up=summary.up.to_string() data-total=summary.total.to_string()>
                {lang.gateways_up(summary.up, summary.total)}
                {format!(" · {:.0} B/s", summary.bytes_per_s)}
            </dd>
            {lowest
                .map(|text| {
                    view! {
                        <dt>{lang.t(Text::LowestBuffer)}</dt>
                        <dd data-testid="gateways-lowest">{text}</dd>
                    }
                })}
        </dl>
        {problems}
    }
}

/// Every gateway, one compact row each in a scrolling box, behind a button: fetched
/// from the bridge (`GET /api/status/gateways`) when opened and every
/// [`LIST_REFRESH_MS`] while open.
#[component]
fn GatewayList(
    /// How many gateways the installation has (the button says it).
    total: u32,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let open = RwSignal::new(false);
    let list = RwSignal::new(Vec::<GatewayStatus>::new());
    let error = RwSignal::new(None::<String>);
    let streaming = Memo::new(move |_| {
        ctx.status
            .with(|status| status.as_ref().is_some_and(|status| streams(status.state)))
    });
    // An answer that comes back once the list is closed or gone is dropped.
    let fetch = move || {
        let Some(client) = ctx.client() else { return };
        spawn_local(async move {
            let answer = client.gateway_statuses().await;
            if open.try_get_untracked() != Some(true) {
                return;
            }
            match answer {
                Ok(all) => {
                    error.set(None);
                    list.set(all);
                }
                Err(failure) => error.set(Some(ctx.failed(&failure))),
            }
        });
    };
    Effect::new(move |_| {
        if !open.get() {
            return;
        }
        fetch();
        match set_interval_with_handle(fetch, Duration::from_millis(LIST_REFRESH_MS)) {
            Ok(handle) => on_cleanup(move || handle.clear()),
            Err(_) => leptos::logging::warn!("cannot refresh the list of gateways"),
        }
    });
    let rows = move || {
        let lang = ctx.lang.get();
        let streaming = streaming.get();
        list.with(|all| {
            all.iter()
                .map(|gateway| {
                    let link = link_key(gateway.link);
                    view! {
                        <li
                            class=format!("link {link}")
                            data-testid="gateway-row"
                            data-index=gateway.index.to_string()
                            data-link=link
                        >
                            <span class="gw-index">{gateway.index}</span>
                            {gateway_text(lang, gateway, streaming)}
                        </li>
                    }
                })
                .collect_view()
        })
    };
    view! {
        <button
            class="gateway-list-toggle"
            data-testid="gateway-list-toggle"
            aria-expanded=move || open.get().to_string()
            on:click=move |_| open.update(|open| *open = !*open)
        >
            {move || {
                let lang = ctx.lang.get();
                if open.get() {
                    lang.t(Text::HideGatewayList).to_owned()
                } else {
                    lang.show_all_gateways(total)
                }
            }}
        </button>
        <Show when=move || open.get()>
            <ErrorNote text=error test_id="gateway-list-error" />
            <ul class="gateways gateway-list" data-testid="gateway-list">
                {rows}
            </ul>
        </Show>
    }
}

fn status_details(ctx: Ctx, status: Status) -> impl IntoView {
    let lang = ctx.lang.get();
    let state = status.state;
    let fraction = progress(&status);
    let row = |label: Text, value: String, test_id: &'static str| {
        view! {
            <dt>{lang.t(label)}</dt>
            <dd data-testid=test_id>{value}</dd>
        }
    };
    let entry = status
        .entry
        .map(|entry| (entry + 1).to_string())
        .unwrap_or_default();
    // Homing shows its own progress where a show's time would be, a given start its
    // countdown.
    let time = homing_text(lang, &status)
        .or_else(|| starting_text(lang, &status))
        .unwrap_or_else(|| time_text(&status));
    let cycle = if status.cycle > 0 {
        status.cycle.to_string()
    } else {
        String::new()
    };
    // Many gateways: a summary; else every gateway's line, as always.
    let gateways = if summarised(&status) {
        gateway_summary(ctx, lang, &status).into_any()
    } else {
        let lines = status
            .gateways
            .iter()
            .map(|gateway| {
                let text = gateway_text(lang, gateway, streams(state));
                let link = link_key(gateway.link);
                view! {
                    <li class=format!("link {link}") data-testid="gateway" data-link=link>
                        {text}
                    </li>
                }
            })
            .collect_view();
        view! { <ul class="gateways">{lines}</ul> }.into_any()
    };
    view! {
        <dl class="facts-grid">
            <dt>{lang.t(Text::State)}</dt>
            <dd>
                <span class=format!("state {}", state_key(state)) data-testid="status-state" data-state=state_key(state)>
                    {lang.player_state(state)}
                </span>
            </dd>
            {row(Text::Entry, entry, "status-entry")}
            {row(Text::ShowLabel, status.show.clone().unwrap_or_default(), "status-show")}
            {row(Text::ShowTime, time, "status-time")}
            {row(Text::Cycle, cycle, "status-cycle")}
            {status
                .armed
                .as_ref()
                .map(|armed| row(Text::ArmedLabel, lang.armed(armed), "status-armed"))}
        </dl>
        {shows_progress(state)
            .then(|| {
                view! {
                    <progress
                        class="wide"
                        data-testid="status-progress"
                        max="1"
                        value=fraction.to_string()
                    ></progress>
                }
            })}
        <h4>{lang.t(Text::Gateways)}</h4>
        {gateways}
        {status
            .last_error
            .map(|error| {
                view! {
                    <p class="note error" data-testid="status-error">
                        {lang.t(Text::LastError)} ": " {error}
                    </p>
                }
            })}
    }
}

/// Where the Live card goes (live mode, recording): a button that opens it, or the
/// card itself (its code in a chunk, [`crate::lazy::live_card`]) once opened or
/// while the matrix is live. Only with a login (an operator's).
#[component]
fn LiveSlot() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let opened = RwSignal::new(false);
    let live_now = Memo::new(move |_| {
        ctx.status
            .with(|status| status.as_ref().is_some_and(|status| status.live.is_some()))
    });
    // Once live, the card stays after live mode ends (its phase says "not live").
    Effect::new(move |_| {
        if live_now.get() {
            opened.set(true);
        }
    });
    let shown = Memo::new(move |_| ctx.logged_in() && (opened.get() || live_now.get()));
    move || {
        if shown.get() {
            crate::lazy::chunk_view(
                ctx.lang.into(),
                Text::ChunkFailed,
                crate::lazy::load_live,
                |card: crate::lazy::PageView| card(),
            )
            .into_any()
        } else if ctx.logged_in() {
            view! {
                <button class="live-open" data-testid="live-open" on:click=move |_| opened.set(true)>
                    {ctx.tr(Text::LiveMode)}
                </button>
            }
            .into_any()
        } else {
            ().into_any()
        }
    }
}

/// The schedule's next start and what it did last (`schedule` messages), when a
/// schedule is followed or did something; a tap opens the Schedule page.
#[component]
fn ScheduleLine() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    move || {
        ctx.schedule.with(|schedule| {
            let schedule = crate::schedule::shown(schedule.as_ref())?;
            let lang = ctx.lang.get();
            let next = schedule.next_start.as_ref().map_or_else(
                || lang.t(Text::ScheduleNone).to_owned(),
                |next| format!("{next} ({})", schedule.time_zone),
            );
            let last = schedule.last.as_ref().map(|last| {
                format!(
                    "{}: {} {}",
                    lang.t(Text::ScheduleLast),
                    last.at,
                    lang.coded(&last.code, &last.params, &last.message)
                )
            });
            let class = if schedule.last.as_ref().is_some_and(|last| !last.done) {
                "note error"
            } else {
                "note"
            };
            Some(view! {
                <div class="schedule-line" data-testid="schedule-line">
                    <p class="note" data-testid="schedule-next">
                        {lang.t(Text::ScheduleNextStart)} ": " {next}
                    </p>
                    {last.map(|last| view! { <p class=class data-testid="schedule-last">{last}</p> })}
                </div>
            })
        })
    }
}

/// The Settings page: default delay and cycles for new entries, and loop.
#[component]
pub fn SettingsPage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let current = ctx
        .playlist
        .with_untracked(|editor| editor.playlist().clone());
    let form = TimingForm::defaults_of(&current);
    let delay = RwSignal::new(form.delay_s);
    let cycles = RwSignal::new(form.cycles);
    let looped = RwSignal::new(current.loop_playlist);
    // Follow the bridge's values when they arrive (a refresh after the page opened).
    Effect::new(move |_| {
        let (form, loop_playlist) = ctx.playlist.with(|editor| {
            let playlist = editor.playlist();
            (TimingForm::defaults_of(playlist), playlist.loop_playlist)
        });
        delay.set(form.delay_s);
        cycles.set(form.cycles);
        looped.set(loop_playlist);
    });
    let note = RwSignal::new(None::<String>);
    let saved = RwSignal::new(false);
    let apply = move |event: leptos::ev::SubmitEvent| {
        event.prevent_default();
        let lang = ctx.lang.get_untracked();
        match TimingForm::parse(&delay.get_untracked(), &cycles.get_untracked()) {
            Err(input) => note.set(Some(lang.input_error(input).into())),
            Ok(timing) => {
                let looped = looped.get_untracked();
                edit_and_save(ctx, note, move |editor| {
                    editor.set_settings(timing.delay_ms, timing.cycles, looped);
                    true
                });
                saved.set(true);
            }
        }
    };
    let unsaved = Callback::new(move |()| saved.set(false));
    view! {
        <section class="control">
            <ControlTabs />
            <form class="card form" data-testid="settings-form" on:submit=apply>
                <TextField
                    label=Text::DefaultDelayS
                    value=delay
                    test_id="default-delay"
                    inputmode="decimal"
                    on_edit=unsaved
                />
                <TextField
                    label=Text::DefaultCycles
                    value=cycles
                    test_id="default-cycles"
                    inputmode="numeric"
                    on_edit=unsaved
                />
                <label class="check">
                    <input
                        type="checkbox"
                        data-testid="loop"
                        prop:checked=looped
                        on:change=move |ev| {
                            saved.set(false);
                            looped.set(event_target_checked(&ev));
                        }
                    />
                    <span>{ctx.tr(Text::LoopPlaylist)}</span>
                </label>
                <button type="submit" class="primary" data-testid="settings-apply">
                    {ctx.tr(Text::Apply)}
                </button>
                <ErrorNote text=note test_id="settings-error" />
                {move || {
                    (saved.get() && note.with(Option::is_none))
                        .then(|| view! { <p class="note done" data-testid="settings-saved">{ctx.tr(Text::Saved)}</p> })
                }}
            </form>
            <button
                class="open-installation"
                data-testid="open-installation"
                on:click=move |_| ctx.page.set(Page::Installation)
            >
                {ctx.tr(Text::OpenInstallation)}
            </button>
            <crate::components::password::PasswordForm />
        </section>
    }
}
