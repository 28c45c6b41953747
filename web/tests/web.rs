//! Component tests in a real browser (`wasm-pack test --headless --chrome web`).
//!
//! Pages are mounted with a fake bridge: [`FakeBridge`] answers HTTP requests as
//! each test scripts it (at once, or held until the test releases them, with upload
//! progress events in between) and records them; [`FakeSocket`] records every
//! WebSocket message instead of sending it.

use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::rc::Rc;

use floatball_shared::api::{
    ClientMessage, FeedbackFrame, GatewayKind, GatewayStatus, LinkState, MboxRegisters, MboxReply,
    PlayerState, Playlist, Problem, QProgramListing, SclReply, ServerMessage, ShowSummary,
    StartFrom, Status,
};
use floatball_shared::show::{Layout, Show, Track, TrackRow};
use floatball_web::client::{
    LocalFuture, Method, OnProgress, Request, Response, Transport, UploadProgress,
};
use floatball_web::components::Shell;
use floatball_web::components::console::ConsolePage;
use floatball_web::components::control::{ControlPage, SettingsPage};
use floatball_web::components::files::FilesPage;
use floatball_web::components::installation::InstallationPage;
use floatball_web::components::login::LoginPage;
use floatball_web::components::preview::PreviewScreen;
use floatball_web::components::topbar::StatusBar;
use floatball_web::components::{ConnectionIndicator, EstopButton, LanguageSwitch};
use floatball_web::connection::Link;
use floatball_web::context::{Ctx, EstopAck, PreviewItem, Sender, Services};
use floatball_web::files::LocalFile;
use floatball_web::i18n::Lang;
use floatball_web::page::Page;
use floatball_web::playlist::PlaylistEditor;
use floatball_web::session::{Origin, Session};
use floatball_web::store::LocalStore;
use leptos::mount::mount_to;
use leptos::prelude::*;
use leptos::task::tick;
use wasm_bindgen::JsCast;
use wasm_bindgen_futures::JsFuture;
use wasm_bindgen_test::*;

use crate::dom::*;

// ----------------------------------------------------------------------------------
// The fake bridge
// ----------------------------------------------------------------------------------

/// What the fake bridge does with a request.
enum Answer {
    /// Answer at once.
    Now(Response),
    /// Hold the request until [`FakeBridge::release`].
    Hold,
}

type Held = (js_sys::Function, Rc<RefCell<Option<Response>>>);

struct FakeBridge {
    route: Box<dyn Fn(&Request) -> Answer>,
    requests: RefCell<Vec<Request>>,
    progress: RefCell<Vec<OnProgress>>,
    held: RefCell<VecDeque<Held>>,
}

impl FakeBridge {
    fn new(route: impl Fn(&Request) -> Answer + 'static) -> Rc<Self> {
        Rc::new(Self {
            route: Box::new(route),
            requests: RefCell::default(),
            progress: RefCell::default(),
            held: RefCell::default(),
        })
    }

    /// Answers the oldest held request.
    fn release(&self, response: Response) {
        let (resolve, slot) = self.held.borrow_mut().pop_front().expect("a held request");
        *slot.borrow_mut() = Some(response);
        resolve.call0(&wasm_bindgen::JsValue::NULL).unwrap();
    }

    /// Reports upload progress on the latest upload.
    fn report(&self, sent_bytes: f64, total_bytes: f64) {
        let progress = self.progress.borrow().last().cloned().expect("an upload");
        progress(UploadProgress {
            sent_bytes,
            total_bytes,
        });
    }

    fn requests_to(&self, method: Method, prefix: &str) -> Vec<Request> {
        self.requests
            .borrow()
            .iter()
            .filter(|r| r.method == method && r.url.starts_with(prefix))
            .cloned()
            .collect()
    }
}

impl Transport for FakeBridge {
    fn send(
        &self,
        request: Request,
        progress: Option<OnProgress>,
    ) -> LocalFuture<Result<Response, String>> {
        if let Some(progress) = progress {
            self.progress.borrow_mut().push(progress);
        }
        let answer = (self.route)(&request);
        self.requests.borrow_mut().push(request);
        match answer {
            Answer::Now(response) => Box::pin(async move { Ok(response) }),
            Answer::Hold => {
                let slot = Rc::new(RefCell::new(None));
                let mut resolver = None;
                let promise = js_sys::Promise::new(&mut |resolve, _| resolver = Some(resolve));
                self.held
                    .borrow_mut()
                    .push_back((resolver.expect("resolver"), Rc::clone(&slot)));
                Box::pin(async move {
                    JsFuture::from(promise).await.expect("released");
                    let response = slot.borrow_mut().take().expect("a response");
                    Ok(response)
                })
            }
        }
    }
}

fn response(status: u16, body: &str) -> Answer {
    Answer::Now(Response {
        status,
        retry_after: None,
        body: body.into(),
    })
}

/// Records WebSocket messages; "open" unless told otherwise.
#[derive(Default)]
struct FakeSocket {
    sent: RefCell<Vec<ClientMessage>>,
    closed: Cell<bool>,
    /// What the app said of the feedback relay, in order.
    relay: RefCell<Vec<bool>>,
}

impl Sender for FakeSocket {
    fn send(&self, message: &ClientMessage) -> bool {
        if self.closed.get() {
            return false;
        }
        self.sent.borrow_mut().push(message.clone());
        true
    }

    fn relay_feedback(&self, on: bool) {
        self.relay.borrow_mut().push(on);
    }
}

const HOST: &str = "bridge.test:8080";

fn context(bridge: &Rc<FakeBridge>, socket: &Rc<FakeSocket>, database: &str) -> Ctx {
    let services = Services {
        transport: bridge.clone(),
        sender: socket.clone(),
        store: LocalStore::new(database),
    };
    let origin = Origin {
        protocol: "http:".into(),
        host: HOST.into(),
    };
    Ctx::new(services, origin, Lang::En)
}

/// `page`, mounted logged in and connected with a bridge that answers every request
/// 500 (it stays mounted for the rest of the test run); the socket and the bridge
/// record what it sends.
fn mount_online<V: IntoView + 'static>(
    database: &str,
    page: fn() -> V,
) -> (web_sys::HtmlElement, Ctx, Rc<FakeSocket>, Rc<FakeBridge>) {
    let container = fresh_container();
    let bridge = FakeBridge::new(|_| response(500, ""));
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, database);
    online(ctx);
    let mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        page()
    });
    std::mem::forget(mounted);
    (container, ctx, socket, bridge)
}

/// Logged in and connected.
fn online(ctx: Ctx) {
    ctx.session.set(Some(Session {
        address: HOST.into(),
        token: "tok".into(),
        must_change_password: false,
    }));
    ctx.link.set(Link::Connected);
}

// ----------------------------------------------------------------------------------
// DOM helpers
// ----------------------------------------------------------------------------------

fn disabled(container: &web_sys::HtmlElement, test_id: &str) -> bool {
    element(container, test_id).has_attribute("disabled")
}

/// Types `value` into an input or textarea as a user would (an `input` event).
fn type_into(container: &web_sys::HtmlElement, test_id: &str, value: &str) {
    set_value(container, test_id, value, "input");
}

fn summary(name: &str) -> ShowSummary {
    ShowSummary {
        name: name.into(),
        bytes: 1234,
        sha256: "00".into(),
        modified: "2026-01-01T00:00:00Z".into(),
        units: 4,
        duration_ms: 2500,
    }
}

// ----------------------------------------------------------------------------------
// Top bar
// ----------------------------------------------------------------------------------

#[wasm_bindgen_test]
async fn connection_indicator_shows_both_states_in_both_languages() {
    let container = fresh_container();
    let link = RwSignal::new(Link::Disconnected);
    let lang = RwSignal::new(Lang::Zh);
    let _mounted = mount_to(container.clone(), move || {
        view! { <ConnectionIndicator link=link lang=lang /> }
    });
    let indicator = element(&container, "connection");
    assert_eq!(indicator.text_content().as_deref(), Some("未连接"));
    assert_eq!(
        indicator.get_attribute("data-state").as_deref(),
        Some("disconnected")
    );

    link.set(Link::Connected);
    tick().await;
    assert_eq!(indicator.text_content().as_deref(), Some("已连接"));
    assert_eq!(
        indicator.get_attribute("data-state").as_deref(),
        Some("connected")
    );

    lang.set(Lang::En);
    tick().await;
    assert_eq!(indicator.text_content().as_deref(), Some("Connected"));

    link.set(Link::Connecting);
    tick().await;
    assert_eq!(indicator.text_content().as_deref(), Some("Not connected"));
    assert_eq!(
        indicator.get_attribute("data-state").as_deref(),
        Some("connecting")
    );
}

#[wasm_bindgen_test]
async fn language_switch_toggles() {
    let container = fresh_container();
    let lang = RwSignal::new(Lang::Zh);
    let _mounted = mount_to(
        container.clone(),
        move || view! { <LanguageSwitch lang=lang /> },
    );
    let switch = element(&container, "lang");
    assert_eq!(switch.text_content().as_deref(), Some("English"));
    switch.click();
    tick().await;
    assert_eq!(lang.get_untracked(), Lang::En);
    assert_eq!(switch.text_content().as_deref(), Some("中文"));
}

#[wasm_bindgen_test]
async fn estop_sends_exactly_one_estop_per_press_and_is_acknowledged() {
    let (container, ctx, socket, bridge) = mount_online("test-estop", || view! { <EstopButton /> });
    let estop = element(&container, "estop");
    assert_eq!(estop.get_attribute("data-ack").as_deref(), Some("ready"));
    assert_eq!(text(&container, "estop-ack"), "");

    estop.click();
    tick().await;
    assert_eq!(*socket.sent.borrow(), [ClientMessage::Estop]);
    assert_eq!(text(&container, "estop-ack"), "E-stop sent");
    assert_eq!(estop.get_attribute("data-ack").as_deref(), Some("sent"));
    assert!(
        bridge.requests.borrow().is_empty(),
        "no HTTP, no confirmation"
    );

    ctx.status.set(Some(Status {
        state: PlayerState::Stopped,
        ..Status::default()
    }));
    tick().await;
    assert_eq!(text(&container, "estop-ack"), "Stopped");

    estop.click();
    tick().await;
    assert_eq!(
        *socket.sent.borrow(),
        [ClientMessage::Estop, ClientMessage::Estop]
    );

    socket.closed.set(true);
    estop.click();
    tick().await;
    assert_eq!(socket.sent.borrow().len(), 2);
    assert_eq!(text(&container, "estop-ack"), "NOT sent: no connection");
}

#[wasm_bindgen_test]
async fn the_estop_acknowledgement_ends_when_the_matrix_leaves_stopped_with_no_button_shown() {
    let bridge = FakeBridge::new(|_| response(500, ""));
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-estop-ack");
    online(ctx);
    let stopped = Status {
        state: PlayerState::Stopped,
        ..Status::default()
    };
    ctx.estop_ack.set(Some((1, EstopAck::Sent)));
    ctx.receive(ServerMessage::Status(stopped.clone()));
    ctx.receive(ServerMessage::Status(stopped));
    tick().await;
    assert_eq!(ctx.estop_ack.get_untracked(), Some((1, EstopAck::Sent)));
    ctx.receive(ServerMessage::Status(Status::default()));
    tick().await;
    assert_eq!(
        ctx.estop_ack.get_untracked(),
        None,
        "stopped → idle ends it"
    );
    ctx.estop_ack.set(Some((2, EstopAck::Sent)));
    ctx.receive(ServerMessage::Status(Status::default()));
    tick().await;
    assert_eq!(
        ctx.estop_ack.get_untracked(),
        Some((2, EstopAck::Sent)),
        "only leaving stopped ends it"
    );
}

#[wasm_bindgen_test]
async fn the_top_bar_shows_the_estop_only_when_connected_and_guards_control_pages() {
    let container = fresh_container();
    let bridge = FakeBridge::new(|_| response(404, ""));
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-shell");
    let _mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <Shell /> }
    });
    tick().await;
    assert!(all(&container, "estop").is_empty());
    assert_eq!(all(&container, "page-files").len(), 1);

    element(&container, "nav-control").click();
    tick().await;
    assert_eq!(
        all(&container, "page-login").len(),
        1,
        "control needs a login"
    );

    online(ctx);
    tick().await;
    assert_eq!(all(&container, "page-control").len(), 1);
    assert_eq!(all(&container, "estop").len(), 2, "top bar and Control");
    element(&container, "connection").click();
    tick().await;
    assert_eq!(
        all(&container, "page-login").len(),
        1,
        "the indicator opens Login"
    );
    assert_eq!(all(&container, "logged-in").len(), 1);

    ctx.link.set(Link::Disconnected);
    tick().await;
    assert!(
        all(&container, "estop").is_empty(),
        "no E-stop that cannot be sent"
    );
}

// ----------------------------------------------------------------------------------
// Login
// ----------------------------------------------------------------------------------

#[wasm_bindgen_test]
async fn login_shows_wrong_password_and_the_rate_limit_wait() {
    let container = fresh_container();
    let attempt = Rc::new(Cell::new(0));
    let bridge = FakeBridge::new({
        let attempt = attempt.clone();
        move |_| {
            attempt.set(attempt.get() + 1);
            if attempt.get() == 1 {
                response(401, "")
            } else {
                Answer::Now(Response {
                    status: 429,
                    retry_after: Some("42".into()),
                    body: String::new(),
                })
            }
        }
    });
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-login");
    let _mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <LoginPage /> }
    });
    let address =
        element(&container, "login-address").unchecked_into::<web_sys::HtmlInputElement>();
    until("the address is prefilled with the page's host", || {
        address.value() == HOST
    })
    .await;

    type_into(&container, "login-password", "wrong");
    element(&container, "login-submit").click();
    until("the error shows", || {
        all(&container, "login-error").len() == 1
    })
    .await;
    assert_eq!(text(&container, "login-error"), "Wrong password");
    let request = bridge.requests.borrow()[0].clone();
    assert_eq!(request.url, "/api/login");
    assert_eq!(request.body.as_deref(), Some(r#"{"password":"wrong"}"#));
    assert_eq!(ctx.session.get_untracked(), None);

    element(&container, "login-submit").click();
    until("the wait shows", || {
        text(&container, "login-error").contains("42")
    })
    .await;
    assert_eq!(
        text(&container, "login-error"),
        "Too many failed logins; try again in 42 s"
    );
}

#[wasm_bindgen_test]
async fn login_with_the_factory_password_forces_a_change() {
    let container = fresh_container();
    let bridge = FakeBridge::new(|request| match request.url.as_str() {
        "http://10.0.0.9:8080/api/login" => {
            response(200, r#"{"token":"t1","must_change_password":true}"#)
        }
        "http://10.0.0.9:8080/api/password" => response(204, ""),
        _ => response(404, ""),
    });
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-password");
    let _mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <LoginPage /> }
    });
    type_into(&container, "login-address", "10.0.0.9:8080");
    type_into(&container, "login-password", "1234");
    element(&container, "login-submit").click();
    until("the password form shows", || {
        all(&container, "password-form").len() == 1
    })
    .await;
    assert!(
        all(&container, "password-current").is_empty(),
        "the password just typed is used"
    );
    type_into(&container, "password-new", "s3cret-show");
    type_into(&container, "password-confirm", "typo");
    element(&container, "password-submit").click();
    tick().await;
    assert_eq!(
        text(&container, "password-error"),
        "The two new passwords differ"
    );

    type_into(&container, "password-confirm", "s3cret-show");
    element(&container, "password-submit").click();
    until("the session is unlocked", || {
        ctx.session
            .get_untracked()
            .is_some_and(|s| !s.must_change_password)
    })
    .await;
    let change = bridge.requests_to(Method::Post, "http://10.0.0.9:8080/api/password");
    assert_eq!(
        change[0].body.as_deref(),
        Some(r#"{"old":"1234","new":"s3cret-show"}"#)
    );
    assert_eq!(change[0].bearer.as_deref(), Some("t1"));
    assert_eq!(ctx.page.get_untracked(), Page::Files);
    assert_eq!(
        ctx.session.get_untracked().unwrap().address,
        "10.0.0.9:8080"
    );
}

// ----------------------------------------------------------------------------------
// Files
// ----------------------------------------------------------------------------------

const CSV: &str = "time_ms,u0,u1,u2,u3\n0,100,100,100,100\n1000,900,700,500,300\n";

fn with_local_file(ctx: Ctx) {
    ctx.local_files.update(|list| {
        list.upsert(LocalFile::new("wave.csv", CSV.into(), 0.0).unwrap());
    });
}

#[wasm_bindgen_test]
async fn upload_shows_progress_then_the_new_controller_file() {
    let container = fresh_container();
    let bridge = FakeBridge::new(|request| match request.method {
        Method::Put => Answer::Hold,
        _ => response(404, ""),
    });
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-upload");
    online(ctx);
    with_local_file(ctx);
    let _mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <FilesPage /> }
    });
    assert!(!disabled(&container, "upload"));
    element(&container, "upload").click();
    until("the progress bar shows", || {
        all(&container, "upload-progress").len() == 1
    })
    .await;
    let upload = bridge.requests.borrow()[0].clone();
    assert_eq!(upload.url, "/api/shows/wave");
    assert_eq!(upload.content_type, Some("text/csv"));
    assert_eq!(upload.body.as_deref(), Some(CSV));
    assert!(disabled(&container, "upload"), "one upload at a time");

    let bar = || {
        element(&container, "upload-progress")
            .unchecked_into::<web_sys::HtmlProgressElement>()
            .value()
    };
    assert_eq!(bar(), 0.0);
    bridge.report(25.0, 100.0);
    tick().await;
    assert_eq!(bar(), 0.25);
    assert_eq!(text(&container, "upload-percent"), "Uploading… 25%");
    bridge.report(100.0, 100.0);
    tick().await;
    assert_eq!(bar(), 1.0);

    bridge.release(Response {
        status: 201,
        retry_after: None,
        body: serde_json::to_string(&summary("wave")).unwrap(),
    });
    until("the upload ends", || {
        all(&container, "upload-progress").is_empty()
    })
    .await;
    assert_eq!(text(&container, "files-message"), "Uploaded: wave");
    element(&container, "tab-controller").click();
    tick().await;
    let rows = all(&container, "controller-file");
    assert_eq!(rows.len(), 1);
    let row = rows[0].text_content().unwrap();
    assert!(
        row.contains("wave") && row.contains("0:02.5") && row.contains("1.2 kB"),
        "{row}"
    );
}

#[wasm_bindgen_test]
async fn a_refused_upload_lists_every_problem() {
    let container = fresh_container();
    let bridge = FakeBridge::new(|_| {
        response(
            422,
            r#"{"error":"the show is not valid","details":["ball u0 (row 1, col 1) at 0.10 s: speed 7500.0 mm/s exceeds the limit of 2000.0 mm/s","ball u3 (row 2, col 2): below the travel"]}"#,
        )
    });
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-refused");
    online(ctx);
    with_local_file(ctx);
    let _mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <FilesPage /> }
    });
    element(&container, "upload").click();
    until("the refusal shows", || {
        all(&container, "upload-details").len() == 1
    })
    .await;
    assert!(
        text(&container, "files-message")
            .starts_with("The controller refused this file: the show is not valid")
    );
    let details = element(&container, "upload-details")
        .query_selector_all("li")
        .unwrap();
    assert_eq!(details.length(), 2);
    assert!(
        details
            .get(0)
            .unwrap()
            .text_content()
            .unwrap()
            .contains("7500.0 mm/s")
    );
}

#[wasm_bindgen_test]
async fn offline_files_cannot_move_but_local_ones_preview() {
    let container = fresh_container();
    let bridge = FakeBridge::new(|_| response(500, ""));
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-offline");
    with_local_file(ctx);
    let _mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <FilesPage /> }
    });
    assert_eq!(all(&container, "offline-hint").len(), 1);
    assert!(disabled(&container, "upload"));
    assert!(!disabled(&container, "preview-local"));
    element(&container, "preview-local").click();
    tick().await;
    assert_eq!(ctx.page.get_untracked(), Page::Preview);
    let Some(PreviewItem::Ready(name, show)) = ctx.preview.get_untracked() else {
        panic!("the local file previews")
    };
    assert_eq!(name, "wave.csv");
    assert_eq!((show.layout.rows, show.layout.cols), (2, 2));

    element(&container, "tab-controller").click();
    tick().await;
    assert!(disabled(&container, "download"));
    assert!(disabled(&container, "refresh"));
    assert!(bridge.requests.borrow().is_empty());
}

#[wasm_bindgen_test]
async fn controller_files_download_to_the_device_and_preview() {
    let container = fresh_container();
    let json = two_ball_show().to_json().unwrap();
    let bridge = FakeBridge::new(move |request| match request.url.as_str() {
        "/api/shows/two" => response(200, &json),
        _ => response(404, ""),
    });
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-download");
    LocalStore::new("test-download")
        .delete("two.json")
        .await
        .unwrap();
    online(ctx);
    ctx.controller_files.update(|list| {
        list.replace(vec![summary("two")]);
        list.select("two");
    });
    let _mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <FilesPage /> }
    });
    element(&container, "tab-controller").click();
    tick().await;
    element(&container, "download").click();
    until("the download is kept", || {
        ctx.local_files
            .with_untracked(|list| list.get("two.json").is_some())
    })
    .await;
    assert_eq!(
        text(&container, "files-message"),
        "Downloaded to the local files: two.json"
    );
    let stored = LocalStore::new("test-download").load_all().await.unwrap();
    assert_eq!(stored[0].name, "two.json");
    assert_eq!(stored[0].to_show().unwrap(), two_ball_show());

    element(&container, "preview-controller").click();
    until("the preview is ready", || {
        matches!(ctx.preview.get_untracked(), Some(PreviewItem::Ready(..)))
    })
    .await;
    assert_eq!(ctx.page.get_untracked(), Page::Preview);
    let Some(PreviewItem::Ready(name, show)) = ctx.preview.get_untracked() else {
        unreachable!()
    };
    assert_eq!((name.as_str(), &*show), ("two", &two_ball_show()));
    assert!(
        bridge
            .requests
            .borrow()
            .iter()
            .all(|r| r.bearer.as_deref() == Some("tok"))
    );
}

#[wasm_bindgen_test]
async fn a_balls_q_program_shows_on_installations_of_moons_drives() {
    let container = fresh_container();
    let listing = QProgramListing {
        unit: 3,
        show: "two".into(),
        text: "[segment 1: main]\nWI3F\nQC2\n[segment 2]\nDI5000\nVE2.5\nFP\nQC\n".into(),
        segments: 2,
        lines: 6,
        moves: 1,
        max_deviation_mm: 0.4,
        at_ms: 1500,
    };
    let json = serde_json::to_string(&listing).unwrap();
    let bridge = FakeBridge::new(move |request| match request.url.as_str() {
        "/api/qprogram/two?unit=3" => response(200, &json),
        "/api/qprogram/two?unit=9" => response(
            422,
            r#"{"error":"the program would deviate 41.2 mm from the show at 12.0 s (tolerance 10 mm)","details":[]}"#,
        ),
        _ => response(404, ""),
    });
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-qprogram");
    online(ctx);
    ctx.controller_files.update(|list| {
        list.replace(vec![summary("two")]);
        list.select("two");
    });
    let _mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <FilesPage /> }
    });
    element(&container, "tab-controller").click();
    tick().await;
    assert!(
        all(&container, "qprogram").is_empty(),
        "no Q programs without MOONS' drives"
    );
    let scl = GatewayStatus {
        index: 0,
        baud: None,
        health: None,
        kind: GatewayKind::Scl,
        port: "/dev/ttyUSB0".into(),
        link: LinkState::Up,
        bytes_per_s: 0.0,
        lowest_water_level: None,
        error: None,
        packets_per_s: None,
        late_frames: None,
        missed_replies: None,
        drives: Vec::new(),
    };
    ctx.receive(ServerMessage::Status(Status {
        gateways: vec![scl],
        ..Status::default()
    }));
    tick().await;
    set_value(&container, "qprogram-ball", "3", "input");
    element(&container, "qprogram-show").click();
    until("the program is shown", || {
        !all(&container, "qprogram-text").is_empty()
    })
    .await;
    assert_eq!(
        text(&container, "qprogram-summary"),
        "1 moves in 2 segments, 6 lines; largest deviation from the show 0.4 mm, at 0:01.5"
    );
    assert!(text(&container, "qprogram-text").contains("WI3F"));

    // A ball whose program would stray too far: the bridge's figure, no listing.
    set_value(&container, "qprogram-ball", "9", "input");
    tick().await;
    assert!(all(&container, "qprogram-text").is_empty(), "stale listing");
    element(&container, "qprogram-show").click();
    until("the refusal is shown", || {
        text(&container, "qprogram-error").contains("41.2 mm")
    })
    .await;
    // Not a number: said at once, nothing asked.
    set_value(&container, "qprogram-ball", "u3", "input");
    element(&container, "qprogram-show").click();
    tick().await;
    assert!(text(&container, "qprogram-error").contains("whole number"));
    assert_eq!(bridge.requests_to(Method::Get, "/api/qprogram/").len(), 2);
}

#[wasm_bindgen_test]
async fn local_files_survive_in_indexeddb() {
    let store = LocalStore::new("test-indexeddb");
    for name in ["a.csv", "b.json"] {
        store.delete(name).await.unwrap();
    }
    store
        .put(&LocalFile::new("a.csv", CSV.into(), 1.0).unwrap())
        .await
        .unwrap();
    store
        .put(&LocalFile::new("b.json", "{}".into(), 2.0).unwrap())
        .await
        .unwrap();
    store
        .put(&LocalFile::new("a.csv", "time_ms,u0\n".into(), 3.0).unwrap())
        .await
        .unwrap();
    let mut files = LocalStore::new("test-indexeddb").load_all().await.unwrap();
    files.sort_by(|a, b| a.name.cmp(&b.name));
    assert_eq!(files.len(), 2);
    assert_eq!(files[0].text, "time_ms,u0\n", "replaced by name");
    assert_eq!(files[1].name, "b.json");
    store.delete("a.csv").await.unwrap();
    let files = store.load_all().await.unwrap();
    assert_eq!(files.len(), 1);
}

// ----------------------------------------------------------------------------------
// Control
// ----------------------------------------------------------------------------------

fn playlist_bridge() -> Rc<FakeBridge> {
    FakeBridge::new(|request| match (request.method, request.url.as_str()) {
        (Method::Put, "/api/playlist") => response(204, ""),
        _ => response(404, ""),
    })
}

fn shown_order(container: &web_sys::HtmlElement) -> Vec<String> {
    all(container, "entry")
        .iter()
        .map(|entry| entry.get_attribute("data-show").unwrap())
        .collect()
}

fn stored_order(bridge: &FakeBridge) -> Vec<String> {
    let puts = bridge.requests_to(Method::Put, "/api/playlist");
    let body = puts.last().expect("a PUT").body.clone().unwrap();
    let playlist: Playlist = serde_json::from_str(&body).unwrap();
    playlist.entries.into_iter().map(|e| e.show).collect()
}

fn check_entry(container: &web_sys::HtmlElement, index: usize) {
    all(container, "entry-check")[index].click();
}

async fn mount_control(
    bridge: &Rc<FakeBridge>,
    socket: &Rc<FakeSocket>,
    database: &str,
) -> (web_sys::HtmlElement, Ctx) {
    let container = fresh_container();
    let ctx = context(bridge, socket, database);
    online(ctx);
    let mut editor = PlaylistEditor::new(Playlist::default());
    for show in ["a", "b", "c"] {
        editor.add(show);
    }
    ctx.playlist.set(editor);
    ctx.controller_files.update(|list| {
        list.replace(vec![summary("a"), summary("b"), summary("c"), summary("d")]);
    });
    let mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <ControlPage /> }
    });
    // Stays mounted for the rest of the test run, like the other tests' pages.
    std::mem::forget(mounted);
    tick().await;
    (container, ctx)
}

#[wasm_bindgen_test]
async fn playlist_moves_deletes_and_edits_the_checked_entries() {
    let bridge = playlist_bridge();
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-playlist").await;
    assert_eq!(shown_order(&container), ["a", "b", "c"]);

    check_entry(&container, 2);
    element(&container, "move-up").click();
    until("c moved up", || shown_order(&container) == ["a", "c", "b"]).await;
    assert_eq!(stored_order(&bridge), ["a", "c", "b"]);
    element(&container, "move-up").click();
    until("c at the top", || {
        shown_order(&container) == ["c", "a", "b"]
    })
    .await;
    element(&container, "move-down").click();
    until("c moved down", || {
        shown_order(&container) == ["a", "c", "b"]
    })
    .await;
    assert_eq!(stored_order(&bridge), ["a", "c", "b"]);

    // Edit the checked entry (c) and one more (a): the unchecked b keeps its values.
    check_entry(&container, 0);
    element(&container, "edit").click();
    tick().await;
    type_into(&container, "edit-delay", "2,5");
    type_into(&container, "edit-cycles", "0");
    element(&container, "edit-apply").click();
    tick().await;
    assert_eq!(
        text(&container, "edit-error"),
        "Cycles must be a whole number from 1 to 1000000"
    );
    type_into(&container, "edit-cycles", "3");
    element(&container, "edit-apply").click();
    until("the edit shows", || {
        all(&container, "entry-facts")
            .iter()
            .filter(|facts| facts.text_content().unwrap() == "2.5 s · ×3")
            .count()
            == 2
    })
    .await;
    let puts = bridge.requests_to(Method::Put, "/api/playlist");
    let stored: Playlist =
        serde_json::from_str(puts.last().unwrap().body.as_deref().unwrap()).unwrap();
    let values: Vec<_> = stored
        .entries
        .iter()
        .map(|e| (e.show.as_str(), e.delay_ms, e.cycles))
        .collect();
    assert_eq!(values, [("a", 2500, 3), ("c", 2500, 3), ("b", 0, 1)]);

    element(&container, "delete").click();
    until("both checked entries are gone", || {
        shown_order(&container) == ["b"]
    })
    .await;
    assert_eq!(stored_order(&bridge), ["b"]);

    // Add picks from the controller files.
    element(&container, "add").click();
    tick().await;
    all(&container, "pick-show")
        .into_iter()
        .find(|pick| pick.get_attribute("data-name").as_deref() == Some("d"))
        .unwrap()
        .click();
    until("d is added", || shown_order(&container) == ["b", "d"]).await;
    assert!(
        socket.sent.borrow().is_empty(),
        "editing sends no control message"
    );
    assert_eq!(ctx.playlist.get_untracked().entries().len(), 2);
}

#[wasm_bindgen_test]
async fn start_and_reset_ignore_the_checkboxes_and_status_is_live() {
    let bridge = playlist_bridge();
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-start").await;
    until("the plan is fetched", || {
        all(&container, "verdict")
            .iter()
            .all(|v| v.get_attribute("data-verdict").as_deref() == Some("unavailable"))
    })
    .await;
    assert_eq!(all(&container, "verdict").len(), 3);
    assert!(!disabled(&container, "start"));
    element(&container, "start").click();
    element(&container, "reset").click();
    tick().await;
    assert_eq!(
        *socket.sent.borrow(),
        [ClientMessage::start()],
        "Reset asks first"
    );
    element(&container, "confirm-yes").click();
    tick().await;
    assert_eq!(
        *socket.sent.borrow(),
        [ClientMessage::start(), ClientMessage::reset()]
    );

    ctx.receive(ServerMessage::Status(Status {
        state: PlayerState::Playing,
        entry: Some(1),
        show: Some("b".into()),
        show_time_ms: 1500,
        show_duration_ms: 2500,
        cycle: 1,
        progress: 0.6,
        ..Status::default()
    }));
    tick().await;
    let state = element(&container, "status-state");
    assert_eq!(
        state.get_attribute("data-state").as_deref(),
        Some("playing")
    );
    assert_eq!(text(&container, "status-show"), "b");
    assert_eq!(text(&container, "status-time"), "0:01.5 / 0:02.5");
    let bar =
        element(&container, "status-progress").unchecked_into::<web_sys::HtmlProgressElement>();
    assert!(
        (bar.value() - 0.6).abs() < 1e-9,
        "{} of {} {}",
        bar.value(),
        bar.max(),
        bar.outer_html()
    );

    ctx.receive(ServerMessage::Error {
        message: "change the password first".into(),
        code: String::new(),
        params: Default::default(),
        reason_problem: None,
        fix_problems: Vec::new(),
    });
    tick().await;
    assert!(text(&container, "bridge-error").contains("change the password first"));

    ctx.link.set(Link::Disconnected);
    tick().await;
    assert_eq!(
        element(&container, "status-state")
            .get_attribute("data-state")
            .as_deref(),
        Some("unknown"),
        "no stale status"
    );
    assert!(disabled(&container, "start"));
}

fn uim_gateway(level: u16) -> GatewayStatus {
    GatewayStatus {
        index: 0,
        baud: None,
        health: None,
        kind: GatewayKind::Uim2503,
        port: "sim".into(),
        link: LinkState::Up,
        bytes_per_s: 100.0,
        lowest_water_level: Some(level),
        error: None,
        packets_per_s: None,
        late_frames: None,
        missed_replies: None,
        drives: Vec::new(),
    }
}

fn is_playing(entry: &web_sys::HtmlElement) -> bool {
    entry.class_list().contains("playing")
}

#[wasm_bindgen_test]
async fn while_a_show_plays_the_playlist_is_locked_and_start_says_why() {
    let bridge = playlist_bridge();
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-locked").await;
    let icons = ["add", "move-up", "move-down", "delete", "edit"];
    assert!(icons.iter().all(|icon| !disabled(&container, icon)));
    assert!(all(&container, "playlist-locked").is_empty());
    element(&container, "add").click();
    tick().await;
    assert_eq!(all(&container, "add-panel").len(), 1);

    ctx.receive(ServerMessage::Status(Status {
        state: PlayerState::Playing,
        entry: Some(1),
        show: Some("b".into()),
        gateways: vec![uim_gateway(12)],
        ..Status::default()
    }));
    tick().await;
    for icon in icons {
        assert!(disabled(&container, icon), "{icon}");
    }
    assert!(
        all(&container, "add-panel").is_empty(),
        "the open panel closed"
    );
    assert!(text(&container, "playlist-locked").contains("cannot change while a show plays"));
    assert!(disabled(&container, "start"));
    assert!(text(&container, "start-reason").starts_with("A show is playing"));
    let entries = all(&container, "entry");
    assert_eq!(
        entries.iter().map(is_playing).collect::<Vec<_>>(),
        [false, true, false]
    );
    assert!(
        text(&container, "gateway").contains("buffered ahead: at least 12 rows"),
        "{}",
        text(&container, "gateway")
    );

    // A status naming another show at that place marks nothing.
    ctx.receive(ServerMessage::Status(Status {
        state: PlayerState::Playing,
        entry: Some(1),
        show: Some("c".into()),
        ..Status::default()
    }));
    tick().await;
    assert!(
        all(&container, "entry")
            .iter()
            .all(|entry| !is_playing(entry))
    );

    // In Chinese too.
    ctx.lang.set(Lang::Zh);
    tick().await;
    assert!(text(&container, "start-reason").contains("演出正在运行"));
    assert!(text(&container, "playlist-locked").contains("不能修改配置"));
    ctx.lang.set(Lang::En);

    ctx.receive(ServerMessage::Status(Status {
        gateways: vec![uim_gateway(12)],
        ..Status::default()
    }));
    tick().await;
    assert!(icons.iter().all(|icon| !disabled(&container, icon)));
    assert!(all(&container, "playlist-locked").is_empty());
    assert!(!disabled(&container, "start"));
    assert!(all(&container, "start-reason").is_empty());
    assert!(
        all(&container, "entry")
            .iter()
            .all(|entry| !is_playing(entry))
    );
    assert!(
        !text(&container, "gateway").contains("buffered"),
        "the buffer only while a show streams"
    );
    assert!(socket.sent.borrow().is_empty());
    assert!(bridge.requests_to(Method::Put, "/api/playlist").is_empty());
}

#[wasm_bindgen_test]
async fn an_edit_the_bridge_refuses_as_locked_says_so_in_the_chosen_language() {
    let bridge = FakeBridge::new(|request| match (request.method, request.url.as_str()) {
        (Method::Put, "/api/playlist") => response(
            409,
            r#"{"error":"the playlist cannot change while the matrix is playing; press E-stop or wait until it is idle (loop and defaults may change)","code":"playlist_locked"}"#,
        ),
        _ => response(404, ""),
    });
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-locked-refusal").await;
    ctx.lang.set(Lang::Zh);
    check_entry(&container, 0);
    element(&container, "delete").click();
    until("the refusal shows", || {
        !all(&container, "control-note").is_empty()
    })
    .await;
    assert!(
        text(&container, "control-note").contains("不能修改配置"),
        "{}",
        text(&container, "control-note")
    );
    ctx.lang.set(Lang::En);
}

#[wasm_bindgen_test]
async fn a_refused_start_and_a_failed_verdict_read_in_the_chosen_language() {
    let bridge = FakeBridge::new(|request| match (request.method, request.url.as_str()) {
        (Method::Get, url) if url.starts_with("/api/plan/") => response(500, "boom"),
        _ => response(404, ""),
    });
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-refused-start").await;
    until("the verdicts fail", || {
        let verdicts = all(&container, "verdict");
        !verdicts.is_empty()
            && verdicts
                .iter()
                .all(|v| v.get_attribute("data-verdict").as_deref() == Some("failed"))
    })
    .await;
    assert!(text(&container, "verdict").contains("The controller failed (HTTP 500)"));
    // The failure is worded when shown: it follows a language switch.
    ctx.lang.set(Lang::Zh);
    tick().await;
    assert!(
        text(&container, "verdict").contains("控制器出错（HTTP 500）"),
        "{}",
        text(&container, "verdict")
    );

    element(&container, "start").click();
    tick().await;
    assert_eq!(*socket.sent.borrow(), [ClientMessage::start()]);
    let param = |pairs: &[(&str, &str)]| {
        pairs
            .iter()
            .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
            .collect()
    };
    ctx.receive(ServerMessage::Error {
        message: "entry 1 (\"a\") cannot run: gateway sim (9600 baud) cannot keep its 100 \
                  units fed. To make it run: raise the line to 19200 baud"
            .into(),
        code: "entry_infeasible".into(),
        params: param(&[
            ("entry", "1"),
            ("show", "a"),
            (
                "reason",
                "gateway sim (9600 baud) cannot keep its 100 units fed",
            ),
            ("fixes", "raise the line to 19200 baud"),
        ]),
        reason_problem: Some(Box::new(Problem {
            code: "line_starved_during".into(),
            params: param(&[
                ("gateway", "sim"),
                ("baud", "9600"),
                ("units", "100"),
                ("show", "a"),
                ("needed_bytes_per_s", "1342"),
                ("available_bytes_per_s", "960"),
                ("preload_rows", "255"),
            ]),
        })),
        fix_problems: vec![Problem {
            code: "fix_faster_line".into(),
            params: param(&[("baud", "19200")]),
        }],
    });
    tick().await;
    let refusal = text(&container, "bridge-error");
    assert!(
        refusal.contains("第 1 项（“a”）无法运行：网关 sim（9600 波特）供不上它的 100 个单元")
            && refusal.contains("建议：把线路提高到 19200 波特"),
        "{refusal}"
    );
    assert!(
        !refusal.contains("baud)") && !refusal.contains("To make it run"),
        "{refusal}"
    );
    ctx.lang.set(Lang::En);
    tick().await;
    let refusal = text(&container, "bridge-error");
    assert!(
        refusal.contains("Entry 1 (\"a\") cannot run: gateway sim (9600 baud)")
            && refusal.contains("To make it run: raise the line to 19200 baud"),
        "{refusal}"
    );
}

#[wasm_bindgen_test]
async fn reset_home_and_start_after_an_estop_ask_first_and_homing_shows_its_progress() {
    let bridge = playlist_bridge();
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-confirm").await;
    ctx.receive(ServerMessage::Status(Status {
        state: PlayerState::Playing,
        entry: Some(0),
        show: Some("a".into()),
        ..Status::default()
    }));
    tick().await;

    // Reset: the confirmation says what moves; Cancel sends nothing.
    element(&container, "reset").click();
    tick().await;
    assert_eq!(attribute(&container, "confirm", "data-action"), "reset");
    assert_eq!(
        text(&container, "confirm-yes"),
        "Confirm: every ball moves home, then the playlist starts again"
    );
    element(&container, "confirm-cancel").click();
    tick().await;
    assert!(all(&container, "confirm").is_empty());
    assert!(socket.sent.borrow().is_empty());
    element(&container, "reset").click();
    tick().await;
    element(&container, "confirm-yes").click();
    tick().await;
    assert_eq!(*socket.sent.borrow(), [ClientMessage::reset()]);
    assert!(all(&container, "confirm").is_empty());

    // The E-stop never asks; its badge clears once the matrix leaves `stopped`.
    element(&container, "estop").click();
    tick().await;
    assert_eq!(
        *socket.sent.borrow(),
        [ClientMessage::reset(), ClientMessage::Estop]
    );
    assert!(all(&container, "confirm").is_empty());
    assert_eq!(text(&container, "estop-ack"), "E-stop sent");
    ctx.receive(ServerMessage::Status(Status {
        state: PlayerState::Stopped,
        ..Status::default()
    }));
    tick().await;
    assert_eq!(text(&container, "estop-ack"), "Stopped");

    // Start after an E-stop: the balls home first, and the confirmation says so.
    element(&container, "start").click();
    tick().await;
    assert_eq!(socket.sent.borrow().len(), 2);
    assert_eq!(
        text(&container, "confirm-yes"),
        "Confirm: every ball moves home, then to the first show's start, and the playlist plays"
    );
    element(&container, "confirm-cancel").click();
    tick().await;
    // Asked after a stop, a Start confirmation goes once the matrix is idle again.
    element(&container, "start").click();
    tick().await;
    ctx.receive(ServerMessage::Status(Status::default()));
    tick().await;
    assert!(all(&container, "confirm").is_empty());
    ctx.receive(ServerMessage::Status(Status {
        state: PlayerState::Stopped,
        ..Status::default()
    }));
    tick().await;
    assert!(
        all(&container, "confirm").is_empty(),
        "it does not come back"
    );
    assert_eq!(socket.sent.borrow().len(), 2);

    // Home: every ball home, then idle.
    element(&container, "home").click();
    tick().await;
    assert_eq!(
        text(&container, "confirm-yes"),
        "Confirm: every ball moves home and stays there"
    );
    element(&container, "confirm-yes").click();
    tick().await;
    assert_eq!(socket.sent.borrow().last(), Some(&ClientMessage::Home));

    ctx.receive(ServerMessage::Status(Status {
        state: PlayerState::Homing,
        progress: 0.5,
        ..Status::default()
    }));
    tick().await;
    assert_eq!(
        text(&container, "status-time"),
        "Homing… 50 %",
        "not a show's time"
    );
    let bar =
        element(&container, "status-progress").unchecked_into::<web_sys::HtmlProgressElement>();
    assert!((bar.value() - 0.5).abs() < 1e-9);
    assert_eq!(text(&container, "estop-ack"), "", "the badge cleared");
    assert_eq!(attribute(&container, "estop", "data-ack"), "ready");

    // Idle again: Start plays without asking.
    ctx.receive(ServerMessage::Status(Status::default()));
    tick().await;
    assert_eq!(text(&container, "status-time"), "");
    element(&container, "start").click();
    tick().await;
    assert_eq!(socket.sent.borrow().last(), Some(&ClientMessage::start()));
    assert!(all(&container, "confirm").is_empty());
}

#[wasm_bindgen_test]
async fn start_begins_at_the_entry_and_time_typed_beside_it() {
    let bridge = FakeBridge::new(|request| match (request.method, request.url.as_str()) {
        (Method::Get, url) if url.starts_with("/api/plan/") => response(500, "boom"),
        _ => response(404, ""),
    });
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-start-from").await;
    until("the verdicts fail", || {
        let verdicts = all(&container, "verdict");
        !verdicts.is_empty()
            && verdicts
                .iter()
                .all(|v| v.get_attribute("data-verdict").as_deref() == Some("failed"))
    })
    .await;
    // A time that does not read: nothing is sent, the note says what is expected.
    type_into(&container, "start-time", "1:75");
    element(&container, "start").click();
    tick().await;
    assert!(
        socket.sent.borrow().is_empty(),
        "{:?}",
        socket.sent.borrow()
    );
    assert!(
        text(&container, "control-note").contains("m:ss"),
        "{}",
        text(&container, "control-note")
    );
    type_into(&container, "start-entry", "2");
    type_into(&container, "start-time", "1:30");
    element(&container, "start").click();
    tick().await;
    assert_eq!(
        *socket.sent.borrow(),
        [ClientMessage::Start(StartFrom {
            entry: Some(2),
            time_ms: Some(90_000)
        })]
    );
    // The Preview opens entry 2's show, to wait at that time.
    element(&container, "start-preview").click();
    tick().await;
    assert_eq!(ctx.page.get_untracked(), Page::Preview);
    assert_eq!(ctx.preview_from_ms.get_untracked(), Some(90_000));
    let previewed = ctx.preview.with_untracked(|item| match item {
        Some(PreviewItem::Loading(name) | PreviewItem::Failed(name, _)) => Some(name.clone()),
        _ => None,
    });
    assert_eq!(previewed.as_deref(), Some("b"));
}

#[wasm_bindgen_test]
async fn an_infeasible_show_blocks_start_and_says_why() {
    let bridge = FakeBridge::new(|request| {
        if request.url.starts_with("/api/plan/") {
            let feasible = !request.url.ends_with("/b");
            response(
                200,
                &serde_json::json!({
                    "show": "x",
                    "feasible": feasible,
                    "reason": if feasible { None } else { Some("9600 baud carries 960 B/s; the show needs 2400 B/s") },
                    "fixes": if feasible { vec![] } else { vec!["raise the baud rate to 38400"] },
                    "gateways": []
                })
                .to_string(),
            )
        } else {
            response(204, "")
        }
    });
    let socket = Rc::new(FakeSocket::default());
    let (container, _ctx) = mount_control(&bridge, &socket, "test-plan").await;
    until("the verdicts arrive", || {
        all(&container, "verdict")
            .iter()
            .any(|v| v.get_attribute("data-verdict").as_deref() == Some("infeasible"))
    })
    .await;
    let verdicts = all(&container, "verdict");
    let bad = verdicts
        .iter()
        .find(|v| v.get_attribute("data-verdict").as_deref() == Some("infeasible"))
        .unwrap()
        .text_content()
        .unwrap();
    assert!(
        bad.contains("cannot run") && bad.contains("2400 B/s") && bad.contains("38400"),
        "{bad}"
    );
    assert!(disabled(&container, "start"));
}

#[wasm_bindgen_test]
async fn a_chinese_ui_says_why_a_show_cannot_run_in_chinese() {
    let bridge = FakeBridge::new(|request| {
        if request.url.starts_with("/api/plan/") {
            response(
                200,
                &serde_json::json!({
                    "show": "x",
                    "feasible": false,
                    "reason": "gateway sim (9600 baud) cannot keep its 100 units fed",
                    "fixes": ["raise the line to 38400 baud"],
                    "reason_problem": {"code": "line_starved", "params": {
                        "gateway": "sim", "baud": "9600", "units": "100", "show": "x",
                        "needed_bytes_per_s": "2400", "available_bytes_per_s": "960",
                        "dry_at_s": "1.5", "preload_rows": "256"}},
                    "fix_problems": [{"code": "fix_faster_line", "params": {"baud": "38400"}}],
                    "gateways": []
                })
                .to_string(),
            )
        } else {
            response(204, "")
        }
    });
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-plan-zh").await;
    ctx.lang.set(Lang::Zh);
    let infeasible = || {
        all(&container, "verdict")
            .into_iter()
            .find(|v| v.get_attribute("data-verdict").as_deref() == Some("infeasible"))
            .and_then(|v| v.text_content())
    };
    until("the verdicts arrive", || infeasible().is_some()).await;
    let zh = infeasible().unwrap();
    assert!(
        zh.contains("网关 sim（9600 波特）供不上它的 100 个单元")
            && zh.contains("1.5 秒后用尽")
            && zh.contains("把线路提高到 38400 波特"),
        "{zh}"
    );
    assert!(
        !zh.contains("cannot keep") && !zh.contains("raise the line"),
        "{zh}"
    );
    ctx.lang.set(Lang::En);
    until("the verdict reads in English", || {
        infeasible().is_some_and(|en| en.contains("cannot keep its 100 units fed"))
    })
    .await;
}

#[wasm_bindgen_test]
async fn settings_store_the_defaults_and_the_loop_flag() {
    let container = fresh_container();
    let bridge = playlist_bridge();
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-settings");
    online(ctx);
    let _mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <SettingsPage /> }
    });
    tick().await;
    type_into(&container, "default-delay", "abc");
    element(&container, "settings-apply").click();
    tick().await;
    assert_eq!(
        text(&container, "settings-error"),
        "The delay must be a number of seconds from 0 to 86400"
    );
    assert!(bridge.requests.borrow().is_empty());

    type_into(&container, "default-delay", "1.5");
    type_into(&container, "default-cycles", "4");
    element(&container, "loop").click();
    element(&container, "settings-apply").click();
    until("the settings are stored", || {
        all(&container, "settings-saved").len() == 1
    })
    .await;
    let puts = bridge.requests_to(Method::Put, "/api/playlist");
    let stored: Playlist = serde_json::from_str(puts[0].body.as_deref().unwrap()).unwrap();
    assert_eq!(
        (
            stored.default_delay_ms,
            stored.default_cycles,
            stored.loop_playlist
        ),
        (1500, 4, true)
    );
    ctx.playlist.update(|editor| editor.add("new"));
    let entry = ctx.playlist.get_untracked().entries()[0].clone();
    assert_eq!(
        (entry.delay_ms, entry.cycles),
        (1500, 4),
        "new entries get the defaults"
    );
}

// ----------------------------------------------------------------------------------
// Console
// ----------------------------------------------------------------------------------

#[wasm_bindgen_test]
async fn console_checks_before_sending_and_decodes_feedback() {
    let (container, ctx, socket, _) = mount_online("test-console", || view! { <ConsolePage /> });
    type_into(&container, "console-input", "*5;\nQT[3]=0;");
    tick().await;
    let check = element(&container, "console-check");
    assert_eq!(check.get_attribute("data-state").as_deref(), Some("error"));
    assert!(text(&container, "console-check").starts_with("line 2, column"));
    assert!(disabled(&container, "console-send"));

    type_into(&container, "console-input", "*5;PV;\n# a comment\n*0;MO=0;");
    tick().await;
    assert_eq!(
        element(&container, "console-check")
            .get_attribute("data-state")
            .as_deref(),
        Some("ok")
    );
    element(&container, "console-send").click();
    tick().await;
    assert_eq!(
        *socket.sent.borrow(),
        [
            ClientMessage::Raw {
                line: "*5;PV;".into(),
                gateway: None
            },
            ClientMessage::Raw {
                line: "*0;MO=0;".into(),
                gateway: None
            }
        ]
    );

    ctx.receive(ServerMessage::Feedback(FeedbackFrame {
        gateway: 0,
        station: 5,
        code: 0x23,
        data: vec![3, 0],
    }));
    tick().await;
    let lines = all(&container, "feedback-line");
    assert_eq!(lines.len(), 1);
    let line = lines[0].text_content().unwrap();
    assert!(line.contains("gw0 #5") && line.contains("PV = 3"), "{line}");
}

/// A status of two MBOX boxes: .201 up, .202 down with counts.
fn mbox_status() -> Status {
    let mbox = |port: &str, link, packets, late, missed| GatewayStatus {
        index: 0,
        baud: None,
        health: None,
        kind: GatewayKind::Mbox,
        port: port.into(),
        link,
        bytes_per_s: 0.0,
        lowest_water_level: None,
        error: None,
        packets_per_s: Some(packets),
        late_frames: Some(late),
        missed_replies: Some(missed),
        drives: Vec::new(),
    };
    Status {
        gateways: vec![
            mbox("192.168.15.201:7408", LinkState::Up, 52.0, 0, 1),
            mbox("192.168.15.202:7408", LinkState::Down, 2.0, 4, 7),
        ],
        ..Status::default()
    }
}

#[wasm_bindgen_test]
async fn console_on_mbox_boxes_checks_box_commands_helps_and_shows_replies() {
    let (container, ctx, socket, _) =
        mount_online("test-console-mbox", || view! { <ConsolePage /> });
    tick().await;
    assert!(
        all(&container, "console-help").is_empty(),
        "no MBOX help on UIM2503"
    );
    ctx.receive(ServerMessage::Status(mbox_status()));
    tick().await;
    let help = text(&container, "console-help");
    assert!(
        help.contains("Box commands") && help.contains("read FN|DN"),
        "{help}"
    );
    assert!(text(&container, "console-check").contains("read FN 0x20 4"));

    // The MBOX parser, with its line and column; UIM2503 text is not box text.
    type_into(&container, "console-input", "reset\nread FX 0x20 4");
    tick().await;
    assert_eq!(
        attribute(&container, "console-check", "data-state"),
        "error"
    );
    assert!(text(&container, "console-check").starts_with("line 2, column 6"));
    assert!(disabled(&container, "console-send"));
    type_into(&container, "console-input", "*5;PV;");
    tick().await;
    assert_eq!(
        attribute(&container, "console-check", "data-state"),
        "error"
    );
    // `@201` needs the selected box's subnet: refused for every box, fine for box 0.
    type_into(&container, "console-input", "@201 reset");
    tick().await;
    assert_eq!(
        attribute(&container, "console-check", "data-state"),
        "error"
    );
    set_value(&container, "console-gateway", "0", "change");
    tick().await;
    assert_eq!(attribute(&container, "console-check", "data-state"), "ok");

    type_into(
        &container,
        "console-input",
        "read FN 0x20 4 # the IP\n\n@all/none estop",
    );
    tick().await;
    assert_eq!(attribute(&container, "console-check", "data-state"), "ok");
    element(&container, "console-send").click();
    tick().await;
    assert_eq!(
        *socket.sent.borrow(),
        [
            ClientMessage::Raw {
                line: "read FN 0x20 4 # the IP".into(),
                gateway: Some(0)
            },
            ClientMessage::Raw {
                line: "@all/none estop".into(),
                gateway: Some(0)
            }
        ]
    );

    assert!(text(&container, "feedback-list").contains("No replies from the boxes yet."));
    ctx.receive(ServerMessage::MboxReply(MboxReply {
        gateway: 0,
        text: "FN0020..FN0023 = 192 168 15 201".into(),
        registers: MboxRegisters {
            bank: "FN".into(),
            start: 0x20,
            values: vec![192, 168, 15, 201],
        },
    }));
    tick().await;
    let lines = all(&container, "feedback-line");
    assert_eq!(lines.len(), 1);
    let line = lines[0].text_content().unwrap();
    assert!(
        line.contains("gw0")
            && line.contains("FN0020..FN0023 = 192 168 15 201")
            && line.contains("00C0 00A8 000F 00C9"),
        "{line}"
    );
    ctx.lang.set(Lang::Zh);
    tick().await;
    assert!(text(&container, "console-help").contains("控制盒命令"));
}

/// A status of one RS-485 line of MOONS' drives.
fn scl_status() -> Status {
    Status {
        gateways: vec![GatewayStatus {
            index: 0,
            baud: None,
            health: None,
            kind: GatewayKind::Scl,
            port: "/dev/ttyUSB0".into(),
            link: LinkState::Up,
            bytes_per_s: 0.0,
            lowest_water_level: None,
            error: None,
            packets_per_s: None,
            late_frames: None,
            missed_replies: None,
            drives: Vec::new(),
        }],
        ..Status::default()
    }
}

#[wasm_bindgen_test]
async fn console_on_moons_drives_checks_scl_lines_helps_and_shows_answers() {
    let (container, ctx, socket, _) =
        mount_online("test-console-scl", || view! { <ConsolePage /> });
    ctx.receive(ServerMessage::Status(scl_status()));
    tick().await;
    let help = text(&container, "console-help");
    assert!(
        help.contains("SCL commands") && help.contains("0IP"),
        "{help}"
    );
    assert!(text(&container, "console-check").contains("0IP"));

    // The SCL parser, with its line and column; UIM2503 text is not SCL.
    type_into(&container, "console-input", "0IP\n0XX5");
    tick().await;
    assert_eq!(
        attribute(&container, "console-check", "data-state"),
        "error"
    );
    assert!(
        text(&container, "console-check").starts_with("line 2"),
        "{}",
        text(&container, "console-check")
    );
    assert!(disabled(&container, "console-send"));
    type_into(&container, "console-input", "*5;PV;");
    tick().await;
    assert_eq!(
        attribute(&container, "console-check", "data-state"),
        "error"
    );

    type_into(&container, "console-input", "0VE2.5\n\n0IP");
    tick().await;
    assert_eq!(attribute(&container, "console-check", "data-state"), "ok");
    element(&container, "console-send").click();
    tick().await;
    assert_eq!(
        *socket.sent.borrow(),
        [
            ClientMessage::Raw {
                line: "0VE2.5".into(),
                gateway: None
            },
            ClientMessage::Raw {
                line: "0IP".into(),
                gateway: None
            }
        ]
    );

    assert!(text(&container, "feedback-list").contains("No answers yet"));
    ctx.receive(ServerMessage::SclReply(SclReply {
        gateway: 0,
        drive: "0".into(),
        request: "0IP".into(),
        text: "IP = -1200".into(),
        raw: "0IP=-1200".into(),
    }));
    tick().await;
    let lines = all(&container, "feedback-line");
    assert_eq!(lines.len(), 1);
    let line = lines[0].text_content().unwrap();
    assert!(
        line.contains("gw0") && line.contains("0IP → IP = -1200") && line.contains("0IP=-1200"),
        "{line}"
    );
    ctx.lang.set(Lang::Zh);
    tick().await;
    assert!(text(&container, "console-help").contains("鸣志驱动器"));
}

#[wasm_bindgen_test]
async fn the_status_shows_mbox_boxes_with_packets_late_frames_and_missed_replies() {
    let bridge = playlist_bridge();
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-status-mbox").await;
    ctx.receive(ServerMessage::Status(mbox_status()));
    tick().await;
    let boxes: Vec<String> = all(&container, "gateway")
        .iter()
        .map(|gateway| gateway.text_content().unwrap())
        .collect();
    assert_eq!(
        boxes,
        [
            "192.168.15.201:7408: up · 52 packets/s · late frames 0 · missed replies 1",
            "192.168.15.202:7408: down · 2 packets/s · late frames 4 · missed replies 7",
        ]
    );
    assert_eq!(
        all(&container, "gateway")[1]
            .get_attribute("data-link")
            .as_deref(),
        Some("down")
    );
    ctx.lang.set(Lang::Zh);
    tick().await;
    let first = all(&container, "gateway")[0].text_content().unwrap();
    assert!(first.contains("52 包/秒 · 迟发帧 0 · 未应答 1"), "{first}");
}

// ----------------------------------------------------------------------------------
// A show for the file tests (the preview's own tests are in tests/preview.rs)
// ----------------------------------------------------------------------------------

fn two_ball_show() -> Show {
    let track = |to_mm| Track {
        start_mm: to_mm,
        rows: vec![
            TrackRow::new(to_mm, 0.0, 250),
            TrackRow::new(to_mm, 0.0, 250),
            TrackRow::new(to_mm, 0.0, 250),
            TrackRow::new(to_mm, 0.0, 250),
        ],
        colours: Vec::new(),
    };
    Show {
        outputs: Vec::new(),
        name: "two".into(),
        layout: Layout {
            rows: 1,
            cols: 2,
            pitch_mm: 500.0,
        },
        tracks: vec![track(100.0), track(7000.0)],
    }
}

// ----------------------------------------------------------------------------------
// Layout: the compact status line, the Preview's folding lists, mm in the console
// ----------------------------------------------------------------------------------

#[wasm_bindgen_test]
async fn the_status_line_shows_state_show_time_and_progress_and_opens_control() {
    let (container, ctx, _, _) = mount_online("test-statusbar", || view! { <StatusBar /> });
    tick().await;
    assert!(all(&container, "statusbar").is_empty(), "no status yet");
    ctx.receive(ServerMessage::Status(Status {
        state: PlayerState::Playing,
        show: Some("wave".into()),
        show_time_ms: 2_000,
        show_duration_ms: 8_000,
        progress: 0.25,
        ..Status::default()
    }));
    tick().await;
    assert_eq!(
        attribute(&container, "statusbar-state", "data-state"),
        "playing"
    );
    assert_eq!(text(&container, "statusbar-state"), "playing");
    assert_eq!(text(&container, "statusbar-show"), "wave");
    assert_eq!(text(&container, "statusbar-time"), "0:02.0 / 0:08.0");
    let fill = element(&container, "statusbar-progress")
        .first_element_child()
        .expect("the bar's fill");
    assert_eq!(fill.get_attribute("style").as_deref(), Some("width: 25.0%"));
    ctx.lang.set(Lang::Zh);
    tick().await;
    assert_eq!(text(&container, "statusbar-state"), "运行中");

    element(&container, "statusbar").click();
    tick().await;
    assert_eq!(ctx.page.get_untracked(), Page::Control);

    // Idle: no progress; gone when the link is.
    ctx.receive(ServerMessage::Status(Status::default()));
    tick().await;
    assert!(all(&container, "statusbar-progress").is_empty());
    ctx.link.set(Link::Disconnected);
    tick().await;
    assert!(all(&container, "statusbar").is_empty());
}

#[wasm_bindgen_test]
async fn the_preview_folds_its_lists_once_a_show_is_chosen() {
    let (container, ctx, _, _) = mount_online("test-preview-fold", || view! { <PreviewScreen /> });
    with_local_file(ctx);
    tick().await;
    let folded = || {
        element(&container, "preview-chooser")
            .class_list()
            .contains("collapsed")
    };
    assert!(!folded(), "nothing chosen: the lists are open");
    element(&container, "preview-pick-local").click();
    tick().await;
    assert!(folded(), "a show chosen: the lists fold away");
    assert_eq!(text(&container, "preview-name"), "wave.csv");
    element(&container, "preview-choose-another").click();
    tick().await;
    assert!(!folded(), "Choose another show opens them again");
    element(&container, "preview-pick-local").click();
    tick().await;
    assert!(folded());
}

#[wasm_bindgen_test]
async fn the_console_gives_positions_in_mm_once_the_installation_is_known() {
    let container = fresh_container();
    let bridge = FakeBridge::new(|request| {
        if request.url.ends_with("/api/installation") {
            response(
                200,
                r#"{"rows": 1, "cols": 2, "pitch_mm": 500.0, "travel_mm": 7500.0,
                    "max_speed_mm_s": 2000.0, "max_accel_mm_s2": 4000.0, "home_mm": 0.0,
                    "approach_speed_mm_s": 250.0, "counts_per_mm": 500.0,
                    "gateways": [{"port": "sim", "stations": [5, 6]}]}"#,
            )
        } else {
            response(500, "")
        }
    });
    let socket = Rc::new(FakeSocket::default());
    let ctx = context(&bridge, &socket, "test-console-mm");
    online(ctx);
    // The app fetches the installation on every connection; here without the app.
    ctx.load_installation();
    let _mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <ConsolePage /> }
    });
    until("the installation", || {
        ctx.feedback
            .with_untracked(|log| log.installation().is_some())
    })
    .await;
    let pa = |station| {
        ServerMessage::Feedback(FeedbackFrame {
            gateway: 0,
            station,
            code: 0x20,
            data: 200_000_i32.to_le_bytes().to_vec(),
        })
    };
    ctx.receive(pa(5));
    ctx.receive(pa(9));
    tick().await;
    let lines: Vec<_> = all(&container, "feedback-line")
        .iter()
        .map(|line| line.text_content().unwrap_or_default())
        .collect();
    assert!(
        lines[0].contains("PA = 200000") && !lines[0].contains("mm"),
        "{lines:?}"
    );
    assert!(lines[1].contains("PA = 200000 (400.0 mm)"), "{lines:?}");
}

// ---- app-install ----

fn installation_json(max_speed_mm_s: f64) -> String {
    serde_json::json!({
        "rows": 10, "cols": 10, "pitch_mm": 500.0, "travel_mm": 7500.0,
        "max_speed_mm_s": max_speed_mm_s, "max_accel_mm_s2": 4000.0, "home_mm": 0.0,
        "approach_speed_mm_s": 250.0, "counts_per_mm": 100.0,
        "gateways": [{"port": "sim", "baud": 115200, "stations": (1..=100).collect::<Vec<u32>>()}]
    })
    .to_string()
}

fn field_value(container: &web_sys::HtmlElement, test_id: &str) -> String {
    element(container, test_id)
        .unchecked_into::<web_sys::HtmlInputElement>()
        .value()
}

#[wasm_bindgen_test]
async fn the_installation_page_lists_every_problem_and_shows_what_was_saved() {
    let puts = Rc::new(Cell::new(0));
    let counted = Rc::clone(&puts);
    let bridge = FakeBridge::new(
        move |request| match (request.method, request.url.as_str()) {
            (Method::Get, "/api/installation") => response(200, &installation_json(2000.0)),
            (Method::Put, "/api/installation") => {
                counted.set(counted.get() + 1);
                if counted.get() == 1 {
                    response(
                    422,
                    &serde_json::json!({
                        "error": "the installation has 2 problems",
                        "code": "installation_invalid",
                        "params": {"problems": "2"},
                        "details": ["pitch_mm = -1 must be a number above 0", "travel_mm = 0 must be a number above 0"],
                        "problems": [
                            {"code": "installation_problem", "params": {"reason": "pitch_mm = -1 must be a number above 0"}},
                            {"code": "installation_problem", "params": {"reason": "travel_mm = 0 must be a number above 0"}}
                        ]
                    })
                    .to_string(),
                )
                } else {
                    response(200, &installation_json(1500.0))
                }
            }
            _ => response(500, ""),
        },
    );
    let socket = Rc::new(FakeSocket::default());
    let container = fresh_container();
    let ctx = context(&bridge, &socket, "test-installation");
    online(ctx);
    let mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <InstallationPage /> }
    });
    std::mem::forget(mounted);
    until("the installation is shown", || {
        !all(&container, "installation-form").is_empty()
    })
    .await;
    assert_eq!(field_value(&container, "rows"), "10");
    assert_eq!(field_value(&container, "max_speed_mm_s"), "2000");
    assert_eq!(field_value(&container, "gateway-port"), "sim");
    assert_eq!(field_value(&container, "gateway-stations"), "1-100");
    assert_eq!(text(&container, "gateway-summary"), "100 units: 1-100");

    // What cannot be read is listed, and nothing is sent.
    type_into(&container, "pitch_mm", "wide");
    type_into(&container, "gateway-baud", "fast");
    element(&container, "installation-save").click();
    tick().await;
    assert_eq!(puts.get(), 0);
    assert_eq!(
        attribute(&container, "installation-problems", "data-total"),
        "2"
    );
    let listed = text(&container, "installation-problems");
    assert!(listed.contains("Pitch (mm): cannot be read"), "{listed}");
    assert!(
        listed.contains("Gateways 1, Line speed (baud): cannot be read"),
        "{listed}"
    );

    // The bridge's 422: every problem listed.
    type_into(&container, "pitch_mm", "-1");
    type_into(&container, "gateway-baud", "115200");
    type_into(&container, "travel_mm", "0");
    element(&container, "installation-save").click();
    until("the refusal is shown", || {
        !all(&container, "installation-error").is_empty()
    })
    .await;
    assert_eq!(puts.get(), 1);
    assert_eq!(
        attribute(&container, "installation-problems", "data-total"),
        "2"
    );
    let listed = text(&container, "installation-problems");
    assert!(
        listed.contains("pitch_mm = -1") && listed.contains("travel_mm = 0"),
        "{listed}"
    );
    let sent: serde_json::Value = serde_json::from_str(
        bridge.requests_to(Method::Put, "/api/installation")[0]
            .body
            .as_deref()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(sent["pitch_mm"], -1.0);
    assert_eq!(
        sent["gateways"][0]["stations"].as_array().map(Vec::len),
        Some(100)
    );

    // A save that succeeds shows the bridge's answer and feeds the preview.
    type_into(&container, "pitch_mm", "500");
    type_into(&container, "travel_mm", "7500");
    type_into(&container, "max_speed_mm_s", "1500");
    element(&container, "installation-save").click();
    until("the save is confirmed", || {
        !all(&container, "installation-saved").is_empty()
    })
    .await;
    assert_eq!(field_value(&container, "max_speed_mm_s"), "1500");
    assert!(all(&container, "installation-problems").is_empty());
    assert_eq!(
        ctx.installation
            .get_untracked()
            .map(|info| info.max_speed_mm_s),
        Some(1500.0)
    );
}

#[wasm_bindgen_test]
async fn control_warns_about_units_and_shows_armed_not_answering_and_the_preload() {
    let bridge = FakeBridge::new(|request| {
        if request.url.starts_with("/api/plan/") {
            response(
                200,
                &serde_json::json!({
                    "show": "x", "feasible": true, "fixes": [], "gateways": [],
                    "preload_ms": 546_000,
                    "advice": [{"code": "no_such_advice_code", "params": {}}]
                })
                .to_string(),
            )
        } else {
            response(204, "")
        }
    });
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-health").await;
    until("the verdicts arrive", || {
        !all(&container, "verdict-preload").is_empty()
    })
    .await;
    assert_eq!(text(&container, "verdict-preload"), " · preload 9.1 min");
    assert!(text(&container, "verdict-advice").contains("no_such_advice_code"));
    assert!(
        all(&container, "units-warning").is_empty(),
        "nothing known, no warning"
    );

    let gateway = GatewayStatus {
        index: 0,
        kind: GatewayKind::Uim2503,
        port: "/dev/ttyUSB0".into(),
        link: LinkState::NotAnswering,
        bytes_per_s: 0.0,
        lowest_water_level: None,
        error: None,
        packets_per_s: None,
        late_frames: None,
        missed_replies: None,
        drives: Vec::new(),
        baud: Some(9600),
        health: Some(floatball_shared::api::UnitHealth {
            expected: 100,
            answering: 98,
            missing: vec![4, 9],
            faults: vec![floatball_shared::api::UnitFault {
                station: 3,
                error: 0x37,
                code: 0,
                index: 0,
            }],
            ..Default::default()
        }),
    };
    ctx.receive(ServerMessage::Status(Status {
        gateways: vec![gateway.clone()],
        armed: Some(floatball_shared::api::ArmedShow {
            entry: 0,
            show: "a".into(),
            progress: 0.5,
        }),
        ..Status::default()
    }));
    tick().await;
    let warning = text(&container, "units-warning");
    assert!(
        warning.contains("98 of 100 units answer") && warning.contains("missing stations 4, 9"),
        "{warning}"
    );
    assert!(warning.contains("station 3: "), "{warning}");
    assert_eq!(
        attribute(&container, "gateway", "data-link"),
        "not_answering"
    );
    assert!(text(&container, "gateway").contains("not answering"));
    assert_eq!(text(&container, "status-armed"), "a: Loading ahead 50%");

    // All well: the warning goes.
    let mut well = gateway;
    well.link = LinkState::Up;
    well.health = Some(floatball_shared::api::UnitHealth {
        expected: 100,
        answering: 100,
        ..Default::default()
    });
    ctx.receive(ServerMessage::Status(Status {
        gateways: vec![well],
        ..Status::default()
    }));
    tick().await;
    assert!(all(&container, "units-warning").is_empty());
    assert!(all(&container, "status-armed").is_empty());
}

// ---- appscale ----

/// Gateway `index` of a 100-gateway installation on the network: up, or down with a
/// reason.
fn network_gateway(index: usize, link: LinkState) -> GatewayStatus {
    GatewayStatus {
        index,
        port: format!("tcp://10.0.1.{index}:4001"),
        link,
        bytes_per_s: if link == LinkState::Up { 1380.0 } else { 0.0 },
        lowest_water_level: Some(40 + (index % 7) as u16),
        error: (link != LinkState::Up).then(|| "connection refused".into()),
        ..uim_gateway(0)
    }
}

/// An installation of `count` gateways of `kind` at the ports [`network_gateway`]
/// gives (MBOX boxes at their addresses).
fn many_gateways(count: usize, kind: GatewayKind) -> floatball_shared::api::InstallationInfo {
    let mut info: floatball_shared::api::InstallationInfo =
        serde_json::from_str(&installation_json(2000.0)).unwrap();
    info.gateways = (0..count)
        .map(|index| floatball_shared::api::InstallationGateway {
            kind,
            port: match kind {
                GatewayKind::Mbox => format!("192.168.15.{}:7408", 101 + index),
                _ => format!("tcp://10.0.1.{index}:4001"),
            },
            baud: None,
            stations: vec![1],
        })
        .collect();
    info
}

/// A status of 100 gateways playing: gateway 7 is down, gateway 42 misses a unit,
/// the lowest buffer is on gateway 63 (not detailed).
fn hundred_gateways_status() -> Status {
    let mut unwell = network_gateway(42, LinkState::Up);
    unwell.health = Some(floatball_shared::api::UnitHealth {
        expected: 100,
        answering: 99,
        missing: vec![17],
        ..Default::default()
    });
    Status {
        state: PlayerState::Playing,
        show: Some("ripple".into()),
        show_duration_ms: 60_000,
        gateways: vec![network_gateway(7, LinkState::Down), unwell],
        gateway_summary: floatball_shared::api::GatewaySummary {
            total: 100,
            up: 99,
            bytes_per_s: 136_620.0,
            lowest_water_level: Some(38),
            lowest_water_gateway: Some(63),
            problems: vec![7, 42],
            complete: false,
        },
        ..Status::default()
    }
}

/// The app's style sheet in the page until the returned element is removed.
fn app_styles() -> web_sys::Element {
    let style = document().create_element("style").unwrap();
    style.set_text_content(Some(include_str!("../../static/style.css")));
    document().head().unwrap().append_child(&style).unwrap();
    style
}

#[wasm_bindgen_test]
async fn a_hundred_gateways_show_as_a_summary_with_their_problems_and_the_full_list_on_request() {
    let every: Vec<GatewayStatus> = (0..100)
        .map(|index| {
            network_gateway(
                index,
                if index == 7 {
                    LinkState::Down
                } else {
                    LinkState::Up
                },
            )
        })
        .collect();
    let listed = serde_json::to_string(&every).unwrap();
    let bridge = FakeBridge::new(
        move |request| match (request.method, request.url.as_str()) {
            (Method::Get, "/api/status/gateways") => response(200, &listed),
            _ => response(404, ""),
        },
    );
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-many-gateways").await;
    let style = app_styles();
    container.style().set_property("width", "360px").unwrap();
    ctx.set_installation(many_gateways(100, GatewayKind::Uim2503));
    ctx.receive(ServerMessage::Status(hundred_gateways_status()));
    tick().await;

    // No line per gateway: the count, the lowest buffer and where, the problems.
    assert!(all(&container, "gateway").is_empty(), "no wall of text");
    assert_eq!(
        text(&container, "gateways-up"),
        "99 of 100 gateways · 136620 B/s"
    );
    assert_eq!(
        text(&container, "gateways-lowest"),
        "at least 38 rows · gateway 63 (tcp://10.0.1.63:4001)"
    );
    let problems = all(&container, "gateway-problem");
    let indices: Vec<_> = problems
        .iter()
        .map(|problem| problem.get_attribute("data-index").unwrap())
        .collect();
    assert_eq!(indices, ["7", "42"]);
    let words: Vec<_> = problems
        .iter()
        .map(|problem| problem.text_content().unwrap())
        .collect();
    assert!(
        words[0].contains("tcp://10.0.1.7:4001: down · connection refused"),
        "{words:?}"
    );
    assert!(
        words[1].contains("99 of 100 units answer; missing stations 17"),
        "{words:?}"
    );
    assert!(
        all(&container, "gateway-list").is_empty(),
        "closed at first"
    );
    assert!(
        bridge
            .requests_to(Method::Get, "/api/status/gateways")
            .is_empty()
    );

    // Opened: every gateway, one compact row each, in a box that scrolls.
    assert_eq!(
        text(&container, "gateway-list-toggle"),
        "Show all 100 gateways"
    );
    element(&container, "gateway-list-toggle").click();
    until("every gateway is listed", || {
        all(&container, "gateway-row").len() == 100
    })
    .await;
    let rows = all(&container, "gateway-row");
    assert_eq!(rows[7].get_attribute("data-link").as_deref(), Some("down"));
    assert!(
        rows[99]
            .text_content()
            .unwrap()
            .contains("tcp://10.0.1.99:4001: up"),
        "{:?}",
        rows[99].text_content()
    );
    let list = element(&container, "gateway-list");
    assert!(
        list.client_height() < 400 && list.scroll_height() > list.client_height(),
        "the list scrolls within its box ({} of {} px)",
        list.client_height(),
        list.scroll_height()
    );
    // A phone's width: nothing wider than the page.
    assert!(
        container.scroll_width() <= 360 && list.scroll_width() <= list.client_width(),
        "fits 360 px ({} px, list {} of {} px)",
        container.scroll_width(),
        list.scroll_width(),
        list.client_width()
    );
    assert_eq!(text(&container, "gateway-list-toggle"), "Hide the list");

    // Refreshed while open.
    until_within("the list is fetched again", 4000, || {
        bridge
            .requests_to(Method::Get, "/api/status/gateways")
            .len()
            >= 2
    })
    .await;

    // The other language.
    ctx.lang.set(Lang::Zh);
    tick().await;
    assert!(
        text(&container, "gateways-up").starts_with("99 / 100 个网关"),
        "{}",
        text(&container, "gateways-up")
    );
    assert!(text(&container, "gateways-lowest").contains("网关 63"));
    assert!(
        all(&container, "gateway-problem")[1]
            .text_content()
            .unwrap()
            .contains("缺失站号 17")
    );
    ctx.lang.set(Lang::En);

    // Closed: no more fetches.
    element(&container, "gateway-list-toggle").click();
    tick().await;
    assert!(all(&container, "gateway-list").is_empty());
    let fetched = bridge
        .requests_to(Method::Get, "/api/status/gateways")
        .len();
    sleep(2500).await;
    assert_eq!(
        bridge
            .requests_to(Method::Get, "/api/status/gateways")
            .len(),
        fetched
    );

    // Ten gateways: every line, as always.
    ctx.receive(ServerMessage::Status(Status {
        gateways: (0..10)
            .map(|index| network_gateway(index, LinkState::Up))
            .collect(),
        gateway_summary: floatball_shared::api::GatewaySummary {
            total: 10,
            up: 10,
            complete: true,
            ..Default::default()
        },
        ..Status::default()
    }));
    tick().await;
    assert_eq!(all(&container, "gateway").len(), 10);
    assert!(all(&container, "gateway-summary").is_empty());
    assert!(all(&container, "gateway-list-toggle").is_empty());
    style.remove();
}

#[wasm_bindgen_test]
async fn many_problems_are_counted_beyond_the_first_few_and_units_warnings_too() {
    let bridge = playlist_bridge();
    let socket = Rc::new(FakeSocket::default());
    let (container, ctx) = mount_control(&bridge, &socket, "test-many-problems").await;
    let mut status = hundred_gateways_status();
    status.gateways = (0..30)
        .map(|index| {
            let mut gateway = network_gateway(index, LinkState::Up);
            gateway.health = Some(floatball_shared::api::UnitHealth {
                expected: 100,
                answering: 98,
                missing: vec![3, 4],
                ..Default::default()
            });
            gateway
        })
        .collect();
    status.gateway_summary.problems = (0..30).collect();
    ctx.receive(ServerMessage::Status(status));
    tick().await;
    assert_eq!(all(&container, "gateway-problem").len(), 8);
    assert_eq!(
        text(&container, "gateway-problems-more"),
        "… and 22 more: see the full list"
    );
    assert_eq!(all(&container, "units-warning-gateway").len(), 8);
    assert!(text(&container, "units-warning").contains("… and 22 more"));
}

#[wasm_bindgen_test]
async fn the_console_takes_the_gateways_from_the_installation_when_the_status_has_few() {
    let (container, ctx, _, _) = mount_online("test-console-many", || view! { <ConsolePage /> });
    // Twenty MBOX boxes, all up: the status details none of them.
    ctx.set_installation(many_gateways(20, GatewayKind::Mbox));
    ctx.receive(ServerMessage::Status(Status {
        gateway_summary: floatball_shared::api::GatewaySummary {
            total: 20,
            up: 20,
            complete: false,
            ..Default::default()
        },
        ..Status::default()
    }));
    tick().await;
    assert!(
        text(&container, "console-help").contains("Box commands"),
        "the family comes from the installation"
    );
    let select =
        element(&container, "console-gateway").unchecked_into::<web_sys::HtmlSelectElement>();
    assert_eq!(select.length(), 21, "every box and \"all\"");
    // `@201` needs the selected box's subnet: found in the installation.
    type_into(&container, "console-input", "@201 reset");
    tick().await;
    assert_eq!(
        attribute(&container, "console-check", "data-state"),
        "error"
    );
    set_value(&container, "console-gateway", "19", "change");
    tick().await;
    assert_eq!(attribute(&container, "console-check", "data-state"), "ok");
}

/// The console, and a button that closes it.
fn closable_console() -> impl IntoView {
    let open = RwSignal::new(true);
    view! {
        <button data-testid="close-console" on:click=move |_| open.set(false)>"close"</button>
        <Show when=move || open.get()>
            <ConsolePage />
        </Show>
    }
}

#[wasm_bindgen_test]
async fn the_gateways_feedback_is_relayed_only_while_the_console_is_open() {
    let (container, _ctx, socket, _) = mount_online("test-console-relay", closable_console);
    tick().await;
    assert_eq!(*socket.relay.borrow(), [true]);
    element(&container, "close-console").click();
    tick().await;
    assert_eq!(*socket.relay.borrow(), [true, false]);
    assert!(all(&container, "console-input").is_empty());
}

thread_local! {
    /// Whether the test chunk below fails to load, and how often it was asked for.
    static CHUNK_OFFLINE: Cell<bool> = const { Cell::new(true) };
    static CHUNK_LOADS: Cell<u32> = const { Cell::new(0) };
}

/// A page "in a chunk" that cannot be fetched while [`CHUNK_OFFLINE`] says so.
fn load_test_chunk() -> std::pin::Pin<
    Box<
        dyn std::future::Future<
                Output = Result<floatball_web::lazy::PageView, floatball_web::lazy::ChunkError>,
            >,
    >,
> {
    Box::pin(async {
        CHUNK_LOADS.set(CHUNK_LOADS.get() + 1);
        if CHUNK_OFFLINE.get() {
            Err(floatball_web::lazy::ChunkError)
        } else {
            let page: floatball_web::lazy::PageView =
                || view! { <p data-testid="lazy-page">"in the chunk"</p> }.into_any();
            Ok(page)
        }
    })
}

#[wasm_bindgen_test]
async fn a_page_whose_chunk_fails_shows_an_error_and_retry_loads_it_in_both_languages() {
    use floatball_web::lazy::LazyPage;
    let (container, ctx, socket, _bridge) = mount_online("test-lazy", || {
        view! { <EstopButton /> <LazyPage load=load_test_chunk /> }
    });
    // Loading until the chunk answers.
    assert_eq!(text(&container, "chunk-loading"), "Loading…");
    until("the chunk's error", || {
        !all(&container, "chunk-error").is_empty()
    })
    .await;
    assert_eq!(
        text(&container, "chunk-error"),
        "This page could not be loaded (offline, or the app was updated).RetryReload the app"
    );
    ctx.lang.set(Lang::Zh);
    tick().await;
    assert_eq!(
        text(&container, "chunk-error"),
        "无法加载此页面（网络断开或应用已更新）。重试重新载入应用"
    );
    // The E-STOP beside it still works.
    element(&container, "estop").click();
    tick().await;
    assert_eq!(*socket.sent.borrow(), [ClientMessage::Estop]);
    // Retry while still offline: the error again, after a new attempt.
    element(&container, "chunk-retry").click();
    until("a second attempt", || CHUNK_LOADS.get() == 2).await;
    until("the error again", || {
        !all(&container, "chunk-error").is_empty()
    })
    .await;
    // Back online: Retry shows the page.
    CHUNK_OFFLINE.set(false);
    element(&container, "chunk-retry").click();
    until("the page", || !all(&container, "lazy-page").is_empty()).await;
    assert!(all(&container, "chunk-error").is_empty());
    assert_eq!(CHUNK_LOADS.get(), 3);
}

// ----------------------------------------------------------------------------------
// The Patch page (live input)
// ----------------------------------------------------------------------------------

/// A 100 × 100 matrix patched from universe 1 address 1 (40 universes), as
/// `GET /api/live/patch` says it.
fn live_patch_json() -> String {
    use floatball_shared::live::patch::{Patch, Profile};

    let patch = Patch::matrix(10_000, Profile::default(), 1, 1).unwrap();
    serde_json::to_string(&floatball_shared::api::LivePatch {
        rows: 100,
        cols: 100,
        enabled: false,
        hold_after_ms: 1000,
        artnet: true,
        sacn: true,
        universes: patch.universes(),
        patch,
    })
    .unwrap()
}

#[wasm_bindgen_test]
fn the_whole_matrix_helper_and_the_universe_summary() {
    use floatball_shared::live::patch::{PatchProblem, Profile};
    use floatball_web::patch::{page_rows, pages, universe_ranges, whole_matrix};

    // A DMX winch's 5 slots: 102 balls a universe, 10,000 balls on 99 universes.
    let winch = Profile {
        speed_limit_bits: Some(16),
        enable: true,
        colour: false,
    };
    let patch = whole_matrix(100, 100, winch, 3, 1).unwrap();
    let ranges = universe_ranges(&patch);
    assert_eq!(ranges.len(), 99);
    assert_eq!(ranges[0].universe, 3);
    assert_eq!((ranges[0].balls, ranges[0].last_slot), (102, 510));
    assert_eq!((ranges[1].first_ball, ranges[1].first_slot), (102, 1));
    assert_eq!(ranges[98].universe, 101);
    assert_eq!(ranges[98].balls, 10_000 - 98 * 102);
    assert_eq!(pages(&patch), 100);
    let second = page_rows(&patch, 100, 1);
    assert_eq!((second[0].ball, second[0].row, second[0].col), (100, 2, 1));
    assert_eq!(
        whole_matrix(1, 2, Profile::default(), 1, 512),
        Err(PatchProblem::Footprint {
            ball: 0,
            address: 512,
            footprint: 2
        })
    );
    assert_eq!(
        Lang::En.profile_channels(winch),
        "5 channels: position (coarse), position (fine), speed limit (coarse), speed limit \
         (fine), enable"
    );
    assert_eq!(
        Lang::Zh.profile_channels(Profile::default()),
        "2 个通道：位置（高）、位置（低）"
    );
}

#[wasm_bindgen_test]
async fn the_patch_page_patches_the_whole_matrix_in_one_tap_and_shows_refusals_in_both_languages() {
    let bridge = FakeBridge::new(
        move |request| match (request.method, request.url.as_str()) {
            (Method::Get, "/api/live/patch") => response(200, &live_patch_json()),
            (Method::Put, "/api/live/patch") => response(
                422,
                &serde_json::json!({
                    "error": "The patch has 1 problem(s) and was not saved",
                    "code": "patch_invalid",
                    "params": {"problems": "1"},
                    "details": ["ball 1 and ball 0 share slots in universe 1 from address 2"],
                    "problems": [{"code": "patch_overlap", "params":
                        {"ball": "1", "other": "0", "universe": "1", "address": "2"}}]
                })
                .to_string(),
            ),
            _ => response(500, ""),
        },
    );
    let socket = Rc::new(FakeSocket::default());
    let container = fresh_container();
    let ctx = context(&bridge, &socket, "test-patch");
    online(ctx);
    let mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! { <floatball_web::components::patch::PatchPage /> }
    });
    std::mem::forget(mounted);
    until("the patch is shown", || {
        !all(&container, "patch-summary").is_empty()
    })
    .await;
    // 10,000 balls: 40 universe lines, 100 ball rows a page.
    assert_eq!(
        text(&container, "patch-summary"),
        "10000 balls on 40 universe(s)"
    );
    assert_eq!(all(&container, "patch-universe").len(), 40);
    assert_eq!(all(&container, "patch-ball").len(), 100);
    assert_eq!(text(&container, "patch-page"), "Page 1 of 100");
    assert!(text(&container, "patch-live").starts_with("Live input off"));

    // An 8-bit speed limit and an enable channel, from universe 5, address 1: 4 slots,
    // 128 balls a universe, 79 universes.
    element(&container, "patch-speed-8").click();
    element(&container, "patch-enable").click();
    tick().await;
    assert!(
        text(&container, "patch-channels").starts_with("4 channels:"),
        "{}",
        text(&container, "patch-channels")
    );
    // The profile alone makes the balls overlap: said before anything is sent.
    assert!(!all(&container, "patch-local-problems").is_empty());
    set_value(&container, "patch-matrix-universe", "5", "input");
    element(&container, "patch-matrix-apply").click();
    tick().await;
    assert_eq!(
        text(&container, "patch-summary"),
        "10000 balls on 79 universe(s)"
    );
    assert_eq!(all(&container, "patch-universe").len(), 79);
    assert!(all(&container, "patch-local-problems").is_empty());
    let next = element(&container, "patch-next");
    assert!(
        !next.has_attribute("disabled"),
        "the next page is disabled: {:?} {}",
        next.get_attribute("disabled"),
        text(&container, "patch-page")
    );
    next.click();
    until("the second page", || {
        text(&container, "patch-page") == "Page 2 of 100"
    })
    .await;
    let first = &all(&container, "patch-ball")[0];
    assert!(
        first.text_content().unwrap_or_default().contains("5.401"),
        "{:?}",
        first.text_content()
    );

    // Save: the bridge's refusal, in English, then in 中文.
    element(&container, "patch-save").click();
    until("the refusal is shown", || {
        !all(&container, "patch-problems").is_empty()
    })
    .await;
    let sent: floatball_shared::live::patch::Patch = serde_json::from_str(
        bridge.requests_to(Method::Put, "/api/live/patch")[0]
            .body
            .as_deref()
            .unwrap(),
    )
    .unwrap();
    assert_eq!(sent.balls.len(), 10_000);
    assert_eq!(sent.balls[100].universe, 5);
    assert_eq!(sent.profile.speed_limit_bits, Some(8));
    let listed = text(&container, "patch-problems");
    assert!(
        listed.contains("Ball 1 and ball 0 share slots in universe 1 from address 2"),
        "{listed}"
    );
    ctx.lang.set(Lang::Zh);
    element(&container, "patch-save").click();
    until("the refusal is shown in 中文", || {
        text(&container, "patch-problems").contains("球 1 与球 0 在域 1 从地址 2 起共用通道")
    })
    .await;
}
