//! The app's shared state and its ways out, provided to every component as one
//! [`Ctx`] in the Leptos context.
//!
//! Components reach the bridge only through [`Services`]: a [`Transport`] for HTTP and
//! a [`Sender`] for WebSocket messages. The app passes the real ones; component tests
//! pass a fake bridge and count what was sent.
//!
//! Also here: a refusal of the bridge as it is kept for display ([`Refusal`], shown in
//! the current language), and the browser's side of the language: its preferred
//! languages at start ([`browser_languages`]) and `<html lang>` ([`set_document_lang`]).

use std::rc::Rc;
use std::sync::Arc;

use floatball_shared::api::{
    ClientMessage, InstallationInfo, PlayerState, Problem, ServerMessage, ShowSummary, Status,
};
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::show::{Show, ShowFormat, read_json};
use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::client::{Client, Failure, Transport};
use crate::connection::Link;
use crate::console::FeedbackLog;
use crate::files::{Listing, LocalFile};
use crate::i18n::{Lang, Text};
use crate::page::Page;
use crate::playlist::PlaylistEditor;
use crate::session::{Origin, Session};
use crate::store::LocalStore;

/// How soon the list of controller files is asked for again while the bridge is still
/// indexing its library, ms.
pub const LIBRARY_RETRY_MS: u64 = 1000;

/// How long a success toast stays, ms.
pub const TOAST_MS: u64 = 4_000;

/// Sends messages to the bridge over the WebSocket.
pub trait Sender {
    /// Sends `message` now; returns whether it was handed to an open socket.
    fn send(&self, message: &ClientMessage) -> bool;

    /// Whether the app wants every gateway's feedback frames (its console is open):
    /// told to the bridge now and on every reconnect. Nothing by default.
    fn relay_feedback(&self, _on: bool) {}
}

/// Everything that leaves the page: HTTP, the WebSocket, the local file store.
#[derive(Clone)]
pub struct Services {
    /// How HTTP requests travel.
    pub transport: Rc<dyn Transport>,
    /// How WebSocket messages travel.
    pub sender: Rc<dyn Sender>,
    /// Where local files are kept.
    pub store: LocalStore,
}

impl std::fmt::Debug for Services {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Services")
            .field("store", &self.store)
            .finish_non_exhaustive()
    }
}

/// What a preview shows: a parsed show, or why there is none.
#[derive(Debug, Clone, PartialEq)]
pub enum PreviewItem {
    /// A controller file is being fetched.
    Loading(String),
    /// The show to draw (shared, never copied: a large show is many megabytes), with
    /// the label of its file.
    Ready(String, Arc<Show>),
    /// The file could not be read.
    Failed(String, String),
}

/// What the E-stop buttons say after a press.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EstopAck {
    /// Handed to the socket.
    Sent,
    /// The socket was not open.
    NotSent,
}

/// The app's state, `Copy` so every closure can hold it.
#[derive(Debug, Clone, Copy)]
pub struct Ctx {
    /// The interface language.
    pub lang: RwSignal<Lang>,
    /// The WebSocket's state.
    pub link: RwSignal<Link>,
    /// The page asked for (shown as [`Page::resolve`] says).
    pub page: RwSignal<Page>,
    /// The login held, if any.
    pub session: RwSignal<Option<Session>>,
    /// Why the app went back to Login by itself (expired login, must change password).
    pub login_notice: RwSignal<Option<Text>>,
    /// The latest status from the bridge.
    pub status: RwSignal<Option<Status>>,
    /// The scheduler's state as the bridge last said it (`schedule` messages).
    pub schedule: RwSignal<Option<floatball_shared::api::ScheduleStatus>>,
    /// The latest request the bridge refused over the WebSocket.
    pub bridge_error: RwSignal<Option<Refusal>>,
    /// Local files.
    pub local_files: RwSignal<Listing<LocalFile>>,
    /// Controller files.
    pub controller_files: RwSignal<Listing<ShowSummary>>,
    /// The bridge is still indexing its library (after a start): the list of
    /// controller files is not complete yet, and is asked for again.
    pub library_indexing: RwSignal<bool>,
    /// The playlist being edited.
    pub playlist: RwSignal<PlaylistEditor>,
    /// Decoded feedback frames for the console.
    pub feedback: RwSignal<FeedbackLog>,
    /// The console's parsers ([`Ctx::load_console_parsers`]), kept once fetched.
    pub console_parsers: RwSignal<crate::console::Parsers>,
    /// What the Preview page shows.
    pub preview: RwSignal<Option<PreviewItem>>,
    /// Where the Preview page opens its next show, paused, ms (the Control page's
    /// start time: where a Start from there begins); `None`: from its start,
    /// playing.
    pub preview_from_ms: RwSignal<Option<u64>>,
    /// The last E-stop press (its number and outcome), shown on every E-stop button
    /// until it times out.
    pub estop_ack: RwSignal<Option<(u32, EstopAck)>>,
    /// The success toast shown now (its number and text), cleared after a few
    /// seconds ([`Ctx::notify`]).
    pub toast: RwSignal<Option<(u32, String)>>,
    /// The installation as the bridge last said it (`GET /api/installation`, and
    /// the answer to a saved change); see [`Ctx::installation_now`].
    pub installation: RwSignal<Option<InstallationInfo>>,
    /// The show being made on the Create page, kept while other pages are open.
    pub create: RwSignal<crate::create::Draft>,
    /// The bridge's timecode chase, when it has one on (`ServerMessage::Timecode`).
    pub timecode: RwSignal<Option<floatball_shared::timecode::chase::TimecodeStatus>>,
    /// The balls' live positions, whole mm (`ServerMessage::LivePositions`, asked for
    /// by the Live card and the Preview page's live picture while they are shown);
    /// empty while not live.
    pub live_positions: RwSignal<Vec<i32>>,
    /// How many views want [`Ctx::live_positions`] now: the last one to go stops
    /// asking (`crate::components::live::want_live_positions`).
    pub live_positions_wanted: StoredValue<u32>,
    /// While the matrix is live, the Preview page shows the show chosen there
    /// instead of the live picture: set when a show is chosen, cleared whenever
    /// live mode begins or ends (the live picture takes over again).
    pub preview_show_while_live: RwSignal<bool>,
    /// Whether the draft kept in the browser was read back into [`Ctx::create`]
    /// (the Create page does it when first opened, its code being a chunk).
    pub create_restored: StoredValue<bool>,
    origin: StoredValue<Origin>,
    services: StoredValue<Services, LocalStorage>,
}

/// A request the bridge refused over the WebSocket: its code and parameters, shown
/// in the current language ([`Lang::coded`]), and its English words for a code the
/// app does not know.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refusal {
    /// The bridge's English sentence.
    pub message: String,
    /// The stable code (empty from an older bridge).
    pub code: String,
    /// The code's parameters.
    pub params: Params,
    /// The `reason` parameter as a coded problem, if the bridge sent it.
    pub reason_problem: Option<Problem>,
    /// The `fixes` parameter as coded problems, if the bridge sent them.
    pub fix_problems: Vec<Problem>,
}

impl Refusal {
    /// A typed error of the shared code (a parse error found before sending).
    pub fn of(error: &(impl Coded + std::fmt::Display)) -> Self {
        Self {
            message: error.to_string(),
            code: error.code().as_str().to_owned(),
            params: error.params(),
            reason_problem: None,
            fix_problems: Vec::new(),
        }
    }

    /// The refusal in `lang` (rendered when shown, so it follows a language switch).
    pub fn text(&self, lang: Lang) -> String {
        lang.refusal(
            &self.code,
            &self.params,
            &self.message,
            self.reason_problem.as_ref(),
            &self.fix_problems,
        )
    }
}

/// The browser's preferred languages (`navigator.languages`, else
/// `navigator.language`), first first. Read through `Reflect`, so no web-sys feature
/// is needed for a list of strings.
pub fn browser_languages() -> Vec<String> {
    let get = |target: &wasm_bindgen::JsValue, name: &str| {
        js_sys::Reflect::get(target, &wasm_bindgen::JsValue::from_str(name)).ok()
    };
    let Some(navigator) = get(&leptos::prelude::window(), "navigator") else {
        return Vec::new();
    };
    let listed: Vec<String> = get(&navigator, "languages")
        .filter(js_sys::Array::is_array)
        .map(|list| {
            js_sys::Array::from(&list)
                .iter()
                .filter_map(|tag| tag.as_string())
                .collect()
        })
        .unwrap_or_default();
    if listed.is_empty() {
        get(&navigator, "language")
            .and_then(|tag| tag.as_string())
            .into_iter()
            .collect()
    } else {
        listed
    }
}

/// Says the page's language to the browser and to assistive technology:
/// `<html lang="zh">` or `<html lang="en">`.
pub fn set_document_lang(lang: Lang) {
    if let Some(root) = leptos::prelude::document().document_element() {
        let _ = root.set_attribute("lang", lang.code());
    }
}

/// `text` in `lang` as a view or an attribute that follows a language switch. Every
/// fixed string of the app goes through this one closure type, so Leptos builds its
/// reactive text once instead of once per string (a closure written at each place is
/// a type, and code, of its own).
pub fn tr_in(
    lang: Signal<Lang>,
    text: impl crate::i18n::Words,
) -> impl Fn() -> &'static str + Copy + Send + Sync + 'static {
    move || lang.get().t(text)
}

impl Ctx {
    /// Fresh state for a page loaded from `origin`.
    pub fn new(services: Services, origin: Origin, lang: Lang) -> Self {
        Self {
            lang: RwSignal::new(lang),
            link: RwSignal::new(Link::Disconnected),
            page: RwSignal::new(Page::default()),
            session: RwSignal::new(None),
            login_notice: RwSignal::new(None),
            status: RwSignal::new(None),
            schedule: RwSignal::new(None),
            bridge_error: RwSignal::new(None),
            local_files: RwSignal::new(Listing::default()),
            controller_files: RwSignal::new(Listing::default()),
            library_indexing: RwSignal::new(false),
            playlist: RwSignal::new(PlaylistEditor::default()),
            feedback: RwSignal::new(FeedbackLog::default()),
            console_parsers: RwSignal::new(crate::console::Parsers::default()),
            preview: RwSignal::new(None),
            preview_from_ms: RwSignal::new(None),
            estop_ack: RwSignal::new(None),
            toast: RwSignal::new(None),
            installation: RwSignal::new(None),
            create: RwSignal::new(crate::create::Draft::new()),
            timecode: RwSignal::new(None),
            live_positions: RwSignal::new(Vec::new()),
            live_positions_wanted: StoredValue::new(0),
            preview_show_while_live: RwSignal::new(false),
            create_restored: StoredValue::new(false),
            origin: StoredValue::new(origin),
            services: StoredValue::new_local(services),
        }
    }

    /// `text` in the current language (tracked).
    pub fn t(&self, text: impl crate::i18n::Words) -> &'static str {
        self.lang.get().t(text)
    }

    /// `text` in the current language as a view or an attribute that follows a
    /// language switch ([`tr_in`]).
    pub fn tr(
        self,
        text: impl crate::i18n::Words,
    ) -> impl Fn() -> &'static str + Copy + Send + Sync + 'static {
        tr_in(self.lang.into(), text)
    }

    /// Where the page came from.
    pub fn origin(&self) -> Origin {
        self.origin.get_value()
    }

    /// The local file store.
    pub fn store(&self) -> LocalStore {
        self.services.with_value(|services| services.store.clone())
    }

    /// A client for the controller at `address`, without a login.
    pub fn client_for(&self, address: &str) -> Client {
        let base = self.origin.with_value(|origin| origin.base_url(address));
        let transport = self
            .services
            .with_value(|services| Rc::clone(&services.transport));
        Client::new(transport, base)
    }

    /// A client with the current login, if there is one.
    pub fn client(&self) -> Option<Client> {
        let session = self.session.get_untracked()?;
        Some(self.client_for(&session.address).with_token(session.token))
    }

    /// Whether the bridge is connected (tracked).
    pub fn connected(&self) -> bool {
        self.link.get() == Link::Connected
    }

    /// Whether a login is held (tracked).
    pub fn logged_in(&self) -> bool {
        self.session.with(Option::is_some)
    }

    /// Sends `message` over the WebSocket; returns whether it went.
    pub fn send(&self, message: &ClientMessage) -> bool {
        self.services
            .with_value(|services| Rc::clone(&services.sender))
            .send(message)
    }

    /// Asks the bridge for every gateway's feedback frames (`true`, while the console
    /// is open) or for none: with a hundred gateways streaming they are thousands a
    /// second, more than a phone should read for nothing.
    pub fn relay_feedback(&self, on: bool) {
        if let Some(sender) = self
            .services
            .try_with_value(|services| Rc::clone(&services.sender))
        {
            sender.relay_feedback(on);
        }
    }

    /// Fetches the console's parsers (their chunk) unless they are here or on their
    /// way; after a failure, asks again.
    pub fn load_console_parsers(&self) {
        use crate::console::Parsers;
        if matches!(
            self.console_parsers.get_untracked(),
            Parsers::Loading | Parsers::Ready(_)
        ) {
            return;
        }
        self.console_parsers.set(Parsers::Loading);
        let parsers = self.console_parsers;
        leptos::task::spawn_local(async move {
            let _ = parsers.try_set(match crate::lazy::console_parsers().await {
                Ok(loaded) => Parsers::Ready(loaded),
                Err(crate::lazy::ChunkError) => Parsers::Failed,
            });
        });
    }

    /// Takes the matrix's status (`None`: none known). The E-stop acknowledgement
    /// ends once the matrix leaves `stopped` (homing, playing…): it no longer
    /// describes the matrix, whether or not an E-stop button is shown. When live mode
    /// begins or ends, the Preview page shows the live picture again (or its show).
    pub fn set_status(&self, status: Option<Status>) {
        let stopped = |status: &Option<Status>| {
            status.as_ref().map(|s| s.state) == Some(PlayerState::Stopped)
        };
        let live = |status: &Option<Status>| status.as_ref().is_some_and(|s| s.live.is_some());
        let was_stopped = self.status.with_untracked(stopped);
        let now_stopped = stopped(&status);
        if self.status.with_untracked(live) != live(&status) {
            self.preview_show_while_live.set(false);
        }
        self.status.set(status);
        if was_stopped && !now_stopped {
            self.estop_ack.set(None);
        }
    }

    /// Takes in one message from the bridge.
    pub fn receive(&self, message: ServerMessage) {
        match message {
            ServerMessage::Status(status) => self.set_status(Some(status)),
            ServerMessage::Feedback(frame) => self.feedback.update(|log| log.push(&frame)),
            ServerMessage::MboxReply(reply) => self.feedback.update(|log| log.push_mbox(&reply)),
            ServerMessage::SclReply(reply) => self.feedback.update(|log| log.push_scl(&reply)),
            ServerMessage::Schedule(schedule) => self.schedule.set(Some(schedule)),
            ServerMessage::Error {
                message,
                code,
                params,
                reason_problem,
                fix_problems,
            } => self.bridge_error.set(Some(Refusal {
                message,
                code,
                params,
                reason_problem: reason_problem.map(|problem| *problem),
                fix_problems,
            })),
            ServerMessage::EstopSent { unreached } if !unreached.is_empty() => {
                let gateways = unreached.join("; ");
                let mut params = Params::new();
                params.insert("gateways".into(), gateways.clone());
                self.bridge_error.set(Some(Refusal {
                    message: format!("E-stop: {gateways}"),
                    code: Code::EstopUnreached.as_str().to_owned(),
                    params,
                    reason_problem: None,
                    fix_problems: Vec::new(),
                }));
            }
            ServerMessage::Timecode(chase) => self.timecode.set(Some(chase)),
            ServerMessage::LivePositions { positions_mm } => self.live_positions.set(positions_mm),
            ServerMessage::Recorded { name, .. } => {
                // A live recording is a show in the store now: list it.
                let lang = self.lang.get_untracked();
                self.notify(format!(
                    "{} \u{201c}{name}\u{201d}",
                    lang.t(Text::RecordedAs)
                ));
                self.refresh();
            }
            ServerMessage::Pong | ServerMessage::EstopSent { .. } => {}
        }
    }

    /// Fetches the installation: its limits, grid and pitch for the preview and its
    /// checks ([`Ctx::installation_now`]), its calibration and stations for the
    /// console's mm ([`FeedbackLog::set_installation`]); a bridge without the call
    /// leaves the defaults and the positions in counts only.
    pub fn load_installation(&self) {
        let Some(client) = self.client() else { return };
        let ctx = *self;
        spawn_local(async move {
            if let Ok(info) = client.installation().await {
                ctx.set_installation(info);
            }
        });
    }

    /// Takes the installation the bridge said (fetched, or answered to a save).
    pub fn set_installation(&self, info: InstallationInfo) {
        self.feedback
            .update(|log| log.set_installation(info.clone()));
        self.installation.set(Some(info));
    }

    /// The installation while connected to its bridge (tracked); `None` offline,
    /// where the preview checks against the defaults.
    pub fn installation_now(&self) -> Option<InstallationInfo> {
        if self.connected() {
            self.installation.get()
        } else {
            None
        }
    }

    /// Reacts to a failure every page treats alike: an expired login goes back to
    /// Login, a refused control call asks for the password change. Returns the
    /// sentence to show.
    pub fn failed(&self, failure: &Failure) -> String {
        match failure {
            Failure::Unauthorized => self.expire(Text::SessionExpired),
            Failure::MustChangePassword => {
                self.session.update(|session| {
                    if let Some(session) = session {
                        session.must_change_password = true;
                    }
                });
                self.login_notice.set(Some(Text::MustChangePasswordFirst));
                self.page.set(Page::Login);
            }
            _ => {}
        }
        self.lang.get_untracked().failure(failure)
    }

    /// Shows `text` as a success toast for [`TOAST_MS`]; a later toast replaces it
    /// (and is not cleared by the earlier one's timer).
    pub fn notify(&self, text: impl Into<String>) {
        let toast = self.toast;
        let number = toast.get_untracked().map_or(1, |(n, _)| n.wrapping_add(1));
        toast.set(Some((number, text.into())));
        set_timeout(
            move || {
                if toast.get_untracked().map(|(n, _)| n) == Some(number) {
                    toast.set(None);
                }
            },
            std::time::Duration::from_millis(TOAST_MS),
        );
    }

    /// Drops the login and goes to Login, saying why.
    pub fn expire(&self, why: Text) {
        self.session.set(None);
        self.set_status(None);
        self.login_notice.set(Some(why));
        self.page.set(Page::Login);
    }

    /// Fetches the controller's files and the playlist again (after a login, a
    /// reconnect, an upload), and again every [`LIBRARY_RETRY_MS`] while the bridge
    /// says its list is not complete yet ([`Ctx::library_indexing`]).
    pub fn refresh(&self) {
        let Some(client) = self.client() else { return };
        let ctx = *self;
        spawn_local(async move {
            match client.shows_listed().await {
                Ok((shows, complete)) => {
                    ctx.controller_files.update(|list| list.replace(shows));
                    ctx.library_indexing.set(!complete);
                    if !complete {
                        // The bridge is still indexing its library: ask again.
                        set_timeout(
                            move || ctx.refresh(),
                            std::time::Duration::from_millis(LIBRARY_RETRY_MS),
                        );
                    }
                }
                Err(failure) => {
                    ctx.failed(&failure);
                    return;
                }
            }
            match client.playlist().await {
                Ok(playlist) => ctx.playlist.update(|editor| editor.replace(playlist)),
                Err(failure) => {
                    ctx.failed(&failure);
                }
            }
        });
    }

    /// Reloads the local files from the browser's store.
    pub fn load_local_files(&self) {
        let ctx = *self;
        let store = self.store();
        spawn_local(async move {
            match store.load_all().await {
                Ok(files) => ctx.local_files.update(|list| list.replace(files)),
                Err(error) => leptos::logging::warn!("cannot read local files: {error}"),
            }
        });
    }

    /// Opens the Preview page on a local file: a JSON file at once; a CSV file once
    /// the CSV reader, a chunk of its own ([`crate::lazy::read_csv`]), is here.
    pub fn preview_local(&self, file: &LocalFile) {
        fn ready(name: String, read: Result<Show, String>) -> PreviewItem {
            match read {
                Ok(show) => PreviewItem::Ready(name, Arc::new(show)),
                Err(why) => PreviewItem::Failed(name, why),
            }
        }
        let name = file.name.clone();
        self.preview_from_ms.set(None);
        self.preview_show_while_live.set(true);
        if file.kind == ShowFormat::Json {
            let lang = self.lang.get_untracked();
            let read = read_json(file.show_name(), file.text.as_bytes())
                .map_err(|refused| lang.refused_json(&refused));
            self.preview.set(Some(ready(name, read)));
            self.page.set(Page::Preview);
            return;
        }
        self.preview.set(Some(PreviewItem::Loading(name.clone())));
        self.page.set(Page::Preview);
        let ctx = *self;
        let file = file.clone();
        spawn_local(async move {
            let lang = ctx.lang.get_untracked();
            let item = match crate::lazy::read_csv(file, lang).await {
                Ok(read) => ready(name.clone(), read),
                Err(crate::lazy::ChunkError) => {
                    PreviewItem::Failed(name.clone(), lang.t(Text::CsvReaderFailed).to_owned())
                }
            };
            // Only if the operator has not picked another file meanwhile.
            ctx.preview.update(|preview| {
                if matches!(preview, Some(PreviewItem::Loading(loading)) if *loading == name) {
                    *preview = Some(item);
                }
            });
        });
    }

    /// Opens the Preview page on a controller file, fetching it first.
    pub fn preview_controller(&self, name: &str) {
        let Some(client) = self.client() else { return };
        let name = name.to_owned();
        self.preview_from_ms.set(None);
        self.preview_show_while_live.set(true);
        self.preview.set(Some(PreviewItem::Loading(name.clone())));
        self.page.set(Page::Preview);
        let ctx = *self;
        spawn_local(async move {
            let item = match client.download(&name).await {
                Ok(json) => match read_json(&name, json.as_bytes()) {
                    Ok(show) => PreviewItem::Ready(name.clone(), Arc::new(show)),
                    Err(refused) => PreviewItem::Failed(
                        name.clone(),
                        ctx.lang.get_untracked().refused_json(&refused),
                    ),
                },
                Err(failure) => PreviewItem::Failed(name.clone(), ctx.failed(&failure)),
            };
            // Only if the operator has not picked another file meanwhile.
            ctx.preview.update(|preview| {
                if matches!(preview, Some(PreviewItem::Loading(loading)) if *loading == name) {
                    *preview = Some(item);
                }
            });
        });
    }
}
