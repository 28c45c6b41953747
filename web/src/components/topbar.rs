//! The bar on every page: the E-stop (when connected), the language switch, the
//! connection button (tap → Login), the page tabs, and the compact status line
//! ([`StatusBar`]: state, show, time and progress, from the same status the Control
//! page shows) — so a phone always sees what the matrix does.

use floatball_shared::api::{ClientMessage, PlayerState};
use leptos::prelude::*;

use crate::context::tr_in;

use crate::components::widgets::TabButton;
use crate::connection::Link;
use crate::context::{Ctx, EstopAck};
use crate::i18n::{Lang, Text};
use crate::page::Page;
use crate::status::{progress, shows_progress, state_key, time_text};

/// How long the E-stop's acknowledgement stays after a press, ms.
const ESTOP_ACK_MS: u64 = 8_000;

/// The top bar.
#[component]
pub fn TopBar() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let tab = move |page: Page| {
        let text = page_name(page);
        let active = move || {
            let current = ctx.page.get();
            current == page || (page == Page::Control && current == Page::Settings)
        };
        view! {
            <TabButton
                text
                test_id=format!("nav-{}", page.key())
                active=Signal::derive(active)
                on_click=Callback::new(move |()| ctx.page.set(page))
            />
        }
    };
    view! {
        <header class="topbar" data-page=move || ctx.page.get().key()>
            <div class="bar">
                {move || {
                    if ctx.connected() {
                        view! { <EstopButton /> }.into_any()
                    } else {
                        view! { <span class="brand">"Floatball"</span> }.into_any()
                    }
                }}
                <StatusBar />
                <span class="spacer"></span>
                <LanguageSwitch lang=ctx.lang />
                <ConnectionIndicator link=ctx.link lang=ctx.lang />
            </div>
            <nav class="tabs">{Page::NAV.map(tab).into_iter().collect_view()}</nav>
        </header>
    }
}

/// One line in the top bar while the bridge reports a status: the state, the show
/// and its time, and a thin progress bar when the state has one. A tap opens
/// Control. (On wide screens the Control page's own status card replaces it there.)
#[component]
pub fn StatusBar() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    // The state and show: the button is rebuilt only when they change; the time
    // and the meter follow every status by themselves.
    let head = Memo::new(move |_| {
        ctx.status.with(|status| {
            status
                .as_ref()
                .filter(|_| ctx.connected())
                .map(|status| (status.state, status.show.clone()))
        })
    });
    let time = move || {
        ctx.status
            .with(|status| status.as_ref().map(time_text).unwrap_or_default())
    };
    let width = move || {
        let progress = ctx
            .status
            .with(|status| status.as_ref().map_or(0.0, progress));
        format!("width: {:.1}%", progress * 100.0)
    };
    move || {
        let (state, show) = head.get()?;
        let lang = ctx.lang.get();
        let key = state_key(state);
        let meter = shows_progress(state).then(|| {
            view! {
                <span class="meter" data-testid="statusbar-progress">
                    <span class="fill" style=width></span>
                </span>
            }
        });
        Some(view! {
            <button
                class="statusbar"
                data-testid="statusbar"
                data-state=key
                title=lang.t(Text::StatusBarHint)
                on:click=move |_| ctx.page.set(Page::Control)
            >
                <span class=format!("state {key}") data-testid="statusbar-state" data-state=key>
                    {lang.player_state(state)}
                </span>
                <span class="show" data-testid="statusbar-show">
                    {show.unwrap_or_default()}
                </span>
                <span class="time mono" data-testid="statusbar-time">
                    {time}
                </span>
                {meter}
            </button>
        })
    }
}

/// A page's name in the navigation.
pub fn page_name(page: Page) -> Text {
    match page {
        Page::Login => Text::LoginTitle,
        Page::Files => Text::NavFiles,
        Page::Create => Text::NavCreate,
        Page::Preview => Text::NavPreview,
        Page::Control => Text::NavControl,
        Page::Settings => Text::NavSettings,
        Page::Console => Text::NavConsole,
        Page::Installation => Text::InstallationTitle,
        Page::Commission => Text::NavCommission,
        Page::Schedule => Text::NavSchedule,
        Page::Patch => Text::NavPatch,
    }
}

/// The connection indicator: 已连接 / 未连接 (Connected / Not connected). Tapping it
/// opens Login (when the app's context is there).
#[component]
pub fn ConnectionIndicator(
    /// The state of the link to the bridge.
    #[prop(into)]
    link: Signal<Link>,
    /// The language to show it in.
    #[prop(into)]
    lang: Signal<Lang>,
) -> impl IntoView {
    let ctx = use_context::<Ctx>();
    let connected = move || link.get() == Link::Connected;
    let label = move || {
        let text = if connected() {
            Text::Connected
        } else {
            Text::NotConnected
        };
        lang.get().t(text)
    };
    let state = move || match link.get() {
        Link::Connected => "connected",
        Link::Connecting => "connecting",
        Link::Disconnected => "disconnected",
    };
    view! {
        <button
            class="connection"
            class:up=connected
            data-testid="connection"
            data-state=state
            on:click=move |_| {
                if let Some(ctx) = ctx {
                    ctx.page.set(Page::Login);
                }
            }
        >
            {label}
        </button>
    }
}

/// The language switch: shows the other language's name and switches to it.
#[component]
pub fn LanguageSwitch(
    /// The current language; the switch changes it.
    lang: RwSignal<Lang>,
) -> impl IntoView {
    view! {
        <button
            class="lang"
            data-testid="lang"
            on:click=move |_| lang.update(|lang| *lang = lang.other())
        >
            {tr_in(lang.into(), Text::SwitchLanguage)}
        </button>
    }
}

/// The E-stop: one press sends one `estop`, at once, without a confirmation; every
/// E-stop button then says it was sent, and "stopped" once the bridge reports it
/// (until the matrix leaves `stopped`: [`Ctx::set_status`]).
#[component]
pub fn EstopButton() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let ack = ctx.estop_ack;
    let press = move |_| {
        let sent = ctx.send(&ClientMessage::Estop);
        // The press's number: a later press's acknowledgement is not cleared by an
        // earlier press's timer.
        let press = ack.get_untracked().map_or(1, |(n, _)| n.wrapping_add(1));
        let outcome = if sent {
            EstopAck::Sent
        } else {
            EstopAck::NotSent
        };
        ack.set(Some((press, outcome)));
        set_timeout(
            move || {
                if ack.get_untracked().map(|(n, _)| n) == Some(press) {
                    ack.set(None);
                }
            },
            std::time::Duration::from_millis(ESTOP_ACK_MS),
        );
    };
    let stopped = move || {
        ctx.status
            .with(|status| status.as_ref().map(|s| s.state) == Some(PlayerState::Stopped))
    };
    let ack_text = move || {
        let text = match ack.get()?.1 {
            EstopAck::NotSent => Text::EstopNotSent,
            EstopAck::Sent if stopped() => Text::EstopStopped,
            EstopAck::Sent => Text::EstopSent,
        };
        Some(ctx.t(text))
    };
    let ack_state = move || match ack.get().map(|(_, ack)| ack) {
        None => "ready",
        Some(EstopAck::NotSent) => "not-sent",
        Some(EstopAck::Sent) if stopped() => "stopped",
        Some(EstopAck::Sent) => "sent",
    };
    view! {
        <button
            class="estop"
            class:acked=move || ack.get().is_some()
            data-testid="estop"
            data-ack=ack_state
            on:click=press
        >
            <span class="estop-label">{ctx.tr(Text::Estop)}</span>
            <span class="estop-ack" data-testid="estop-ack">
                {ack_text}
            </span>
        </button>
    }
}
