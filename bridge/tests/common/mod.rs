//! A real bridge on a free port with a temporary data directory, and a small HTTP
//! client that speaks to it over real sockets.
#![allow(dead_code)] // Each test binary uses its own part of this.

pub mod golden;
pub mod mbox_sim;
pub mod olad;
pub mod process;
pub mod scl_peer;

use std::net::{IpAddr, SocketAddr};
use std::path::Path;
use std::time::Duration;

use axum::body::Bytes;
use axum::http::{HeaderMap, Method, Request, StatusCode, header};
use floatball_bridge::auth::Clock;
use floatball_bridge::config::{Config, Overrides};
use floatball_bridge::server;
use floatball_bridge::state::{AppState, Paths};
use floatball_shared::api::{ApiError, LoginResponse};
use futures_util::{SinkExt, StreamExt};
use http_body_util::{BodyExt, Full};
use hyper_util::client::legacy::Client;
use hyper_util::client::legacy::connect::HttpConnector;
use hyper_util::rt::TokioExecutor;
use tempfile::TempDir;
use tokio_tungstenite::tungstenite::Message;

/// The password tests change the initial one to.
pub const PASSWORD: &str = "ball-operator";

/// A running bridge in this process.
pub struct Bridge {
    remote: Remote,
    pub state: AppState,
    pub clock: Clock,
    pub data: TempDir,
    stop: tokio::sync::oneshot::Sender<()>,
    serving: tokio::task::JoinHandle<std::io::Result<()>>,
}

/// An HTTP answer.
#[derive(Debug)]
pub struct Reply {
    pub status: StatusCode,
    pub headers: HeaderMap,
    pub body: Bytes,
}

impl Reply {
    /// The body as JSON of type `T`.
    pub fn json<T: serde::de::DeserializeOwned>(&self) -> T {
        serde_json::from_slice(&self.body).unwrap_or_else(|error| {
            panic!(
                "body is not the expected JSON ({error}): {}",
                String::from_utf8_lossy(&self.body)
            )
        })
    }

    /// The body as an [`ApiError`].
    pub fn error(&self) -> ApiError {
        self.json()
    }
}

impl Bridge {
    /// A bridge with the default configuration.
    pub async fn start() -> Self {
        Self::start_with("").await
    }

    /// A bridge whose floatball.toml holds `config`.
    pub async fn start_with(config: &str) -> Self {
        let data = tempfile::tempdir().expect("temp dir");
        std::fs::write(data.path().join("floatball.toml"), config).expect("write config");
        Self::start_in(data).await
    }

    /// A bridge on an existing data directory.
    pub async fn start_in(data: TempDir) -> Self {
        let config = Config::load_or_create(
            data.path(),
            &Overrides {
                listen: Some("127.0.0.1:0".parse().expect("addr")),
                gateway_ports: Vec::new(),
            },
        )
        .expect("config");
        let static_dir = static_dir(data.path());
        let clock = Clock::adjustable();
        let state = AppState::open(
            config,
            Paths {
                data_dir: data.path().to_owned(),
                static_dir,
            },
            clock.clone(),
        )
        .expect("open the data directory");
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
            .await
            .expect("bind");
        let addr = listener.local_addr().expect("addr");
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let serving = tokio::spawn(server::run(listener, state.clone(), async {
            let _ = stopped.await;
        }));
        Self {
            remote: Remote { addr },
            state,
            clock,
            data,
            stop,
            serving,
        }
    }

    /// Stops this bridge and starts another on the same data directory.
    pub async fn restart(self) -> Self {
        let Self {
            data,
            stop,
            serving,
            state,
            ..
        } = self;
        let _ = stop.send(());
        drop(state);
        tokio::time::timeout(Duration::from_secs(5), serving)
            .await
            .expect("the server stops within 5 s")
            .expect("server task")
            .expect("server");
        Self::start_in(data).await
    }

    pub fn data_dir(&self) -> &Path {
        self.data.path()
    }
}

impl std::ops::Deref for Bridge {
    type Target = Remote;

    fn deref(&self) -> &Remote {
        &self.remote
    }
}

/// A bridge seen from outside, over HTTP and WebSocket (in this process or another).
#[derive(Debug, Clone, Copy)]
pub struct Remote {
    pub addr: SocketAddr,
}

impl Remote {
    pub fn url(&self, path: &str) -> String {
        format!("http://{}{path}", self.addr)
    }

    /// Sends a request from 127.0.0.1.
    pub async fn request(
        &self,
        method: Method,
        path: &str,
        token: Option<&str>,
        body: Option<(&str, Vec<u8>)>,
    ) -> Reply {
        self.request_from(
            "127.0.0.1".parse().expect("ip"),
            method,
            path,
            token,
            body,
            &[],
        )
        .await
    }

    /// `GET /api/sim/positions`: every simulated unit, box and drive as it is now.
    pub async fn sim_positions(&self, token: &str) -> floatball_shared::api::SimPositions {
        let reply = self
            .request(Method::GET, "/api/sim/positions", Some(token), None)
            .await;
        assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
        reply.json()
    }

    /// Sends a request from a chosen loopback address with extra headers.
    pub async fn request_from(
        &self,
        from: IpAddr,
        method: Method,
        path: &str,
        token: Option<&str>,
        body: Option<(&str, Vec<u8>)>,
        headers: &[(&str, &str)],
    ) -> Reply {
        let mut connector = HttpConnector::new();
        connector.set_local_address(Some(from));
        let client: Client<_, Full<Bytes>> = Client::builder(TokioExecutor::new()).build(connector);
        let mut request = Request::builder().method(method).uri(self.url(path));
        if let Some(token) = token {
            request = request.header(header::AUTHORIZATION, format!("Bearer {token}"));
        }
        for (name, value) in headers {
            request = request.header(*name, *value);
        }
        let body = match body {
            Some((content_type, bytes)) => {
                if !content_type.is_empty() {
                    request = request.header(header::CONTENT_TYPE, content_type);
                }
                Full::new(Bytes::from(bytes))
            }
            None => Full::new(Bytes::new()),
        };
        let response = tokio::time::timeout(
            Duration::from_secs(30),
            client.request(request.body(body).expect("request")),
        )
        .await
        .expect("an answer within 30 s")
        .expect("HTTP exchange");
        let status = response.status();
        let headers = response.headers().clone();
        let body = response
            .into_body()
            .collect()
            .await
            .expect("body")
            .to_bytes();
        Reply {
            status,
            headers,
            body,
        }
    }

    /// `POST /api/login`.
    pub async fn login(&self, password: &str) -> Reply {
        self.request(
            Method::POST,
            "/api/login",
            None,
            Some((
                "application/json",
                serde_json::to_vec(&serde_json::json!({ "password": password })).expect("json"),
            )),
        )
        .await
    }

    /// Logs in with the initial password.
    pub async fn token(&self) -> String {
        let reply = self.login("1234").await;
        assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
        reply.json::<LoginResponse>().token
    }

    /// Logs in with the initial password and changes it to [`PASSWORD`].
    pub async fn operator(&self) -> String {
        let token = self.token().await;
        let reply = self.change_password(&token, "1234", PASSWORD).await;
        assert_eq!(reply.status, StatusCode::NO_CONTENT, "{:?}", reply.body);
        token
    }

    /// `POST /api/password`.
    pub async fn change_password(&self, token: &str, old: &str, new: &str) -> Reply {
        self.request(
            Method::POST,
            "/api/password",
            Some(token),
            Some((
                "application/json",
                serde_json::to_vec(&serde_json::json!({ "old": old, "new": new })).expect("json"),
            )),
        )
        .await
    }

    /// `PUT /api/shows/{name}` (name already percent-encoded as needed).
    pub async fn upload(&self, token: &str, name: &str, content_type: &str, body: &[u8]) -> Reply {
        self.request(
            Method::PUT,
            &format!("/api/shows/{name}"),
            Some(token),
            Some((content_type, body.to_vec())),
        )
        .await
    }

    /// Opens `/ws?token=…`.
    pub async fn ws(&self, token: &str) -> Ws {
        let (ws, _) =
            tokio_tungstenite::connect_async(format!("ws://{}/ws?token={token}", self.addr))
                .await
                .expect("WebSocket connect");
        ws
    }
}

/// A WebSocket client.
pub type Ws =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// The next JSON message from the bridge, within 5 s.
pub async fn next_message(ws: &mut Ws) -> floatball_shared::api::ServerMessage {
    loop {
        let frame = tokio::time::timeout(Duration::from_secs(5), ws.next())
            .await
            .expect("a message within 5 s")
            .expect("stream open")
            .expect("valid frame");
        if let Message::Text(text) = frame {
            return serde_json::from_str(text.as_str()).expect("a ServerMessage");
        }
    }
}

/// The next message from the bridge that is not a `status` (statuses come whenever a
/// link changes).
pub async fn next_reply(ws: &mut Ws) -> floatball_shared::api::ServerMessage {
    loop {
        match next_message(ws).await {
            floatball_shared::api::ServerMessage::Status(_) => {}
            other => return other,
        }
    }
}

/// Reads statuses until one satisfies `what`; panics if none does within `within`.
pub async fn status_until(
    ws: &mut Ws,
    within: Duration,
    what: impl Fn(&floatball_shared::api::Status) -> bool,
) -> floatball_shared::api::Status {
    use floatball_shared::api::ServerMessage;
    // What came meanwhile, for the failure's message: a refused request says why.
    let mut last_status = None;
    let mut others = Vec::new();
    let found = tokio::time::timeout(within, async {
        loop {
            match next_message(ws).await {
                ServerMessage::Status(status) if what(&status) => return status,
                ServerMessage::Status(status) => last_status = Some(status),
                other => others.push(other),
            }
        }
    })
    .await;
    found.unwrap_or_else(|_| {
        panic!(
            "the status never matched within {within:?}; the last status: {last_status:?}; \
             the other messages: {others:?}"
        )
    })
}

/// Sends a text frame.
pub async fn send_text(ws: &mut Ws, text: &str) {
    ws.send(Message::text(text)).await.expect("send");
}

/// Percent-encodes every byte that is not an unreserved ASCII character.
pub fn encode_path(name: &str) -> String {
    name.bytes()
        .map(|byte| {
            if byte.is_ascii_alphanumeric() || b"-._~".contains(&byte) {
                char::from(byte).to_string()
            } else {
                format!("%{byte:02X}")
            }
        })
        .collect()
}

/// A native show for a `rows` × `cols` matrix: every ball drops `depth_mm` and comes
/// back, 2 × 250 ms (within the default limits up to 40 mm).
pub fn show_json(name: &str, rows: u32, cols: u32, depth_mm: f64) -> Vec<u8> {
    let units: Vec<serde_json::Value> = (0..rows * cols)
        .map(|_| serde_json::json!({ "start_mm": 0.0, "rows": [[depth_mm, 0.0, 250], [0.0, 0.0, 250]] }))
        .collect();
    native_show(name, rows, cols, units)
}

/// A native show file for a `rows` × `cols` matrix with one track per unit.
pub fn native_show(name: &str, rows: u32, cols: u32, units: Vec<serde_json::Value>) -> Vec<u8> {
    serde_json::to_vec(&serde_json::json!({
        "format": "floatball-show",
        "version": 1,
        "name": name,
        "layout": { "rows": rows, "cols": cols, "pitch_mm": 500.0 },
        "units": units,
    }))
    .expect("json")
}

/// A stand-in web app under `data/static`; returns its folder.
pub fn static_dir(data: &Path) -> std::path::PathBuf {
    let static_dir = data.join("static");
    std::fs::create_dir_all(&static_dir).expect("static dir");
    std::fs::write(
        static_dir.join("index.html"),
        "<!doctype html><title>t</title>",
    )
    .expect("index");
    static_dir
}

/// Reads statuses until `wanted` holds, within `limit`; returns every state seen
/// on the way and the matching status.
pub async fn until(
    ws: &mut Ws,
    limit: Duration,
    wanted: impl Fn(&floatball_shared::api::Status) -> bool,
) -> (
    Vec<floatball_shared::api::PlayerState>,
    floatball_shared::api::Status,
) {
    let deadline = tokio::time::Instant::now() + limit;
    let mut states = Vec::new();
    let mut last_error = None;
    loop {
        let frame = tokio::time::timeout_at(deadline, futures_util::StreamExt::next(ws))
            .await
            .unwrap_or_else(|_| {
                panic!(
                    "no such status within {limit:?}; seen {states:?}, last error {last_error:?}"
                )
            })
            .expect("open")
            .expect("frame");
        let tokio_tungstenite::tungstenite::Message::Text(text) = frame else {
            continue;
        };
        match serde_json::from_str(text.as_str()) {
            Ok(floatball_shared::api::ServerMessage::Status(status)) => {
                if states.last() != Some(&status.state) {
                    states.push(status.state);
                }
                if status.last_error.is_some() {
                    last_error.clone_from(&status.last_error);
                }
                if wanted(&status) {
                    return (states, status);
                }
            }
            Ok(floatball_shared::api::ServerMessage::Error { message, .. }) => {
                panic!("error: {message}")
            }
            _ => {}
        }
    }
}
