//! The app's views. Thin: state and decisions live in plain types elsewhere.

use leptos::prelude::*;

use crate::connection::Link;
use crate::i18n::{Lang, Text};
use crate::socket::{self, Socket};

/// Where the chosen language is remembered in the browser.
const LANG_KEY: &str = "floatball.lang";

fn stored_lang() -> Lang {
    window()
        .local_storage()
        .ok()
        .flatten()
        .and_then(|storage| storage.get_item(LANG_KEY).ok().flatten())
        .map(|code| Lang::from_code(&code))
        .unwrap_or_default()
}

fn store_lang(lang: Lang) {
    if let Some(storage) = window().local_storage().ok().flatten() {
        let _ = storage.set_item(LANG_KEY, lang.code());
    }
}

/// The whole app.
#[component]
pub fn App() -> impl IntoView {
    let lang = RwSignal::new(stored_lang());
    let link = RwSignal::new(Link::Disconnected);
    if let Some(url) = socket::page_ws_url() {
        let socket = Socket::connect(url, link, |_message| {});
        provide_context(StoredValue::new_local(socket));
    }
    Effect::new(move |_| store_lang(lang.get()));
    view! {
        <header class="topbar">
            <span class="brand">"Floatball"</span>
            <span class="spacer"></span>
            <LanguageSwitch lang=lang />
            <ConnectionIndicator link=link lang=lang />
        </header>
        <main class="page"></main>
    }
}

/// The top bar's connection indicator: 已连接 / 未连接 (Connected / Not connected).
#[component]
pub fn ConnectionIndicator(
    /// The state of the link to the bridge.
    #[prop(into)]
    link: Signal<Link>,
    /// The language to show it in.
    #[prop(into)]
    lang: Signal<Lang>,
) -> impl IntoView {
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
            {move || lang.get().t(Text::SwitchLanguage)}
        </button>
    }
}
