//! The WebSocket to the bridge: opens it, reconnects with backoff when it closes,
//! pings while connected and drops a connection that has gone silent, so the top bar
//! never shows a stale "Connected". Decisions come from [`crate::connection`].
//!
//! The URL carries the login's token (`/ws?token=…`); the app opens a socket only
//! while it holds a login.

use std::cell::{Cell, RefCell};
use std::rc::{Rc, Weak};
use std::time::Duration;

use floatball_shared::api::{ClientMessage, ServerMessage};
use leptos::prelude::*;
use wasm_bindgen::JsCast;
use wasm_bindgen::closure::Closure;
use web_sys::{Event, MessageEvent, WebSocket};

use crate::connection::{Connection, Link, PING_INTERVAL_MS, SILENCE_TIMEOUT_MS};
use crate::wire::{Decoded, decode};

/// A self-reconnecting WebSocket to the bridge. Dropping every clone does not close
/// the socket; call [`Socket::close`] for that.
#[derive(Clone)]
pub struct Socket {
    inner: Rc<RefCell<Inner>>,
}

impl std::fmt::Debug for Socket {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Socket")
            .field("url", &self.inner.borrow().url)
            .finish_non_exhaustive()
    }
}

type Handler<T> = Closure<dyn FnMut(T)>;

struct Inner {
    url: String,
    /// Whether the app wants the gateways' feedback frames; said on every connect.
    relay_feedback: Rc<Cell<bool>>,
    connection: Connection,
    link: RwSignal<Link>,
    on_message: Rc<dyn Fn(ServerMessage)>,
    /// Bumped for every new socket so events of an old one are ignored.
    generation: u64,
    ws: Option<WebSocket>,
    handlers: Vec<Handler<Event>>,
    on_ws_message: Option<Handler<MessageEvent>>,
    last_heard_ms: f64,
    closed: bool,
    /// `schedule` and `timecode` frames received, and the last handed on after its
    /// reading in the show-control chunk ([`Decoded::ShowControl`]): an older one
    /// read later is dropped.
    show_control_sent: u64,
    show_control_handed: u64,
    /// The same for `live_positions` frames ([`Decoded::LivePositions`]).
    live_sent: u64,
    live_handed: u64,
}

impl Socket {
    /// Opens a socket to `url`, reflecting its state in `link` and handing every
    /// message from the bridge to `on_message`. Each time it connects it tells the
    /// bridge whether to relay the gateways' feedback frames (`relay_feedback` then).
    pub fn connect(
        url: String,
        link: RwSignal<Link>,
        relay_feedback: Rc<Cell<bool>>,
        on_message: impl Fn(ServerMessage) + 'static,
    ) -> Self {
        let inner = Rc::new(RefCell::new(Inner {
            url,
            relay_feedback,
            connection: Connection::new(),
            link,
            on_message: Rc::new(on_message),
            generation: 0,
            ws: None,
            handlers: Vec::new(),
            on_ws_message: None,
            last_heard_ms: 0.0,
            closed: false,
            show_control_sent: 0,
            show_control_handed: 0,
            live_sent: 0,
            live_handed: 0,
        }));
        open(&inner);
        let weak = Rc::downgrade(&inner);
        // The watchdog: ping while connected, give up on a silent connection.
        let interval = set_interval_with_handle(
            move || watchdog(&weak),
            Duration::from_millis(u64::from(PING_INTERVAL_MS)),
        );
        if let Err(err) = interval {
            leptos::logging::warn!(
                "cannot start the connection watchdog: {}",
                crate::http::describe_js_error(err)
            );
        }
        Self { inner }
    }

    /// Sends `message` if connected; returns whether it was handed to the socket.
    pub fn send(&self, message: &ClientMessage) -> bool {
        let inner = self.inner.borrow();
        if inner.connection.link() != Link::Connected {
            return false;
        }
        let (Some(ws), Ok(text)) = (&inner.ws, serde_json::to_string(message)) else {
            return false;
        };
        ws.send_with_str(&text).is_ok()
    }

    /// Checks the connection at once, for when the page wakes up (the phone was
    /// asleep, the tab hidden): a connection not heard from within the ping interval
    /// is dropped now, and reopened after the first backoff step, instead of showing
    /// "Connected" until the next watchdog round. (A socket already down retries
    /// within [`crate::connection::MAX_RETRY_MS`] anyway.)
    pub fn wake(&self) {
        let inner = self.inner.borrow();
        let stale = inner.connection.link() == Link::Connected
            && now_ms() - inner.last_heard_ms > f64::from(PING_INTERVAL_MS);
        let generation = inner.generation;
        drop(inner);
        if stale {
            lost(&self.inner, generation);
        }
    }

    /// Closes the socket for good (no reconnect).
    pub fn close(&self) {
        let mut inner = self.inner.borrow_mut();
        inner.closed = true;
        inner.generation += 1;
        inner.detach();
        let link = inner.link;
        drop(inner);
        link.set(Link::Disconnected);
    }
}

impl Inner {
    /// Forgets the current socket: handlers off first (so no callback reaches a
    /// dropped closure), then close it.
    fn detach(&mut self) {
        if let Some(ws) = self.ws.take() {
            ws.set_onopen(None);
            ws.set_onmessage(None);
            ws.set_onclose(None);
            ws.set_onerror(None);
            let _ = ws.close();
        }
        self.handlers.clear();
        self.on_ws_message = None;
    }
}

fn now_ms() -> f64 {
    js_sys::Date::now()
}

fn open(this: &Rc<RefCell<Inner>>) {
    let mut inner = this.borrow_mut();
    if inner.closed {
        return;
    }
    inner.detach();
    inner.generation += 1;
    let generation = inner.generation;
    inner.connection.on_connecting();
    let link = inner.link;
    let ws = match WebSocket::new(&inner.url) {
        Ok(ws) => ws,
        Err(err) => {
            leptos::logging::warn!(
                "cannot open {}: {}",
                inner.url,
                crate::http::describe_js_error(err)
            );
            drop(inner);
            lost(this, generation);
            return;
        }
    };
    let weak = Rc::downgrade(this);
    let on_message = Closure::<dyn FnMut(MessageEvent)>::new({
        let weak = weak.clone();
        move |event: MessageEvent| received(&weak, generation, &event)
    });
    let on_close = Closure::<dyn FnMut(Event)>::new({
        let weak = weak.clone();
        move |_: Event| {
            if let Some(this) = weak.upgrade() {
                lost(&this, generation);
            }
        }
    });
    ws.set_onmessage(Some(on_message.as_ref().unchecked_ref()));
    ws.set_onclose(Some(on_close.as_ref().unchecked_ref()));
    // An error is always followed by a close event; the close handler reconnects.
    inner.ws = Some(ws);
    inner.on_ws_message = Some(on_message);
    inner.handlers = vec![on_close];
    drop(inner);
    link.set(Link::Connecting);
}

fn received(weak: &Weak<RefCell<Inner>>, generation: u64, event: &MessageEvent) {
    let Some(this) = weak.upgrade() else { return };
    let mut inner = this.borrow_mut();
    if inner.generation != generation {
        return;
    }
    inner.last_heard_ms = now_ms();
    inner.connection.on_message();
    let link = inner.link;
    let on_message = Rc::clone(&inner.on_message);
    drop(inner);
    if link.get_untracked() != Link::Connected {
        link.set(Link::Connected);
        // A new session relays every feedback frame until told otherwise.
        let relay = this.borrow().relay_feedback.get();
        Socket {
            inner: Rc::clone(&this),
        }
        .send(&ClientMessage::Feedback { relay });
    }
    let Some(text) = event.data().as_string() else {
        return;
    };
    match decode(&text) {
        Ok(Decoded::Message(message)) => on_message(message),
        Ok(decoded @ (Decoded::ShowControl(_) | Decoded::LivePositions(_))) => {
            // Read in its chunk; handed on in the order the frames of its kind came,
            // and only while this socket is the current one.
            let live = matches!(decoded, Decoded::LivePositions(_));
            let (Decoded::ShowControl(text) | Decoded::LivePositions(text)) = decoded else {
                return;
            };
            let order = {
                let mut inner = this.borrow_mut();
                let sent = if live {
                    &mut inner.live_sent
                } else {
                    &mut inner.show_control_sent
                };
                *sent += 1;
                *sent
            };
            let weak = Rc::downgrade(&this);
            leptos::task::spawn_local(async move {
                let read = if live {
                    crate::lazy::read_live_positions(text).await
                } else {
                    crate::lazy::read_show_control(text).await
                };
                let Some(this) = weak.upgrade() else { return };
                let mut inner = this.borrow_mut();
                let current = inner.generation == generation;
                let handed = if live {
                    &mut inner.live_handed
                } else {
                    &mut inner.show_control_handed
                };
                if !current || order <= *handed {
                    return;
                }
                *handed = order;
                let on_message = Rc::clone(&inner.on_message);
                drop(inner);
                match read {
                    Ok(Some(message)) => on_message(message),
                    Ok(None) => {}
                    Err(crate::lazy::ChunkError) => leptos::logging::warn!(
                        "a schedule, timecode or live-positions message could not be read: its chunk did not load"
                    ),
                }
            });
        }
        Err(err) => leptos::logging::warn!("ignoring a message the app does not understand: {err}"),
    }
}

fn lost(this: &Rc<RefCell<Inner>>, generation: u64) {
    let mut inner = this.borrow_mut();
    if inner.generation != generation || inner.closed {
        return;
    }
    // Events of this socket are ignored from now on.
    inner.generation += 1;
    inner.detach();
    let delay_ms = inner.connection.on_lost();
    let link = inner.link;
    drop(inner);
    link.set(Link::Disconnected);
    let weak = Rc::downgrade(this);
    set_timeout(
        move || {
            if let Some(this) = weak.upgrade() {
                open(&this);
            }
        },
        Duration::from_millis(u64::from(delay_ms)),
    );
}

fn watchdog(weak: &Weak<RefCell<Inner>>) {
    let Some(this) = weak.upgrade() else { return };
    let inner = this.borrow();
    if inner.connection.link() != Link::Connected {
        return;
    }
    let generation = inner.generation;
    if now_ms() - inner.last_heard_ms > f64::from(SILENCE_TIMEOUT_MS) {
        drop(inner);
        lost(&this, generation);
        return;
    }
    if let (Some(ws), Ok(ping)) = (&inner.ws, serde_json::to_string(&ClientMessage::Ping)) {
        let _ = ws.send_with_str(&ping);
    }
}
