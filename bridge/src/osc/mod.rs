//! Show control over OSC (issue 37; `docs/show-control.md`): commands in on the UDP
//! port `[osc] listen` names, feedback out to `[osc] feedback`, off unless configured
//! ([`crate::config::OscConfig`]).
//!
//! Commands ([`command`]): `/floatball/estop`, `/floatball/start [entry] [time]`,
//! `/floatball/reset [entry] [time]`, `/floatball/home`, `/floatball/goto <entry>` —
//! the entry 1-based, the time in seconds (an int or a float). Each is carried out by
//! the same functions as the WebSocket's: the e-stop by
//! [`Playback::estop`](crate::playback::Playback::estop) right in the receiving task
//! (no lock, no await: [`crate::estop`]), the others by [`control::issue`] (which
//! tags them with the e-stop generation on arrival, Reset and Home stopping first).
//! Nothing from OSC releases an e-stop: while it is latched, Start, Reset, Home and
//! goto are refused (only an operator's Start, Reset or Home in the app releases it); `estop = true` (the default) and `motion = false` (the
//! default) let an installation take only the e-stop from OSC.
//!
//! Refused, each logged at warn level with the sender's address and why: a sender
//! `allow` does not list (never answered), a packet over [`MAX_PACKET_BYTES`] or that
//! is not OSC, an unknown address, wrong arguments, a command switched off, motion
//! before the initial password is changed, and a Start, Reset, Home or goto the player
//! refuses ([`REFUSALS_LOGGED_PER_S`] a second one by one, the rest of a flood
//! counted). Refusals of an allowed sender also go to the feedback address as
//! `/floatball/refused <address> <why>`, except of messages on the feedback's own
//! addresses ([`FEEDBACK_ADDRESSES`]: two bridges would answer each other for ever).
//!
//! Packets are read strictly as OSC 1.0 defines them ([`decode`], our own reader: the
//! `rosc` crate's let a malformed bundle element hand the next message's address no
//! arguments): a packet with any defect — an element size that is not a multiple of
//! 4, a string without its padding, type tags that do not match the data, bundles
//! nested too deep — is refused whole, logged and reported, and nothing in it is
//! carried out. Bundles are taken apart and their messages carried out at once, in
//! order (their time tags are not waited for). Nothing here panics on any bytes.
//!
//! A command is checked before it has any effect ([`control::issue_unless_latched`]):
//! one that will be refused — no such entry, a time past the show's end, the e-stop
//! latched — changes nothing (no stop, no latch, no home); a button's release is
//! ignored.
//!
//! Feedback ([`feedback_messages`]): `/floatball/state`, `/floatball/entry`,
//! `/floatball/show`, `/floatball/time`, `/floatball/latched`, each its own datagram,
//! sent from the OSC port whenever they change (the show time at most
//! [`FEEDBACK_PER_S`] times a second) and every [`FEEDBACK_REFRESH`] regardless, for a
//! client that starts later or lost a datagram.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use floatball_shared::api::{PlayerState, ServerMessage, StartFrom};
use rosc::{OscMessage, OscPacket, OscType};
use tokio::net::UdpSocket;
use tokio::time::Instant;

use crate::config::OscConfig;

mod decode;
use crate::control::{self, Control};
use crate::state::AppState;
pub use decode::{MAX_ARRAY_DEPTH, MAX_BUNDLE_DEPTH, MAX_PACKET_BYTES, decode};

/// Most feedback rounds a second (while the show time runs).
pub const FEEDBACK_PER_S: u32 = 10;

/// How often the feedback is sent even when nothing changed.
pub const FEEDBACK_REFRESH: Duration = Duration::from_secs(1);

/// The longest show time a command may name, seconds (the longest show accepted).
const MAX_TIME_S: f64 = 24.0 * 60.0 * 60.0;

/// Most refusals logged one by one in a second: beyond, they are counted and the count
/// logged with their senders once the second is over, so that a flood of datagrams
/// cannot fill the log.
pub const REFUSALS_LOGGED_PER_S: u32 = 20;

/// The addresses the feedback is sent on ([`feedback_messages`], and refusals).
pub const FEEDBACK_ADDRESSES: [&str; 6] = [
    "/floatball/state",
    "/floatball/entry",
    "/floatball/show",
    "/floatball/time",
    "/floatball/latched",
    "/floatball/refused",
];

/// A command the bridge carries out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// `/floatball/estop`.
    Estop,
    /// `/floatball/start`, `/floatball/reset`, `/floatball/home`, `/floatball/goto`.
    Control(Control),
    /// A single argument 0: a button's release (TouchOSC sends 1 on press and 0 on
    /// release), not acted on.
    Release,
}

/// Binds the OSC port of `config`.
///
/// # Errors
/// The address cannot be bound (in use, not this host's).
pub async fn bind(config: &OscConfig) -> std::io::Result<UdpSocket> {
    UdpSocket::bind(config.listen).await
}

/// Serves OSC on `socket` for `state` as `config` says: commands in, and feedback out
/// when `config` names a feedback address; ends when the bridge stops. Must run inside
/// the async runtime.
pub fn spawn(state: AppState, socket: UdpSocket, config: OscConfig) {
    let socket = Arc::new(socket);
    let config = Arc::new(config);
    if let Some(to) = config.feedback {
        tokio::spawn(feedback(state.clone(), Arc::clone(&socket), to));
    }
    tokio::spawn(receive(state, socket, config));
}

/// Receives and carries out commands until the bridge stops.
async fn receive(state: AppState, socket: Arc<UdpSocket>, config: Arc<OscConfig>) {
    let mut stopping = state.stopping();
    // Room for any datagram, so that one too large is seen as such (not cut short).
    let mut buffer = vec![0u8; 65_536];
    let mut refusals = Refusals::new();
    loop {
        let due = refusals.due();
        let received = tokio::select! {
            _ = stopping.changed() => return,
            received = socket.recv_from(&mut buffer) => received,
            () = tokio::time::sleep_until(due.unwrap_or_else(Instant::now)), if due.is_some() => {
                refusals.flush();
                continue;
            }
        };
        match received {
            Ok((length, sender)) => {
                let packet = buffer.get(..length).unwrap_or_default();
                handle(&state, &socket, &config, &mut refusals, packet, sender);
            }
            Err(error) => tracing::debug!("OSC: receiving: {error}"),
        }
    }
}

/// The log of refusals: at most [`REFUSALS_LOGGED_PER_S`] a second one by one, the
/// rest counted, with their senders, and the count logged once the second is over.
#[derive(Debug)]
struct Refusals {
    since: Instant,
    logged: u32,
    unlogged: u32,
    senders: Vec<std::net::IpAddr>,
}

/// How many senders the count of refusals not logged one by one names at most.
const SENDERS_NAMED: usize = 8;

impl Refusals {
    fn new() -> Self {
        Self {
            since: Instant::now(),
            logged: 0,
            unlogged: 0,
            senders: Vec::new(),
        }
    }

    /// Logs that `sender`'s `what` was refused, `why`.
    fn log(&mut self, sender: SocketAddr, what: &str, why: &str) {
        if self.since.elapsed() >= Duration::from_secs(1) {
            self.flush();
        }
        if self.logged < REFUSALS_LOGGED_PER_S {
            self.logged += 1;
            tracing::warn!("OSC from {sender}{what} refused: {why}");
        } else {
            self.unlogged += 1;
            if self.senders.len() < SENDERS_NAMED && !self.senders.contains(&sender.ip()) {
                self.senders.push(sender.ip());
            }
        }
    }

    /// When the count of refusals not logged is due, if there is one.
    fn due(&self) -> Option<Instant> {
        (self.unlogged > 0).then_some(self.since + Duration::from_secs(1))
    }

    /// Logs the count of refusals not logged one by one, and starts a new second.
    fn flush(&mut self) {
        if self.unlogged > 0 {
            let senders: Vec<String> = self.senders.iter().map(ToString::to_string).collect();
            tracing::warn!(
                "OSC: {} more refusals in a second, not logged one by one, from {}{}",
                self.unlogged,
                senders.join(", "),
                if self.senders.len() == SENDERS_NAMED {
                    " and maybe more"
                } else {
                    ""
                }
            );
        }
        *self = Self::new();
    }
}

/// Acts on one datagram from `sender`.
fn handle(
    state: &AppState,
    socket: &Arc<UdpSocket>,
    config: &Arc<OscConfig>,
    refusals: &mut Refusals,
    packet: &[u8],
    sender: SocketAddr,
) {
    if !config
        .allow
        .iter()
        .any(|source| source.contains(sender.ip()))
    {
        refusals.log(sender, "", "the sender is not in [osc] allow");
        return;
    }
    let mut refuse = |address: &str, why: &str| {
        refusals.log(sender, &format!(": {address:?}"), why);
        // Never about feedback (another bridge's, or this one's sent back to it): two
        // bridges would answer each other's answers for ever.
        if let Some(to) = config.feedback
            && !FEEDBACK_ADDRESSES.contains(&address)
        {
            send(
                socket,
                to,
                message(
                    "/floatball/refused",
                    vec![
                        OscType::String(address.to_owned()),
                        OscType::String(why.to_owned()),
                    ],
                ),
            );
        }
    };
    let messages = match decode(packet) {
        Ok(messages) => messages,
        Err(why) => return refuse("", &why),
    };
    for osc in messages {
        let command = match command(&osc) {
            Ok(command) => command,
            Err(why) => {
                refuse(&osc.addr, &why);
                continue;
            }
        };
        match command {
            Command::Release => {
                tracing::debug!("OSC from {sender}: {:?} 0 (a release) ignored", osc.addr);
            }
            Command::Estop if !config.estop => {
                refuse(
                    &osc.addr,
                    "the e-stop over OSC is switched off ([osc] estop)",
                );
            }
            Command::Estop => {
                let unreached = state.playback().estop();
                tracing::warn!("e-stop requested over OSC by {sender}");
                if !unreached.is_empty() {
                    tracing::error!("the e-stop did not reach {}", unreached.join("; "));
                }
            }
            Command::Control(_) if !config.motion => refuse(
                &osc.addr,
                "motion over OSC is switched off ([osc] motion = false): only the e-stop \
                 is obeyed",
            ),
            Command::Control(_) if state.password().is_default() => refuse(
                &osc.addr,
                "the initial password has not been changed yet: change it in the app first",
            ),
            Command::Control(control) => {
                // Only an operator in the app releases an e-stop: a Start, Reset, Home
                // or goto from OSC is refused while one is latched, and void if one is
                // pressed as it is issued.
                // Checked before it has any effect: a refused Reset or goto stops
                // nothing and latches nothing.
                let running = match control::issue_unless_latched(state, control) {
                    Ok(running) => running,
                    Err(not_issued) => {
                        refuse(&osc.addr, &not_issued.to_string());
                        continue;
                    }
                };
                tracing::info!("OSC from {sender}: {control:?}");
                let (socket, config, address) =
                    (Arc::clone(socket), Arc::clone(config), osc.addr.clone());
                tokio::spawn(async move {
                    if let Err(ServerMessage::Error { message: why, .. }) = running.await {
                        tracing::warn!("OSC from {sender}: {address:?} refused: {why}");
                        if let Some(to) = config.feedback {
                            send(
                                &socket,
                                to,
                                message(
                                    "/floatball/refused",
                                    vec![OscType::String(address), OscType::String(why)],
                                ),
                            );
                        }
                    }
                });
            }
        }
    }
}

/// What `message` asks for.
///
/// # Errors
/// An unknown address or wrong arguments, in words.
pub fn command(message: &OscMessage) -> Result<Command, String> {
    let args = &message.args;
    let release = matches!(args.as_slice(), [only] if number(only) == Some(0.0));
    let control = match message.addr.as_str() {
        // Always pressed, whatever its arguments (a button's release presses it again).
        "/floatball/estop" => return Ok(Command::Estop),
        _ if release => return Ok(Command::Release),
        "/floatball/start" => Control::Start(start_from(args)?),
        "/floatball/reset" => Control::Reset(start_from(args)?),
        "/floatball/home" if args.is_empty() || release_or_press(args) => Control::Home,
        "/floatball/home" => return Err("home takes no arguments".to_owned()),
        "/floatball/goto" => match args.as_slice() {
            [entry] => Control::Reset(StartFrom {
                entry: Some(entry_number(entry)?),
                time_ms: None,
            }),
            _ => return Err("goto takes one argument: the entry (1-based)".to_owned()),
        },
        _ => return Err("unknown address".to_owned()),
    };
    Ok(Command::Control(control))
}

/// Whether `args` is a button's press: one argument 1.
fn release_or_press(args: &[OscType]) -> bool {
    matches!(args, [only] if number(only) == Some(1.0))
}

/// Start's and Reset's arguments: none, `entry`, or `entry time`.
fn start_from(args: &[OscType]) -> Result<StartFrom, String> {
    match args {
        [] => Ok(StartFrom::default()),
        [entry] => Ok(StartFrom {
            entry: Some(entry_number(entry)?),
            time_ms: None,
        }),
        [entry, time] => Ok(StartFrom {
            entry: Some(entry_number(entry)?),
            time_ms: Some(time_ms(time)?),
        }),
        _ => Err("at most two arguments: the entry (1-based) and the time (s)".to_owned()),
    }
}

/// A numeric argument's value.
fn number(arg: &OscType) -> Option<f64> {
    match *arg {
        OscType::Int(value) => Some(f64::from(value)),
        OscType::Long(value) => Some(value as f64),
        OscType::Float(value) => Some(f64::from(value)),
        OscType::Double(value) => Some(value),
        _ => None,
    }
}

/// An entry, 1-based: a whole number from 1 (an int, or a float such as 2.0).
fn entry_number(arg: &OscType) -> Result<usize, String> {
    number(arg)
        .filter(|entry| entry.fract() == 0.0 && (1.0..=1e6).contains(entry))
        .map(|entry| entry as usize)
        .ok_or_else(|| {
            format!(
                "the entry must be a whole number from 1, not {}",
                shown(arg)
            )
        })
}

/// A time inside a show, seconds (an int or a float) from 0 to 24 hours, in ms.
fn time_ms(arg: &OscType) -> Result<u64, String> {
    number(arg)
        .filter(|time| (0.0..=MAX_TIME_S).contains(time))
        .map(|time| (time * 1000.0).round() as u64)
        .ok_or_else(|| {
            format!(
                "the time must be seconds from 0 to 86400, not {}",
                shown(arg)
            )
        })
}

/// An argument in a refusal: a number's value, or the kind of anything else (never
/// the whole of what a sender sent).
fn shown(arg: &OscType) -> String {
    match number(arg) {
        Some(value) => value.to_string(),
        None => match arg {
            OscType::String(_) => "a string".to_owned(),
            OscType::Blob(_) => "a blob".to_owned(),
            OscType::Array(_) => "an array".to_owned(),
            _ => "an argument of another type".to_owned(),
        },
    }
}

/// An OSC message.
fn message(addr: &str, args: Vec<OscType>) -> OscMessage {
    OscMessage {
        addr: addr.to_owned(),
        args,
    }
}

/// Sends `message` to `to` without waiting (a full send buffer drops it: feedback is
/// refreshed anyway).
fn send(socket: &UdpSocket, to: SocketAddr, message: OscMessage) {
    match rosc::encoder::encode(&OscPacket::Message(message)) {
        Ok(bytes) => {
            if let Err(error) = socket.try_send_to(&bytes, to) {
                tracing::debug!("OSC feedback to {to}: {error}");
            }
        }
        Err(error) => tracing::debug!("OSC feedback cannot be encoded: {error}"),
    }
}

/// What the feedback says, as it changes.
#[derive(Debug, Clone, PartialEq)]
pub struct Feedback {
    /// The player's state (`PlayerState::as_str`).
    pub state: PlayerState,
    /// The entry playing, 1-based; 0 when none.
    pub entry: usize,
    /// The show playing, `""` when none.
    pub show: String,
    /// The show's time, ms.
    pub show_time_ms: u64,
    /// Whether an e-stop is in force.
    pub latched: bool,
}

/// The feedback messages for `feedback`, in the order sent.
pub fn feedback_messages(feedback: &Feedback) -> Vec<OscMessage> {
    vec![
        message(
            "/floatball/state",
            vec![OscType::String(feedback.state.as_str().to_owned())],
        ),
        message(
            "/floatball/entry",
            vec![OscType::Int(
                i32::try_from(feedback.entry).unwrap_or(i32::MAX),
            )],
        ),
        message(
            "/floatball/show",
            vec![OscType::String(feedback.show.clone())],
        ),
        message(
            "/floatball/time",
            vec![OscType::Float(feedback.show_time_ms as f32 / 1000.0)],
        ),
        message(
            "/floatball/latched",
            vec![OscType::Int(i32::from(feedback.latched))],
        ),
    ]
}

/// Sends the feedback to `to` on every change (at most [`FEEDBACK_PER_S`] times a
/// second) and every [`FEEDBACK_REFRESH`], until the bridge stops.
async fn feedback(state: AppState, socket: Arc<UdpSocket>, to: SocketAddr) {
    let mut stopping = state.stopping();
    let mut status = state.subscribe_status();
    let period = Duration::from_secs(1) / FEEDBACK_PER_S;
    let mut sent: Option<Feedback> = None;
    let mut sent_at = Instant::now();
    loop {
        // Copied out: the guard is dropped before anything else is looked at.
        let mut current = {
            let status = status.borrow_and_update();
            Feedback {
                state: status.state,
                entry: status.entry.map_or(0, |entry| entry + 1),
                show: status.show.clone().unwrap_or_default(),
                show_time_ms: status.show_time_ms,
                latched: false,
            }
        };
        current.latched = state.playback().latch().is_latched();
        if sent.as_ref() != Some(&current) || sent_at.elapsed() >= FEEDBACK_REFRESH {
            for message in feedback_messages(&current) {
                send(&socket, to, message);
            }
            sent = Some(current);
            sent_at = Instant::now();
        }
        // At most one round a period; then until the status changes, the latch is
        // looked at again, or the refresh is due.
        tokio::time::sleep(period).await;
        let refresh = sent_at + FEEDBACK_REFRESH;
        tokio::select! {
            _ = stopping.changed() => return,
            changed = status.changed() => if changed.is_err() { return },
            () = tokio::time::sleep_until(refresh.min(Instant::now() + period * 5)) => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn osc(addr: &str, args: Vec<OscType>) -> OscMessage {
        message(addr, args)
    }

    #[test]
    fn commands_take_an_entry_and_a_time_in_seconds() {
        let start = |entry, time_ms| {
            Ok(Command::Control(Control::Start(StartFrom {
                entry,
                time_ms,
            })))
        };
        assert_eq!(command(&osc("/floatball/start", vec![])), start(None, None));
        assert_eq!(
            command(&osc(
                "/floatball/start",
                vec![OscType::Int(2), OscType::Float(0.5)]
            )),
            start(Some(2), Some(500))
        );
        assert_eq!(
            command(&osc(
                "/floatball/start",
                vec![OscType::Float(3.0), OscType::Int(90)]
            )),
            start(Some(3), Some(90_000))
        );
        assert_eq!(
            command(&osc(
                "/floatball/reset",
                vec![OscType::Long(1), OscType::Double(1.25)]
            )),
            Ok(Command::Control(Control::Reset(StartFrom {
                entry: Some(1),
                time_ms: Some(1_250)
            })))
        );
        assert_eq!(
            command(&osc("/floatball/goto", vec![OscType::Int(4)])),
            Ok(Command::Control(Control::Reset(StartFrom {
                entry: Some(4),
                time_ms: None
            })))
        );
        assert_eq!(
            command(&osc("/floatball/home", vec![])),
            Ok(Command::Control(Control::Home))
        );
        assert_eq!(
            command(&osc("/floatball/home", vec![OscType::Float(1.0)])),
            Ok(Command::Control(Control::Home))
        );
        for args in [vec![], vec![OscType::Float(0.0)], vec![OscType::Int(1)]] {
            assert_eq!(command(&osc("/floatball/estop", args)), Ok(Command::Estop));
        }
        for addr in ["/floatball/start", "/floatball/home", "/floatball/goto"] {
            assert_eq!(
                command(&osc(addr, vec![OscType::Float(0.0)])),
                Ok(Command::Release),
                "{addr}"
            );
        }
    }

    #[test]
    fn wrong_commands_are_refused_with_why() {
        for (addr, args, why) in [
            ("/floatball/stop", vec![], "unknown address"),
            ("/floatball/start", vec![OscType::Int(-1)], "the entry"),
            ("/floatball/start", vec![OscType::Float(1.5)], "the entry"),
            (
                "/floatball/start",
                vec![OscType::Int(1), OscType::Float(-0.5)],
                "the time",
            ),
            (
                "/floatball/start",
                vec![OscType::Int(1), OscType::Float(f32::NAN)],
                "the time",
            ),
            (
                "/floatball/start",
                vec![OscType::Int(1), OscType::String("0.5".into())],
                "the time",
            ),
            (
                "/floatball/start",
                vec![OscType::Int(1), OscType::Int(1), OscType::Int(1)],
                "at most two",
            ),
            ("/floatball/goto", vec![], "goto takes one"),
            ("/floatball/home", vec![OscType::Int(3)], "no arguments"),
        ] {
            let refused = command(&osc(addr, args.clone())).unwrap_err();
            assert!(refused.contains(why), "{addr} {args:?}: {refused}");
        }
    }

    #[test]
    fn a_flood_of_refusals_is_counted_past_the_limit() {
        let mut refusals = Refusals::new();
        for sender in 0..(REFUSALS_LOGGED_PER_S + 12) {
            let sender = SocketAddr::from(([10, 0, 0, (sender % 10) as u8], 9000));
            refusals.log(sender, "", "the sender is not in [osc] allow");
        }
        assert_eq!(refusals.logged, REFUSALS_LOGGED_PER_S);
        assert_eq!(refusals.unlogged, 12);
        assert_eq!(refusals.senders.len(), SENDERS_NAMED);
        assert_eq!(
            refusals.due(),
            Some(refusals.since + Duration::from_secs(1))
        );
        refusals.flush();
        assert_eq!(
            (refusals.logged, refusals.unlogged, refusals.due()),
            (0, 0, None)
        );
    }

    /// No bytes make decoding or reading a command panic or exhaust the stack: random
    /// packets, valid packets with bytes changed, and bundles and arrays nested as
    /// deeply as the size limit allows.
    #[test]
    fn no_bytes_panic() {
        let mut seed = 0x9E37_79B9_7F4A_7C15_u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let valid = rosc::encoder::encode(&OscPacket::Bundle(rosc::OscBundle {
            timetag: (0, 1).into(),
            content: vec![OscPacket::Message(osc(
                "/floatball/start",
                vec![OscType::Int(1), OscType::Float(0.5)],
            ))],
        }))
        .unwrap();
        let read = |bytes: &[u8]| {
            if let Ok(messages) = decode(bytes) {
                for message in &messages {
                    let _ = command(message);
                }
            }
        };
        for round in 0..20_000 {
            let bytes: Vec<u8> = if round % 2 == 0 {
                let length = (next() % 64) as usize;
                (0..length).map(|_| next() as u8).collect()
            } else {
                let mut bytes = valid.clone();
                for _ in 0..1 + next() % 4 {
                    let at = (next() as usize) % bytes.len();
                    bytes[at] = next() as u8;
                }
                bytes.truncate(bytes.len() - (next() % 3) as usize);
                bytes
            };
            read(&bytes);
        }
        // Bundles inside bundles, each one element of the next: refused past the
        // depth taken.
        let mut nested = valid.clone();
        while nested.len() + 20 <= MAX_PACKET_BYTES {
            let mut bundle = b"#bundle\0\0\0\0\0\0\0\0\x01".to_vec();
            bundle.extend(u32::try_from(nested.len()).unwrap().to_be_bytes());
            bundle.extend(&nested);
            nested = bundle;
        }
        assert!(decode(&nested).unwrap_err().contains("nested over"));
        // Arrays inside arrays: `[[[…]]]` as the type tags.
        let depth = (MAX_PACKET_BYTES - 24) / 2;
        let mut arrays = b"/floatball/start\0\0\0\0,".to_vec();
        arrays.extend(std::iter::repeat_n(b'[', depth));
        arrays.extend(std::iter::repeat_n(b']', depth));
        arrays.push(0);
        while !arrays.len().is_multiple_of(4) {
            arrays.push(0);
        }
        read(&arrays);
    }
}
