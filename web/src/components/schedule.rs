//! The Schedule page (`#/schedule`, reached from Control's tabs; a chunk of its own,
//! `crate::lazy`): the weekly schedule's windows per weekday with their program, the
//! dated exceptions, the time zone and the switch; saved with `PUT /api/schedule`,
//! whose coded problems are shown in the operator's language. Fields are taken when
//! they change (on leaving them), so a redraw never takes the cursor away.

use floatball_shared::schedule::Weekday;
use leptos::prelude::*;
use leptos::task::spawn_local;

use super::control::ControlTabs;
use super::widgets::ErrorNote;
use crate::client::Failure;
use crate::context::Ctx;
use crate::i18n::{Lang, ScheduleText};
use crate::schedule::{ExceptionForm, FormError, FormProblem, ScheduleForm, WindowForm};

/// Where a list of windows is: a weekday (0 = Monday) or an exception (0-based).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Place {
    Day(usize),
    Exception(usize),
}

fn windows_mut(form: &mut ScheduleForm, place: Place) -> Option<&mut Vec<WindowForm>> {
    match place {
        Place::Day(day) => form.week.get_mut(day),
        Place::Exception(index) => form
            .exceptions
            .get_mut(index)
            .map(|exception| &mut exception.windows),
    }
}

fn day_text(day: Weekday) -> ScheduleText {
    match day {
        Weekday::Monday => ScheduleText::Monday,
        Weekday::Tuesday => ScheduleText::Tuesday,
        Weekday::Wednesday => ScheduleText::Wednesday,
        Weekday::Thursday => ScheduleText::Thursday,
        Weekday::Friday => ScheduleText::Friday,
        Weekday::Saturday => ScheduleText::Saturday,
        Weekday::Sunday => ScheduleText::Sunday,
    }
}

/// A field the form cannot read, in `lang`: where, then what.
fn form_problem(lang: Lang, problem: FormProblem) -> String {
    let what = lang.t(match problem.error {
        FormError::Time => ScheduleText::ScheduleBadTime,
        FormError::Minutes => ScheduleText::ScheduleBadMinutes,
        FormError::Date => ScheduleText::ScheduleBadDate,
    });
    let mut place = match (problem.weekday, problem.exception) {
        (Some(day), _) => lang.t(day_text(day)).to_owned(),
        (None, Some(number)) => format!("{} {number}", lang.t(ScheduleText::ScheduleException)),
        (None, None) => String::new(),
    };
    if let Some(window) = problem.window {
        place.push_str(&format!(
            ", {} {window}",
            lang.t(ScheduleText::ScheduleWindow)
        ));
    }
    format!("{place}: {what}")
}

/// The Schedule page.
#[component]
pub fn SchedulePage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let form = RwSignal::new(None::<ScheduleForm>);
    let error = RwSignal::new(None::<String>);
    let problems = RwSignal::new(Vec::<String>::new());
    let saved = RwSignal::new(false);
    let busy = RwSignal::new(false);
    if let Some(client) = ctx.client() {
        spawn_local(async move {
            match client.schedule().await {
                Ok(schedule) => form.set(Some(ScheduleForm::of(&schedule))),
                Err(failure) => error.set(Some(ctx.failed(&failure))),
            }
        });
    }
    let edit = move |change: &dyn Fn(&mut ScheduleForm)| {
        saved.set(false);
        form.update(|form| {
            if let Some(form) = form {
                change(form);
            }
        });
    };
    let save = move |event: leptos::ev::SubmitEvent| {
        event.prevent_default();
        let lang = ctx.lang.get_untracked();
        problems.set(Vec::new());
        error.set(None);
        let Some(read) = form.with_untracked(|form| form.as_ref().map(ScheduleForm::read)) else {
            return;
        };
        let schedule = match read {
            Ok(schedule) => schedule,
            Err(problem) => {
                error.set(Some(form_problem(lang, problem)));
                return;
            }
        };
        let Some(client) = ctx.client() else {
            return;
        };
        busy.set(true);
        spawn_local(async move {
            let answer = client.put_schedule(&schedule).await;
            busy.set(false);
            match answer {
                Ok(stored) => {
                    form.set(Some(ScheduleForm::of(&stored)));
                    saved.set(true);
                    ctx.notify(ctx.lang.get_untracked().t(ScheduleText::ScheduleSaved));
                }
                Err(failure) => {
                    let lang = ctx.lang.get_untracked();
                    if let Failure::Rejected(refusal) = &failure {
                        problems.set(lang.problems(refusal));
                    }
                    error.set(Some(ctx.failed(&failure)));
                }
            }
        });
    };
    let window_rows = move |place: Place, windows: Vec<WindowForm>| {
        let key = match place {
            Place::Day(day) => format!("day{day}"),
            Place::Exception(index) => format!("exception{index}"),
        };
        let rows = windows
            .into_iter()
            .enumerate()
            .map(|(index, window)| {
                let at = move |change: fn(&mut WindowForm, String), value: String| {
                    edit(&|form| {
                        if let Some(window) =
                            windows_mut(form, place).and_then(|windows| windows.get_mut(index))
                        {
                            change(window, value.clone());
                        }
                    });
                };
                let every = window.every;
                let id = format!("{key}-window{index}");
                view! {
                    <div class="schedule-window" data-testid=id.clone()>
                        <label>
                            <span>{ctx.tr(ScheduleText::ScheduleFrom)}</span>
                            <input
                                data-testid=format!("{id}-start")
                                placeholder="HH:MM"
                                prop:value=window.start
                                on:change=move |ev| at(|w, v| w.start = v, event_target_value(&ev))
                            />
                        </label>
                        <label>
                            <span>{ctx.tr(ScheduleText::ScheduleTo)}</span>
                            <input
                                data-testid=format!("{id}-end")
                                placeholder="HH:MM"
                                prop:value=window.end
                                on:change=move |ev| at(|w, v| w.end = v, event_target_value(&ev))
                            />
                        </label>
                        <select
                            data-testid=format!("{id}-program")
                            on:change=move |ev| {
                                at(|w, v| w.every = v == "every", event_target_value(&ev))
                            }
                        >
                            <option value="loop" selected=!every>{ctx.tr(ScheduleText::ScheduleLoop)}</option>
                            <option value="every" selected=every>{ctx.tr(ScheduleText::ScheduleEvery)}</option>
                        </select>
                        {every.then(|| view! {
                            <label>
                                <span>{ctx.tr(ScheduleText::ScheduleMinutes)}</span>
                                <input
                                    data-testid=format!("{id}-minutes")
                                    inputmode="numeric"
                                    prop:value=window.minutes.clone()
                                    on:change=move |ev| at(|w, v| w.minutes = v, event_target_value(&ev))
                                />
                            </label>
                        })}
                        <button
                            type="button"
                            data-testid=format!("{id}-remove")
                            on:click=move |_| {
                                edit(&|form| {
                                    if let Some(windows) = windows_mut(form, place)
                                        && index < windows.len()
                                    {
                                        windows.remove(index);
                                    }
                                });
                            }
                        >
                            {ctx.tr(ScheduleText::ScheduleRemove)}
                        </button>
                    </div>
                }
            })
            .collect_view();
        view! {
            {rows}
            <button
                type="button"
                data-testid=format!("{key}-add")
                on:click=move |_| {
                    edit(&|form| {
                        if let Some(windows) = windows_mut(form, place) {
                            windows.push(WindowForm::default());
                        }
                    });
                }
            >
                {ctx.tr(ScheduleText::ScheduleAddWindow)}
            </button>
        }
    };
    let body = move || {
        let current = form.get()?;
        let days = Weekday::ALL
            .into_iter()
            .enumerate()
            .map(|(day, weekday)| {
                let windows = current.week[day].clone();
                view! {
                    <fieldset class="schedule-day" data-testid=format!("schedule-day{day}")>
                        <legend>{ctx.tr(day_text(weekday))}</legend>
                        {window_rows(Place::Day(day), windows)}
                    </fieldset>
                }
            })
            .collect_view();
        let exceptions = current
            .exceptions
            .iter()
            .cloned()
            .enumerate()
            .map(|(index, exception)| {
                let closed = exception.windows.is_empty();
                let set = move |change: fn(&mut ExceptionForm, String), value: String| {
                    edit(&|form| {
                        if let Some(exception) = form.exceptions.get_mut(index) {
                            change(exception, value.clone());
                        }
                    });
                };
                view! {
                    <fieldset class="schedule-exception" data-testid=format!("schedule-exception{index}")>
                        <label>
                            <span>{ctx.tr(ScheduleText::ScheduleDate)}</span>
                            <input
                                data-testid=format!("exception{index}-date")
                                placeholder="YYYY-MM-DD"
                                prop:value=exception.date
                                on:change=move |ev| set(|e, v| e.date = v, event_target_value(&ev))
                            />
                        </label>
                        <label>
                            <span>{ctx.tr(ScheduleText::ScheduleNote)}</span>
                            <input
                                data-testid=format!("exception{index}-note")
                                prop:value=exception.note
                                on:change=move |ev| set(|e, v| e.note = v, event_target_value(&ev))
                            />
                        </label>
                        {closed.then(|| view! { <p class="note">{ctx.tr(ScheduleText::ScheduleClosed)}</p> })}
                        {window_rows(Place::Exception(index), exception.windows)}
                        <button
                            type="button"
                            data-testid=format!("exception{index}-remove")
                            on:click=move |_| {
                                edit(&|form| {
                                    if index < form.exceptions.len() {
                                        form.exceptions.remove(index);
                                    }
                                });
                            }
                        >
                            {ctx.tr(ScheduleText::ScheduleRemove)}
                        </button>
                    </fieldset>
                }
            })
            .collect_view();
        Some(view! {
            <label class="check">
                <input
                    type="checkbox"
                    data-testid="schedule-enabled"
                    prop:checked=current.enabled
                    on:change=move |ev| {
                        let on = event_target_checked(&ev);
                        edit(&|form| form.enabled = on);
                    }
                />
                <span>{ctx.tr(ScheduleText::ScheduleEnabled)}</span>
            </label>
            <label>
                <span>{ctx.tr(ScheduleText::ScheduleTimeZone)}</span>
                <input
                    data-testid="schedule-time-zone"
                    prop:value=current.time_zone.clone()
                    on:change=move |ev| {
                        let zone = event_target_value(&ev);
                        edit(&|form| form.time_zone.clone_from(&zone));
                    }
                />
            </label>
            {days}
            <h3>{ctx.tr(ScheduleText::ScheduleExceptions)}</h3>
            {exceptions}
            <button
                type="button"
                data-testid="schedule-add-exception"
                on:click=move |_| edit(&|form| form.exceptions.push(ExceptionForm::default()))
            >
                {ctx.tr(ScheduleText::ScheduleAddException)}
            </button>
        })
    };
    view! {
        <section class="control">
            <ControlTabs />
            <form class="card form schedule" data-testid="schedule-form" on:submit=save>
                <p class="note">{ctx.tr(ScheduleText::ScheduleIntro)}</p>
                {body}
                <button
                    type="submit"
                    class="primary"
                    data-testid="schedule-save"
                    prop:disabled=move || busy.get() || form.with(Option::is_none)
                >
                    {ctx.tr(ScheduleText::ScheduleSave)}
                </button>
                <ErrorNote text=error test_id="schedule-error" />
                <ul class="problems" data-testid="schedule-problems">
                    {move || problems.get().into_iter().map(|p| view! { <li>{p}</li> }).collect_view()}
                </ul>
                {move || {
                    (saved.get() && error.with(Option::is_none))
                        .then(|| view! { <p class="note done" data-testid="schedule-saved">{ctx.tr(ScheduleText::ScheduleSaved)}</p> })
                }}
            </form>
        </section>
    }
}
