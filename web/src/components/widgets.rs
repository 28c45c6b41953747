//! Small views used on several pages, so that each page states only what is its own:
//!
//! - [`Field`] (a label over any control) and [`TextField`] (a labelled text input);
//! - [`ErrorNote`]: an error under a form, when there is one; [`BridgeError`]: the
//!   latest request the bridge refused;
//! - [`ActionButton`]: a toolbar button; [`ConfirmButton`]: Delete that asks for a
//!   second press;
//! - [`TabButton`]: a tab of the top bar or of a page;
//! - [`RowButton`]: a pickable row of a list (a file, a show); [`EmptyItem`]: what an
//!   empty list says;
//! - [`ProblemList`]: a list of problems, the first [`SHOWN_PROBLEMS`] and "show
//!   all"; [`ToastArea`]: the success toast of [`Ctx::notify`].
//!
//! They need the app's [`Ctx`] for the language.

use leptos::prelude::*;

use crate::context::Ctx;
use crate::files::{SHOWN_PROBLEMS, clip_message};
use crate::i18n::{Text, Words};

/// A label (in the current language) over `children`, the control it names.
#[component]
pub fn Field<W: Words>(
    /// What the control is.
    label: W,
    /// The label's class, if any.
    #[prop(optional)]
    class: Option<&'static str>,
    children: Children,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! {
        <label class=class>
            <span>{ctx.tr(label)}</span>
            {children()}
        </label>
    }
}

/// A labelled text input bound to `value`.
#[component]
pub fn TextField<W: Words>(
    /// What the field is.
    label: W,
    /// What is typed; the field shows it and writes every edit to it.
    value: RwSignal<String>,
    /// The input's `data-testid`.
    test_id: &'static str,
    /// The input's `type`.
    #[prop(default = "text")]
    kind: &'static str,
    /// The keyboard a phone offers (`decimal`, `numeric`, `url`).
    #[prop(optional)]
    inputmode: Option<&'static str>,
    /// What the browser may fill in.
    #[prop(optional)]
    autocomplete: Option<&'static str>,
    /// Told of every edit, after `value` is set.
    #[prop(optional)]
    on_edit: Option<Callback<()>>,
) -> impl IntoView {
    view! {
        <Field label>
            <input
                type=kind
                inputmode=inputmode
                autocomplete=autocomplete
                data-testid=test_id
                prop:value=value
                on:input=move |ev| {
                    if let Some(on_edit) = on_edit {
                        on_edit.run(());
                    }
                    value.set(event_target_value(&ev));
                }
            />
        </Field>
    }
}

/// The error under a form while `text` holds one; `alert` makes screen readers say it
/// at once.
#[component]
pub fn ErrorNote(
    /// The error, if any.
    #[prop(into)]
    text: Signal<Option<String>>,
    /// The note's `data-testid`.
    test_id: &'static str,
    /// Whether the note is an ARIA alert.
    #[prop(optional)]
    alert: bool,
) -> impl IntoView {
    let role = alert.then_some("alert");
    move || {
        text.get().map(|text| {
            view! {
                <p class="note error" data-testid=test_id role=role>
                    {text}
                </p>
            }
        })
    }
}

/// What the bridge said about the latest request it refused over the WebSocket.
#[component]
pub fn BridgeError() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    move || {
        ctx.bridge_error.get().map(|refusal| {
            view! {
                <p class="note error" data-testid="bridge-error">
                    {ctx.tr(Text::BridgeSays)} " " {move || refusal.text(ctx.lang.get())}
                </p>
            }
        })
    }
}

/// A button that says what it does (in the current language).
#[component]
pub fn ActionButton(
    /// What it does.
    text: Text,
    /// The button's `data-testid`.
    test_id: &'static str,
    /// Whether it cannot be pressed now.
    #[prop(into)]
    disabled: Signal<bool>,
    /// The action.
    on_click: Callback<()>,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! {
        <button data-testid=test_id disabled=disabled on:click=move |_| on_click.run(())>
            {ctx.tr(text)}
        </button>
    }
}

/// Delete, pressed twice: the first press arms it (it then says "confirm" and looks
/// dangerous), the second runs `on_confirm`. The page disarms it (`armed`) when the
/// choice changes.
#[component]
pub fn ConfirmButton(
    /// The button's `data-testid`.
    test_id: &'static str,
    /// Whether the next press deletes.
    armed: RwSignal<bool>,
    /// Whether the button cannot be pressed.
    #[prop(into)]
    disabled: Signal<bool>,
    /// The deletion.
    on_confirm: Callback<()>,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! {
        <button
            data-testid=test_id
            class:danger=armed
            disabled=disabled
            on:click=move |_| {
                if armed.get_untracked() {
                    armed.set(false);
                    on_confirm.run(());
                } else {
                    armed.set(true);
                }
            }
        >
            {move || ctx.t(if armed.get() { Text::ConfirmDelete } else { Text::Delete })}
        </button>
    }
}

/// A tab: marked while `active`.
#[component]
pub fn TabButton(
    /// The tab's name.
    text: Text,
    /// The button's `data-testid`.
    #[prop(into)]
    test_id: String,
    /// Whether its page or list is the one shown.
    #[prop(into)]
    active: Signal<bool>,
    /// What choosing it does.
    on_click: Callback<()>,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! {
        <button
            class="tab"
            class:active=active
            data-testid=test_id
            on:click=move |_| on_click.run(())
        >
            {ctx.tr(text)}
        </button>
    }
}

/// One pickable row of a list: the item's name, and its facts if given.
#[component]
pub fn RowButton(
    /// The item's name (also its `data-name`).
    name: String,
    /// The button's `data-testid`.
    test_id: &'static str,
    /// Whether it is the item chosen.
    #[prop(optional)]
    selected: bool,
    /// Whether it cannot be picked now.
    #[prop(optional)]
    disabled: bool,
    /// A line of facts after the name (size, length).
    #[prop(optional)]
    facts: Option<String>,
    /// What picking it does.
    on_click: Callback<()>,
) -> impl IntoView {
    let label = match facts {
        Some(facts) => view! {
            <span class="name">{name.clone()}</span>
            <span class="facts muted">{facts}</span>
        }
        .into_any(),
        None => name.clone().into_any(),
    };
    view! {
        <li>
            <button
                class="row"
                class:selected=selected
                aria-pressed=selected.to_string()
                disabled=disabled
                data-testid=test_id
                data-name=name
                on:click=move |_| on_click.run(())
            >
                {label}
            </button>
        </li>
    }
}

/// The one item of an empty list, saying so.
#[component]
pub fn EmptyItem(
    /// What is missing.
    text: Text,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! { <li class="empty muted">{ctx.tr(text)}</li> }
}

/// Problems (a refused upload's, a file that cannot be read): the first
/// [`SHOWN_PROBLEMS`], how many more there are and a "show all" toggle; each one cut
/// to a readable length ([`clip_message`]).
#[component]
pub fn ProblemList(
    /// Every problem.
    problems: Vec<String>,
    /// The list's `data-testid`.
    test_id: &'static str,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let total = problems.len();
    let all_shown = RwSignal::new(false);
    let problems = StoredValue::new(problems);
    // How many are listed now; the rest are hidden behind "show all".
    let shown = move || {
        if all_shown.get() {
            total
        } else {
            total.min(SHOWN_PROBLEMS)
        }
    };
    let hidden = move || total - shown();
    let items = move || {
        let shown = shown();
        problems.with_value(|problems| {
            problems[..shown]
                .iter()
                .map(|problem| view! { <li>{clip_message(problem)}</li> })
                .collect_view()
        })
    };
    view! {
        <ul class="problems" data-testid=test_id data-total=total>
            {items}
        </ul>
        {(total > SHOWN_PROBLEMS)
            .then(|| {
                view! {
                    <p class="more-problems">
                        <span data-testid="problems-more">
                            {move || {
                                let hidden = hidden();
                                (hidden > 0).then(|| ctx.lang.get().more_problems(hidden, total))
                            }}
                        </span>
                        " "
                        <button
                            class="link-button"
                            data-testid="problems-toggle"
                            aria-expanded=move || all_shown.get().to_string()
                            on:click=move |_| all_shown.update(|all| *all = !*all)
                        >
                            {move || ctx.t(if all_shown.get() { Text::ShowFewer } else { Text::ShowAll })}
                        </button>
                    </p>
                }
            })}
    }
}

/// The success toast of [`Ctx::notify`], while there is one: polite for screen
/// readers, gone after a few seconds.
#[component]
pub fn ToastArea() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    view! {
        <div
            class="toasts"
            role="status"
            aria-live="polite"
            aria-label=ctx.tr(Text::Notifications)
        >
            {move || {
                ctx.toast
                    .get()
                    .map(|(_, text)| view! { <p class="toast" data-testid="toast">{text}</p> })
            }}
        </div>
    }
}
