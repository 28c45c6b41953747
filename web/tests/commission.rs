//! Component tests of the Commissioning page in a real browser (`wasm-pack test
//! --headless --chrome web --test browser -- commission::`), against a fake bridge: the roll
//! call's collision and flags, "assign all in grid order", a unit's own station,
//! Identify then a tap on the grid, a tap that moves a ball, "save mapping" with the
//! bridge's problems, and the guided line-speed change (held while the gateway is
//! power-cycled, then its result or its coded refusal), in both languages.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;

use floatball_shared::api::{
    AssignRequest, ClientMessage, FoundUnit, GatewayKind, IdentifyRequest, InstallationGateway,
    InstallationInfo, RollCall, UnitFault,
};
use floatball_web::client::{LocalFuture, Method, OnProgress, Request, Response, Transport};
use floatball_web::components::commission::CommissionPage;
use floatball_web::components::widgets::ToastArea;
use floatball_web::connection::Link;
use floatball_web::context::{Ctx, Sender, Services};
use floatball_web::i18n::Lang;
use floatball_web::session::{Origin, Session};
use floatball_web::store::LocalStore;
use leptos::mount::mount_to;
use leptos::prelude::*;
use leptos::task::tick;
use wasm_bindgen_futures::JsFuture;
use wasm_bindgen_test::*;

use crate::dom::*;

/// How the fake bridge answers a request: at once, or held until the test releases
/// it (a line-speed change waiting for the gateway's power cycle).
enum Answer {
    Now(Response),
    Hold,
}

type Held = (js_sys::Function, Rc<RefCell<Option<Response>>>);

/// A bridge that answers as its route says and records every request.
struct FakeBridge {
    route: Box<dyn Fn(&Request) -> Answer>,
    requests: RefCell<Vec<Request>>,
    held: RefCell<VecDeque<Held>>,
}

impl FakeBridge {
    fn new(route: impl Fn(&Request) -> Answer + 'static) -> Rc<Self> {
        Rc::new(Self {
            route: Box::new(route),
            requests: RefCell::default(),
            held: RefCell::default(),
        })
    }

    fn requests_to(&self, method: Method, url: &str) -> Vec<Request> {
        self.requests
            .borrow()
            .iter()
            .filter(|r| r.method == method && r.url.ends_with(url))
            .cloned()
            .collect()
    }

    fn release(&self, response: Response) {
        let (resolve, slot) = self.held.borrow_mut().pop_front().expect("a held request");
        *slot.borrow_mut() = Some(response);
        resolve.call0(&wasm_bindgen::JsValue::NULL).unwrap();
    }
}

impl Transport for FakeBridge {
    fn send(
        &self,
        request: Request,
        _progress: Option<OnProgress>,
    ) -> LocalFuture<Result<Response, String>> {
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

fn answer(status: u16, body: &str) -> Response {
    Response {
        status,
        retry_after: None,
        body: body.into(),
    }
}

fn json(status: u16, value: &impl serde::Serialize) -> Answer {
    Answer::Now(answer(status, &serde_json::to_string(value).unwrap()))
}

struct NoSocket;

impl Sender for NoSocket {
    fn send(&self, _: &ClientMessage) -> bool {
        true
    }
}

const HOST: &str = "bridge.test:8080";

/// A 2 × 2 matrix on one simulated UIM2503 gateway (stations 1–4), and an MBOX box
/// when `with_mbox`.
fn installation(stations: Vec<u8>) -> InstallationInfo {
    InstallationInfo {
        rows: 2,
        cols: 2,
        pitch_mm: 500.0,
        travel_mm: 3000.0,
        max_speed_mm_s: 500.0,
        max_accel_mm_s2: 1000.0,
        home_mm: 0.0,
        approach_speed_mm_s: 200.0,
        counts_per_mm: 10.0,
        gateways: vec![InstallationGateway {
            kind: GatewayKind::Uim2503,
            port: "sim".into(),
            baud: Some(9600),
            stations,
        }],
    }
}

fn unit(serial: u64, station: u8) -> FoundUnit {
    FoundUnit {
        serial,
        station,
        position_mm: Some(0.0),
        last_answer_age_ms: 120,
        fault: None,
        cell: None,
    }
}

/// Four factory-fresh units: all on station 5, the configured 1–4 silent.
fn fresh_roll_call() -> RollCall {
    RollCall {
        gateway: 0,
        units: vec![unit(104, 5), unit(101, 5), unit(103, 5), unit(102, 5)],
        duplicated: vec![5],
        missing: vec![1, 2, 3, 4],
        unexpected: vec![5],
        took_ms: 1500,
    }
}

/// The same units after "assign all": serial order → stations 1–4.
fn assigned_roll_call() -> RollCall {
    let mut faulty = unit(104, 4);
    faulty.fault = Some(UnitFault {
        station: 4,
        error: 0x40,
        code: 0,
        index: 0,
    });
    RollCall {
        gateway: 0,
        units: vec![unit(101, 1), unit(102, 2), unit(103, 3), faulty],
        duplicated: Vec::new(),
        missing: Vec::new(),
        unexpected: Vec::new(),
        took_ms: 900,
    }
}

/// The page mounted logged in and connected, in `lang`, with `bridge`.
fn mount(bridge: &Rc<FakeBridge>, lang: Lang) -> (web_sys::HtmlElement, Ctx) {
    let container = fresh_container();
    let services = Services {
        transport: bridge.clone(),
        sender: Rc::new(NoSocket),
        store: LocalStore::new("commission-tests"),
    };
    let origin = Origin {
        protocol: "http:".into(),
        host: HOST.into(),
    };
    let ctx = Ctx::new(services, origin, lang);
    ctx.session.set(Some(Session {
        address: HOST.into(),
        token: "tok".into(),
        must_change_password: false,
    }));
    ctx.link.set(Link::Connected);
    let mounted = mount_to(container.clone(), move || {
        provide_context(ctx);
        view! {
            <CommissionPage />
            <ToastArea />
        }
    });
    std::mem::forget(mounted);
    (container, ctx)
}

fn click(container: &web_sys::HtmlElement, test_id: &str) {
    element(container, test_id).click();
}

/// The bridge of a commissioning: GET / PUT installation, roll call, assign,
/// identify; PUT answers what was sent.
fn commissioning_bridge() -> Rc<FakeBridge> {
    FakeBridge::new(|request| {
        let url = request.url.as_str();
        match request.method {
            Method::Get if url.ends_with("/api/installation") => {
                json(200, &installation(vec![1, 2, 3, 4]))
            }
            Method::Put if url.ends_with("/api/installation") => {
                Answer::Now(answer(200, request.body.as_deref().unwrap_or_default()))
            }
            Method::Post if url.ends_with("/rollcall") => json(200, &fresh_roll_call()),
            Method::Post if url.ends_with("/assign") => json(200, &assigned_roll_call()),
            Method::Post if url.ends_with("/identify") => {
                let asked: IdentifyRequest =
                    serde_json::from_str(request.body.as_deref().unwrap()).unwrap();
                Answer::Now(answer(
                    202,
                    &format!(
                        r#"{{"station":{},"distance_mm":300.0,"duration_ms":3000}}"#,
                        asked.station
                    ),
                ))
            }
            _ => Answer::Now(answer(500, "")),
        }
    })
}

#[wasm_bindgen_test]
async fn roll_call_flags_the_collision_and_assign_all_follows_the_serials() {
    let bridge = commissioning_bridge();
    let (container, _ctx) = mount(&bridge, Lang::En);
    until("the installation is loaded", || {
        all(&container, "grid").len() == 1
    })
    .await;
    assert_eq!(all(&container, "cell").len(), 4);
    assert!(text(&container, "no-rollcall").contains("No roll call yet"));
    assert!(disabled(&container, "assign-all"));

    click(&container, "rollcall");
    until("the units are listed", || {
        all(&container, "unit").len() == 4
    })
    .await;
    assert_eq!(
        bridge
            .requests_to(Method::Post, "/api/gateways/0/rollcall")
            .len(),
        1
    );
    assert_eq!(
        attribute(&container, "duplicated-stations", "data-stations"),
        "5"
    );
    assert_eq!(
        attribute(&container, "missing-stations", "data-stations"),
        "1, 2, 3, 4"
    );
    assert!(text(&container, "roll-summary").contains("4 units"));
    for row in all(&container, "unit") {
        assert_eq!(row.get_attribute("data-station").as_deref(), Some("5"));
        assert_eq!(
            row.get_attribute("data-flags").as_deref(),
            Some("duplicated unexpected")
        );
    }

    click(&container, "assign-all");
    until("a clean roll call", || {
        all(&container, "roll-clean").len() == 1
    })
    .await;
    let sent = bridge.requests_to(Method::Post, "/api/gateways/0/assign");
    let body: AssignRequest = serde_json::from_str(sent[0].body.as_deref().unwrap()).unwrap();
    let pairs: Vec<(u64, u8)> = body
        .assignments
        .iter()
        .map(|one| (one.serial, one.station))
        .collect();
    assert_eq!(pairs, [(101, 1), (102, 2), (103, 3), (104, 4)]);
    assert_eq!(
        text(&container, "toast"),
        "4 units were given their stations"
    );
    // The last unit reported an overload: in words, and flagged.
    let fault = text(&container, "unit-fault");
    assert!(fault.contains("cannot follow"), "{fault}");
    let rows = all(&container, "unit");
    assert_eq!(
        rows[3].get_attribute("data-flags").as_deref(),
        Some("fault")
    );
}

#[wasm_bindgen_test]
async fn one_unit_gets_the_station_typed_and_a_bad_one_is_refused() {
    let bridge = commissioning_bridge();
    let (container, _ctx) = mount(&bridge, Lang::En);
    until("the page is ready", || {
        all(&container, "rollcall").len() == 1
    })
    .await;
    click(&container, "rollcall");
    until("the units are listed", || {
        all(&container, "unit").len() == 4
    })
    .await;
    // Units are listed by serial as the bridge sent them: 104 first.
    set_value(&container, "unit-station", "200", "input");
    click(&container, "unit-assign");
    tick().await;
    assert!(text(&container, "bad-station").contains("1 to 127"));
    assert!(
        bridge
            .requests_to(Method::Post, "/api/gateways/0/assign")
            .is_empty()
    );
    set_value(&container, "unit-station", "12", "input");
    click(&container, "unit-assign");
    until("assigned", || {
        bridge
            .requests_to(Method::Post, "/api/gateways/0/assign")
            .len()
            == 1
    })
    .await;
    let sent = bridge.requests_to(Method::Post, "/api/gateways/0/assign");
    assert_eq!(
        sent[0].body.as_deref(),
        Some(r#"{"assignments":[{"serial":104,"station":12}]}"#)
    );
}

#[wasm_bindgen_test]
async fn identify_then_tap_maps_the_cell_and_save_puts_the_stations() {
    let bridge = commissioning_bridge();
    let (container, _ctx) = mount(&bridge, Lang::En);
    until("the page is ready", || all(&container, "grid").len() == 1).await;
    assert!(disabled(&container, "save-mapping"));
    click(&container, "rollcall");
    until("the units are listed", || {
        all(&container, "unit").len() == 4
    })
    .await;
    click(&container, "assign-all");
    until("a clean roll call", || {
        all(&container, "roll-clean").len() == 1
    })
    .await;

    // A distance that is not one is refused before anything is sent.
    set_value(&container, "identify-distance", "-3", "input");
    all(&container, "unit-identify")[0].click();
    until("the refusal", || {
        all(&container, "commission-error").len() == 1
    })
    .await;
    assert!(text(&container, "commission-error").contains("above 0"));
    assert!(
        bridge
            .requests_to(Method::Post, "/api/gateways/0/identify")
            .is_empty()
    );
    set_value(&container, "identify-distance", "", "input");

    // Identify station 1 (the first unit): the ball moves; it hangs above cell 3.
    all(&container, "unit-identify")[0].click();
    until("the moving ball is named", || {
        all(&container, "identified").len() == 1
    })
    .await;
    let sent = bridge.requests_to(Method::Post, "/api/gateways/0/identify");
    assert_eq!(sent[0].body.as_deref(), Some(r#"{"station":1}"#));
    assert!(text(&container, "identified").contains("station 1 moves 300 mm"));
    all(&container, "cell")[3].click();
    until("the cell is placed", || {
        all(&container, "cell")[3]
            .get_attribute("data-station")
            .as_deref()
            == Some("1")
    })
    .await;
    let cells = all(&container, "cell");
    assert_eq!(
        cells[3].get_attribute("data-placed").as_deref(),
        Some("true")
    );
    // Station 4 took cell 3's old place: no station twice.
    assert_eq!(cells[0].get_attribute("data-station").as_deref(), Some("4"));
    assert!(all(&container, "identified").is_empty());
    assert!(text(&container, "placed").contains("1 of 4"));

    // A tap on a cell with nothing identified moves that cell's ball, as far as
    // asked.
    set_value(&container, "identify-distance", "20", "input");
    all(&container, "cell")[1].click();
    until("identify sent", || {
        bridge
            .requests_to(Method::Post, "/api/gateways/0/identify")
            .len()
            == 2
    })
    .await;
    let sent = bridge.requests_to(Method::Post, "/api/gateways/0/identify");
    assert_eq!(
        sent[1].body.as_deref(),
        Some(r#"{"station":2,"distance_mm":20.0}"#)
    );
    until("the moving ball is named", || {
        all(&container, "identified").len() == 1
    })
    .await;
    click(&container, "cancel-identify");
    tick().await;
    assert!(all(&container, "identified").is_empty());

    click(&container, "save-mapping");
    until("saved", || {
        bridge.requests_to(Method::Put, "/api/installation").len() == 1
    })
    .await;
    let put = bridge.requests_to(Method::Put, "/api/installation");
    let body: InstallationInfo = serde_json::from_str(put[0].body.as_deref().unwrap()).unwrap();
    assert_eq!(body.gateways[0].stations, [4, 2, 3, 1]);
    assert_eq!(body.rows, 2);
    until("the toast", || {
        all(&container, "toast").first().is_some_and(|toast| {
            toast.text_content().unwrap_or_default() == "Mapping saved and applied"
        })
    })
    .await;
}

#[wasm_bindgen_test]
async fn a_refused_save_lists_every_problem() {
    let bridge = FakeBridge::new(|request| match request.method {
        Method::Get => json(200, &installation(vec![1, 2, 3, 4])),
        Method::Post => Answer::Now(answer(
            202,
            r#"{"station":3,"distance_mm":300.0,"duration_ms":3000}"#,
        )),
        _ => Answer::Now(answer(
            422,
            r#"{"error":"the installation is not valid","code":"installation_invalid","details":["one","two"]}"#,
        )),
    });
    let (container, _ctx) = mount(&bridge, Lang::En);
    until("the page is ready", || all(&container, "cell").len() == 4).await;
    all(&container, "cell")[2].click();
    until("identified", || all(&container, "identified").len() == 1).await;
    all(&container, "cell")[0].click();
    tick().await;
    click(&container, "save-mapping");
    until("the refusal", || {
        all(&container, "commission-error").len() == 1
    })
    .await;
    let problems = element(&container, "commission-problems");
    assert_eq!(problems.get_attribute("data-total").as_deref(), Some("2"));
    assert!(text(&container, "commission-problems").contains("two"));
}

#[wasm_bindgen_test]
async fn the_line_speed_change_explains_waits_and_reports() {
    let bridge = FakeBridge::new(|request| match request.method {
        Method::Get => json(200, &installation(vec![1, 2, 3, 4])),
        _ => Answer::Hold,
    });
    let (container, _ctx) = mount(&bridge, Lang::En);
    until("the page is ready", || {
        all(&container, "baud-now").len() == 1
    })
    .await;
    assert!(text(&container, "baud-now").contains("9600"));
    set_value(&container, "baud-select", "9600", "change");
    tick().await;
    assert!(disabled(&container, "baud-change"), "already at 9600");
    set_value(&container, "baud-select", "115200", "change");
    tick().await;
    click(&container, "baud-change");
    tick().await;
    assert!(text(&container, "baud-explain").contains("switch the gateway off and on"));
    assert!(bridge.requests_to(Method::Post, "/baud").is_empty());
    click(&container, "baud-confirm");
    until("waiting", || all(&container, "baud-waiting").len() == 1).await;
    let sent = bridge.requests_to(Method::Post, "/api/gateways/0/baud");
    assert_eq!(sent[0].body.as_deref(), Some(r#"{"baud":115200}"#));
    bridge.release(answer(
        200,
        r#"{"from_baud":9600,"baud":115200,"took_ms":2500}"#,
    ));
    until("the result", || all(&container, "baud-result").len() == 1).await;
    assert_eq!(attribute(&container, "baud-result", "data-outcome"), "ok");
    assert!(text(&container, "baud-result").contains("answers at 115200 baud"));
    assert!(text(&container, "baud-now").contains("115200"));

    // A gateway that does not answer at the new speed: the coded refusal.
    set_value(&container, "baud-select", "57600", "change");
    tick().await;
    click(&container, "baud-change");
    tick().await;
    click(&container, "baud-confirm");
    until("waiting", || all(&container, "baud-waiting").len() == 1).await;
    bridge.release(answer(
        409,
        r#"{"error":"the matrix is not idle","code":"playlist_locked"}"#,
    ));
    until("the result", || all(&container, "baud-result").len() == 1).await;
    assert_eq!(
        attribute(&container, "baud-result", "data-outcome"),
        "error"
    );
    assert!(!text(&container, "baud-result").is_empty());
}

#[wasm_bindgen_test]
async fn the_page_speaks_chinese_too() {
    let bridge = commissioning_bridge();
    let (container, ctx) = mount(&bridge, Lang::Zh);
    until("the page is ready", || all(&container, "grid").len() == 1).await;
    assert_eq!(text(&container, "rollcall"), "点名");
    assert_eq!(text(&container, "save-mapping"), "保存映射");
    click(&container, "rollcall");
    until("the units are listed", || {
        all(&container, "unit").len() == 4
    })
    .await;
    assert!(text(&container, "duplicated-stations").contains("多个单元共用的站号"));
    ctx.lang.set(Lang::En);
    tick().await;
    assert_eq!(text(&container, "rollcall"), "Roll call");
    assert!(text(&container, "duplicated-stations").contains("Stations several units"));
}

fn disabled(container: &web_sys::HtmlElement, test_id: &str) -> bool {
    element(container, test_id).has_attribute("disabled")
}

#[wasm_bindgen_test]
async fn a_new_line_speed_keeps_the_cells_placed_so_far() {
    let bridge = FakeBridge::new(|request| match request.method {
        Method::Get => json(200, &installation(vec![1, 2, 3, 4])),
        _ if request.url.ends_with("/identify") => Answer::Now(answer(
            202,
            r#"{"station":3,"distance_mm":300.0,"duration_ms":3000}"#,
        )),
        _ => Answer::Now(answer(
            200,
            r#"{"from_baud":9600,"baud":115200,"took_ms":800}"#,
        )),
    });
    let (container, _ctx) = mount(&bridge, Lang::En);
    until("the page is ready", || all(&container, "cell").len() == 4).await;
    all(&container, "cell")[2].click();
    until("identified", || all(&container, "identified").len() == 1).await;
    all(&container, "cell")[0].click();
    tick().await;
    assert_eq!(
        all(&container, "cell")[0]
            .get_attribute("data-station")
            .as_deref(),
        Some("3")
    );
    set_value(&container, "baud-select", "115200", "change");
    tick().await;
    click(&container, "baud-change");
    tick().await;
    click(&container, "baud-confirm");
    until("the result", || all(&container, "baud-result").len() == 1).await;
    assert!(text(&container, "baud-now").contains("115200"));
    let cells = all(&container, "cell");
    assert_eq!(cells[0].get_attribute("data-station").as_deref(), Some("3"));
    assert_eq!(
        cells[0].get_attribute("data-placed").as_deref(),
        Some("true")
    );
    assert!(!disabled(&container, "save-mapping"));
}
