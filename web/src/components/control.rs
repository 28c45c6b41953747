//! The Control and Settings pages: the playlist with its checkboxes and icons (add,
//! move up, move down, delete, edit), Start / E-stop / Reset, the bandwidth verdict
//! and the live status (PROTOCOL §1.7).
//!
//! Every edit is applied to [`crate::playlist::PlaylistEditor`] and then stored on
//! the bridge (`PUT /api/playlist`); what the bridge answers is what the page shows.

use floatball_shared::api::{ClientMessage, Status};
use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::components::topbar::EstopButton;
use crate::context::Ctx;
use crate::files::format_duration_ms;
use crate::i18n::Text;
use crate::page::Page;
use crate::playlist::{
    PlaylistEditor, Verdict, can_start, format_delay_s, parse_cycles, parse_delay_s,
};
use crate::status::{progress, shows_progress, state_key, time_text};

/// Applies `edit` to the playlist and stores the result on the bridge; `note` gets
/// the bridge's refusal, if any (then the bridge's playlist is fetched again).
fn edit_and_save(
    ctx: Ctx,
    note: RwSignal<Option<String>>,
    edit: impl FnOnce(&mut PlaylistEditor) -> bool,
) {
    let mut changed = false;
    ctx.playlist.update(|editor| changed = edit(editor));
    if !changed {
        return;
    }
    let Some(client) = ctx.client() else { return };
    let playlist = ctx
        .playlist
        .with_untracked(|editor| editor.playlist().clone());
    note.set(None);
    spawn_local(async move {
        match client.put_playlist(&playlist).await {
            Ok(stored) => ctx.playlist.update(|editor| editor.replace(stored)),
            Err(failure) => {
                note.set(Some(ctx.failed(&failure)));
                ctx.refresh();
            }
        }
    });
}

/// Which panel under the icons is open.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Panel {
    None,
    Add,
    Edit,
}

/// The Control / Settings switch (the vendor app's left-hand buttons).
#[component]
fn ControlTabs() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let tab = move |page: Page, text: Text| {
        view! {
            <button
                class="tab"
                class:active=move || ctx.page.get() == page
                data-testid=format!("subtab-{}", page.key())
                on:click=move |_| ctx.page.set(page)
            >
                {move || ctx.t(text)}
            </button>
        }
    };
    view! {
        <div class="subtabs">
            {tab(Page::Control, Text::NavControl)} {tab(Page::Settings, Text::NavSettings)}
        </div>
    }
}

/// The Control page.
#[component]
pub fn ControlPage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let panel = RwSignal::new(Panel::None);
    let note = RwSignal::new(None::<String>);
    let verdicts = RwSignal::new(Vec::<(String, Verdict)>::new());
    let plan_round = StoredValue::new(0u32);

    // The bandwidth report of each show, fetched again when the shows change.
    let shows = Memo::new(move |_| ctx.playlist.with(PlaylistEditor::shows));
    Effect::new(move |_| {
        let shows = shows.get();
        let connected = ctx.connected();
        plan_round.update_value(|round| *round += 1);
        let round = plan_round.get_value();
        let Some(client) = ctx.client().filter(|_| connected) else {
            verdicts.set(Vec::new());
            return;
        };
        verdicts.set(
            shows
                .iter()
                .map(|show| (show.clone(), Verdict::Pending))
                .collect(),
        );
        for show in shows {
            let client = client.clone();
            spawn_local(async move {
                let verdict = match client.plan(&show).await {
                    Ok(report) => Verdict::of(report),
                    Err(failure) => Verdict::Failed(ctx.lang.get_untracked().failure(&failure)),
                };
                if plan_round.get_value() == round {
                    verdicts.update(|verdicts| {
                        if let Some(slot) = verdicts.iter_mut().find(|(name, _)| *name == show) {
                            slot.1 = verdict;
                        }
                    });
                }
            });
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
                title=move || ctx.t(text)
                on:click=move |_| action()
            >
                <span class="symbol" aria-hidden="true">
                    {symbol}
                </span>
                <span class="caption">{move || ctx.t(text)}</span>
            </button>
        }
    };
    let needs_checks = move |edit: fn(&mut PlaylistEditor) -> bool| {
        move || {
            if ctx.playlist.with_untracked(PlaylistEditor::checked_count) == 0 {
                note.set(Some(ctx.lang.get_untracked().t(Text::CheckFirst).into()));
                return;
            }
            edit_and_save(ctx, note, edit);
        }
    };
    let toggle_panel = move |which: Panel| {
        move || {
            if which == Panel::Edit
                && ctx.playlist.with_untracked(PlaylistEditor::checked_count) == 0
            {
                note.set(Some(ctx.lang.get_untracked().t(Text::CheckFirst).into()));
                return;
            }
            note.set(None);
            panel.update(|open| *open = if *open == which { Panel::None } else { which });
        }
    };
    let start_allowed = move || {
        ctx.connected()
            && verdicts.with(|verdicts| ctx.playlist.with(|editor| can_start(editor, verdicts)))
    };
    let send = move |message: ClientMessage| {
        ctx.bridge_error.set(None);
        ctx.send(&message);
    };
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
            {move || {
                note.get()
                    .map(|text| view! { <p class="note error" data-testid="control-note">{text}</p> })
            }}
            {move || match panel.get() {
                Panel::None => ().into_any(),
                Panel::Add => view! { <AddPanel panel=panel note=note /> }.into_any(),
                Panel::Edit => view! { <EditPanel panel=panel note=note /> }.into_any(),
            }}
            <PlaylistView />
            <div class="actions">
                <button
                    class="start primary"
                    data-testid="start"
                    disabled=move || !start_allowed()
                    on:click=move |_| send(ClientMessage::Start)
                >
                    {move || ctx.t(Text::Start)}
                </button>
                <EstopButton />
                <button
                    class="reset"
                    data-testid="reset"
                    disabled=move || !ctx.connected()
                    on:click=move |_| send(ClientMessage::Reset)
                >
                    {move || ctx.t(Text::Reset)}
                </button>
            </div>
            {move || {
                ctx.bridge_error
                    .get()
                    .map(|message| {
                        view! {
                            <p class="note error" data-testid="bridge-error">
                                {move || ctx.t(Text::BridgeSays)} " " {message}
                            </p>
                        }
                    })
            }}
            </div>
            <div class="control-side">
                <PlanView verdicts=verdicts />
                <StatusView />
            </div>
            </div>
        </section>
    }
}

/// The playlist with a checkbox per entry.
#[component]
fn PlaylistView() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! {
        <h3>{move || ctx.t(Text::Playlist)}</h3>
        <ol class="list playlist" data-testid="playlist">
            {move || {
                let editor = ctx.playlist.get();
                if editor.entries().is_empty() {
                    return view! {
                        <li class="empty muted">{move || ctx.t(Text::EmptyPlaylist)}</li>
                    }
                        .into_any();
                }
                let playing = ctx.status.with(|status| status.as_ref().and_then(|s| s.entry));
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
                                class:playing=playing == Some(index)
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
            <h3>{move || ctx.t(Text::PickShow)}</h3>
            <ul class="list">
                {move || {
                    let files = ctx.controller_files.get();
                    if files.items().is_empty() {
                        return view! {
                            <li class="empty muted">{move || ctx.t(Text::NoControllerFiles)}</li>
                        }
                            .into_any();
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
                            view! {
                                <li>
                                    <button
                                        class="row"
                                        data-testid="pick-show"
                                        data-name=name.clone()
                                        on:click=move |_| {
                                            let name = name.clone();
                                            edit_and_save(
                                                ctx,
                                                note,
                                                move |editor| {
                                                    editor.add(&name);
                                                    true
                                                },
                                            );
                                            panel.set(Panel::None);
                                        }
                                    >
                                        <span class="name">{show.name.clone()}</span>
                                        <span class="facts muted">{facts}</span>
                                    </button>
                                </li>
                            }
                        })
                        .collect_view()
                        .into_any()
                }}
            </ul>
            <button on:click=move |_| panel.set(Panel::None)>{move || ctx.t(Text::Cancel)}</button>
        </div>
    }
}

/// Delay and cycles of the checked entries.
#[component]
fn EditPanel(panel: RwSignal<Panel>, note: RwSignal<Option<String>>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let first = ctx
        .playlist
        .with_untracked(|editor| editor.first_checked().cloned());
    let delay = RwSignal::new(
        first
            .as_ref()
            .map_or_else(|| "0".to_owned(), |entry| format_delay_s(entry.delay_ms)),
    );
    let cycles =
        RwSignal::new(first.map_or_else(|| "1".to_owned(), |entry| entry.cycles.to_string()));
    let error = RwSignal::new(None::<&'static str>);
    let apply = move |event: leptos::ev::SubmitEvent| {
        event.prevent_default();
        let lang = ctx.lang.get_untracked();
        let parsed = parse_delay_s(&delay.get_untracked())
            .and_then(|delay_ms| Ok((delay_ms, parse_cycles(&cycles.get_untracked())?)));
        match parsed {
            Err(input) => error.set(Some(lang.input_error(input))),
            Ok((delay_ms, cycles)) => {
                error.set(None);
                edit_and_save(ctx, note, move |editor| {
                    editor.edit_checked(delay_ms, cycles) > 0
                });
                panel.set(Panel::None);
            }
        }
    };
    view! {
        <form class="card panel form" data-testid="edit-panel" on:submit=apply>
            <label>
                <span>{move || ctx.t(Text::DelayS)}</span>
                <input
                    type="text"
                    inputmode="decimal"
                    data-testid="edit-delay"
                    prop:value=delay
                    on:input=move |ev| delay.set(event_target_value(&ev))
                />
            </label>
            <label>
                <span>{move || ctx.t(Text::Cycles)}</span>
                <input
                    type="text"
                    inputmode="numeric"
                    data-testid="edit-cycles"
                    prop:value=cycles
                    on:input=move |ev| cycles.set(event_target_value(&ev))
                />
            </label>
            {move || error.get().map(|text| view! { <p class="note error" data-testid="edit-error">{text}</p> })}
            <div class="row-buttons">
                <button type="submit" class="primary" data-testid="edit-apply">
                    {move || ctx.t(Text::Apply)}
                </button>
                <button type="button" on:click=move |_| panel.set(Panel::None)>
                    {move || ctx.t(Text::Cancel)}
                </button>
            </div>
        </form>
    }
}

/// The bandwidth verdict of each show before Start.
#[component]
fn PlanView(verdicts: RwSignal<Vec<(String, Verdict)>>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! {
        <Show when=move || verdicts.with(|verdicts| !verdicts.is_empty())>
            <div class="card" data-testid="plan">
                <h3>{move || ctx.t(Text::PlanTitle)}</h3>
                <ul class="verdicts">
                    {move || {
                        verdicts
                            .get()
                            .into_iter()
                            .map(|(show, verdict)| {
                                let key = verdict.key();
                                let (word, reason, fixes) = match verdict {
                                    Verdict::Pending => (Text::PlanPending, None, Vec::new()),
                                    Verdict::Feasible(_) => (Text::PlanFeasible, None, Vec::new()),
                                    Verdict::Infeasible(report) => {
                                        (Text::PlanInfeasible, report.reason, report.fixes)
                                    }
                                    Verdict::Unavailable => (Text::PlanUnavailable, None, Vec::new()),
                                    Verdict::Failed(message) => {
                                        (Text::PlanUnavailable, Some(message), Vec::new())
                                    }
                                };
                                view! {
                                    <li class=format!("verdict {key}") data-testid="verdict" data-verdict=key>
                                        <strong>{show}</strong>
                                        ": "
                                        {move || ctx.t(word)}
                                        {reason.map(|reason| view! { <p>{reason}</p> })}
                                        {(!fixes.is_empty())
                                            .then(|| {
                                                view! {
                                                    <p class="muted">
                                                        {move || ctx.t(Text::PlanFixes)} " "
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

/// The live status from the bridge.
#[component]
fn StatusView() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! {
        <div class="card status" data-testid="status">
            <h3>{move || ctx.t(Text::StatusTitle)}</h3>
            {move || {
                let status = ctx.status.get().filter(|_| ctx.connected());
                match status {
                    None => {
                        view! {
                            <p class="muted" data-testid="status-state" data-state="unknown">
                                {move || ctx.t(Text::StatusUnavailable)}
                            </p>
                        }
                            .into_any()
                    }
                    Some(status) => status_details(ctx, status).into_any(),
                }
            }}
        </div>
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
    let cycle = if status.cycle > 0 {
        status.cycle.to_string()
    } else {
        String::new()
    };
    let gateways = status
        .gateways
        .iter()
        .map(|gateway| {
            let mut text = format!(
                "{}: {} · {:.0} B/s",
                gateway.port,
                lang.link_state(gateway.link),
                gateway.bytes_per_s
            );
            if let Some(level) = gateway.lowest_water_level {
                text.push_str(&format!(" · FIFO ≥ {level}"));
            }
            if let Some(error) = &gateway.error {
                text.push_str(&format!(" · {error}"));
            }
            let link = format!("{:?}", gateway.link).to_lowercase();
            view! {
                <li class=format!("link {link}") data-testid="gateway" data-link=link>
                    {text}
                </li>
            }
        })
        .collect_view();
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
            {row(Text::ShowTime, time_text(&status), "status-time")}
            {row(Text::Cycle, cycle, "status-cycle")}
        </dl>
        {shows_progress(state)
            .then(|| {
                view! {
                    <progress
                        class="wide"
                        data-testid="status-progress"
                        max="1"
                        prop:value=fraction
                    ></progress>
                }
            })}
        <h4>{lang.t(Text::Gateways)}</h4>
        <ul class="gateways">{gateways}</ul>
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

/// The Settings page: default delay and cycles for new entries, and loop.
#[component]
pub fn SettingsPage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let current = ctx
        .playlist
        .with_untracked(|editor| editor.playlist().clone());
    let delay = RwSignal::new(format_delay_s(current.default_delay_ms));
    let cycles = RwSignal::new(current.default_cycles.to_string());
    let looped = RwSignal::new(current.loop_playlist);
    // Follow the bridge's values when they arrive (a refresh after the page opened).
    Effect::new(move |_| {
        let playlist = ctx.playlist.with(|editor| editor.playlist().clone());
        delay.set(format_delay_s(playlist.default_delay_ms));
        cycles.set(playlist.default_cycles.to_string());
        looped.set(playlist.loop_playlist);
    });
    let note = RwSignal::new(None::<String>);
    let saved = RwSignal::new(false);
    let apply = move |event: leptos::ev::SubmitEvent| {
        event.prevent_default();
        let lang = ctx.lang.get_untracked();
        let parsed = parse_delay_s(&delay.get_untracked())
            .and_then(|delay_ms| Ok((delay_ms, parse_cycles(&cycles.get_untracked())?)));
        match parsed {
            Err(input) => note.set(Some(lang.input_error(input).into())),
            Ok((delay_ms, cycles)) => {
                let looped = looped.get_untracked();
                edit_and_save(ctx, note, move |editor| {
                    editor.set_settings(delay_ms, cycles, looped);
                    true
                });
                saved.set(true);
            }
        }
    };
    view! {
        <section class="control">
            <ControlTabs />
            <form class="card form" data-testid="settings-form" on:submit=apply>
                <label>
                    <span>{move || ctx.t(Text::DefaultDelayS)}</span>
                    <input
                        type="text"
                        inputmode="decimal"
                        data-testid="default-delay"
                        prop:value=delay
                        on:input=move |ev| {
                            saved.set(false);
                            delay.set(event_target_value(&ev));
                        }
                    />
                </label>
                <label>
                    <span>{move || ctx.t(Text::DefaultCycles)}</span>
                    <input
                        type="text"
                        inputmode="numeric"
                        data-testid="default-cycles"
                        prop:value=cycles
                        on:input=move |ev| {
                            saved.set(false);
                            cycles.set(event_target_value(&ev));
                        }
                    />
                </label>
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
                    <span>{move || ctx.t(Text::LoopPlaylist)}</span>
                </label>
                <button type="submit" class="primary" data-testid="settings-apply">
                    {move || ctx.t(Text::Apply)}
                </button>
                {move || {
                    note.get()
                        .map(|text| view! { <p class="note error" data-testid="settings-error">{text}</p> })
                }}
                {move || {
                    (saved.get() && note.with(Option::is_none))
                        .then(|| view! { <p class="note done" data-testid="settings-saved">{move || ctx.t(Text::Saved)}</p> })
                }}
            </form>
        </section>
    }
}
