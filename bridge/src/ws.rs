//! The WebSocket endpoint `/ws?token=…` (`docs/architecture.md` §4): status and feedback out, control
//! and console lines in.
//!
//! Before the upgrade: a browser's cross-site `Origin` is refused (403) — allowed are
//! no `Origin` (programs), the bridge's own host, and the configured
//! `allowed_origins` — and the token must be valid (401).
//!
//! A session then gets the status at once and on every change, at most
//! [`STATUS_PER_S`] times a second (changes in between are merged: the latest wins),
//! and every feedback frame of every gateway until it sends `{"type":"feedback",
//! "relay":false}` (and again from `"relay":true`: the app asks for them only while its
//! console is open). The balls' live positions (`live_positions`, whole mm, ten a
//! second or fewer on a large matrix, one empty message when live mode ends) only
//! after it sends `{"type":"live_positions","on":true}` (the app: while it shows the
//! Preview or the Live card): copied out of the playback task's watch, no borrow
//! held while sending. Its reading and writing are separate
//! tasks: what the client sends is acted on as it arrives, even while a status waits
//! for a client that reads slowly. Every message from the client counts as
//! use of its token; when the token has expired or was ended by a logout, the
//! session says so and closes. Anything the bridge cannot do is answered with an
//! `error` message and the connection stays open.
//!
//! No reply is dropped in silence: the reading half queues each in the session's
//! [`Outbox`] without waiting (`estop_sent` ahead of everything, runs of `pong` as a
//! count), and a client that gets more than [`REPLY_LIMIT`] other replies waiting is
//! flooding: what it sends from then on is not acted on (except `estop`, always
//! pressed and acknowledged), and the session closes with 1008 and [`FLOODED`].
//!
//! `estop` is always obeyed, even before the initial password is changed: it is
//! carried out right here, before anything else, by pressing the e-stop latch (no lock,
//! no await: [`crate::estop`]), and answered with `estop_sent`. Start, Reset and Home
//! are tagged with the e-stop generation at the moment they arrive, so an e-stop that
//! arrives after them voids them even while they are still being prepared. `raw`
//! console lines are parsed by the codec; a valid line is queued, in order, on the
//! bulk lane of its gateway (or of all), by a task of the session so that a full lane
//! never holds up status and feedback. While the e-stop is latched, a line that could
//! move a ball is refused (queries still go). A line holding `BDR=x;` is refused
//! whole: the line speed changes only through the guided change
//! ([`crate::ports::uim2503::Link::change_baud`]), which keeps the link in step with the gateway.
//!
//! On an MBOX installation a `raw` line is MBOX console text
//! (`floatball_shared::mbox::console`, docs/gateways.md §7), parsed with the selected
//! box's route (the last two octets of gateway N's configured IP address, sent as
//! every box since only that box's socket receives it; every box when no gateway is
//! given) and handed to
//! [`crate::ports::mbox::MboxNet::console`]. While the e-stop is latched only reads and the
//! e-stop write (`estop`) go; `release` and every other write are refused: releasing is
//! Start, Reset or Home. The console's `estop` is a register write only — it does not
//! set the bridge's latch (the `estop` message does). Replies to console reads reach
//! every session as `mbox_reply`.
//!
//! On an installation of MOONS' drives a `raw` line is SCL (one command a line,
//! `floatball_shared::scl::parse_script`; a refusal names its line and column): each
//! command goes to the drive its address character names on gateway N (0 when no
//! gateway is given; no address: the entry's only drive), by
//! [`crate::ports::scl::program::console`]. While the e-stop is latched only queries and
//! stops go. Every drive's decoded answer reaches every session as `scl_reply`.

use std::collections::{HashMap, VecDeque};
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::{CloseFrame, Message, WebSocket, WebSocketUpgrade, close_code};
use axum::extract::{Query, State};
use axum::http::{HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use floatball_shared::api::{ClientMessage, FeedbackFrame, PlayerState, ServerMessage, Status};
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::mbox::console::{self as mbox_console, Operation};
use floatball_shared::mbox::{BoxAddress, Route};
use floatball_shared::params;
use floatball_shared::uim2503::ascii::{Batch, Form, GatewayCommand, Instruction, parse_script};
use futures_util::{SinkExt, StreamExt};
use tokio::sync::{broadcast, mpsc, watch};
use tokio::time::Instant;

use crate::control::{self, Control};
use crate::http::Failure;
use crate::origin::origin_allowed;
use crate::ports::mbox::MboxNet;
use crate::ports::scl::SclNet;
use crate::state::AppState;

/// Most `status` messages per second to one client.
pub const STATUS_PER_S: u32 = 10;

/// Largest message a client may send, bytes.
pub const MAX_MESSAGE_BYTES: usize = 64 * 1024;

/// Console lines one session may have waiting for room on a bulk lane.
const CONSOLE_QUEUE: usize = 32;

/// A console line on its way: the gateway (all when `None`), the instructions, and the
/// e-stop generation it was issued at.
type ConsoleLine = (Option<usize>, Batch, u64);

/// How long a closing session waits for the client to answer its close frame.
const CLOSE_HANDSHAKE: Duration = Duration::from_secs(1);

/// How often an open session checks that its token is still valid.
const TOKEN_CHECK_INTERVAL: Duration = Duration::from_secs(1);

/// `GET /ws?token=…`: checks the origin and the token, then upgrades.
pub async fn upgrade(
    State(state): State<AppState>,
    Query(query): Query<HashMap<String, String>>,
    headers: HeaderMap,
    upgrade: WebSocketUpgrade,
) -> Response {
    if !origin_allowed(&headers, &state.config().allowed_origins) {
        return Failure::from_template(
            StatusCode::FORBIDDEN,
            Code::OriginNotAllowed,
            Params::new(),
        )
        .into_response();
    }
    let Some(token) = query.get("token").cloned() else {
        return Failure::coded(
            StatusCode::UNAUTHORIZED,
            Code::LoginRequired,
            "log in first: open /ws?token=<token from POST /api/login>",
        )
        .into_response();
    };
    if !state.tokens().touch(&token, state.clock().now()) {
        return Failure::from_template(
            StatusCode::UNAUTHORIZED,
            Code::SessionExpired,
            Params::new(),
        )
        .into_response();
    }
    upgrade
        .max_message_size(MAX_MESSAGE_BYTES)
        .on_upgrade(move |socket| session(socket, state, token))
}

/// What a session's writing loop does next.
enum Step {
    Continue,
    Close,
}

/// What a session's reading half tells its writing half (besides replies, which go
/// through the [`Outbox`]).
#[derive(Debug)]
enum Inbound {
    /// The client used a token that is no longer valid.
    EndSession,
    /// The client sent what cannot be received: close with this frame.
    Refuse(CloseFrame),
    /// The client closed the connection, or it broke.
    Closed,
}

/// Session events the reading half may have waiting for the writing half.
const INBOUND_QUEUE: usize = 8;

/// Replies to a client's messages, other than `pong`, that may wait for its writer
/// (waiting pongs are a count: they never overflow). A client that sends so fast that
/// more would wait is flooding: the message that would overflow is not acted on, nor
/// any after it except `estop`, and the session closes with 1008 and [`FLOODED`] once
/// the `estop_sent` already waiting have been sent.
pub const REPLY_LIMIT: usize = 1024;

/// The close reason of a session whose client flooded it.
pub const FLOODED: &str =
    "flooded: over 1024 replies were waiting; later messages were not acted on (estop always is)";

/// The replies waiting for a session's writer, filled by its reader without waiting:
/// acknowledgements of `estop` ahead of everything, then the others in order, runs of
/// `pong` as one count. A guard is taken, a reply pushed or popped, and the guard
/// dropped at once.
#[derive(Default)]
struct Outbox {
    pending: std::sync::Mutex<Pending>,
    ready: tokio::sync::Notify,
}

#[derive(Default)]
struct Pending {
    /// `estop_sent`, sent ahead of everything.
    safety: VecDeque<ServerMessage>,
    /// Every other reply, in order.
    replies: VecDeque<Waiting>,
    /// How many replies `replies` holds besides its pongs.
    count: usize,
    /// The client flooded: the session closes.
    flooded: bool,
}

enum Waiting {
    Pongs(usize),
    Reply(Box<ServerMessage>),
}

/// What a session's writer sends next.
enum Next {
    Reply(Box<ServerMessage>),
    /// Close with 1008 and [`FLOODED`].
    Flooded,
    Nothing,
}

impl Outbox {
    fn pending(&self) -> std::sync::MutexGuard<'_, Pending> {
        self.pending
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Whether another message from the client may be acted on: there is room for its
    /// reply. When there is not, the client is flooding: the writer is told to close.
    fn admit(&self) -> bool {
        let mut pending = self.pending();
        if !pending.flooded && pending.count >= REPLY_LIMIT {
            pending.flooded = true;
            drop(pending);
            tracing::warn!("closing a WebSocket whose client sends faster than it reads");
            self.ready.notify_one();
            return false;
        }
        !pending.flooded
    }

    /// Queues `reply` for the writer: an `estop_sent` ahead of everything, any other
    /// after those waiting (dropped once the session is flooded: it is closing).
    fn push(&self, reply: ServerMessage) {
        let mut pending = self.pending();
        match reply {
            ServerMessage::EstopSent { .. } => {
                if pending.safety.len() < REPLY_LIMIT {
                    pending.safety.push_back(reply);
                } else {
                    pending.flooded = true;
                }
            }
            _ if pending.flooded => return,
            ServerMessage::Pong => {
                if let Some(Waiting::Pongs(run)) = pending.replies.back_mut() {
                    *run += 1;
                } else {
                    pending.replies.push_back(Waiting::Pongs(1));
                }
            }
            reply => {
                pending.count += 1;
                pending.replies.push_back(Waiting::Reply(Box::new(reply)));
            }
        }
        drop(pending);
        self.ready.notify_one();
    }

    /// What the writer sends next.
    fn next(&self) -> Next {
        let mut pending = self.pending();
        if let Some(reply) = pending.safety.pop_front() {
            return Next::Reply(Box::new(reply));
        }
        if pending.flooded {
            return Next::Flooded;
        }
        match pending.replies.front_mut() {
            None => Next::Nothing,
            Some(Waiting::Pongs(run)) if *run > 1 => {
                *run -= 1;
                Next::Reply(Box::new(ServerMessage::Pong))
            }
            Some(Waiting::Pongs(_)) => {
                pending.replies.pop_front();
                Next::Reply(Box::new(ServerMessage::Pong))
            }
            Some(Waiting::Reply(_)) => match pending.replies.pop_front() {
                Some(Waiting::Reply(reply)) => {
                    pending.count -= 1;
                    Next::Reply(reply)
                }
                _ => Next::Nothing,
            },
        }
    }
}

/// Sends every reply waiting in `outbox`; closes with 1008 when the client flooded.
async fn send_replies(
    sink: &mut Sink,
    outbox: &Outbox,
    inbound: &mut mpsc::Receiver<Inbound>,
) -> Step {
    loop {
        match outbox.next() {
            Next::Reply(reply) => {
                if send(sink, &reply).await.is_err() {
                    return Step::Close;
                }
            }
            Next::Flooded => {
                let closing = sink
                    .send(Message::Close(Some(CloseFrame {
                        code: close_code::POLICY,
                        reason: FLOODED.into(),
                    })))
                    .await;
                // The reader goes on pressing every e-stop the client still sends
                // until its side of the closing handshake (no answer can follow a
                // close frame).
                if closing.is_ok() {
                    closing_handshake(inbound).await;
                }
                return Step::Close;
            }
            Next::Nothing => return Step::Continue,
        }
    }
}

type Sink = futures_util::stream::SplitSink<WebSocket, Message>;
type Stream = futures_util::stream::SplitStream<WebSocket>;

/// A status made `age` ago, as it stands when it is sent: a show's time runs on
/// the units' clock, so a status held back for the client's rate is brought to the
/// instant it goes (issue 34, item 5: the show's time a client sees is the units'
/// within a few milliseconds, not up to a status period behind). Nothing else in it
/// changes with time alone; a show's end is left to the next status.
fn as_sent(mut status: Status, age: Duration) -> Status {
    let age_ms = u64::try_from(age.as_millis()).unwrap_or(u64::MAX);
    match status.state {
        PlayerState::Playing => {
            let show_time_ms = status.show_time_ms.saturating_add(age_ms);
            if show_time_ms < status.show_duration_ms {
                status.show_time_ms = show_time_ms;
                status.progress = show_time_ms as f64 / status.show_duration_ms as f64;
            }
        }
        PlayerState::Loading => {
            if let Some(starts_in_ms) = &mut status.show_starts_in_ms {
                *starts_in_ms = starts_in_ms.saturating_sub(age_ms);
            }
        }
        _ => {}
    }
    status
}

/// One client's session: a reading half that acts on every message the moment it
/// arrives (so an `estop` is pressed even while the writing half waits for a slow
/// client to take a status), and a writing half that sends statuses, feedback and
/// replies.
async fn session(socket: WebSocket, state: AppState, token: String) {
    let (mut sink, stream) = socket.split();
    let mut status = state.subscribe_status();
    let mut schedule = state.schedules().subscribe();
    let (relay, mut relay_wanted) = watch::channel(true);
    let (positions_wish, mut positions_wanted) = watch::channel(false);
    let mut positions: Option<crate::playback::PositionsWatch> = None;
    let mut feedback = Some(state.gateways().subscribe_feedback());
    let mut mbox_replies = state.playback().boxes().map(MboxNet::subscribe_replies);
    let mut scl_replies = state.playback().scl().map(SclNet::subscribe_replies);
    let (console_lines, waiting_lines) = mpsc::channel(CONSOLE_QUEUE);
    let (console_errors, mut console_failures) = mpsc::channel(CONSOLE_QUEUE);
    let replies = console_errors.clone();
    tokio::spawn(console(state.clone(), waiting_lines, console_errors));
    let (inbound_tx, mut inbound) = mpsc::channel(INBOUND_QUEUE);
    let outbox = Arc::new(Outbox::default());
    let reader = tokio::spawn(read_messages(
        stream,
        state.clone(),
        token.clone(),
        Senders {
            console_lines,
            replies,
            outbox: Arc::clone(&outbox),
            inbound: inbound_tx,
            relay: Wishes {
                feedback: relay,
                live_positions: positions_wish,
            },
        },
    ));
    let _stop_reading = AbortOnDrop(reader);
    let first = status.borrow_and_update().clone();
    let mut sent_state = first.state;
    let first = ServerMessage::Status(first);
    if send(&mut sink, &first).await.is_err() {
        return;
    }
    // The scheduler's state, when there is one to tell (a schedule followed, or what
    // it did last); then whenever it changes.
    let scheduled = schedule.borrow_and_update().clone();
    if (scheduled.enabled || scheduled.last.is_some())
        && send(&mut sink, &ServerMessage::Schedule(scheduled))
            .await
            .is_err()
    {
        return;
    }
    // The timecode chase's status, when it is on: now, then on every change (its
    // task publishes at most ten a second).
    let mut timecode = state.subscribe_timecode();
    let chase = timecode.borrow_and_update().clone();
    if let Some(chase) = chase
        && send(&mut sink, &ServerMessage::Timecode(chase))
            .await
            .is_err()
    {
        return;
    }
    let status_interval = Duration::from_secs(1) / STATUS_PER_S;
    let mut status_sent_at = Instant::now();
    // When the latest status was made: the playback task publishes each the instant
    // it builds it, and this half learns of it at once.
    let mut status_made = Instant::now();
    let mut status_pending = false;
    let mut token_check = tokio::time::interval(TOKEN_CHECK_INTERVAL);
    let mut stopping = state.stopping();
    if *stopping.borrow_and_update() {
        return;
    }
    loop {
        let step = tokio::select! {
            _ = stopping.changed() => {
                let _ = sink
                    .send(Message::Close(Some(CloseFrame {
                        code: close_code::AWAY,
                        reason: "the bridge is stopping".into(),
                    })))
                    .await;
                Step::Close
            }
            changed = status.changed() => {
                if changed.is_err() {
                    Step::Close
                } else {
                    // Seen (the next change wakes this again); sent within the rate,
                    // but a new state at once (`playing` as the balls start).
                    let state = status.borrow_and_update().state;
                    status_made = Instant::now();
                    if state == sent_state {
                        status_pending = true;
                        Step::Continue
                    } else {
                        status_pending = false;
                        status_sent_at = Instant::now();
                        sent_state = state;
                        let latest = status.borrow().clone();
                        sent(send(&mut sink, &ServerMessage::Status(latest)).await)
                    }
                }
            }
            changed = schedule.changed() => {
                if changed.is_err() {
                    Step::Close
                } else {
                    let latest = schedule.borrow_and_update().clone();
                    sent(send(&mut sink, &ServerMessage::Schedule(latest)).await)
                }
            }
            () = tokio::time::sleep_until(status_sent_at + status_interval), if status_pending => {
                status_pending = false;
                status_sent_at = Instant::now();
                let latest = status.borrow().clone();
                sent_state = latest.state;
                let message = ServerMessage::Status(as_sent(latest, status_made.elapsed()));
                sent(send(&mut sink, &message).await)
            }
            changed = timecode.changed() => {
                let chase = if changed.is_ok() { timecode.borrow_and_update().clone() } else { None };
                match chase {
                    Some(chase) => sent(send(&mut sink, &ServerMessage::Timecode(chase)).await),
                    None => Step::Continue,
                }
            }
            changed = relay_wanted.changed() => {
                if changed.is_ok() {
                    // Subscribed only while wanted: with no subscriber, no gateway
                    // builds frames for the WebSocket relay.
                    // The wish is copied out: no watch borrow is held while
                    // subscribing.
                    let wanted = *relay_wanted.borrow_and_update();
                    feedback = wanted.then(|| {
                        feedback
                            .take()
                            .unwrap_or_else(|| state.gateways().subscribe_feedback())
                    });
                }
                Step::Continue
            }
            changed = positions_wanted.changed() => {
                if changed.is_ok() {
                    let wanted = *positions_wanted.borrow_and_update();
                    positions = wanted.then(|| {
                        positions.take().unwrap_or_else(|| {
                            let mut watch = state.playback().live_positions();
                            // The latest goes out at once (empty when not live).
                            watch.mark_changed();
                            watch
                        })
                    });
                }
                Step::Continue
            }
            latest = next_positions(positions.as_mut()) => match latest {
                Some(positions_mm) => {
                    let message = ServerMessage::LivePositions { positions_mm };
                    sent(send(&mut sink, &message).await)
                }
                None => {
                    positions = None;
                    Step::Continue
                }
            },
            frame = next_frame(feedback.as_mut()) => match frame {
                Ok(frame) => sent(send(&mut sink, &ServerMessage::Feedback(frame)).await),
                Err(broadcast::error::RecvError::Lagged(missed)) => {
                    let message = ServerMessage::from_template(
                        Code::FeedbackDropped,
                        params! {"count" => missed},
                    );
                    sent(send(&mut sink, &message).await)
                }
                Err(broadcast::error::RecvError::Closed) => {
                    feedback = None;
                    Step::Continue
                }
            },
            reply = next_reply(mbox_replies.as_mut()) => match reply {
                Some(reply) => sent(send(&mut sink, &ServerMessage::MboxReply(reply)).await),
                None => {
                    mbox_replies = None;
                    Step::Continue
                }
            },
            reply = next_reply(scl_replies.as_mut()) => match reply {
                Some(reply) => sent(send(&mut sink, &ServerMessage::SclReply(reply)).await),
                None => {
                    scl_replies = None;
                    Step::Continue
                }
            },
            Some(failure) = console_failures.recv() => sent(send(&mut sink, &failure).await),
            _ = token_check.tick() => {
                if state.tokens().is_valid(&token, state.clock().now()) {
                    Step::Continue
                } else {
                    end_session(&mut sink, &mut inbound).await
                }
            }
            () = outbox.ready.notified() => send_replies(&mut sink, &outbox, &mut inbound).await,
            message = inbound.recv() => match message {
                Some(Inbound::EndSession) => end_session(&mut sink, &mut inbound).await,
                Some(Inbound::Refuse(frame)) => {
                    let _ = sink.send(Message::Close(Some(frame))).await;
                    Step::Close
                }
                Some(Inbound::Closed) | None => Step::Close,
            },
        };
        if let Step::Close = step {
            return;
        }
    }
}

/// The next answer to a console line (an MBOX box's to a read, a MOONS' drive's);
/// `None` when there will be none; never when the installation has no such family.
/// The balls' live positions when they next change (empty when live mode ended),
/// copied out with the borrow dropped at once; never when this client did not ask for
/// them; `None` when the playback task is gone.
async fn next_positions(
    positions: Option<&mut crate::playback::PositionsWatch>,
) -> Option<Vec<i32>> {
    match positions {
        Some(positions) => {
            positions.changed().await.ok()?;
            let latest = positions.borrow_and_update().clone();
            Some(latest.map(|mm| mm.to_vec()).unwrap_or_default())
        }
        None => std::future::pending().await,
    }
}

/// What a client asked to be sent besides its status.
struct Wishes {
    /// The gateways' feedback frames.
    feedback: watch::Sender<bool>,
    /// The balls' live positions.
    live_positions: watch::Sender<bool>,
}

/// The next feedback frame, or never when feedback is not relayed to this client.
async fn next_frame(
    feedback: Option<&mut broadcast::Receiver<FeedbackFrame>>,
) -> Result<FeedbackFrame, broadcast::error::RecvError> {
    match feedback {
        Some(feedback) => feedback.recv().await,
        None => std::future::pending().await,
    }
}

async fn next_reply<T: Clone>(replies: Option<&mut broadcast::Receiver<T>>) -> Option<T> {
    let Some(replies) = replies else {
        return std::future::pending().await;
    };
    loop {
        match replies.recv().await {
            Ok(reply) => return Some(reply),
            Err(broadcast::error::RecvError::Lagged(_)) => {}
            Err(broadcast::error::RecvError::Closed) => return None,
        }
    }
}

/// Aborts a session's reading task when the session ends.
struct AbortOnDrop(tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

/// A session's reading half: every message is acted on as it arrives; what the client
/// must be told goes to the writing half.
/// Where a session's reading half hands what it read.
struct Senders {
    /// Console lines, to be sent in order.
    console_lines: mpsc::Sender<ConsoleLine>,
    /// Replies sent by the console task.
    replies: mpsc::Sender<ServerMessage>,
    /// Replies to the client's messages, for the writing half.
    outbox: Arc<Outbox>,
    /// Session events for the writing half.
    inbound: mpsc::Sender<Inbound>,
    /// Whether the client wants the gateways' feedback frames and the live positions.
    relay: Wishes,
}

async fn read_messages(mut stream: Stream, state: AppState, token: String, senders: Senders) {
    let Senders {
        console_lines,
        replies,
        outbox,
        inbound,
        relay,
    } = senders;
    loop {
        let reply = match stream.next().await {
            Some(Ok(Message::Text(text))) => {
                if !state.tokens().touch(&token, state.clock().now()) {
                    let _ = inbound.send(Inbound::EndSession).await;
                    // Keep reading: the client's side of the closing handshake.
                    continue;
                }
                // Past the limit only an e-stop is acted on (and acknowledged first).
                if !outbox.admit() && !is_estop(text.as_str()) {
                    continue;
                }
                answer(&state, &console_lines, &replies, &relay, text.as_str())
            }
            Some(Ok(Message::Binary(_))) if !outbox.admit() => None,
            Some(Ok(Message::Binary(_))) => Some(templated(Code::BinaryFrame)),
            Some(Ok(Message::Ping(_) | Message::Pong(_))) => None,
            Some(Ok(Message::Close(_))) | None => {
                let _ = inbound.send(Inbound::Closed).await;
                return;
            }
            Some(Err(error)) => {
                let refusal = receive_failed(&error).map_or(Inbound::Closed, Inbound::Refuse);
                let _ = inbound.send(refusal).await;
                return;
            }
        };
        if let Some(reply) = reply {
            outbox.push(reply);
        }
    }
}

/// Whether a client's text frame is an `estop`.
fn is_estop(text: &str) -> bool {
    matches!(
        serde_json::from_str::<ClientMessage>(text),
        Ok(ClientMessage::Estop)
    )
}

/// Sends a session's console lines in order, each waiting for room on its lanes;
/// reports the lines a gateway refused. Ends with the session.
async fn console(
    state: AppState,
    mut lines: mpsc::Receiver<ConsoleLine>,
    failures: mpsc::Sender<ServerMessage>,
) {
    while let Some((gateway, batch, generation)) = lines.recv().await {
        if let Err(reason) = state.gateways().send(gateway, batch, generation).await
            && failures
                .send(ServerMessage::from_template(
                    Code::LineNotSent,
                    params! {"reason" => reason},
                ))
                .await
                .is_err()
        {
            return;
        }
    }
}

fn sent(result: Result<(), axum::Error>) -> Step {
    match result {
        Ok(()) => Step::Continue,
        Err(_) => Step::Close,
    }
}

/// What to answer a client that sent what cannot be received. A message over
/// [`MAX_MESSAGE_BYTES`] is answered with close code 1009 (Message Too Big); other
/// failures (a broken connection) need no answer.
fn receive_failed(error: &axum::Error) -> Option<CloseFrame> {
    let too_big = std::error::Error::source(error)
        .and_then(|source| source.downcast_ref::<tungstenite::Error>())
        .is_some_and(|error| matches!(error, tungstenite::Error::Capacity(_)));
    too_big.then(|| {
        tracing::info!("closing a WebSocket whose client sent a message over the limit");
        CloseFrame {
            code: close_code::SIZE,
            reason: format!("messages are limited to {MAX_MESSAGE_BYTES} bytes").into(),
        }
    })
}

/// Tells the client its token is no longer valid and closes, waiting a moment for the
/// client's side of the closing handshake.
async fn end_session(sink: &mut Sink, inbound: &mut mpsc::Receiver<Inbound>) -> Step {
    let _ = send(sink, &templated(Code::SessionExpired)).await;
    let closing = sink
        .send(Message::Close(Some(CloseFrame {
            code: close_code::POLICY,
            reason: "session ended".into(),
        })))
        .await;
    if closing.is_ok() {
        closing_handshake(inbound).await;
    }
    Step::Close
}

/// Waits, at most [`CLOSE_HANDSHAKE`], for the client's side of the closing handshake.
async fn closing_handshake(inbound: &mut mpsc::Receiver<Inbound>) {
    let _ = tokio::time::timeout(CLOSE_HANDSHAKE, async {
        while let Some(message) = inbound.recv().await {
            if let Inbound::Closed | Inbound::Refuse(_) = message {
                break;
            }
        }
    })
    .await;
}

/// A refusal with `code` and no parameters, in words of its own.
fn error(code: Code, message: impl Into<String>) -> ServerMessage {
    ServerMessage::error(code, message, Params::new())
}

/// A refusal with `code` and no parameters, in the words of the code's template.
fn templated(code: Code) -> ServerMessage {
    ServerMessage::from_template(code, Params::new())
}

/// The refusal of a console line that does not parse: its code and parameters (line,
/// column…), and the parser's words.
fn invalid_line(parse_error: &(impl Coded + std::fmt::Display)) -> ServerMessage {
    ServerMessage::error(
        parse_error.code(),
        format!("the line is not valid: {parse_error}"),
        parse_error.params(),
    )
}

/// The refusal of a gateway number past the last.
fn no_such_gateway(index: usize, count: usize) -> ServerMessage {
    ServerMessage::from_template(
        Code::NoSuchGateway,
        params! {"gateway" => index, "last" => count.saturating_sub(1)},
    )
}

/// The reply to one text frame from a client, if it needs one. Replies that take time
/// (Start, Reset) come later through `replies`.
fn answer(
    state: &AppState,
    console_lines: &mpsc::Sender<ConsoleLine>,
    replies: &mpsc::Sender<ServerMessage>,
    relay: &Wishes,
    text: &str,
) -> Option<ServerMessage> {
    let message = match serde_json::from_str::<ClientMessage>(text) {
        Ok(message) => message,
        Err(err) => {
            return Some(ServerMessage::from_template(
                Code::BadMessage,
                params! {"reason" => err},
            ));
        }
    };
    match message {
        ClientMessage::Ping => Some(ServerMessage::Pong),
        ClientMessage::Feedback { relay: wanted } => {
            relay.feedback.send_replace(wanted);
            None
        }
        ClientMessage::LivePositions { on } => {
            relay.live_positions.send_replace(on);
            None
        }
        ClientMessage::Estop => {
            let unreached = state.playback().estop();
            tracing::warn!("e-stop requested over the WebSocket");
            if !unreached.is_empty() {
                tracing::error!("the e-stop did not reach {}", unreached.join("; "));
            }
            Some(ServerMessage::EstopSent { unreached })
        }
        ClientMessage::Start(_) | ClientMessage::Reset(_) | ClientMessage::Home
            if state.password().is_default() =>
        {
            Some(templated(Code::MustChangePasswordFirst))
        }
        ClientMessage::Start(_) | ClientMessage::Reset(_) | ClientMessage::Home => {
            let control = match message {
                ClientMessage::Reset(from) => Control::Reset(from),
                ClientMessage::Start(from) => Control::Start(from),
                _ => Control::Home,
            };
            // Checked first (a refused one changes nothing), then Reset and Home stop
            // at once; every one of them is tagged now.
            let running = match control::issue(state, control) {
                Ok(running) => running,
                Err(refusal) => {
                    if let ServerMessage::Error { message, .. } = &refusal {
                        tracing::warn!("{control:?} refused: {message}");
                    }
                    return Some(refusal);
                }
            };
            let replies = replies.clone();
            tokio::spawn(async move {
                if let Err(refusal) = running.await {
                    if let ServerMessage::Error { message, .. } = &refusal {
                        tracing::warn!("{control:?} refused: {message}");
                    }
                    let _ = replies.send(refusal).await;
                }
            });
            None
        }
        ClientMessage::Live { .. } | ClientMessage::Record { .. } | ClientMessage::RecordStop
            if state.password().is_default() =>
        {
            Some(templated(Code::MustChangePasswordFirst))
        }
        ClientMessage::Live { .. } | ClientMessage::Record { .. } | ClientMessage::RecordStop => {
            crate::live::record::spawn_request(state, message, replies.clone());
            None
        }
        ClientMessage::Raw { .. } if state.password().is_default() => {
            Some(templated(Code::MustChangePasswordFirst))
        }
        ClientMessage::Raw { line, gateway } => {
            if let Some(boxes) = state.playback().boxes() {
                return mbox_line(state, boxes, &line, gateway);
            }
            if let Some(drives) = state.playback().scl() {
                let latch = state.playback().latch();
                return crate::ports::scl::program::console(
                    drives,
                    &line,
                    gateway,
                    latch.is_latched(),
                    latch.generation(),
                )
                .err();
            }
            let count = state.gateways().links().len();
            if let Some(index) = gateway.filter(|index| *index >= count) {
                return Some(no_such_gateway(index, count));
            }
            let instructions = match parse_script(&line) {
                Ok(instructions) if instructions.is_empty() => {
                    return Some(templated(Code::EmptyLine));
                }
                Ok(instructions) => instructions,
                Err(parse_error) => return Some(invalid_line(&parse_error)),
            };
            if let Some(baud) = instructions
                .iter()
                .find_map(|instruction| match instruction {
                    Instruction::Gateway(GatewayCommand::SetBaud { baud }) => Some(*baud),
                    _ => None,
                })
            {
                return Some(ServerMessage::from_template(
                    Code::ConsoleLineSpeed,
                    params! {"baud" => baud},
                ));
            }
            if state.playback().latch().is_latched()
                && !instructions
                    .iter()
                    .all(|instruction| instruction.is_inert())
            {
                return Some(templated(Code::EstopLatched));
            }
            let generation = state.playback().latch().generation();
            let batch = match Batch::encode(&instructions, Form::Standard) {
                Ok(batch) => batch,
                Err(encode_error) => {
                    return Some(ServerMessage::from_template(
                        Code::AsciiNotEncodable,
                        params! {"reason" => encode_error},
                    ));
                }
            };
            // The line may change what the units hold: nothing stays armed.
            crate::arming::disarm(state);
            match console_lines.try_send((gateway, batch, generation)) {
                Ok(()) => None,
                Err(_) => Some(templated(Code::ConsoleBusy)),
            }
        }
    }
}

/// An MBOX console line: parsed, checked against the e-stop latch, handed to the
/// boxes' sender; the answer when it is refused.
fn mbox_line(
    state: &AppState,
    boxes: &MboxNet,
    line: &str,
    gateway: Option<usize>,
) -> Option<ServerMessage> {
    if let Some(index) = gateway.filter(|index| *index >= boxes.len()) {
        return Some(no_such_gateway(index, boxes.len()));
    }
    let selected = match gateway.and_then(|index| boxes.address(index)) {
        Some(SocketAddr::V4(address)) => Route::to(BoxAddress::of_ip(*address.ip())),
        _ => Route::BROADCAST,
    };
    let operations = match mbox_console::parse(line, selected) {
        Ok(operations) if operations.is_empty() => {
            return Some(error(Code::EmptyLine, "the line holds no command"));
        }
        // The datagram goes to the selected box's socket only: addressed to every box,
        // so a box whose IP registers differ from its configured address (behind NAT,
        // a twin on loopback) executes and answers too.
        Ok(operations) => operations
            .into_iter()
            .map(|operation| match operation {
                Operation::Read(mut read) if read.route == selected => {
                    read.route = Route::BROADCAST;
                    Operation::Read(read)
                }
                Operation::Write(mut write) if write.route == selected => {
                    write.route = Route::BROADCAST;
                    Operation::Write(write)
                }
                other => other,
            })
            .collect::<Vec<_>>(),
        Err(parse_error) => return Some(invalid_line(&parse_error)),
    };
    let latch = state.playback().latch();
    if latch.is_latched() && !operations.iter().all(Operation::is_inert) {
        return Some(error(
            Code::EstopLatched,
            "the e-stop is latched: only reads and estop can be sent until Start, Reset or \
             Home (which release the boxes); this line was not sent",
        ));
    }
    let generation = latch.generation();
    for operation in operations {
        boxes.console(gateway, operation, generation);
    }
    None
}

async fn send(sink: &mut Sink, message: &ServerMessage) -> Result<(), axum::Error> {
    let text = serde_json::to_string(message).map_err(axum::Error::new)?;
    sink.send(Message::Text(text.into())).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_flood_reason_names_the_limit_and_fits_a_close_frame() {
        assert!(FLOODED.contains(&REPLY_LIMIT.to_string()));
        assert!(FLOODED.len() <= 123);
    }

    #[test]
    fn estop_acknowledgements_go_first_and_pongs_keep_their_count_and_order() {
        let outbox = Outbox::default();
        outbox.push(ServerMessage::Pong);
        outbox.push(ServerMessage::Pong);
        outbox.push(error(Code::EmptyLine, "x"));
        outbox.push(ServerMessage::Pong);
        outbox.push(ServerMessage::EstopSent {
            unreached: Vec::new(),
        });
        let mut sent = Vec::new();
        while let Next::Reply(reply) = outbox.next() {
            sent.push(match *reply {
                ServerMessage::Pong => "pong",
                ServerMessage::EstopSent { .. } => "estop_sent",
                _ => "error",
            });
        }
        assert_eq!(sent, ["estop_sent", "pong", "pong", "error", "pong"]);
    }

    #[test]
    fn past_the_limit_the_outbox_is_flooded_but_estop_is_still_acknowledged() {
        let outbox = Outbox::default();
        for _ in 0..10 * REPLY_LIMIT {
            assert!(outbox.admit());
            outbox.push(ServerMessage::Pong);
        }
        for _ in 0..REPLY_LIMIT {
            assert!(outbox.admit());
            outbox.push(error(Code::BadMessage, "x"));
        }
        assert!(!outbox.admit());
        outbox.push(error(Code::BadMessage, "x"));
        outbox.push(ServerMessage::EstopSent {
            unreached: Vec::new(),
        });
        assert!(
            matches!(outbox.next(), Next::Reply(reply) if matches!(*reply, ServerMessage::EstopSent { .. }))
        );
        assert!(matches!(outbox.next(), Next::Flooded));
    }

    #[test]
    fn a_status_held_back_is_brought_to_the_instant_it_is_sent() {
        let playing = Status {
            state: PlayerState::Playing,
            show_time_ms: 1_000,
            show_duration_ms: 4_000,
            progress: 0.25,
            ..Status::default()
        };
        let sent = as_sent(playing.clone(), Duration::from_millis(18));
        assert_eq!(sent.show_time_ms, 1_018);
        assert!((sent.progress - 1_018.0 / 4_000.0).abs() < 1e-12);
        // Never past the show's end: that is the next status's to say.
        let late = as_sent(
            Status {
                show_time_ms: 3_995,
                ..playing
            },
            Duration::from_millis(18),
        );
        assert_eq!(late.show_time_ms, 3_995);
        let given = Status {
            state: PlayerState::Loading,
            show_starts_in_ms: Some(30),
            ..Status::default()
        };
        assert_eq!(
            as_sent(given, Duration::from_millis(12)).show_starts_in_ms,
            Some(18)
        );
        let idle = Status::default();
        assert_eq!(as_sent(idle.clone(), Duration::from_millis(50)), idle);
    }
}
