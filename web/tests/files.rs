//! Component tests of the Files page's behaviour and the login's wait, in a real
//! browser (`wasm-pack test --headless --chrome web --test browser -- files::`), with the
//! app's own style sheet: the selected row is highlighted, long problem lists are
//! cut to 20 with "show all", long messages are clipped, the login's wait counts
//! down and logs in by itself, the password changes from Settings with a toast.

use std::cell::RefCell;
use std::rc::Rc;

use floatball_shared::api::{ClientMessage, ShowSummary};
use floatball_web::client::{LocalFuture, Method, OnProgress, Request, Response, Transport};
use floatball_web::components::control::SettingsPage;
use floatball_web::components::files::FilesPage;
use floatball_web::components::login::LoginPage;
use floatball_web::components::widgets::ToastArea;
use floatball_web::connection::Link;
use floatball_web::context::{Ctx, PreviewItem, Sender, Services};
use floatball_web::files::{LocalFile, MAX_MESSAGE_CHARS, SHOWN_PROBLEMS};
use floatball_web::i18n::Lang;
use floatball_web::page::Page;
use floatball_web::session::{Origin, Session};
use floatball_web::store::LocalStore;
use leptos::mount::mount_to;
use leptos::prelude::*;
use leptos::task::tick;
use wasm_bindgen::JsCast;
use wasm_bindgen_test::*;

use crate::dom::*;

/// How the fake bridge answers: given the request and how many came before it.
type Route = Box<dyn Fn(&Request, usize) -> Response>;

/// A bridge that answers every request at once as its [`Route`] says, and records
/// them.
struct FakeBridge {
    route: Route,
    requests: RefCell<Vec<Request>>,
}

impl FakeBridge {
    /// `route` gets each request and how many came before it.
    fn new(route: impl Fn(&Request, usize) -> Response + 'static) -> Rc<Self> {
        Rc::new(Self {
            route: Box::new(route),
            requests: RefCell::default(),
        })
    }

    fn requests_to(&self, method: Method, url: &str) -> Vec<Request> {
        self.requests
            .borrow()
            .iter()
            .filter(|r| r.method == method && r.url == url)
            .cloned()
            .collect()
    }
}

impl Transport for FakeBridge {
    fn send(
        &self,
        request: Request,
        _progress: Option<OnProgress>,
    ) -> LocalFuture<Result<Response, String>> {
        let answer = (self.route)(&request, self.requests.borrow().len());
        self.requests.borrow_mut().push(request);
        Box::pin(async move { Ok(answer) })
    }
}

fn answer(status: u16, body: &str) -> Response {
    Response {
        status,
        retry_after: None,
        body: body.into(),
    }
}

struct NoSocket;

impl Sender for NoSocket {
    fn send(&self, _: &ClientMessage) -> bool {
        true
    }
}

const HOST: &str = "bridge.test:8080";

/// The app's state with `bridge`, in English; logged in and connected if `online`.
fn context(bridge: &Rc<FakeBridge>, database: &str, online: bool) -> Ctx {
    let services = Services {
        transport: bridge.clone(),
        sender: Rc::new(NoSocket),
        store: LocalStore::new(database),
    };
    let origin = Origin {
        protocol: "http:".into(),
        host: HOST.into(),
    };
    let ctx = Ctx::new(services, origin, Lang::En);
    if online {
        ctx.session.set(Some(Session {
            address: HOST.into(),
            token: "tok".into(),
            must_change_password: false,
        }));
        ctx.link.set(Link::Connected);
    }
    ctx
}

/// Mounts `page` and the toast area with `ctx` in a fresh container.
fn mount<V: IntoView + 'static>(ctx: Ctx, page: fn() -> V) -> web_sys::HtmlElement {
    let container = fresh_container();
    let mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! {
            {page()}
            <ToastArea />
        }
    });
    std::mem::forget(mounted);
    container
}

/// The app's style sheet in the page, once.
fn with_app_styles() {
    let document = document();
    if document.get_element_by_id("app-style").is_some() {
        return;
    }
    let style = document.create_element("style").unwrap();
    style.set_id("app-style");
    style.set_text_content(Some(include_str!("../../static/style.css")));
    document.head().unwrap().append_child(&style).unwrap();
}

fn background(element: &web_sys::HtmlElement) -> String {
    window()
        .get_computed_style(element)
        .unwrap()
        .unwrap()
        .get_property_value("background-color")
        .unwrap()
}

const CSV: &str = "time_ms,u0,u1,u2,u3\n0,100,100,100,100\n1000,900,700,500,300\n";

fn with_local_files(ctx: Ctx, names: &[&str]) {
    ctx.local_files.update(|list| {
        for name in names {
            list.upsert(LocalFile::new(name, CSV.into(), 0.0).unwrap());
        }
    });
}

fn row(container: &web_sys::HtmlElement, name: &str) -> web_sys::HtmlElement {
    all(container, "local-file")
        .into_iter()
        .find(|row| row.get_attribute("data-name").as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no row {name}"))
}

#[wasm_bindgen_test]
async fn the_selected_file_is_highlighted() {
    with_app_styles();
    let bridge = FakeBridge::new(|_, _| answer(500, ""));
    let ctx = context(&bridge, "files-highlight", false);
    with_local_files(ctx, &["a.csv", "b.csv"]);
    ctx.local_files.update(|list| list.select("a.csv"));
    let container = mount(ctx, || view! { <FilesPage /> });
    tick().await;
    let (a, b) = (row(&container, "a.csv"), row(&container, "b.csv"));
    assert!(a.class_list().contains("selected"));
    assert_eq!(a.get_attribute("aria-pressed").as_deref(), Some("true"));
    assert_eq!(b.get_attribute("aria-pressed").as_deref(), Some("false"));
    assert_ne!(
        background(&a),
        background(&b),
        "the selected row looks different"
    );
    assert_ne!(background(&a), "rgba(0, 0, 0, 0)", "and is not transparent");

    b.click();
    tick().await;
    let (a, b) = (row(&container, "a.csv"), row(&container, "b.csv"));
    assert_eq!(
        ctx.local_files.get_untracked().selected_name(),
        Some("b.csv")
    );
    assert_eq!(background(&a), "rgba(0, 0, 0, 0)");
    assert_ne!(background(&b), "rgba(0, 0, 0, 0)");
}

#[wasm_bindgen_test]
async fn a_long_problem_list_shows_twenty_then_all() {
    with_app_styles();
    let details: Vec<String> = (0..100).map(|i| format!("problem {i}")).collect();
    let body = serde_json::json!({ "error": "the show is not valid", "details": details });
    let body = body.to_string();
    let bridge = FakeBridge::new(move |_, _| answer(422, &body));
    let ctx = context(&bridge, "files-problems", true);
    with_local_files(ctx, &["wave.csv"]);
    let container = mount(ctx, || view! { <FilesPage /> });
    element(&container, "upload").click();
    until("the refusal shows", || {
        all(&container, "upload-details").len() == 1
    })
    .await;
    let items = || {
        element(&container, "upload-details")
            .query_selector_all("li")
            .unwrap()
            .length() as usize
    };
    assert_eq!(items(), SHOWN_PROBLEMS);
    assert_eq!(attribute(&container, "upload-details", "data-total"), "100");
    assert_eq!(
        text(&container, "problems-more"),
        "80 more not shown (100 in all)"
    );
    assert_eq!(text(&container, "problems-toggle"), "Show all");

    element(&container, "problems-toggle").click();
    tick().await;
    assert_eq!(items(), 100);
    assert_eq!(text(&container, "problems-more"), "");
    assert_eq!(text(&container, "problems-toggle"), "Show fewer");
    element(&container, "problems-toggle").click();
    tick().await;
    assert_eq!(items(), SHOWN_PROBLEMS);

    // A short list has no toggle.
    let short = FakeBridge::new(|_, _| {
        answer(
            422,
            r#"{"error":"the show is not valid","details":["one","two"]}"#,
        )
    });
    let ctx = context(&short, "files-problems-short", true);
    with_local_files(ctx, &["wave.csv"]);
    let container = mount(ctx, || view! { <FilesPage /> });
    element(&container, "upload").click();
    until("the refusal shows", || {
        all(&container, "upload-details").len() == 1
    })
    .await;
    assert!(all(&container, "problems-toggle").is_empty());
}

#[wasm_bindgen_test]
async fn a_long_message_is_clipped_and_wraps() {
    with_app_styles();
    // What a binary file renamed .csv gives: one long token.
    let token = "\u{fffd}x".repeat(5_000);
    let body = serde_json::json!({ "error": token, "details": [token] }).to_string();
    let bridge = FakeBridge::new(move |_, _| answer(422, &body));
    let ctx = context(&bridge, "files-long", true);
    with_local_files(ctx, &["noise.csv"]);
    let container = mount(ctx, || view! { <FilesPage /> });
    container.style().set_property("width", "360px").unwrap();
    element(&container, "upload").click();
    until("the refusal shows", || {
        all(&container, "upload-details").len() == 1
    })
    .await;
    let message = element(&container, "files-message");
    let heading = message.query_selector("p").unwrap().unwrap();
    let shown = heading.text_content().unwrap();
    assert!(shown.ends_with('…'), "{shown}");
    assert!(shown.chars().count() < MAX_MESSAGE_CHARS + 60, "{shown}");
    let detail = element(&container, "upload-details")
        .query_selector("li")
        .unwrap()
        .unwrap();
    assert_eq!(
        detail.text_content().unwrap().chars().count(),
        MAX_MESSAGE_CHARS + 1
    );
    assert!(
        message.scroll_width() <= 360,
        "the message wraps within the page ({} px)",
        message.scroll_width()
    );
}

#[wasm_bindgen_test]
async fn uploads_and_deletes_are_confirmed_with_a_toast() {
    let bridge = FakeBridge::new(|request, _| match request.method {
        Method::Put => answer(
            201,
            &serde_json::to_string(&ShowSummary {
                name: "wave".into(),
                bytes: 10,
                sha256: "00".into(),
                modified: "2026-01-01T00:00:00Z".into(),
                units: 4,
                duration_ms: 1000,
            })
            .unwrap(),
        ),
        Method::Delete => answer(204, ""),
        _ => answer(404, ""),
    });
    let ctx = context(&bridge, "files-toast", true);
    with_local_files(ctx, &["wave.csv"]);
    let container = mount(ctx, || view! { <FilesPage /> });
    element(&container, "upload").click();
    until("the toast shows", || all(&container, "toast").len() == 1).await;
    assert_eq!(text(&container, "toast"), "Uploaded: wave");
    let area = element(&container, "toast").parent_element().unwrap();
    assert_eq!(area.get_attribute("aria-live").as_deref(), Some("polite"));

    element(&container, "tab-controller").click();
    tick().await;
    element(&container, "delete-controller").click();
    tick().await;
    element(&container, "delete-controller").click();
    until("the delete is confirmed", || {
        text(&container, "toast") == "Deleted: wave"
    })
    .await;
    assert_eq!(
        bridge.requests_to(Method::Delete, "/api/shows/wave").len(),
        1
    );
    until_within("the toast goes", 6_000, || {
        all(&container, "toast").is_empty()
    })
    .await;
}

#[wasm_bindgen_test]
async fn offline_the_files_page_offers_the_login() {
    let bridge = FakeBridge::new(|_, _| answer(500, ""));
    let ctx = context(&bridge, "files-login", false);
    let container = mount(ctx, || view! { <FilesPage /> });
    element(&container, "files-login").click();
    tick().await;
    assert_eq!(ctx.page.get_untracked(), Page::Login);
}

#[wasm_bindgen_test]
async fn the_login_wait_counts_down_and_logs_in_by_itself() {
    let bridge = FakeBridge::new(|request, before| match (request.url.as_str(), before) {
        ("/api/login", 0) => answer(401, ""),
        ("/api/login", 1) => Response {
            status: 429,
            retry_after: Some("2".into()),
            body: String::new(),
        },
        ("/api/login", _) => answer(200, r#"{"token":"t2","must_change_password":false}"#),
        _ => answer(404, ""),
    });
    let ctx = context(&bridge, "files-countdown", false);
    ctx.page.set(Page::Login);
    let container = mount(ctx, || view! { <LoginPage /> });
    type_into(&container, "login-password", "late-show");
    element(&container, "login-submit").click();
    until("the wrong password shows", || {
        text(&container, "login-error") == "Wrong password"
    })
    .await;
    element(&container, "login-submit").click();
    until("the wait shows", || {
        all(&container, "login-error")
            .iter()
            .any(|note| note.text_content().unwrap_or_default().ends_with("in 2 s"))
    })
    .await;
    assert_eq!(all(&container, "login-wait-note").len(), 1);
    assert!(
        disabled(&container, "login-submit"),
        "no tries while waiting"
    );
    until_within("the wait counts down", 1_800, || {
        all(&container, "login-error")
            .iter()
            .any(|note| note.text_content().unwrap_or_default().ends_with("in 1 s"))
    })
    .await;
    until_within("the app logs in by itself", 3_000, || {
        ctx.session.get_untracked().is_some()
    })
    .await;
    let logins = bridge.requests_to(Method::Post, "/api/login");
    assert_eq!(logins.len(), 3);
    assert_eq!(
        logins[2].body.as_deref(),
        Some(r#"{"password":"late-show"}"#)
    );
    assert_eq!(ctx.session.get_untracked().unwrap().token, "t2");
    assert_eq!(ctx.page.get_untracked(), Page::Files);
}

#[wasm_bindgen_test]
async fn settings_change_the_password_and_confirm_it() {
    let bridge = FakeBridge::new(|request, _| match request.url.as_str() {
        "/api/password"
            if request
                .body
                .as_deref()
                .is_some_and(|b| b.contains("\"old\":\"bad\"")) =>
        {
            answer(403, r#"{"error":"the current password is wrong"}"#)
        }
        "/api/password" => answer(204, ""),
        "/api/playlist" => answer(204, ""),
        _ => answer(404, ""),
    });
    let ctx = context(&bridge, "files-password", true);
    let container = mount(ctx, || view! { <SettingsPage /> });
    tick().await;
    assert_eq!(all(&container, "settings-password-form").len(), 1);

    type_into(&container, "password-current", "bad");
    type_into(&container, "password-new", "new-show-9");
    type_into(&container, "password-confirm", "new-show-9");
    element(&container, "password-submit").click();
    until("the wrong password shows", || {
        all(&container, "password-error").len() == 1
    })
    .await;
    assert_eq!(
        text(&container, "password-error"),
        "The current password is wrong"
    );
    assert!(ctx.session.get_untracked().is_some(), "still logged in");
    assert_eq!(ctx.page.get_untracked(), Page::Files, "nowhere else");

    type_into(&container, "password-current", "old-show-1");
    element(&container, "password-submit").click();
    until("the change is confirmed", || {
        all(&container, "password-done").len() == 1
    })
    .await;
    assert_eq!(text(&container, "toast"), "The password was changed");
    let changes = bridge.requests_to(Method::Post, "/api/password");
    assert_eq!(
        changes[1].body.as_deref(),
        Some(r#"{"old":"old-show-1","new":"new-show-9"}"#)
    );
    tick().await;
    for field in ["password-current", "password-new", "password-confirm"] {
        let input = element(&container, field).unchecked_into::<web_sys::HtmlInputElement>();
        assert_eq!(input.value(), "", "{field} is emptied");
    }

    // The playlist's settings, stored, are confirmed with a toast too.
    element(&container, "settings-apply").click();
    until("the playlist is confirmed", || {
        all(&container, "toast")
            .first()
            .is_some_and(|toast| toast.text_content().as_deref() == Some("Playlist saved"))
    })
    .await;
    assert_eq!(bridge.requests_to(Method::Put, "/api/playlist").len(), 1);
}

fn disabled(container: &web_sys::HtmlElement, test_id: &str) -> bool {
    element(container, test_id).has_attribute("disabled")
}

fn type_into(container: &web_sys::HtmlElement, test_id: &str, value: &str) {
    set_value(container, test_id, value, "input");
}

/// A local file that does not read says why in the operator's language: a CSV file
/// with the CSV reader's problem and where it is (worded in the reader's chunk,
/// `floatball_web::lazy::read_csv`), a JSON file with the JSON parser's (worded in
/// the main module).
#[wasm_bindgen_test]
async fn a_local_file_that_does_not_read_says_why_in_the_chosen_language() {
    let bridge = FakeBridge::new(|_, _| answer(500, ""));
    let ctx = context(&bridge, "files-refused", false);
    let csv = LocalFile::new("bad.csv", "time_ms,u0\n0,100\nsoon,200\n".into(), 0.0).unwrap();
    let json = LocalFile::new("bad.json", "{\"version\": 1,".into(), 0.0).unwrap();
    for lang in [Lang::En, Lang::Zh] {
        ctx.lang.set(lang);
        for file in [&csv, &json] {
            ctx.preview_local(file);
            let mut waited_ticks = 0;
            while matches!(ctx.preview.get_untracked(), Some(PreviewItem::Loading(_))) {
                assert!(waited_ticks < 100, "{} is still loading", file.name);
                tick().await;
                waited_ticks += 1;
            }
            let expected = lang.refused(&file.to_show().unwrap_err());
            assert_eq!(
                ctx.preview.get_untracked(),
                Some(PreviewItem::Failed(file.name.clone(), expected.clone()))
            );
            if file.name == "bad.csv" {
                let line = match lang {
                    Lang::En => "line 3, column 1: ",
                    Lang::Zh => "第 3 行第 1 列：",
                };
                assert!(expected.starts_with(line), "{expected}");
            }
        }
    }
}
