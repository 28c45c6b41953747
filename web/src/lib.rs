//! Floatball's operator app: a Leptos client-side app compiled to WebAssembly.
//!
//! Logic lives in plain types that are tested natively ([`connection`], [`i18n`]);
//! components stay thin ([`components`]); the browser plumbing is in [`socket`].
//!
//! # Layout
//! - [`connection`]: the connection state machine and its reconnect backoff.
//! - [`i18n`]: the two languages (中文 / English) and every user-visible string.
//! - [`socket`]: the WebSocket to the bridge, reconnecting by itself.
//! - [`components`]: the views.

pub mod components;
pub mod connection;
pub mod i18n;
pub mod socket;

use wasm_bindgen::prelude::wasm_bindgen;

/// Entry point called by `index.html`: mounts the app into `<body>`.
#[wasm_bindgen]
pub fn start() {
    leptos::mount::mount_to_body(components::App);
}
