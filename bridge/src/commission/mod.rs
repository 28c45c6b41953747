//! Commissioning a UIM2503 gateway's units (`docs/gateways.md` §2–§4: the roll call
//! by serial number, `SN`, and the station each unit is given): find them,
//! give them their stations, show which ball is which, and keep their health.
//!
//! - **Roll call** ([`Commission::roll_call`]): the broadcast serial query `*0;SN;`
//!   (every unit answers with its serial, from its station), then one probe per
//!   station: `*s;SN;PA;` for each configured station nobody answered on (a unit whose
//!   answer was lost), `*s;PA;` for each station one unit answered on (its position).
//!   Answers are awaited by the line's time: until everything is written and the line
//!   has been quiet for [`QUIET_BYTES`] byte times (plus [`QUIET_SLACK`]), never longer
//!   than twice the time the expected answers need. The answers are tallied by
//!   [`rollcall`] into a [`RollCall`].
//! - **Assignment** ([`Commission::assign`]): `*0;SN[X]=s/n;` for each unit (only the
//!   unit with that serial takes the station, and answers from it), then a new roll
//!   call. A simulated gateway's units remember their stations ([`sim_units`]).
//! - **Identify** ([`Commission::identify`]): one station's ball goes down and back
//!   (`MO=1;SP=…;PA=…;BG;`, then `PA=…;BG;`), planned by [`identify`]; a ball shared by
//!   several units, or silent, is refused.
//! - **Health** ([`health`]): a monitor per gateway keeps [`UnitHealth`] from roll
//!   calls, every frame and a light probe while the matrix is at rest.
//!
//! Everything goes through the link's ordinary bulk lane, so the e-stop latch governs
//! it as any console line: a move issued before an e-stop is void, and while the latch
//! is set the calls that would move or renumber are refused. All three calls are
//! refused while the player is not at rest (idle, stopped or in error) or a Start is
//! being prepared, and one call at a time runs per gateway.

pub mod health;
pub mod identify;
pub mod rollcall;
pub mod sim_units;

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use floatball_shared::api::{
    AssignRequest, IdentifyRequest, Identifying, PlayerState, RollCall, Status, UnitFault,
    UnitHealth,
};
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::line::Line;
use floatball_shared::params;
use floatball_shared::plan::{DriveKind, Installation};
use floatball_shared::uim2503::ascii::{Batch, Form, Instruction};
use floatball_shared::uim2503::feedback::{Ack, Feedback, Frame};
use floatball_shared::uim2503::sim::MAX_UNITS;
use tokio::sync::{broadcast, mpsc, oneshot, watch};

use crate::ports::uim2503::Link;
use health::{HealthView, MonitorConfig, Report, at_rest};
use identify::{IdentifyMove, MoveLimits};
use rollcall::{Context, Tally};

/// Byte times of silence after which no more answers are expected.
pub const QUIET_BYTES: u32 = 48;

/// Added to the quiet time for the gateway's and the host's own delays.
pub const QUIET_SLACK: Duration = Duration::from_millis(50);

/// How often a wait for answers looks whether the link has written everything.
const POLL: Duration = Duration::from_millis(10);

/// How long after the ball should be back its driver is switched off again (when it
/// was off before): the units' own acceleration may differ from the installation's.
const MOTOR_OFF_MARGIN: Duration = Duration::from_millis(500);

/// Bytes of one `SN` answer on the line (header, station, code, 8 data bytes, tail).
const SERIAL_FRAME_BYTES: usize = 12;

/// Bytes of one `PA` or `MO` answer at most.
const POSITION_FRAME_BYTES: usize = 8;

/// Why a commissioning call was refused. Its text is its code's English template, but
/// for [`CommissionError::EstopLatched`] and [`CommissionError::NotSent`], whose codes'
/// templates speak of console lines.
#[derive(Debug, Clone, PartialEq)]
pub enum CommissionError {
    /// No gateway with that number.
    NoSuchGateway {
        /// The number asked for.
        gateway: usize,
        /// The last gateway's number.
        last: usize,
    },
    /// The gateway is not a UIM2503 (its drives have no stations to commission).
    NotUim2503 {
        /// The gateway.
        gateway: usize,
    },
    /// The matrix is busy (a show, a homing, a Start being prepared).
    NotAtRest {
        /// What it is doing (`playing`…, or `starting` for a Start being prepared).
        state: String,
    },
    /// Another commissioning call is using the gateway.
    InProgress {
        /// The gateway.
        gateway: usize,
    },
    /// The gateway's link is not up.
    NotConnected {
        /// The gateway.
        gateway: usize,
    },
    /// The e-stop is latched: nothing moves or is renumbered.
    EstopLatched,
    /// A station outside 1–127.
    BadStation {
        /// The station given.
        station: u8,
    },
    /// An identify distance that is not a positive number of mm.
    BadDistance {
        /// The distance given.
        distance_mm: f64,
    },
    /// Nobody answered on the station.
    StationSilent {
        /// The gateway.
        gateway: usize,
        /// The station.
        station: u8,
    },
    /// Several units answer on the station: all of them would move.
    StationShared {
        /// The gateway.
        gateway: usize,
        /// The station.
        station: u8,
        /// How many units answered on it.
        units: usize,
    },
    /// An assignment request without assignments.
    NoAssignments,
    /// The same serial twice in one request.
    SerialTwice {
        /// The serial.
        serial: u64,
    },
    /// The same station for two units in one request.
    StationTwice {
        /// The station.
        station: u8,
    },
    /// A serial too long for the gateway's 20 characters.
    SerialTooLong {
        /// The serial.
        serial: u64,
        /// The gateway's limit.
        max: usize,
    },
    /// The link refused the instructions (it went down meanwhile).
    NotSent {
        /// Why.
        reason: String,
    },
}

impl std::fmt::Display for CommissionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::EstopLatched => f.write_str(
                "the E-stop is latched: only queries can be sent until Start, Reset or Home; \
                 nothing was sent",
            ),
            Self::NotSent { reason } => write!(f, "the instructions were not sent: {reason}"),
            _ => f.write_str(&floatball_shared::codes::english_text(
                self.code(),
                &self.params(),
            )),
        }
    }
}

impl std::error::Error for CommissionError {}

impl Coded for CommissionError {
    fn code(&self) -> Code {
        match self {
            Self::NoSuchGateway { .. } => Code::NoSuchGateway,
            Self::NotUim2503 { .. } => Code::CommissionNotUim2503,
            Self::NotAtRest { .. } => Code::CommissionNotIdle,
            Self::InProgress { .. } => Code::CommissionInProgress,
            Self::NotConnected { .. } => Code::GatewayNotConnected,
            Self::EstopLatched => Code::EstopLatched,
            Self::BadStation { .. } => Code::CommissionBadStation,
            Self::BadDistance { .. } => Code::CommissionBadDistance,
            Self::StationSilent { .. } => Code::CommissionStationSilent,
            Self::StationShared { .. } => Code::CommissionStationShared,
            Self::NoAssignments => Code::CommissionNoAssignments,
            Self::SerialTwice { .. } => Code::CommissionSerialTwice,
            Self::StationTwice { .. } => Code::CommissionStationTwice,
            Self::SerialTooLong { .. } => Code::CommissionSerialTooLong,
            Self::NotSent { .. } => Code::LineNotSent,
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::NoSuchGateway { gateway, last } => {
                params! { "gateway" => gateway, "last" => last }
            }
            Self::NotUim2503 { gateway }
            | Self::InProgress { gateway }
            | Self::NotConnected { gateway } => params! { "gateway" => gateway },
            Self::NotAtRest { state } => params! { "state" => state },
            Self::EstopLatched | Self::NoAssignments => Params::new(),
            Self::BadStation { station } | Self::StationTwice { station } => {
                params! { "station" => station }
            }
            Self::BadDistance { distance_mm } => params! { "distance_mm" => distance_mm },
            Self::StationSilent { gateway, station } => {
                params! { "gateway" => gateway, "station" => station }
            }
            Self::StationShared {
                gateway,
                station,
                units,
            } => params! { "gateway" => gateway, "station" => station, "units" => units },
            Self::SerialTwice { serial } => params! { "serial" => serial },
            Self::SerialTooLong { serial, max } => params! { "serial" => serial, "max" => max },
            Self::NotSent { reason } => params! { "reason" => reason },
        }
    }
}

/// One UIM2503 gateway's commissioning desk (a cheap copy: a call takes one).
#[derive(Debug, Clone)]
struct Desk {
    link: Link,
    /// Set while a call uses the gateway (the health probe waits too).
    busy: Arc<AtomicBool>,
    /// To the health monitor.
    reports: mpsc::Sender<Report>,
}

impl Desk {
    /// The faults the health monitor heard.
    async fn faults(&self) -> Vec<UnitFault> {
        let (reply, answer) = oneshot::channel();
        if self.reports.send(Report::Faults(reply)).await.is_err() {
            return Vec::new();
        }
        answer.await.unwrap_or_default()
    }
}

/// Clears a desk's busy flag when the call ends.
#[derive(Debug)]
struct Busy(Arc<AtomicBool>);

impl Drop for Busy {
    fn drop(&mut self) {
        self.0.store(false, Ordering::Release);
    }
}

/// Health snapshots for `count` gateways: the monitors' senders, and the views the
/// playback task copies into the status.
pub fn health_channels(count: usize) -> (Vec<watch::Sender<Option<UnitHealth>>>, Vec<HealthView>) {
    (0..count).map(|_| watch::channel(None)).unzip()
}

/// The commissioning desks of every UIM2503 gateway, and their health monitors.
#[derive(Debug)]
pub struct Commission {
    /// The desks now; replaced whole by [`Commission::reopen`] (a new installation),
    /// the lock held only to copy or swap the pointer.
    desks: std::sync::RwLock<Arc<Vec<Desk>>>,
    data_dir: PathBuf,
    status: watch::Receiver<Status>,
    starts_pending: Arc<AtomicUsize>,
}

impl Commission {
    /// Desks for `links` (with the stations `installation` gives their gateways), each
    /// with a health monitor publishing on its sender of `health` (same order as the
    /// links). Must run inside the async runtime.
    pub fn open(
        links: &[Link],
        installation: &Installation,
        data_dir: PathBuf,
        status: watch::Receiver<Status>,
        starts_pending: Arc<AtomicUsize>,
        health: Vec<watch::Sender<Option<UnitHealth>>>,
    ) -> Self {
        let commission = Self {
            desks: std::sync::RwLock::new(Arc::new(Vec::new())),
            data_dir,
            status,
            starts_pending,
        };
        commission.reopen(links, installation, health);
        commission
    }

    /// New desks and health monitors for `links` of a new `installation` (applied
    /// while idle): the old monitors end when their desks go (a call under way keeps
    /// its desk to the end), so no old link is held open.
    pub fn reopen(
        &self,
        links: &[Link],
        installation: &Installation,
        health: Vec<watch::Sender<Option<UnitHealth>>>,
    ) {
        let desks: Vec<Desk> = links
            .iter()
            .zip(health)
            .map(|(link, health)| {
                let (reports, inbox) = mpsc::channel(16);
                let busy = Arc::new(AtomicBool::new(false));
                tokio::spawn(health::monitor(
                    MonitorConfig {
                        link: link.clone(),
                        stations: installation.stations_on(link.index()),
                        status: self.status.clone(),
                        busy: Arc::clone(&busy),
                        starts_pending: Arc::clone(&self.starts_pending),
                    },
                    inbox,
                    health,
                ));
                Desk {
                    link: link.clone(),
                    busy,
                    reports,
                }
            })
            .collect();
        let desks = Arc::new(desks);
        match self.desks.write() {
            Ok(mut now) => *now = desks,
            Err(poisoned) => *poisoned.into_inner() = desks,
        }
    }

    /// Whether a commissioning call is using any gateway (an identified ball is still
    /// on its way back): the armer and a new installation wait for it.
    pub fn busy(&self) -> bool {
        self.desks()
            .iter()
            .any(|desk| desk.busy.load(Ordering::Acquire))
    }

    /// The desks now (a copy of the pointer).
    fn desks(&self) -> Arc<Vec<Desk>> {
        match self.desks.read() {
            Ok(desks) => Arc::clone(&desks),
            Err(poisoned) => Arc::clone(&poisoned.into_inner()),
        }
    }

    /// The desk of gateway `gateway`.
    fn desk(&self, gateway: usize, installation: &Installation) -> Result<Desk, CommissionError> {
        let count = installation.gateways.len();
        let spec = installation
            .gateways
            .get(gateway)
            .ok_or(CommissionError::NoSuchGateway {
                gateway,
                last: count.saturating_sub(1),
            })?;
        if spec.kind != DriveKind::Uim2503 {
            return Err(CommissionError::NotUim2503 { gateway });
        }
        self.desks()
            .iter()
            .find(|desk| desk.link.index() == gateway)
            .cloned()
            .ok_or(CommissionError::NotUim2503 { gateway })
    }

    /// Takes the desk of `gateway` for one call: the matrix must be at rest, the link
    /// up, and no other call under way; `moves` calls are refused while the e-stop is
    /// latched.
    fn begin(
        &self,
        gateway: usize,
        installation: &Installation,
        moves: bool,
    ) -> Result<(Desk, Busy), CommissionError> {
        let desk = self.desk(gateway, installation)?;
        let state = self.status.borrow().state;
        if !at_rest(state) {
            return Err(CommissionError::NotAtRest {
                state: state.as_str().to_owned(),
            });
        }
        if self.starts_pending.load(Ordering::SeqCst) > 0 {
            return Err(CommissionError::NotAtRest {
                state: "starting".to_owned(),
            });
        }
        if !desk.link.is_up() {
            return Err(CommissionError::NotConnected { gateway });
        }
        if moves && desk.link.latch().is_latched() {
            return Err(CommissionError::EstopLatched);
        }
        desk.busy
            .compare_exchange(false, true, Ordering::AcqRel, Ordering::Acquire)
            .map_err(|_| CommissionError::InProgress { gateway })?;
        let busy = Busy(Arc::clone(&desk.busy));
        Ok((desk, busy))
    }

    /// `POST /api/gateways/{gateway}/rollcall`.
    ///
    /// # Errors
    /// [`CommissionError`]: no such gateway, not a UIM2503, not at rest, busy, link
    /// down.
    pub async fn roll_call(
        &self,
        gateway: usize,
        installation: &Installation,
    ) -> Result<RollCall, CommissionError> {
        let (desk, _busy) = self.begin(gateway, installation, false)?;
        roll_call_on(&desk, gateway, installation).await
    }

    /// `POST /api/gateways/{gateway}/assign`: every assignment's `*0;SN[X]=s/n;`, then
    /// a new roll call.
    ///
    /// # Errors
    /// As [`Commission::roll_call`], and a request that is empty, names a serial or a
    /// station twice, a station outside 1–127 or a serial too long to send; refused
    /// while the e-stop is latched.
    pub async fn assign(
        &self,
        gateway: usize,
        installation: &Installation,
        request: &AssignRequest,
    ) -> Result<RollCall, CommissionError> {
        let batch = assignment_batch(request)?;
        let (desk, _busy) = self.begin(gateway, installation, true)?;
        let mut frames = desk.link.feedback();
        send(&desk.link, batch).await?;
        let expected = request.assignments.len() * SERIAL_FRAME_BYTES;
        collect(&desk.link, &mut frames, expected, |_, _, _| {}).await;
        if let Some(view) = desk.link.sim_view() {
            let stations: Vec<u8> =
                view.with_gateway(|sim| sim.units().map(|unit| unit.station).collect());
            let data_dir = self.data_dir.clone();
            let saved = tokio::task::spawn_blocking(move || {
                sim_units::remember(&data_dir, gateway, stations)
            })
            .await;
            match saved {
                Ok(Ok(())) => {}
                Ok(Err(error)) => {
                    tracing::error!("the simulated units' stations were not saved: {error}");
                }
                Err(error) => {
                    tracing::error!("the simulated units' stations were not saved: {error}");
                }
            }
        }
        roll_call_on(&desk, gateway, installation).await
    }

    /// `POST /api/gateways/{gateway}/identify`: the ball of one station goes down and
    /// back; answers once it has started.
    ///
    /// # Errors
    /// As [`Commission::roll_call`], and a bad station or distance, a silent or shared
    /// station; refused while the e-stop is latched.
    pub async fn identify(
        &self,
        gateway: usize,
        installation: &Installation,
        request: &IdentifyRequest,
    ) -> Result<Identifying, CommissionError> {
        let station = request.station;
        if !(1..=127).contains(&station) {
            return Err(CommissionError::BadStation { station });
        }
        let distance_mm = request.distance_mm.unwrap_or(identify::DEFAULT_DISTANCE_MM);
        if !(distance_mm.is_finite() && distance_mm > 0.0) {
            return Err(CommissionError::BadDistance { distance_mm });
        }
        let (desk, busy) = self.begin(gateway, installation, true)?;
        let generation = desk.link.latch().generation();
        let mut frames = desk.link.feedback();
        let question = encode(&[
            Instruction::Select { station },
            Instruction::QuerySerial,
            Instruction::PtpPosition {
                position_counts: None,
            },
            Instruction::Motor { on: None },
        ])?;
        send(&desk.link, question).await?;
        let mut serials = BTreeSet::new();
        let mut positions = BTreeSet::new();
        let mut motor_on = None;
        let expected = SERIAL_FRAME_BYTES + 2 * POSITION_FRAME_BYTES;
        collect(&desk.link, &mut frames, expected, |_, from, feedback| {
            if from != station {
                return;
            }
            match *feedback {
                Feedback::Ack(Ack::Serial { serial }) => {
                    serials.insert(serial);
                }
                Feedback::Ack(Ack::PtpPosition { position_counts }) => {
                    positions.insert(position_counts);
                }
                Feedback::Ack(Ack::Motor { on }) => motor_on = Some(on),
                _ => {}
            }
        })
        .await;
        if serials.len() > 1 || positions.len() > 1 {
            return Err(CommissionError::StationShared {
                gateway,
                station,
                units: serials.len().max(positions.len()),
            });
        }
        let Some(&from_counts) = positions.first() else {
            return Err(CommissionError::StationSilent { gateway, station });
        };
        let limits = MoveLimits {
            travel_mm: installation.limits.travel_mm,
            max_speed_mm_s: installation.limits.max_speed_mm_s,
            max_accel_mm_s2: installation.limits.max_accel_mm_s2,
            counts_per_mm: installation.counts_per_mm,
        };
        let planned = identify::plan(from_counts, distance_mm, &limits)
            .ok_or(CommissionError::BadDistance { distance_mm })?;
        let down = encode(&[
            Instruction::Select { station },
            Instruction::Motor { on: Some(true) },
            Instruction::PtpSpeed {
                speed_counts_s: Some(planned.speed_counts_s),
            },
            Instruction::PtpPosition {
                position_counts: Some(planned.to_counts),
            },
            Instruction::Begin { at_us: None },
        ])?;
        let back = encode(&[
            Instruction::Select { station },
            Instruction::PtpPosition {
                position_counts: Some(planned.from_counts),
            },
            Instruction::Begin { at_us: None },
        ])?;
        let motor_off = encode(&[
            Instruction::Select { station },
            Instruction::Motor { on: Some(false) },
        ])?;
        let byte_time = Line::new(desk.link.baud()).byte_time();
        let line_time = byte_time * u32::try_from(down.len() + back.len()).unwrap_or(u32::MAX);
        desk.link
            .send_issued(down, generation)
            .await
            .map_err(|error| CommissionError::NotSent {
                reason: error.to_string(),
            })?;
        let motor_off = (motor_on == Some(false)).then_some(motor_off);
        // Back where it was includes the driver off again, when it was off.
        let settle = motor_off.as_ref().map_or(Duration::ZERO, |batch| {
            MOTOR_OFF_MARGIN + byte_time * u32::try_from(batch.len()).unwrap_or(u32::MAX)
        });
        let duration = planned.duration() + line_time + settle;
        tokio::spawn(come_back(
            ComeBack {
                link: desk.link.clone(),
                status: self.status.clone(),
                starts_pending: Arc::clone(&self.starts_pending),
                generation,
                planned,
                back,
                motor_off,
            },
            busy,
        ));
        Ok(Identifying {
            station,
            distance_mm: planned.distance_mm,
            duration_ms: u64::try_from(duration.as_millis()).unwrap_or(u64::MAX),
        })
    }
}

/// The second half of an identify move.
struct ComeBack {
    link: Link,
    status: watch::Receiver<Status>,
    /// Starts and Resets being prepared: a Start's approach moves every ball.
    starts_pending: Arc<AtomicUsize>,
    generation: u64,
    planned: IdentifyMove,
    back: Batch,
    /// Sent once back when the motor was off before.
    motor_off: Option<Batch>,
}

impl ComeBack {
    /// Whether the move may go on: no e-stop since, the player still leaves the line
    /// alone, no Start is being prepared (its approach moves this ball too) and nothing
    /// is being armed.
    fn may_go_on(&self) -> bool {
        let (state, armed) = {
            let status = self.status.borrow();
            (status.state, status.armed.is_some())
        };
        self.link.latch().generation() == self.generation
            && at_rest(state)
            && state != PlayerState::Stopped
            && !armed
            && self.starts_pending.load(Ordering::SeqCst) == 0
    }
}

/// Brings the ball back once it is down, then gives the desk back (`busy`).
async fn come_back(back: ComeBack, busy: Busy) {
    let _busy = busy;
    tokio::time::sleep(back.planned.leg + identify::PAUSE).await;
    if !back.may_go_on()
        || back
            .link
            .send_issued(back.back.clone(), back.generation)
            .await
            .is_err()
    {
        return;
    }
    // The driver goes off only once the ball is surely back: motor off stops it
    // where it is.
    let byte_time = Line::new(back.link.baud()).byte_time();
    let on_the_line = byte_time * u32::try_from(back.back.len()).unwrap_or(u32::MAX);
    tokio::time::sleep(back.planned.leg + on_the_line + MOTOR_OFF_MARGIN).await;
    if let Some(motor_off) = &back.motor_off
        && back.may_go_on()
    {
        let _ = back
            .link
            .send_issued(motor_off.clone(), back.generation)
            .await;
    }
}

/// The batch of an assignment request, checked.
fn assignment_batch(request: &AssignRequest) -> Result<Batch, CommissionError> {
    if request.assignments.is_empty() {
        return Err(CommissionError::NoAssignments);
    }
    let mut serials = BTreeSet::new();
    let mut stations = BTreeSet::new();
    let mut batch = encode(&[Instruction::Select { station: 0 }])?;
    for assignment in &request.assignments {
        let (serial, station) = (assignment.serial, assignment.station);
        if !(1..=127).contains(&station) {
            return Err(CommissionError::BadStation { station });
        }
        if !serials.insert(serial) {
            return Err(CommissionError::SerialTwice { serial });
        }
        if !stations.insert(station) {
            return Err(CommissionError::StationTwice { station });
        }
        batch
            .push(&Instruction::SetStation { station, serial }, Form::Standard)
            .map_err(|_| CommissionError::SerialTooLong {
                serial,
                max: floatball_shared::uim2503::ascii::MAX_LEN,
            })?;
    }
    Ok(batch)
}

/// A roll call on a desk already taken.
async fn roll_call_on(
    desk: &Desk,
    gateway: usize,
    installation: &Installation,
) -> Result<RollCall, CommissionError> {
    let cells = installation.stations_on(gateway);
    let first_cell = installation.units_on(gateway).next().unwrap_or(0);
    let faults = desk.faults().await;
    let mut frames = desk.link.feedback();
    let mut tally = Tally::new(Instant::now());
    let mut heard = |at: Instant, station: u8, feedback: &Feedback| {
        tally.frame(at, station, feedback);
    };
    send(
        &desk.link,
        encode(&[Instruction::Select { station: 0 }, Instruction::QuerySerial])?,
    )
    .await?;
    collect(
        &desk.link,
        &mut frames,
        MAX_UNITS * SERIAL_FRAME_BYTES,
        &mut heard,
    )
    .await;
    let answered = tally.answered();
    let duplicated: BTreeSet<u8> = tally.duplicated().into_iter().collect();
    let configured: BTreeSet<u8> = cells.iter().copied().collect();
    let mut probe = Vec::new();
    let mut expected = 0;
    for &station in configured.union(&answered) {
        if duplicated.contains(&station) {
            continue;
        }
        probe.push(Instruction::Select { station });
        if !answered.contains(&station) {
            probe.push(Instruction::QuerySerial);
            expected += SERIAL_FRAME_BYTES;
        }
        probe.push(Instruction::PtpPosition {
            position_counts: None,
        });
        expected += POSITION_FRAME_BYTES;
    }
    if !probe.is_empty() {
        send(&desk.link, encode(&probe)?).await?;
        collect(
            &desk.link,
            &mut frames,
            expected,
            |at, station, feedback: &Feedback| tally.frame(at, station, feedback),
        )
        .await;
    }
    let call = tally.finish(
        Instant::now(),
        &Context {
            gateway,
            cells: &cells,
            first_cell,
            counts_per_mm: installation.counts_per_mm,
            faults: &faults,
        },
    );
    let _ = desk
        .reports
        .send(Report::RollCall(call.clone(), cells))
        .await;
    Ok(call)
}

fn encode(instructions: &[Instruction]) -> Result<Batch, CommissionError> {
    Batch::encode(instructions, Form::Standard).map_err(|error| CommissionError::NotSent {
        reason: error.to_string(),
    })
}

/// Queues `batch` on the link's bulk lane.
async fn send(link: &Link, batch: Batch) -> Result<(), CommissionError> {
    link.send(batch)
        .await
        .map_err(|error| CommissionError::NotSent {
            reason: error.to_string(),
        })
}

/// Hands every frame that arrives to `heard` until the link has written everything
/// and the line has been quiet for [`QUIET_BYTES`] byte times plus [`QUIET_SLACK`], or
/// until twice the time `expected_bytes` of answers (and what is still queued) need,
/// plus a second.
async fn collect(
    link: &Link,
    frames: &mut broadcast::Receiver<Frame>,
    expected_bytes: usize,
    mut heard: impl FnMut(Instant, u8, &Feedback),
) {
    let byte_time = Line::new(link.baud()).byte_time();
    let quiet = byte_time * QUIET_BYTES + QUIET_SLACK;
    let start = Instant::now();
    let line_bytes = u32::try_from(link.queued_bytes() + expected_bytes).unwrap_or(u32::MAX);
    let deadline =
        start + byte_time.saturating_mul(line_bytes).saturating_mul(2) + Duration::from_secs(1);
    let mut last = start;
    let mut drained = false;
    loop {
        let now = Instant::now();
        if !drained && link.queued_bytes() == 0 {
            drained = true;
            last = last.max(now);
        }
        if now >= deadline || (drained && now >= last + quiet) {
            return;
        }
        let until = if drained {
            (last + quiet).min(deadline)
        } else {
            (now + POLL).min(deadline)
        };
        match tokio::time::timeout(until.saturating_duration_since(now), frames.recv()).await {
            Ok(Ok(frame)) => {
                let at = Instant::now();
                if let Ok(feedback) = Feedback::from_frame(&frame) {
                    heard(at, frame.station(), &feedback);
                }
                last = at;
            }
            Ok(Err(broadcast::error::RecvError::Lagged(missed))) => {
                tracing::warn!(
                    "gateway {}: commissioning missed {missed} feedback frames",
                    link.index()
                );
            }
            Ok(Err(broadcast::error::RecvError::Closed)) => return,
            Err(_) => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use floatball_shared::api::Assignment;

    use super::*;

    fn request(pairs: &[(u64, u8)]) -> AssignRequest {
        AssignRequest {
            assignments: pairs
                .iter()
                .map(|&(serial, station)| Assignment { serial, station })
                .collect(),
        }
    }

    #[test]
    fn assignments_go_out_after_one_broadcast_selection() {
        let batch = assignment_batch(&request(&[(123_456, 1), (98_765_432_109, 127)])).unwrap();
        assert_eq!(
            String::from_utf8_lossy(batch.as_bytes()),
            "*0;SN[1]=123456;SN[127]=98765432109;"
        );
    }

    #[test]
    fn bad_assignments_are_refused_with_their_reason() {
        let refuse = |pairs: &[(u64, u8)]| assignment_batch(&request(pairs)).unwrap_err();
        assert_eq!(refuse(&[]), CommissionError::NoAssignments);
        assert_eq!(
            refuse(&[(1, 0)]),
            CommissionError::BadStation { station: 0 }
        );
        assert_eq!(
            refuse(&[(1, 128)]),
            CommissionError::BadStation { station: 128 }
        );
        assert_eq!(
            refuse(&[(1, 2), (1, 3)]),
            CommissionError::SerialTwice { serial: 1 }
        );
        assert_eq!(
            refuse(&[(1, 2), (4, 2)]),
            CommissionError::StationTwice { station: 2 }
        );
        assert_eq!(
            refuse(&[(123_456_789_012, 100)]),
            CommissionError::SerialTooLong {
                serial: 123_456_789_012,
                max: 20
            }
        );
        let error = refuse(&[(1, 2), (4, 2)]);
        assert_eq!(error.code(), Code::CommissionStationTwice);
        assert_eq!(error.params()["station"], "2");
        // Worded by the code's English template.
        assert_eq!(error.to_string(), "Station 2 is given to two units");
    }
}
