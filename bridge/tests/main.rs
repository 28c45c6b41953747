//! The bridge's integration tests: the real `floatball` binary (and the bridge's
//! library, in-process) over real sockets, pseudo-terminals and peers. One test
//! binary of many modules, a module per subject: one link instead of one per subject.
//!
//! `cargo xtask test` runs the modules side by side, each in a process of its own (a
//! module's tests are `<module>::…`): run one as
//! `cargo test -p floatball-bridge --test integration -- <module>::`.

mod common;

mod arming;
mod baud_pending;
mod commission;
mod console_baud;
mod control;
mod estop_race;
mod gateways;
mod generate;
mod generate_text_image;
mod greeting;
mod hardening;
mod http;
mod installation;
mod link_net;
mod link_serial;
mod link_sim;
mod live;
mod live_bench;
mod live_limits;
mod live_mode;
mod login_load;
mod mbox;
mod mbox_bench;
mod osc;
mod playback;
mod playlist_lock;
mod process;
mod qprogram;
mod scale_bench;
mod schedule;
mod scl;
mod scl_bench;
mod scl_golden;
mod scl_sim;
mod ser2net;
mod simulate;
mod simulate_mbox;
mod simulate_scl;
mod simulate_tcp;
mod start_from;
mod startup_bench;
mod static_files;
mod status_clock;
mod status_gateways;
mod stress;
mod timecode;
mod timecode_bench;
mod untrusted;
mod ws;
mod ws_flood;
