//! Floatball's operator app: a Leptos client-side app compiled to WebAssembly.
//!
//! Logic lives in plain types that are tested natively; components stay thin and reach
//! the bridge only through the services in [`context`], so component tests run them
//! against a fake bridge.
//!
//! # Layout
//! Plain logic (native tests):
//! - [`client`]: the HTTP API as typed calls over a transport, status codes as failures;
//! - [`commission`]: the Commissioning page's decisions: roll call flags, assignment in
//!   grid order, the cell ↔ station mapping built by tapping the grid;
//! - [`connection`]: the connection state machine and its reconnect backoff;
//! - [`console`]: instruction checking and feedback decoding for the console;
//! - [`control`]: the Control and Settings pages' decisions: plan verdicts by round,
//!   panels, the delay-and-cycles forms, saving an edit;
//! - [`create`]: the Create page's draft (a timeline of patterns), what it is made
//!   for, and the generated show with its notes, limit check and bandwidth verdict;
//! - [`files`]: local and controller file lists, formats, CSV preview layout;
//! - [`installation`]: the installation's limits for the preview, its settings form,
//!   stations as ranges, and the units' health warnings before Start;
//! - [`schedule`]: the Schedule page's form (the weekly schedule as typed) and what
//!   the Control page says of the scheduler.
//! - [`lazy`]: the pages loaded when opened (Create, Commissioning, Installation),
//!   each a split point whose code the release build moves into its own wasm chunk;
//! - [`json`]: the bridge's JSON read with structs as objects only (less code);
//! - [`i18n`]: the two languages (中文 / English) and every user-visible string,
//!   including a text for every error code of the bridge and the shared parsers;
//! - [`page`]: the pages and their URL fragments;
//! - [`playlist`]: playlist editing (check, move, delete, edit), form input, Start verdict;
//! - [`session`]: the controller's address, base and WebSocket URLs, the stored login;
//! - [`status`]: reading the bridge's status;
//! - [`wire`]: the bridge's WebSocket messages read without serde's buffering;
//! - the preview's plain parts: [`preview::playback`] (the controls), [`preview::live`]
//!   (the machine's clock), [`preview::model`] (the clock on screen, the renderer
//!   chosen, the ball selected), [`preview::camera`], [`preview::scene`],
//!   [`preview::gestures`] (the 3D view's maths and touch), [`preview::plot`] (one
//!   ball over the show), [`preview::top_view`] (the 2D fallback), and the synthetic
//!   shows of [`preview::perf`].
//!
//! Browser plumbing: [`http`] (XMLHttpRequest), [`socket`] (the WebSocket), [`store`]
//! (IndexedDB). State shared by the views: [`context`]. Views: [`components`] (with
//! the widgets the pages share in [`components::widgets`]), [`preview`].

pub mod client;
pub mod commission;
pub mod components;
pub mod connection;
pub mod console;
pub mod context;
pub mod control;
pub mod create;
pub mod files;
pub mod http;
pub mod i18n;
pub mod installation;
pub mod json;
pub mod lazy;
pub mod page;
pub mod patch;
pub mod plan_worker;
pub mod playlist;
pub mod preview;
pub mod schedule;
pub mod session;
pub mod socket;
pub mod status;
pub mod store;
pub mod wire;

use wasm_bindgen::prelude::wasm_bindgen;

// The unit tests run on wasm32 in the browser, with the browser tests (`wasm-pack
// test --headless --chrome web`), as the app runs; natively too, with `cargo test`.
#[cfg(test)]
wasm_bindgen_test::wasm_bindgen_test_configure!(run_in_browser);

/// Entry point called by `index.html`: mounts the app into `<body>`.
#[wasm_bindgen]
pub fn start() {
    leptos::mount::mount_to_body(components::App);
}

/// Entry point called by `static/plan-worker.js`, off the page's thread: the
/// planner's verdict on a recipe for an installation ([`create::plan_recipe`]), in
/// the Create chunk, which the worker loads on its first request ([`lazy`]).
///
/// # Errors
/// What cannot be read or made, in words; or that the chunk could not be loaded.
#[wasm_bindgen]
pub async fn plan_recipe(recipe_json: String, installation_json: String) -> Result<String, String> {
    lazy::plan_recipe(recipe_json, installation_json)
        .await
        .map_err(|lazy::ChunkError| "the Create page's code could not be loaded".to_owned())?
}
