//! The Console page (for engineers): instruction lines checked by the parser before
//! they are sent, and the feedback frames decoded as they arrive. On an MBOX
//! installation: box commands checked by the MBOX parser, their help, and the boxes'
//! replies to reads; on MOONS' drives: SCL lines checked by the SCL parser, their
//! help, and the drives' answers. Positions in counts are also shown in mm once the
//! installation's calibration is known (`Ctx::load_installation`). The family and
//! the gateway choice come from the installation (every gateway), else from the
//! gateways the status details.

use floatball_shared::api::ClientMessage;
use leptos::prelude::*;

use crate::components::widgets::{BridgeError, Field};
use crate::console::{Check, Family, FeedbackLog, mbox_route};
use crate::context::Ctx;
use crate::i18n::Text;

/// How many sent lines the page lists.
const SENT_LINES: usize = 50;

/// The Console page.
#[component]
pub fn ConsolePage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    // The gateways' answers are relayed only while the console is open.
    ctx.relay_feedback(true);
    on_cleanup(move || ctx.relay_feedback(false));
    // The parsers are a chunk of their own, fetched as the page opens.
    ctx.load_console_parsers();
    let text = RwSignal::new(String::new());
    let gateway = RwSignal::new(None::<usize>);
    let sent = RwSignal::new(Vec::<String>::new());
    // The installation knows every gateway; a status of many details only those with
    // a problem.
    let family = Memo::new(move |_| {
        ctx.installation.with(|installation| {
            ctx.status
                .with(|status| Family::of_either(installation.as_ref(), status.as_ref()))
        })
    });
    let checked = Memo::new(move |_| {
        let family = family.get();
        let selected = if family == Family::Mbox {
            ctx.installation.with(|installation| {
                ctx.status.with(|status| {
                    mbox_route(status.as_ref(), installation.as_ref(), gateway.get())
                })
            })
        } else {
            floatball_shared::mbox::Route::BROADCAST
        };
        let parsers = ctx.console_parsers.get();
        text.with(|text| parsers.check(family, text, selected))
    });
    let ready = move || matches!(checked.get(), Check::Ready { .. }) && ctx.connected();
    let send = move |_| {
        let Check::Ready { lines, .. } = checked.get_untracked() else {
            return;
        };
        ctx.bridge_error.set(None);
        let gateway = gateway.get_untracked();
        for line in lines {
            if ctx.send(&ClientMessage::Raw {
                line: line.clone(),
                gateway,
            }) {
                sent.update(|sent| {
                    sent.insert(0, line);
                    sent.truncate(SENT_LINES);
                });
            }
        }
    };
    let verdict = move || {
        match checked.get() {
        Check::Empty => view! {
            <p class="muted" data-testid="console-check" data-state="empty">
                {move || {
                    ctx.t(
                        match family.get() {
                            Family::Mbox => Text::MboxConsoleHint,
                            Family::Scl => Text::SclConsoleHint,
                            Family::Uim2503 => Text::ConsoleHint,
                        },
                    )
                }}
            </p>
        }
        .into_any(),
        Check::Ready { instructions, .. } => view! {
            <p class="note done" data-testid="console-check" data-state="ok">
                {move || ctx.lang.get().ready_to_send(instructions)}
            </p>
        }
        .into_any(),
        Check::Invalid(error) => view! {
            <p class="note error" data-testid="console-check" data-state="error">
                {move || error.text(ctx.lang.get())}
            </p>
        }
        .into_any(),
        Check::Loading => view! {
            <p class="muted" data-testid="console-check" data-state="loading" aria-busy="true">
                {ctx.tr(Text::CheckerLoading)}
            </p>
        }
        .into_any(),
        Check::Unavailable => view! {
            <div class="note error" data-testid="console-check" data-state="unavailable" role="alert">
                <p>{ctx.tr(Text::CheckerFailed)}</p>
                <button data-testid="console-retry" on:click=move |_| ctx.load_console_parsers()>
                    {ctx.tr(Text::Retry)}
                </button>
                <button data-testid="console-reload" on:click=move |_| crate::lazy::reload_app()>
                    {ctx.tr(Text::ReloadApp)}
                </button>
            </div>
        }
        .into_any(),
    }
    };
    // Every gateway by its index and port: the installation's, else those the status
    // details. A Memo, so that a status that changes no port leaves the options alone.
    let ports = Memo::new(move |_| {
        ctx.installation.with(|installation| match installation {
            Some(installation) if !installation.gateways.is_empty() => installation
                .gateways
                .iter()
                .enumerate()
                .map(|(index, gateway)| (index, gateway.port.clone()))
                .collect::<Vec<_>>(),
            _ => ctx.status.with(|status| {
                status
                    .iter()
                    .flat_map(|status| &status.gateways)
                    .map(|gateway| (gateway.index, gateway.port.clone()))
                    .collect()
            }),
        })
    });
    let gateways = move || {
        ports
            .get()
            .into_iter()
            .map(|(index, port)| {
                view! { <option value=index.to_string()>{format!("{index}: {port}")}</option> }
            })
            .collect_view()
    };
    view! {
        <section class="console">
            <Field label=Text::Instructions class="stack">
                <textarea
                    rows="4"
                    spellcheck="false"
                    autocapitalize="characters"
                    data-testid="console-input"
                    prop:value=text
                    on:input=move |ev| text.set(event_target_value(&ev))
                ></textarea>
            </Field>
            {verdict}
            {move || {
                let (title, help) = match family.get() {
                    Family::Mbox => (Text::MboxHelpTitle, Text::MboxHelp),
                    Family::Scl => (Text::SclHelpTitle, Text::SclHelp),
                    Family::Uim2503 => return None,
                };
                Some(
                    view! {
                        <details class="help" data-testid="console-help">
                            <summary>{ctx.tr(title)}</summary>
                            <pre class="mono">{ctx.tr(help)}</pre>
                        </details>
                    },
                )
            }}
            <div class="toolbar">
                <Field label=Text::Gateway class="inline">
                    <select
                        data-testid="console-gateway"
                        on:change=move |ev| gateway.set(event_target_value(&ev).parse().ok())
                    >
                        <option value="">{ctx.tr(Text::AllGateways)}</option>
                        {gateways}
                    </select>
                </Field>
                <button
                    class="primary"
                    data-testid="console-send"
                    disabled=move || !ready()
                    on:click=send
                >
                    {ctx.tr(Text::Send)}
                </button>
            </div>
            <BridgeError />
            <Show when=move || sent.with(|sent| !sent.is_empty())>
                <h3>{ctx.tr(Text::SentLines)}</h3>
                <ul class="mono sent" data-testid="sent-lines">
                    {move || sent.get().into_iter().map(|line| view! { <li>{line}</li> }).collect_view()}
                </ul>
            </Show>
            <div class="heading-row">
                <h3>{move || {
                    ctx.t(
                        match family.get() {
                            Family::Mbox => Text::MboxReplies,
                            Family::Scl => Text::SclAnswers,
                            Family::Uim2503 => Text::Feedback,
                        },
                    )
                }}</h3>
                <button data-testid="feedback-clear" on:click=move |_| ctx.feedback.update(|log| log.clear())>
                    {ctx.tr(Text::Clear)}
                </button>
            </div>
            <ul class="mono feedback" data-testid="feedback-list">
                {move || {
                    ctx.feedback.with(FeedbackLog::is_empty).then(|| {
                        let empty = move || {
                            ctx.t(
                                match family.get() {
                                    Family::Mbox => Text::NoMboxReplies,
                                    Family::Scl => Text::NoSclAnswers,
                                    Family::Uim2503 => Text::NoFeedback,
                                },
                            )
                        };
                        view! { <li class="muted">{empty}</li> }
                    })
                }}
                // Keyed by the line's id: a new frame adds one line at the top and
                // drops the oldest, instead of rewriting all of them (a gateway sends
                // many frames a second; the page kept a phone's core busy).
                <For
                    each=move || ctx.feedback.with(|log| log.lines().cloned().collect::<Vec<_>>())
                    key=|line| line.id
                    children=move |line| {
                        let (source, hex) = (line.source(), line.hex.clone());
                        view! {
                            <li data-testid="feedback-line">
                                <span class="where">{source}</span>
                                <span class="what">{move || line.text_in(ctx.lang.get())}</span>
                                <span class="hex muted">{hex}</span>
                            </li>
                        }
                    }
                />
            </ul>
        </section>
    }
}
