//! The browser's side of [`crate::client::Transport`]: `XMLHttpRequest`, because
//! only it reports upload progress (`upload.onprogress`; `fetch` has none).

use std::rc::Rc;

use wasm_bindgen::JsCast;
use wasm_bindgen::closure::Closure;
use web_sys::{Event, ProgressEvent, XmlHttpRequest};

use crate::client::{LocalFuture, OnProgress, Request, Response, Transport, UploadProgress};

/// How long a request may take before it counts as failed, ms (uploads of large shows
/// over a slow WiFi included).
pub const TIMEOUT_MS: u32 = 120_000;

/// Sends requests with `XMLHttpRequest`.
#[derive(Debug, Default, Clone, Copy)]
pub struct XhrTransport;

impl Transport for XhrTransport {
    fn send(
        &self,
        request: Request,
        progress: Option<OnProgress>,
    ) -> LocalFuture<Result<Response, String>> {
        Box::pin(async move {
            let mut handlers = Vec::new();
            let promise = js_sys::Promise::new(&mut |resolve, reject| match start(
                &request,
                progress.clone(),
                resolve,
                reject.clone(),
            ) {
                Ok(started) => handlers = started,
                Err(error) => drop(reject.call1(&wasm_bindgen::JsValue::NULL, &error)),
            });
            let xhr = wasm_bindgen_futures::JsFuture::from(promise).await;
            // The request has ended and its handlers are detached: they may go now.
            drop(handlers);
            let xhr = xhr.map_err(describe_js_error)?;
            let xhr: XmlHttpRequest = xhr.unchecked_into();
            Ok(Response {
                status: xhr.status().unwrap_or(0),
                retry_after: xhr.get_response_header("Retry-After").ok().flatten(),
                body: xhr.response_text().ok().flatten().unwrap_or_default(),
            })
        })
    }
}

type Handler = Closure<dyn FnMut(Event)>;

/// Opens and sends the request; `resolve` gets the finished `XMLHttpRequest`,
/// `reject` a message. Returns the event handlers, which must live until the request
/// ends.
fn start(
    request: &Request,
    progress: Option<OnProgress>,
    resolve: js_sys::Function,
    reject: js_sys::Function,
) -> Result<Vec<Handler>, wasm_bindgen::JsValue> {
    let xhr = XmlHttpRequest::new()?;
    xhr.open(request.method.as_str(), &request.url)?;
    xhr.set_timeout(TIMEOUT_MS);
    if let Some(token) = &request.bearer {
        xhr.set_request_header("Authorization", &format!("Bearer {token}"))?;
    }
    if let Some(content_type) = request.content_type {
        xhr.set_request_header("Content-Type", content_type)?;
    }
    let finish = {
        let xhr = xhr.clone();
        move |outcome: Result<(), &str>| {
            match outcome {
                Ok(()) => drop(resolve.call1(&wasm_bindgen::JsValue::NULL, &xhr)),
                Err(message) => drop(reject.call1(
                    &wasm_bindgen::JsValue::NULL,
                    &wasm_bindgen::JsValue::from_str(message),
                )),
            }
            xhr.set_onload(None);
            xhr.set_onerror(None);
            xhr.set_ontimeout(None);
            xhr.set_onabort(None);
            if let Ok(upload) = xhr.upload() {
                upload.set_onprogress(None);
            }
        }
    };
    let finish = Rc::new(finish);
    let handler = |outcome: Result<(), &'static str>| {
        let finish = Rc::clone(&finish);
        Handler::new(move |_: Event| finish(outcome))
    };
    let on_load = handler(Ok(()));
    let on_error = handler(Err("network error"));
    let on_timeout = handler(Err("timed out"));
    let on_abort = handler(Err("aborted"));
    xhr.set_onload(Some(on_load.as_ref().unchecked_ref()));
    xhr.set_onerror(Some(on_error.as_ref().unchecked_ref()));
    xhr.set_ontimeout(Some(on_timeout.as_ref().unchecked_ref()));
    xhr.set_onabort(Some(on_abort.as_ref().unchecked_ref()));
    let mut closures = vec![on_load, on_error, on_timeout, on_abort];
    if let Some(progress) = progress {
        let on_progress = Handler::new(move |event: Event| {
            if let Some(event) = event.dyn_ref::<ProgressEvent>() {
                progress(UploadProgress {
                    sent_bytes: event.loaded(),
                    total_bytes: if event.length_computable() {
                        event.total()
                    } else {
                        0.0
                    },
                });
            }
        });
        xhr.upload()?
            .set_onprogress(Some(on_progress.as_ref().unchecked_ref()));
        closures.push(on_progress);
    }
    match &request.body {
        Some(body) => xhr.send_with_opt_str(Some(body))?,
        None => xhr.send()?,
    }
    Ok(closures)
}

/// A thrown JavaScript value as a message.
pub fn describe_js_error(error: wasm_bindgen::JsValue) -> String {
    error
        .as_string()
        .or_else(|| {
            error
                .dyn_ref::<js_sys::Error>()
                .map(|error| String::from(error.message()))
        })
        .or_else(|| js_sys::JSON::stringify(&error).ok().map(String::from))
        .unwrap_or_else(|| "?".into())
}
