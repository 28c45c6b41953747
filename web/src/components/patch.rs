//! The Patch page (`#/patch`, reached from Control's tabs): each ball's universe,
//! start address and profile for live input (`GET` / `PUT /api/live/patch`).
//!
//! The page keeps a draft of the bridge's patch: the default profile's channels
//! (speed limit none / 8 / 16 bits, enable, colour), "patch the whole matrix from
//! universe U, address N, row by row" in one tap, and Save. The draft's problems are
//! listed as it changes (the shared [`Patch::problems`]) and the bridge checks it
//! again on Save (422 lists every problem, 409 while the matrix plays), in the
//! app's language. At 10,000 balls the page stays short: the universes in use are
//! one line each (40 of them), and the ball table shows
//! [`crate::patch::PAGE_ROWS`] balls a page.
//! The logic is [`crate::patch`]'s.

use floatball_shared::api::LivePatch;
use floatball_shared::live::patch::{Patch, Profile};
use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::client::Failure;
use crate::components::widgets::{ErrorNote, ProblemList};
use crate::context::Ctx;
use crate::i18n::{PatchText, Text};
use crate::page::Page;
use crate::patch::{page_rows, pages, universe_ranges, whole_matrix, with_profile};

/// The Patch page.
#[component]
pub fn PatchPage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    // The bridge's answer (grid, settings) and the draft being edited.
    let live = RwSignal::new(None::<LivePatch>);
    let draft = RwSignal::new(None::<Patch>);
    let error = RwSignal::new(None::<String>);
    let problems = RwSignal::new(Vec::<String>::new());
    let busy = RwSignal::new(false);
    let saved = RwSignal::new(false);
    let page = RwSignal::new(0usize);
    let universe = RwSignal::new("1".to_owned());
    let address = RwSignal::new("1".to_owned());

    if let Some(client) = ctx.client() {
        spawn_local(async move {
            match client.live_patch().await {
                Ok(now) => {
                    if let Some(first) = now.patch.balls.first() {
                        universe.set(first.universe.to_string());
                        address.set(first.address.to_string());
                    }
                    draft.set(Some(now.patch.clone()));
                    live.set(Some(now));
                }
                Err(failure) => error.set(Some(ctx.failed(&failure))),
            }
        });
    }

    let grid = move || live.with(|live| live.as_ref().map_or((0, 0), |l| (l.rows, l.cols)));
    let profile = move || draft.with(|d| d.as_ref().map(|d| d.profile).unwrap_or_default());
    let set_profile = move |change: &dyn Fn(&mut Profile)| {
        saved.set(false);
        draft.update(|draft| {
            if let Some(patch) = draft {
                let mut profile = patch.profile;
                change(&mut profile);
                *patch = with_profile(patch, profile);
            }
        });
    };
    // The draft's problems, in the app's language, as it changes.
    let local_problems = Memo::new(move |_| {
        let (rows, cols) = grid();
        let lang = ctx.lang.get();
        draft.with(|draft| {
            draft.as_ref().map_or_else(Vec::new, |patch| {
                patch
                    .problems(rows as usize * cols as usize)
                    .iter()
                    .map(|problem| lang.error_of(problem))
                    .collect::<Vec<_>>()
            })
        })
    });
    let patch_matrix = move |_| {
        let lang = ctx.lang.get_untracked();
        let (rows, cols) = grid();
        let (Ok(u), Ok(a)) = (
            universe.get_untracked().trim().parse::<u16>(),
            address.get_untracked().trim().parse::<u16>(),
        ) else {
            error.set(Some(lang.t(Text::FieldsNotRead).into()));
            return;
        };
        match whole_matrix(rows, cols, profile(), u, a) {
            Ok(patch) => {
                error.set(None);
                problems.set(Vec::new());
                saved.set(false);
                page.set(0);
                draft.set(Some(patch));
            }
            Err(problem) => error.set(Some(lang.error_of(&problem))),
        }
    };
    let save = move |_| {
        let Some(patch) = draft.get_untracked() else {
            return;
        };
        let Some(client) = ctx.client() else { return };
        error.set(None);
        problems.set(Vec::new());
        saved.set(false);
        busy.set(true);
        spawn_local(async move {
            let answer = client.put_live_patch(&patch).await;
            busy.set(false);
            let lang = ctx.lang.get_untracked();
            match answer {
                Ok(now) => {
                    draft.set(Some(now.patch.clone()));
                    live.set(Some(now));
                    saved.set(true);
                    ctx.notify(lang.t(PatchText::PatchSaved));
                }
                Err(failure) => {
                    if let Failure::Rejected(refusal) = &failure {
                        problems.set(lang.problems(refusal));
                    }
                    error.set(Some(ctx.failed(&failure)));
                }
            }
        });
    };

    let universes = move || {
        let cols = grid().1;
        let lang = ctx.lang.get();
        draft.with(|draft| {
            let Some(patch) = draft else {
                return Vec::new();
            };
            universe_ranges(patch)
                .into_iter()
                .map(|range| {
                    view! {
                        <tr data-testid="patch-universe">
                            <td class="mono">{range.universe}</td>
                            <td>{range.balls}</td>
                            <td class="mono">
                                {lang.ball_place(range.first_ball, cols)} " – "
                                {lang.ball_place(range.last_ball, cols)}
                            </td>
                            <td class="mono">{range.first_slot} "–" {range.last_slot}</td>
                        </tr>
                    }
                })
                .collect::<Vec<_>>()
        })
    };
    let balls = move || {
        let cols = grid().1;
        let lang = ctx.lang.get();
        let own = lang.t(PatchText::PatchOwnProfile);
        draft.with(|draft| {
            let Some(patch) = draft else {
                return Vec::new();
            };
            page_rows(patch, cols, page.get())
                .into_iter()
                .map(|row| {
                    view! {
                        <tr data-testid="patch-ball">
                            <td>{row.ball}</td>
                            <td class="mono">{row.row} ", " {row.col}</td>
                            <td class="mono">{row.universe} "." {row.address}</td>
                            <td class="small">
                                {lang.profile_channels(row.profile)} {row.own.then_some(own)}
                            </td>
                        </tr>
                    }
                })
                .collect::<Vec<_>>()
        })
    };
    let page_count = move || draft.with(|d| d.as_ref().map_or(1, pages));
    let speed_choice = move |bits: Option<u8>, text: PatchText, test_id: &'static str| {
        view! {
            <label>
                <input
                    type="radio"
                    name="patch-speed"
                    data-testid=test_id
                    prop:checked=move || profile().speed_limit_bits == bits
                    on:change=move |_| set_profile(&|p| p.speed_limit_bits = bits)
                />
                {ctx.tr(text)}
            </label>
        }
    };

    view! {
        <section class="patch">
            <crate::components::control::ControlTabs />
            <h2>{ctx.tr(Text::NavPatch)}</h2>
            <p class="muted small">{ctx.tr(PatchText::PatchLater)}</p>
            <Show
                when=move || draft.with(Option::is_some)
                fallback=move || {
                    view! {
                        <p class="muted" data-testid="patch-unavailable">{ctx.tr(PatchText::PatchUnavailable)}</p>
                        <ErrorNote text=error test_id="patch-error" alert=true />
                    }
                }
            >
                <p class="muted small" data-testid="patch-live">
                    {move || live.with(|l| l.as_ref().map(|l| ctx.lang.get().live_settings(l)))}
                </p>
                <div class="card" data-testid="patch-profile">
                    <h3>{ctx.tr(PatchText::PatchProfile)}</h3>
                    <fieldset>
                        <legend>{ctx.tr(PatchText::PatchSpeedLimit)}</legend>
                        {speed_choice(None, PatchText::PatchSpeedNone, "patch-speed-none")}
                        {speed_choice(Some(8), PatchText::PatchSpeed8, "patch-speed-8")}
                        {speed_choice(Some(16), PatchText::PatchSpeed16, "patch-speed-16")}
                    </fieldset>
                    <label>
                        <input
                            type="checkbox"
                            data-testid="patch-enable"
                            prop:checked=move || profile().enable
                            on:change=move |ev| {
                                let on = event_target_checked(&ev);
                                set_profile(&|p| p.enable = on);
                            }
                        />
                        {ctx.tr(PatchText::PatchEnable)}
                    </label>
                    <label>
                        <input
                            type="checkbox"
                            data-testid="patch-colour"
                            prop:checked=move || profile().colour
                            on:change=move |ev| {
                                let on = event_target_checked(&ev);
                                set_profile(&|p| p.colour = on);
                            }
                        />
                        {ctx.tr(PatchText::PatchColour)}
                    </label>
                    <p class="muted small" data-testid="patch-channels">
                        {move || ctx.lang.get().profile_channels(profile())}
                    </p>
                </div>
                <div class="card" data-testid="patch-matrix">
                    <h3>{ctx.tr(PatchText::PatchWholeMatrix)}</h3>
                    <label>
                        <span>{ctx.tr(PatchText::PatchUniverse)}</span>
                        <input
                            inputmode="numeric"
                            data-testid="patch-matrix-universe"
                            prop:value=move || universe.get()
                            on:input=move |ev| universe.set(event_target_value(&ev))
                        />
                    </label>
                    <label>
                        <span>{ctx.tr(PatchText::PatchAddress)}</span>
                        <input
                            inputmode="numeric"
                            data-testid="patch-matrix-address"
                            prop:value=move || address.get()
                            on:input=move |ev| address.set(event_target_value(&ev))
                        />
                    </label>
                    <button data-testid="patch-matrix-apply" on:click=patch_matrix>
                        {ctx.tr(PatchText::PatchWholeMatrixButton)}
                    </button>
                </div>
                <div class="card">
                    <h3>{ctx.tr(PatchText::PatchUniverses)}</h3>
                    <p data-testid="patch-summary">
                        {move || {
                            draft.with(|d| {
                                d.as_ref().map(|d| {
                                    ctx.lang.get().patch_summary(d.balls.len(), d.universes().len())
                                })
                            })
                        }}
                    </p>
                    <table class="patch-universes">
                        <thead>
                            <tr>
                                <th>{ctx.tr(PatchText::PatchUniverse)}</th>
                                <th>{ctx.tr(PatchText::PatchBallsIn)}</th>
                                <th>{ctx.tr(PatchText::PatchRowCol)}</th>
                                <th>{ctx.tr(PatchText::PatchSlots)}</th>
                            </tr>
                        </thead>
                        <tbody>{universes}</tbody>
                    </table>
                </div>
                <div class="card">
                    <h3>{ctx.tr(PatchText::PatchBalls)}</h3>
                    <table class="patch-balls">
                        <thead>
                            <tr>
                                <th>{ctx.tr(PatchText::PatchBall)}</th>
                                <th>{ctx.tr(PatchText::PatchRowCol)}</th>
                                <th>{ctx.tr(PatchText::PatchUniverse)} "." {ctx.tr(PatchText::PatchAddress)}</th>
                                <th>{ctx.tr(PatchText::PatchProfile)}</th>
                            </tr>
                        </thead>
                        <tbody>{balls}</tbody>
                    </table>
                    <div class="pager">
                        <button
                            data-testid="patch-previous"
                            disabled=move || page.get() == 0
                            on:click=move |_| page.update(|p| *p = p.saturating_sub(1))
                        >
                            {ctx.tr(PatchText::PatchPrevious)}
                        </button>
                        <span data-testid="patch-page">
                            {move || ctx.lang.get().table_page(page.get() + 1, page_count())}
                        </span>
                        <button
                            data-testid="patch-next"
                            disabled=move || { page.get() + 1 >= page_count() }
                            on:click=move |_| page.update(|p| *p += 1)
                        >
                            {ctx.tr(PatchText::PatchNext)}
                        </button>
                    </div>
                </div>
                {move || {
                    let found = local_problems.get();
                    (!found.is_empty())
                        .then(|| {
                            view! {
                                <p class="note">{ctx.tr(PatchText::PatchProblems)}</p>
                                <ProblemList problems=found test_id="patch-local-problems" />
                            }
                        })
                }}
                <button class="primary" data-testid="patch-save" disabled=move || busy.get() on:click=save>
                    {ctx.tr(PatchText::PatchSave)}
                </button>
                <ErrorNote text=error test_id="patch-error" alert=true />
                {move || {
                    let problems = problems.get();
                    (!problems.is_empty())
                        .then(|| view! { <ProblemList problems test_id="patch-problems" /> })
                }}
                {move || {
                    (saved.get() && error.with(Option::is_none))
                        .then(|| view! { <p class="note done" data-testid="patch-saved">{ctx.tr(PatchText::PatchSaved)}</p> })
                }}
                <button data-testid="patch-back" on:click=move |_| ctx.page.set(Page::Control)>
                    "← " {ctx.tr(Text::NavControl)}
                </button>
            </Show>
        </section>
    }
}
