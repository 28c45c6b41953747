//! The views. Thin: state and decisions live in plain types elsewhere; everything
//! that leaves the page goes through [`crate::context::Services`].
//!
//! - [`App`]: the real app: browser services, the WebSocket, storage, the URL;
//! - [`Shell`]: the top bar and the current page (mounted by tests with fakes);
//! - one module per page ([`installation`] is reached from Settings, [`commission`]
//!   from Control's tabs; [`qprogram`] is a part of the Files page, [`password`] of
//!   Login and Settings), [`topbar`] for the bar on every page, and [`widgets`] for
//!   the small views several pages share (labelled fields, notes, the two-press
//!   Delete, tabs, list rows).

pub mod commission;
pub mod console;
pub mod control;
pub mod create;
pub mod files;
pub mod installation;
pub mod live;
pub mod login;
pub mod password;
pub mod patch;
pub mod preview;
pub mod qprogram;
pub mod schedule;
pub mod topbar;
pub mod widgets;

use std::cell::{Cell, RefCell};
use std::rc::Rc;

use floatball_shared::api::ClientMessage;
use leptos::prelude::*;

use crate::connection::Link;
use crate::context::{Ctx, Sender, Services};
use crate::http::XhrTransport;
use crate::i18n::Lang;
use crate::lazy::LazyPage;
use crate::page::Page;
use crate::session::{Origin, Session};
use crate::socket::Socket;
use crate::store::LocalStore;

pub use topbar::{ConnectionIndicator, EstopButton, LanguageSwitch, TopBar};

/// Where the chosen language is remembered in the browser.
const LANG_KEY: &str = "floatball.lang";
/// Where the login is remembered (see [`crate::session`] for why `localStorage`).
const SESSION_KEY: &str = "floatball.session";
fn storage() -> Option<web_sys::Storage> {
    window().local_storage().ok().flatten()
}

/// The value kept in the browser's `localStorage` under `key`.
pub(crate) fn stored(key: &str) -> Option<String> {
    storage()?.get_item(key).ok().flatten()
}

/// Keeps `value` in the browser's `localStorage` under `key` (`None`: forgets it).
pub(crate) fn store(key: &str, value: Option<&str>) {
    if let Some(storage) = storage() {
        // A full or disabled storage only costs the memory across reloads.
        let _ = match value {
            Some(value) => storage.set_item(key, value),
            None => storage.remove_item(key),
        };
    }
}

/// The WebSocket of the current login, if any: what the app's [`Sender`] writes to;
/// and whether the app wants the gateways' feedback frames (told to every socket).
#[derive(Debug, Default, Clone)]
struct SocketSlot(Rc<RefCell<Option<Socket>>>, Rc<Cell<bool>>);

impl Sender for SocketSlot {
    fn send(&self, message: &ClientMessage) -> bool {
        self.0
            .borrow()
            .as_ref()
            .is_some_and(|socket| socket.send(message))
    }

    fn relay_feedback(&self, on: bool) {
        if self.1.replace(on) != on {
            self.send(&ClientMessage::Feedback { relay: on });
        }
    }
}

impl SocketSlot {
    /// Closes the current socket and, for a login, opens one with its token.
    fn reconnect(&self, ctx: Ctx, session: Option<(String, String)>) {
        if let Some(socket) = self.0.borrow_mut().take() {
            socket.close();
        }
        ctx.set_status(None);
        if let Some((address, token)) = session {
            let url = ctx.origin().ws_url(&address, &token);
            let socket = Socket::connect(url, ctx.link, Rc::clone(&self.1), move |message| {
                ctx.receive(message);
            });
            *self.0.borrow_mut() = Some(socket);
        }
    }

    fn wake(&self) {
        if let Some(socket) = self.0.borrow().as_ref() {
            socket.wake();
        }
    }
}

/// The whole app, with the browser's services.
#[component]
pub fn App() -> impl IntoView {
    let location = window().location();
    let origin = Origin {
        protocol: location.protocol().unwrap_or_else(|_| "http:".into()),
        host: location.host().unwrap_or_default(),
    };
    let lang = Lang::at_start(
        stored(LANG_KEY).as_deref(),
        &crate::context::browser_languages(),
    );
    let slot = SocketSlot::default();
    let services = Services {
        transport: Rc::new(XhrTransport),
        sender: Rc::new(slot.clone()),
        store: LocalStore::default(),
    };
    let ctx = Ctx::new(services, origin, lang);
    ctx.session
        .set(stored(SESSION_KEY).and_then(|text| crate::json::from_str::<Session>(&text).ok()));
    ctx.page
        .set(Page::from_hash(&location.hash().unwrap_or_default()));
    provide_context(ctx);

    // The language is stored only once the operator chose one, so that a browser in
    // another language starts in its own; `<html lang>` follows every switch.
    let started_in = lang;
    Effect::new(move |_| {
        let lang = ctx.lang.get();
        crate::context::set_document_lang(lang);
        if lang != started_in || stored(LANG_KEY).is_some() {
            store(LANG_KEY, Some(lang.code()));
        }
    });
    Effect::new(move |_| {
        let text = ctx
            .session
            .with(|session| session.as_ref().and_then(|s| serde_json::to_string(s).ok()));
        store(SESSION_KEY, text.as_deref());
    });

    // The page in the URL, so a reload and the back button keep it.
    Effect::new(move |_| {
        let hash = ctx.page.get().hash();
        let location = window().location();
        let current = location.hash().unwrap_or_default();
        // The first page replaces the bare URL, so that Back does not bounce off it;
        // later pages are history entries of their own.
        let _ = if current.is_empty() {
            location.replace(&hash)
        } else if current != hash {
            location.set_hash(&hash)
        } else {
            Ok(())
        };
    });
    let hash_listener = window_event_listener(leptos::ev::hashchange, move |_| {
        let hash = window().location().hash().unwrap_or_default();
        ctx.page.set(Page::from_hash(&hash));
    });

    // One socket per login: opened with its token, closed on logout.
    let key = Memo::new(move |_| {
        ctx.session.with(|session| {
            session
                .as_ref()
                .map(|s| (s.address.clone(), s.token.clone()))
        })
    });
    {
        let slot = slot.clone();
        Effect::new(move |_| slot.reconnect(ctx, key.get()));
    }

    // On every (re)connection, fetch the state again; when the socket drops, check
    // whether the login is still valid (a refused socket looks like any drop).
    Effect::new(move |previous: Option<Link>| {
        let link = ctx.link.get();
        match (previous, link) {
            (Some(Link::Connected), Link::Connected) => {}
            (_, Link::Connected) => {
                ctx.refresh();
                ctx.load_installation();
            }
            (Some(Link::Connecting | Link::Connected), Link::Disconnected) => {
                if let Some(client) = ctx.client() {
                    leptos::task::spawn_local(async move {
                        if let Err(crate::client::Failure::Unauthorized) = client.playlist().await {
                            ctx.expire(crate::i18n::Text::SessionExpired);
                        }
                    });
                }
            }
            _ => {}
        }
        link
    });

    // A phone waking up, a tab coming back, the network returning: check the socket
    // now (`visibilitychange` bubbles from the document to the window).
    let wake_on = |event: &str| {
        let slot = slot.clone();
        window_event_listener_untyped(event, move |_| {
            if document().visibility_state() == web_sys::VisibilityState::Visible {
                slot.wake();
            }
        })
    };
    let listeners = [
        hash_listener,
        wake_on("visibilitychange"),
        wake_on("pageshow"),
        wake_on("online"),
    ];
    on_cleanup(move || listeners.into_iter().for_each(|listener| listener.remove()));

    ctx.load_local_files();
    view! { <Shell /> }
}

/// The top bar and the page asked for (Login instead of a page that needs a login).
#[component]
pub fn Shell() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let shown = Memo::new(move |_| ctx.page.get().resolve(ctx.logged_in()));
    // A refusal belongs to the page where the request was made; a new page starts
    // at its top (not under the sticky bar, scrolled as far as the last page was).
    Effect::new(move |previous: Option<Page>| {
        let page = shown.get();
        ctx.bridge_error.set(None);
        if previous.is_some_and(|previous| previous != page) {
            window().scroll_to_with_x_and_y(0.0, 0.0);
        }
        page
    });
    view! {
        <TopBar />
        <main class="page" data-testid=move || format!("page-{}", shown.get().key())>
            {move || match shown.get() {
                Page::Login => view! { <login::LoginPage /> }.into_any(),
                Page::Files => view! { <files::FilesPage /> }.into_any(),
                Page::Create => view! { <LazyPage load=crate::lazy::load_create /> }.into_any(),
                Page::Preview => view! { <preview::PreviewScreen /> }.into_any(),
                Page::Control => view! { <control::ControlPage /> }.into_any(),
                Page::Settings => view! { <LazyPage load=crate::lazy::load_settings /> }.into_any(),
                Page::Console => view! { <console::ConsolePage /> }.into_any(),
                Page::Installation => {
                    view! { <LazyPage load=crate::lazy::load_installation /> }.into_any()
                }
                Page::Commission => {
                    view! { <LazyPage load=crate::lazy::load_commission /> }.into_any()
                }
                Page::Schedule => {
                    view! { <LazyPage load=crate::lazy::load_schedule /> }.into_any()
                }
                Page::Patch => view! { <LazyPage load=crate::lazy::load_patch /> }.into_any(),
            }}
        </main>
        <widgets::ToastArea />
    }
}
