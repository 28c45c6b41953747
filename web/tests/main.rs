//! The web app's browser tests, one binary of a module per subject, run in headless
//! Chromium by `wasm-pack test --headless --chrome web` (one module alone: `wasm-pack
//! test --headless --chrome web --test browser -- preview::`). One binary is linked,
//! bound and opened in a browser once instead of once a subject; every test mounts
//! into a container of its own (see [`dom`]), so they share the page without
//! sharing state.

use wasm_bindgen_test::wasm_bindgen_test_configure;

wasm_bindgen_test_configure!(run_in_browser);

mod dom;

mod commission;
mod create;
mod files;
mod plan_worker;
mod preview;
mod web;
