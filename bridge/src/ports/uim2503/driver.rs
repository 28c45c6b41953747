//! The network driver: one thread that reads and writes every network link
//! (`tcp://`, `rfc2217://`) while its line streams.
//!
//! A thread per link woken before every instruction costs a context switch and a timer
//! per instruction — at 100 gateways of 115,200 baud about 100,000 a second. The driver
//! instead makes one pass over all its lines at most every [`PASS`]: it reads whatever
//! came in on the sockets the poller reports readable (Telnet requests answered on the
//! spot: the driver owns the whole socket), then gives each line's writer a turn
//! ([`Drive::step`]) with an `ahead` window of [`AHEAD`]: a line that will be free
//! within it gets its next instructions, up to one longest instruction's bytes per
//! write. Between passes it parks; a handle handing over work, or the e-stop, unparks it
//! at once (the writers look at the latch first thing in every turn).
//!
//! A line's supervisor thread sets the connection up and hands it over as a
//! [`Session`] ([`drive`]); the driver hands it back when the line is done (lost, a
//! failed write, the link closed) or when a line-speed change is due, which the
//! supervisor carries out itself. Writes never block: a socket that takes nothing keeps
//! its bytes in its own backlog, and only its own link waits.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, SyncSender, channel, sync_channel};
use std::sync::{Arc, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

use mio::{Events, Interest, Poll, Token};

use super::net::NetIo;
use super::writer::{Drive, IDLE_TICK, LineWrite, Step};
use super::{Input, Shared};

/// The shortest time between two passes while lines are busy.
pub const PASS: Duration = Duration::from_millis(1);

/// How far ahead of the line being free a writer is given its next write: two passes,
/// so a pass that comes late still finds the line busy.
pub const AHEAD: Duration = Duration::from_millis(2);

/// The longest the driver sleeps while it serves lines: what came in is read at least
/// this often.
const READ_TICK: Duration = Duration::from_millis(5);

/// How many turns a line gets in one pass at most (each writes at most one chunk).
const TURNS_PER_PASS: usize = 16;

/// A network line being served.
pub(super) struct Session {
    pub(super) drive: Drive,
    pub(super) shared: Arc<Shared>,
    pub(super) inbox: Receiver<Input>,
    pub(super) io: NetIo,
    pub(super) lost: Arc<AtomicBool>,
    /// Why the line was lost, when reading or writing found out.
    pub(super) lost_reason: Option<String>,
}

/// Why the driver hands a session back.
pub(super) enum Back {
    /// The line is done: why.
    Done(String),
    /// A line-speed change is due: the supervisor carries it out and hands the session
    /// over again.
    ChangeBaud,
}

type Adoption = (Session, SyncSender<(Session, Back)>);

/// The driver thread and the way to hand it sessions.
struct Driver {
    adopt: Sender<Adoption>,
    thread: Thread,
}

static DRIVER: OnceLock<Result<Driver, String>> = OnceLock::new();

fn driver() -> Result<&'static Driver, String> {
    DRIVER
        .get_or_init(|| {
            let poll = Poll::new().map_err(|err| format!("cannot watch sockets: {err}"))?;
            let (adopt, adopted) = channel();
            let thread = std::thread::Builder::new()
                .name("links-net".to_owned())
                .spawn(move || run(poll, &adopted))
                .map_err(|err| format!("cannot start the network driver: {err}"))?;
            Ok(Driver {
                adopt,
                thread: thread.thread().clone(),
            })
        })
        .as_ref()
        .map_err(Clone::clone)
}

/// Hands `session` to the driver and waits until it comes back, with why. `Err` (the
/// inbox to go on with) when there is no driver.
pub(super) fn drive(session: Session) -> Result<(Session, Back), Receiver<Input>> {
    let driver = match driver() {
        Ok(driver) => driver,
        Err(reason) => {
            tracing::error!("gateway {}: {reason}", session.shared.config.port);
            return Err(session.inbox);
        }
    };
    let _ = session.shared.driver.set(driver.thread.clone());
    let (back, returned) = sync_channel(1);
    if let Err(refused) = driver.adopt.send((session, back)) {
        return Err(refused.0.0.inbox);
    }
    driver.thread.unpark();
    returned.recv().map_err(|_| {
        tracing::error!("the network driver stopped");
        channel().1
    })
}

/// A session in the driver's hands.
struct Served {
    session: Session,
    back: SyncSender<(Session, Back)>,
    readable: bool,
}

/// The driver thread: passes over every line until the process ends.
fn run(mut poll: Poll, adopted: &Receiver<Adoption>) {
    let mut events = Events::with_capacity(1024);
    let mut slots: Vec<Option<Served>> = Vec::new();
    loop {
        while let Ok((mut session, back)) = adopted.try_recv() {
            let slot = slots.iter().position(Option::is_none).unwrap_or_else(|| {
                slots.push(None);
                slots.len() - 1
            });
            if let Err(err) =
                poll.registry()
                    .register(session.io.source(), Token(slot), Interest::READABLE)
            {
                let reason = format!("cannot watch the connection: {err}");
                let _ = back.send((session, Back::Done(reason)));
                continue;
            }
            // Whatever came before it was watched is read in this pass.
            slots[slot] = Some(Served {
                session,
                back,
                readable: true,
            });
        }
        if let Err(err) = poll.poll(&mut events, Some(Duration::ZERO))
            && err.kind() != std::io::ErrorKind::Interrupted
        {
            tracing::warn!("the network driver cannot poll its sockets: {err}");
        }
        for event in &events {
            if let Some(Some(served)) = slots.get_mut(event.token().0) {
                served.readable = true;
            }
        }
        let pass_started = Instant::now();
        let mut sleep = READ_TICK;
        // Starts due go first, on every line, before anything is read or streamed: the
        // synchronised start leaves all sockets within the shortest time.
        for slot in &mut slots {
            if slot
                .as_ref()
                .is_some_and(|served| served.session.drive.start_due(pass_started))
            {
                visit(slot, &poll, (pass_started, false), &mut sleep);
            }
        }
        for slot in &mut slots {
            visit(slot, &poll, (pass_started, true), &mut sleep);
        }
        if slots.iter().all(Option::is_none) {
            sleep = IDLE_TICK;
        }
        // At most one pass a PASS while busy; a handle or the e-stop wakes it at once.
        let elapsed = pass_started.elapsed();
        let sleep = sleep.max(PASS.saturating_sub(elapsed));
        std::thread::park_timeout(sleep);
    }
}

/// Gives the line in `slot` its turn (reading first if `read`); hands the session back
/// when it is done.
fn visit(
    slot: &mut Option<Served>,
    poll: &Poll,
    (now, read): (Instant, bool),
    sleep: &mut Duration,
) {
    let Some(served) = slot else {
        return;
    };
    match turn(served, now, read) {
        Ok(wait) => *sleep = (*sleep).min(wait),
        Err(back) => {
            if let Some(mut served) = slot.take() {
                let _ = poll.registry().deregister(served.session.io.source());
                let back = match back {
                    Back::Done(reason) => {
                        Back::Done(served.session.lost_reason.take().unwrap_or(reason))
                    }
                    Back::ChangeBaud => Back::ChangeBaud,
                };
                let _ = served.back.send((served.session, back));
            }
        }
    }
}

/// One line's part of a pass: read, then writer turns until it waits; without `read`,
/// one turn only (a due start). `Ok` is how long the line can wait; `Err` hands the
/// session back.
fn turn(served: &mut Served, now: Instant, read: bool) -> Result<Duration, Back> {
    let session = &mut served.session;
    if read && (served.readable || session.io.backlog() > 0) {
        served.readable = false;
        if let Err(err) = session.io.service(&session.shared) {
            session.lost_reason = Some(err.to_string());
            session.lost.store(true, Ordering::Release);
        }
    }
    let mut now = now;
    // A start's own pass writes the start and moves on to the next line's.
    let turns = if read { TURNS_PER_PASS } else { 1 };
    for _ in 0..turns {
        match session.drive.step(
            &session.shared,
            &session.inbox,
            &mut session.io,
            &session.lost,
            now,
            AHEAD,
        ) {
            Step::Wait(wait) if wait.is_zero() => now = Instant::now(),
            Step::Wait(wait) => return Ok(wait),
            Step::Done(reason) => return Err(Back::Done(reason)),
            Step::ChangeBaud => return Err(Back::ChangeBaud),
        }
    }
    Ok(Duration::ZERO)
}
