//! The bridge's HTTP API (`docs/architecture.md` §4) as typed calls over a [`Transport`].
//!
//! The client knows the contract: which path, which method, which body, and what
//! each status code means ([`Failure`]). It does not know how bytes travel: the app
//! passes [`crate::http::XhrTransport`], tests pass a fake bridge. The base URL is a
//! parameter, so the same client talks to the bridge the page came from (`""`) or to
//! another controller (`http://192.168.1.17:8080`).

use std::future::Future;
use std::pin::Pin;
use std::rc::Rc;

use floatball_shared::api::{
    ApiError, AssignRequest, Assignment, BaudChanged, BaudRequest, IdentifyRequest, Identifying,
    InstallationInfo, LoginRequest, LoginResponse, PasswordChange, PlanReport, Playlist,
    QProgramListing, RollCall, ShowSummary,
};
use floatball_shared::codes::Code;
use floatball_shared::show::ShowFormat;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// A future that stays on the browser's single thread.
pub type LocalFuture<T> = Pin<Box<dyn Future<Output = T>>>;

/// An HTTP method the API uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// `GET`
    Get,
    /// `POST`
    Post,
    /// `PUT`
    Put,
    /// `DELETE`
    Delete,
}

impl Method {
    /// The method's name on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            Method::Get => "GET",
            Method::Post => "POST",
            Method::Put => "PUT",
            Method::Delete => "DELETE",
        }
    }
}

/// One HTTP request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Request {
    /// The method.
    pub method: Method,
    /// The full URL (base + path).
    pub url: String,
    /// The bearer token, sent as `Authorization: Bearer …`.
    pub bearer: Option<String>,
    /// The body's `Content-Type`.
    pub content_type: Option<&'static str>,
    /// The body.
    pub body: Option<String>,
}

/// One HTTP answer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Response {
    /// The status code.
    pub status: u16,
    /// The `Retry-After` header, if any.
    pub retry_after: Option<String>,
    /// The body as text.
    pub body: String,
}

/// How far an upload has got.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UploadProgress {
    /// Bytes sent so far.
    pub sent_bytes: f64,
    /// Bytes to send in all.
    pub total_bytes: f64,
}

impl UploadProgress {
    /// The share sent, 0.0 to 1.0 (0 while the total is unknown).
    pub fn fraction(self) -> f64 {
        if self.total_bytes > 0.0 {
            (self.sent_bytes / self.total_bytes).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// Called as an upload's bytes leave the browser.
pub type OnProgress = Rc<dyn Fn(UploadProgress)>;

/// How requests reach the bridge: the browser's XMLHttpRequest in the app, a fake in
/// tests.
pub trait Transport {
    /// Sends `request`; reports upload progress to `progress` if given. Resolves to
    /// the answer, whatever its status, or to an error when no answer came (the
    /// bridge is unreachable, the connection dropped, CORS refused it).
    fn send(
        &self,
        request: Request,
        progress: Option<OnProgress>,
    ) -> LocalFuture<Result<Response, String>>;
}

/// Why an API call did not succeed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Failure {
    /// No answer: the controller cannot be reached at this address.
    Network(String),
    /// 401: a wrong password (login, password change) or an unknown or expired token.
    Unauthorized,
    /// 403: the default password must be changed first.
    MustChangePassword,
    /// 429: too many failed logins; try again after this many seconds.
    TooManyAttempts {
        /// The `Retry-After` header in seconds, if the bridge sent one.
        retry_after_s: Option<u64>,
    },
    /// 404: no such show (or the call is not available on this bridge).
    NotFound,
    /// 413: the file is over the bridge's size limit.
    TooLarge,
    /// 400, 409 or 422, or any refusal with a code: the bridge refused the request and
    /// said why (rendered by [`crate::i18n::Lang::api_error`]).
    Rejected(ApiError),
    /// Any other status.
    Unexpected {
        /// The status code.
        status: u16,
        /// The body, for the engineer.
        body: String,
    },
}

/// Reads a `Retry-After` header given in seconds (an HTTP date is not understood and
/// gives `None`).
pub fn parse_retry_after(value: &str) -> Option<u64> {
    value.trim().parse().ok()
}

/// The failure an error status means.
pub fn failure_of(response: &Response) -> Failure {
    let api_error = || crate::json::from_str::<ApiError>(&response.body).ok();
    match response.status {
        401 => Failure::Unauthorized,
        // A 403 other than "change the password first" (a wrong current password).
        403 => match api_error() {
            Some(error)
                if !error.code.is_empty() && error.code != Code::MustChangePassword.as_str() =>
            {
                Failure::Rejected(error)
            }
            _ => Failure::MustChangePassword,
        },
        404 => Failure::NotFound,
        413 => Failure::TooLarge,
        429 => Failure::TooManyAttempts {
            retry_after_s: response.retry_after.as_deref().and_then(parse_retry_after),
        },
        400 | 409 | 422 => Failure::Rejected(api_error().unwrap_or_else(|| ApiError {
            error: response.body.trim().to_owned(),
            ..ApiError::default()
        })),
        status => match api_error() {
            // Any other refusal the bridge explains with a code.
            Some(error) if !error.code.is_empty() => Failure::Rejected(error),
            _ => Failure::Unexpected {
                status,
                body: response.body.clone(),
            },
        },
    }
}

/// Percent-encodes `text` for one URL path segment (RFC 3986 unreserved characters
/// stay, everything else becomes `%XX` of its UTF-8 bytes).
pub fn encode_path_segment(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for byte in text.bytes() {
        if byte.is_ascii_alphanumeric() || matches!(byte, b'-' | b'.' | b'_' | b'~') {
            out.push(char::from(byte));
        } else {
            out.push_str(&format!("%{byte:02X}"));
        }
    }
    out
}

/// The typed API of one bridge.
#[derive(Clone)]
pub struct Client {
    transport: Rc<dyn Transport>,
    base: String,
    token: Option<String>,
}

impl std::fmt::Debug for Client {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Client")
            .field("base", &self.base)
            .field("token", &self.token.as_ref().map(|_| "…"))
            .finish_non_exhaustive()
    }
}

impl Client {
    /// A client for the bridge at `base` (`""` for the page's own origin), not yet
    /// logged in.
    pub fn new(transport: Rc<dyn Transport>, base: impl Into<String>) -> Self {
        Self {
            transport,
            base: base.into(),
            token: None,
        }
    }

    /// The same client, sending `token` with every call.
    #[must_use]
    pub fn with_token(mut self, token: impl Into<String>) -> Self {
        self.token = Some(token.into());
        self
    }

    async fn call(
        &self,
        method: Method,
        path: &str,
        body: Option<(&'static str, String)>,
        progress: Option<OnProgress>,
    ) -> Result<Response, Failure> {
        let (content_type, body) = match body {
            Some((content_type, body)) => (Some(content_type), Some(body)),
            None => (None, None),
        };
        let request = Request {
            method,
            url: format!("{}{path}", self.base),
            bearer: self.token.clone(),
            content_type,
            body,
        };
        let response = self
            .transport
            .send(request, progress)
            .await
            .map_err(Failure::Network)?;
        if (200..300).contains(&response.status) {
            Ok(response)
        } else {
            Err(failure_of(&response))
        }
    }

    async fn call_json<T: DeserializeOwned>(
        &self,
        method: Method,
        path: &str,
        body: Option<(&'static str, String)>,
    ) -> Result<T, Failure> {
        let response = self.call(method, path, body, None).await?;
        parse(&response)
    }

    /// `POST /api/login`. A wrong password is [`Failure::Unauthorized`].
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn login(&self, password: &str) -> Result<LoginResponse, Failure> {
        let body = json(&LoginRequest {
            password: password.to_owned(),
        })?;
        self.call_json(Method::Post, "/api/login", Some(body)).await
    }

    /// `POST /api/logout`.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn logout(&self) -> Result<(), Failure> {
        self.call(Method::Post, "/api/logout", None, None)
            .await
            .map(drop)
    }

    /// `POST /api/password`. A wrong old password is [`Failure::Unauthorized`]; an
    /// unacceptable new one is [`Failure::Rejected`].
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn change_password(&self, old: &str, new: &str) -> Result<(), Failure> {
        let body = json(&PasswordChange {
            old: old.to_owned(),
            new: new.to_owned(),
        })?;
        self.call(Method::Post, "/api/password", Some(body), None)
            .await
            .map(drop)
    }

    /// `GET /api/shows`.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn shows(&self) -> Result<Vec<ShowSummary>, Failure> {
        self.shows_listed().await.map(|(shows, _complete)| shows)
    }

    /// `GET /api/shows`, and whether the list is complete: right after a start, a
    /// bridge still indexing its library answers the shows so far with `Retry-After`
    /// (and `Floatball-Library: indexing`).
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn shows_listed(&self) -> Result<(Vec<ShowSummary>, bool), Failure> {
        let response = self.call(Method::Get, "/api/shows", None, None).await?;
        Ok((parse(&response)?, response.retry_after.is_none()))
    }

    /// `PUT /api/shows/{name}` with the file's text, reporting progress as it goes.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered; a show it refuses is
    /// [`Failure::Rejected`] with every problem in `details`.
    pub async fn upload(
        &self,
        name: &str,
        kind: ShowFormat,
        text: String,
        progress: OnProgress,
    ) -> Result<ShowSummary, Failure> {
        let path = format!("/api/shows/{}", encode_path_segment(name));
        let response = self
            .call(
                Method::Put,
                &path,
                Some((kind.content_type(), text)),
                Some(progress),
            )
            .await?;
        parse(&response)
    }

    /// `GET /api/shows/{name}`: the stored show as native JSON text.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn download(&self, name: &str) -> Result<String, Failure> {
        let path = format!("/api/shows/{}", encode_path_segment(name));
        Ok(self.call(Method::Get, &path, None, None).await?.body)
    }

    /// `DELETE /api/shows/{name}`.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn delete_show(&self, name: &str) -> Result<(), Failure> {
        let path = format!("/api/shows/{}", encode_path_segment(name));
        self.call(Method::Delete, &path, None, None).await.map(drop)
    }

    /// `GET /api/playlist`.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn playlist(&self) -> Result<Playlist, Failure> {
        self.call_json(Method::Get, "/api/playlist", None).await
    }

    /// `PUT /api/playlist`; returns the playlist as stored (the one sent when the
    /// bridge answers without a body).
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered (an unknown show is [`Failure::Rejected`]).
    pub async fn put_playlist(&self, playlist: &Playlist) -> Result<Playlist, Failure> {
        let response = self
            .call(Method::Put, "/api/playlist", Some(json(playlist)?), None)
            .await?;
        if response.body.trim().is_empty() {
            Ok(playlist.clone())
        } else {
            parse(&response)
        }
    }

    /// `GET /api/schedule`: the weekly schedule.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn schedule(&self) -> Result<floatball_shared::schedule::Schedule, Failure> {
        self.call_json(Method::Get, "/api/schedule", None).await
    }

    /// `PUT /api/schedule`; returns the schedule as stored.
    ///
    /// # Errors
    /// [`Failure::Rejected`] with every problem (422); [`Failure`] as the bridge
    /// answered otherwise.
    pub async fn put_schedule(
        &self,
        schedule: &floatball_shared::schedule::Schedule,
    ) -> Result<floatball_shared::schedule::Schedule, Failure> {
        self.call_json(Method::Put, "/api/schedule", Some(json(schedule)?))
            .await
    }

    /// `GET /api/qprogram/{name}?unit=N`: ball `unit`'s Q program for MOONS' drives
    /// (the listing and the compiler's report).
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered (a show over the tolerance is
    /// [`Failure::Rejected`] with the figure).
    pub async fn qprogram(&self, name: &str, unit: usize) -> Result<QProgramListing, Failure> {
        let path = format!("/api/qprogram/{}?unit={unit}", encode_path_segment(name));
        self.call_json(Method::Get, &path, None).await
    }

    /// `GET /api/plan/{name}`; `None` when this bridge has no planner yet (404).
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn plan(&self, name: &str) -> Result<Option<PlanReport>, Failure> {
        let path = format!("/api/plan/{}", encode_path_segment(name));
        match self.call_json(Method::Get, &path, None).await {
            Ok(report) => Ok(Some(report)),
            Err(Failure::NotFound) => Ok(None),
            Err(failure) => Err(failure),
        }
    }

    /// `GET /api/installation`: the calibration and the gateways' stations.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered (a bridge older than the call: not found).
    pub async fn installation(&self) -> Result<InstallationInfo, Failure> {
        self.call_json(Method::Get, "/api/installation", None).await
    }

    /// `GET /api/status/gateways`: every gateway's status, in installation order (a
    /// status with many gateways details only those with a problem).
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered (a bridge older than the call: not found).
    pub async fn gateway_statuses(
        &self,
    ) -> Result<Vec<floatball_shared::api::GatewayStatus>, Failure> {
        self.call_json(Method::Get, "/api/status/gateways", None)
            .await
    }

    /// `GET /api/live/patch`: the patch of live input.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered (a bridge older than the call: not found).
    pub async fn live_patch(&self) -> Result<floatball_shared::api::LivePatch, Failure> {
        self.call_json(Method::Get, "/api/live/patch", None).await
    }

    /// `PUT /api/live/patch`: a whole new patch, checked, saved into `floatball.toml`;
    /// answers the patch now.
    ///
    /// # Errors
    /// [`Failure::Rejected`] with every problem (422), or while the matrix is not
    /// idle (409); [`Failure`] as the bridge answered otherwise.
    pub async fn put_live_patch(
        &self,
        patch: &floatball_shared::live::patch::Patch,
    ) -> Result<floatball_shared::api::LivePatch, Failure> {
        self.call_json(Method::Put, "/api/live/patch", Some(json(patch)?))
            .await
    }

    /// `PUT /api/installation`: the changed installation, checked by the bridge as
    /// `floatball check` does, saved and applied; answers the installation now.
    ///
    /// # Errors
    /// [`Failure::Rejected`] with every problem (422), or while the matrix is not
    /// idle (409); [`Failure`] as the bridge answered otherwise.
    pub async fn put_installation(
        &self,
        info: &InstallationInfo,
    ) -> Result<InstallationInfo, Failure> {
        self.call_json(Method::Put, "/api/installation", Some(json(info)?))
            .await
    }

    /// `POST /api/gateways/{gateway}/rollcall`: every unit on the gateway's bus.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn roll_call(&self, gateway: usize) -> Result<RollCall, Failure> {
        let path = format!("/api/gateways/{gateway}/rollcall");
        self.call_json(Method::Post, &path, None).await
    }

    /// `POST /api/gateways/{gateway}/assign`: new stations by serial number; the
    /// answer is a fresh roll call.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn assign(
        &self,
        gateway: usize,
        assignments: Vec<Assignment>,
    ) -> Result<RollCall, Failure> {
        let path = format!("/api/gateways/{gateway}/assign");
        let body = json(&AssignRequest { assignments })?;
        self.call_json(Method::Post, &path, Some(body)).await
    }

    /// `POST /api/gateways/{gateway}/identify`: the ball of `station` moves down
    /// `distance_mm` (the bridge's default when `None`) and back.
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn identify(
        &self,
        gateway: usize,
        station: u8,
        distance_mm: Option<f64>,
    ) -> Result<Identifying, Failure> {
        let path = format!("/api/gateways/{gateway}/identify");
        let body = json(&IdentifyRequest {
            station,
            distance_mm,
        })?;
        self.call_json(Method::Post, &path, Some(body)).await
    }

    /// `POST /api/gateways/{gateway}/baud`: the guided line-speed change; answers
    /// once the gateway answered at `baud` (or the wait for it ended).
    ///
    /// # Errors
    /// [`Failure`] as the bridge answered.
    pub async fn change_baud(&self, gateway: usize, baud: u32) -> Result<BaudChanged, Failure> {
        let path = format!("/api/gateways/{gateway}/baud");
        let body = json(&BaudRequest { baud })?;
        self.call_json(Method::Post, &path, Some(body)).await
    }
}

fn json(value: &impl Serialize) -> Result<(&'static str, String), Failure> {
    serde_json::to_string(value)
        .map(|text| ("application/json", text))
        .map_err(|err| Failure::Unexpected {
            status: 0,
            body: err.to_string(),
        })
}

fn parse<T: DeserializeOwned>(response: &Response) -> Result<T, Failure> {
    crate::json::from_str(&response.body).map_err(|err| Failure::Unexpected {
        status: response.status,
        body: format!("unreadable answer ({err}): {}", response.body),
    })
}

#[cfg(test)]
mod tests {
    use std::cell::RefCell;
    use std::task::{Context, Poll, Waker};
    use wasm_bindgen_test::wasm_bindgen_test;

    use super::*;

    /// A fake bridge that answers every request at once with a fixed response, and
    /// remembers what it was asked.
    struct Canned {
        response: Result<Response, String>,
        requests: RefCell<Vec<Request>>,
    }

    impl Transport for Canned {
        fn send(
            &self,
            request: Request,
            progress: Option<OnProgress>,
        ) -> LocalFuture<Result<Response, String>> {
            if let (Some(progress), Some(body)) = (progress, &request.body) {
                let total = body.len() as f64;
                progress(UploadProgress {
                    sent_bytes: total,
                    total_bytes: total,
                });
            }
            self.requests.borrow_mut().push(request);
            let response = self.response.clone();
            Box::pin(async move { response })
        }
    }

    fn bridge(status: u16, body: &str) -> Rc<Canned> {
        Rc::new(Canned {
            response: Ok(Response {
                status,
                retry_after: None,
                body: body.into(),
            }),
            requests: RefCell::new(Vec::new()),
        })
    }

    /// Runs a future that the fake bridge completes without waiting.
    fn run<T>(future: impl Future<Output = T>) -> T {
        let mut future = std::pin::pin!(future);
        match future
            .as_mut()
            .poll(&mut Context::from_waker(Waker::noop()))
        {
            Poll::Ready(value) => value,
            Poll::Pending => panic!("the fake bridge answers at once"),
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn login_posts_the_password_and_reads_the_token() {
        let fake = bridge(200, r#"{"token":"t1","must_change_password":true}"#);
        let client = Client::new(fake.clone(), "http://10.0.0.2:8080");
        let answer = run(client.login("1234")).unwrap();
        assert_eq!(answer.token, "t1");
        assert!(answer.must_change_password);
        let request = &fake.requests.borrow()[0];
        assert_eq!(request.method, Method::Post);
        assert_eq!(request.url, "http://10.0.0.2:8080/api/login");
        assert_eq!(request.body.as_deref(), Some(r#"{"password":"1234"}"#));
        assert_eq!(request.content_type, Some("application/json"));
        assert_eq!(request.bearer, None);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn wrong_password_and_rate_limit_are_told_apart() {
        let client = Client::new(bridge(401, ""), "");
        assert_eq!(run(client.login("x")), Err(Failure::Unauthorized));
        let limited = Rc::new(Canned {
            response: Ok(Response {
                status: 429,
                retry_after: Some(" 37 ".into()),
                body: String::new(),
            }),
            requests: RefCell::new(Vec::new()),
        });
        let client = Client::new(limited, "");
        assert_eq!(
            run(client.login("x")),
            Err(Failure::TooManyAttempts {
                retry_after_s: Some(37)
            })
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn an_unreachable_bridge_is_a_network_failure() {
        let fake = Rc::new(Canned {
            response: Err("connection refused".into()),
            requests: RefCell::new(Vec::new()),
        });
        let client = Client::new(fake, "http://10.9.9.9");
        assert_eq!(
            run(client.shows()),
            Err(Failure::Network("connection refused".into()))
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn calls_carry_the_token() {
        let fake = bridge(200, "[]");
        let client = Client::new(fake.clone(), "").with_token("abc");
        assert_eq!(run(client.shows()), Ok(Vec::new()));
        assert_eq!(fake.requests.borrow()[0].bearer.as_deref(), Some("abc"));
        assert_eq!(fake.requests.borrow()[0].url, "/api/shows");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_list_with_retry_after_is_not_complete() {
        let client = Client::new(bridge(200, "[]"), "");
        assert_eq!(run(client.shows_listed()), Ok((Vec::new(), true)));
        let indexing = Rc::new(Canned {
            response: Ok(Response {
                status: 200,
                retry_after: Some("1".into()),
                body: "[]".into(),
            }),
            requests: RefCell::new(Vec::new()),
        });
        let client = Client::new(indexing, "");
        assert_eq!(run(client.shows_listed()), Ok((Vec::new(), false)));
        assert_eq!(run(client.shows()), Ok(Vec::new()));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn upload_encodes_the_name_sends_the_type_and_reports_progress() {
        let fake = bridge(
            201,
            r#"{"name":"波浪 1","bytes":10,"sha256":"ab","modified":"2026-01-01T00:00:00Z","units":4,"duration_ms":500}"#,
        );
        let client = Client::new(fake.clone(), "").with_token("abc");
        let seen = Rc::new(RefCell::new(Vec::new()));
        let progress: OnProgress = {
            let seen = seen.clone();
            Rc::new(move |p: UploadProgress| seen.borrow_mut().push(p.fraction()))
        };
        let summary = run(client.upload(
            "波浪 1",
            ShowFormat::Csv,
            "time_ms,u0\n0,0\n".into(),
            progress,
        ))
        .unwrap();
        assert_eq!(summary.units, 4);
        let request = &fake.requests.borrow()[0];
        assert_eq!(request.method, Method::Put);
        assert_eq!(request.url, "/api/shows/%E6%B3%A2%E6%B5%AA%201");
        assert_eq!(request.content_type, Some("text/csv"));
        assert_eq!(*seen.borrow(), vec![1.0]);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn validation_details_come_through() {
        let fake = bridge(
            422,
            r#"{"error":"the show is not valid","details":["ball u0: too fast","ball u3: too low"]}"#,
        );
        let client = Client::new(fake, "").with_token("abc");
        let progress: OnProgress = Rc::new(|_| {});
        let failure = run(client.upload("x", ShowFormat::Json, "{}".into(), progress)).unwrap_err();
        let Failure::Rejected(error) = failure else {
            panic!("{failure:?}")
        };
        assert_eq!(error.error, "the show is not valid");
        assert_eq!(error.details.len(), 2);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn status_codes_map_to_failures() {
        let response = |status: u16, body: &str| Response {
            status,
            retry_after: None,
            body: body.into(),
        };
        assert_eq!(failure_of(&response(403, "")), Failure::MustChangePassword);
        assert_eq!(failure_of(&response(413, "")), Failure::TooLarge);
        assert_eq!(failure_of(&response(404, "")), Failure::NotFound);
        assert_eq!(
            failure_of(&response(400, "bad name")),
            Failure::Rejected(ApiError {
                error: "bad name".into(),
                ..ApiError::default()
            })
        );
        assert_eq!(
            failure_of(&response(429, "")),
            Failure::TooManyAttempts {
                retry_after_s: None
            }
        );
        assert!(matches!(
            failure_of(&response(500, "boom")),
            Failure::Unexpected { status: 500, .. }
        ));
        let locked = r#"{"error":"locked","code":"playlist_locked"}"#;
        assert!(
            matches!(failure_of(&response(409, locked)), Failure::Rejected(error) if error.code == "playlist_locked")
        );
        let wrong = r#"{"error":"wrong","code":"wrong_current_password"}"#;
        assert!(matches!(
            failure_of(&response(403, wrong)),
            Failure::Rejected(_)
        ));
        let busy = r#"{"error":"busy","code":"login_busy","params":{"retry_after_s":"5"}}"#;
        assert!(matches!(
            failure_of(&response(503, busy)),
            Failure::Rejected(_)
        ));
        assert_eq!(parse_retry_after("Wed, 21 Oct 2015 07:28:00 GMT"), None);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_missing_planner_is_not_an_error() {
        let client = Client::new(bridge(404, ""), "").with_token("t");
        assert_eq!(run(client.plan("wave")), Ok(None));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn playlist_put_without_a_body_returns_what_was_sent() {
        let fake = bridge(204, "");
        let client = Client::new(fake.clone(), "").with_token("t");
        let playlist = Playlist {
            loop_playlist: true,
            ..Playlist::default()
        };
        assert_eq!(run(client.put_playlist(&playlist)), Ok(playlist));
        let body = fake.requests.borrow()[0].body.clone().unwrap();
        assert!(body.contains(r#""loop":true"#), "{body}");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn commissioning_calls_post_to_the_gateway() {
        let roll = r#"{"gateway":1,"units":[{"serial":7,"station":5,"last_answer_age_ms":3}],"duplicated":[5],"took_ms":40}"#;
        let fake = bridge(200, roll);
        let client = Client::new(fake.clone(), "").with_token("t");
        let answer = run(client.roll_call(1)).unwrap();
        assert_eq!(answer.duplicated, [5]);
        let assignments = vec![Assignment {
            serial: 7,
            station: 12,
        }];
        assert_eq!(run(client.assign(1, assignments)), Ok(answer));
        let requests = fake.requests.borrow();
        assert_eq!(requests[0].method, Method::Post);
        assert_eq!(requests[0].url, "/api/gateways/1/rollcall");
        assert_eq!(requests[1].url, "/api/gateways/1/assign");
        assert_eq!(
            requests[1].body.as_deref(),
            Some(r#"{"assignments":[{"serial":7,"station":12}]}"#)
        );

        let fake = bridge(
            202,
            r#"{"station":12,"distance_mm":300.0,"duration_ms":4000}"#,
        );
        let client = Client::new(fake.clone(), "").with_token("t");
        assert_eq!(run(client.identify(0, 12, None)).unwrap().duration_ms, 4000);
        assert_eq!(fake.requests.borrow()[0].url, "/api/gateways/0/identify");
        assert_eq!(
            fake.requests.borrow()[0].body.as_deref(),
            Some(r#"{"station":12}"#)
        );
        run(client.identify(0, 12, Some(20.0))).unwrap();
        assert_eq!(
            fake.requests.borrow()[1].body.as_deref(),
            Some(r#"{"station":12,"distance_mm":20.0}"#)
        );

        let fake = bridge(200, r#"{"from_baud":9600,"baud":115200,"took_ms":900}"#);
        let client = Client::new(fake.clone(), "").with_token("t");
        assert_eq!(run(client.change_baud(2, 115_200)).unwrap().from_baud, 9600);
        assert_eq!(fake.requests.borrow()[0].url, "/api/gateways/2/baud");
        assert_eq!(
            fake.requests.borrow()[0].body.as_deref(),
            Some(r#"{"baud":115200}"#)
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn path_segments_are_percent_encoded() {
        assert_eq!(encode_path_segment("wave-2_a.b~"), "wave-2_a.b~");
        assert_eq!(encode_path_segment("a/b?c#d e"), "a%2Fb%3Fc%23d%20e");
    }
}
