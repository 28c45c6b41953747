//! The end-to-end tests: the real `floatball` binary, the app as operators get it and
//! headless Chromium over WebDriver. One test binary of a module per subject (one link
//! instead of one per subject); `cargo xtask test` runs the modules side by side, each
//! in a process of its own: run one as
//! `cargo test -p floatball-e2e --test end_to_end -- <module>::`.

mod assets;
mod commission;
mod connection;
mod controls;
mod create;
mod files;
mod gateways_many;
mod installation;
mod language;
mod leftovers;
mod operator;
mod operator_mbox;
mod operator_scl;
mod screens;
