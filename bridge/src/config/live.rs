//! The `[live]` table of `floatball.toml`: live input from a lighting console (issue
//! 38, docs/live.md) — whether it is on (`enabled`, off by default), which protocols
//! are received (`artnet`, `sacn`), how long input may be lost before the balls hold
//! (`hold_after_ms`), and the patch: the default `profile`, the whole matrix patched
//! row by row from one universe and address (`matrix = { universe = 1, address = 1 }`,
//! the default), and per-ball overrides (`[[live.ball]]` with `ball`, `universe`,
//! `address` and optionally its own `profile`).
//!
//! The receivers and live mode come in a later step: these keys are read and checked
//! now (every mistake with its line and column, the patch against the installation's
//! ball count and the problems of [`Patch::problems`]) and used when live mode lands.
//!
//! [`edit_patch`] writes a patch back in the same compact form (`PUT
//! /api/live/patch`): the matrix start that leaves the fewest balls apart, and one
//! `[[live.ball]]` per ball that differs from it — a patch of 10,000 balls made in
//! one tap stays two lines.

use std::net::{Ipv4Addr, SocketAddr};

use floatball_shared::live::patch::{MAX_UNIVERSE, Patch, PatchEntry, PatchProblem, Profile};
use toml::Spanned;
use toml_edit::{ArrayOfTables, DocumentMut, InlineTable, Item, Table, Value};

use super::ConfigError;
use super::check::Checker;
use super::edit::EditError;
use super::raw::{RawLive, RawProfile};

/// `hold_after_ms` unless configured.
pub const DEFAULT_HOLD_AFTER_MS: u32 = 1000;

/// `artnet_listen` unless configured.
pub const DEFAULT_ARTNET_LISTEN: SocketAddr =
    SocketAddr::new(std::net::IpAddr::V4(Ipv4Addr::UNSPECIFIED), 6454);

/// `sacn_listen` unless configured.
pub const DEFAULT_SACN_LISTEN: SocketAddr =
    SocketAddr::new(std::net::IpAddr::V4(Ipv4Addr::UNSPECIFIED), 5568);

/// The shortest and longest `hold_after_ms` accepted.
pub const HOLD_AFTER_RANGE_MS: std::ops::RangeInclusive<u32> = 100..=60_000;

/// `[live]`, checked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LiveConfig {
    /// Live input switched on (`enabled = true`); off by default.
    pub enabled: bool,
    /// Art-Net received (default: yes).
    pub artnet: bool,
    /// sACN (E1.31) received (default: yes).
    pub sacn: bool,
    /// Where Art-Net is received (`artnet_listen`, default `0.0.0.0:6454`); one socket
    /// with the timecode chase's when `[timecode] listen` is the same.
    pub artnet_listen: SocketAddr,
    /// Where sACN is received (`sacn_listen`, default `0.0.0.0:5568`).
    pub sacn_listen: SocketAddr,
    /// The interface (its IPv4 address) the sACN multicast groups are joined on
    /// (`sacn_interface`, default `0.0.0.0`: the one the system routes multicast to).
    pub sacn_interface: Ipv4Addr,
    /// Input lost this long → the balls hold.
    pub hold_after_ms: u32,
    /// Every ball's channels.
    pub patch: Patch,
    /// Where the whole matrix is patched from: (universe, address).
    pub matrix_start: (u16, u16),
}

impl LiveConfig {
    /// One line for `floatball check`: on or off, the protocols, how many balls are
    /// patched on how many universes, and the profile.
    pub fn summary(&self) -> String {
        let universes = self.patch.universes();
        let range = match (universes.first(), universes.last()) {
            (Some(first), Some(last)) if first == last => format!("universe {first}"),
            (Some(first), Some(last)) => format!("universes {first}–{last}"),
            _ => "no universe".to_owned(),
        };
        let protocols: Vec<&str> = [(self.artnet, "Art-Net"), (self.sacn, "sACN")]
            .into_iter()
            .filter_map(|(on, name)| on.then_some(name))
            .collect();
        let own = self
            .patch
            .balls
            .iter()
            .filter(|entry| entry.profile.is_some())
            .count();
        format!(
            "live input {} ({}; hold after {} ms): {} balls patched on {} universe(s), {range}; \
             profile {}{}",
            if self.enabled { "on" } else { "off" },
            if protocols.is_empty() {
                "no protocol".to_owned()
            } else {
                protocols.join(" and ")
            },
            self.hold_after_ms,
            self.patch.balls.len(),
            universes.len(),
            profile_words(self.patch.profile),
            if own == 0 {
                String::new()
            } else {
                format!(" ({own} with their own profile)")
            }
        )
    }
}

/// A profile in words: `16-bit position + 8-bit speed limit + enable (4 channels)`.
pub fn profile_words(profile: Profile) -> String {
    let mut words = vec!["16-bit position".to_owned()];
    if let Some(bits) = profile.speed_limit_bits {
        words.push(format!("{bits}-bit speed limit"));
    }
    if profile.enable {
        words.push("enable".to_owned());
    }
    if profile.colour {
        words.push("colour".to_owned());
    }
    format!("{} ({} channels)", words.join(" + "), profile.footprint())
}

impl Checker<'_> {
    /// A profile as written (`profile = { speed_limit_bits = 8, enable = true }`).
    fn live_profile(&self, raw: &RawProfile) -> Result<Profile, ConfigError> {
        let speed_limit_bits = match &raw.speed_limit_bits {
            Some(bits) if ![8, 16].contains(bits.get_ref()) => {
                return Err(self.at(
                    &bits.span(),
                    format!(
                        "[live] speed_limit_bits = {} must be 8 or 16 (leave it out for no \
                         speed-limit channel)",
                        bits.get_ref()
                    ),
                ));
            }
            Some(bits) => Some(*bits.get_ref()),
            None => None,
        };
        Ok(Profile {
            speed_limit_bits,
            enable: raw.enable.as_ref().is_some_and(|on| *on.get_ref()),
            colour: raw.colour.as_ref().is_some_and(|on| *on.get_ref()),
        })
    }

    /// A universe or an address as written, within its range.
    fn live_number(&self, value: &Spanned<i64>, key: &str, max: u16) -> Result<u16, ConfigError> {
        u16::try_from(*value.get_ref())
            .ok()
            .filter(|number| (1..=max).contains(number))
            .ok_or_else(|| {
                self.at(
                    &value.span(),
                    format!("[live] {key} = {} is outside 1–{max}", value.get_ref()),
                )
            })
    }

    /// An address and UDP port as written (`artnet_listen`, `sacn_listen`).
    fn live_listen(
        &self,
        value: Option<&Spanned<String>>,
        key: &str,
        default: SocketAddr,
    ) -> Result<SocketAddr, ConfigError> {
        let Some(value) = value else {
            return Ok(default);
        };
        value.get_ref().trim().parse().map_err(|_| {
            self.at(
                &value.span(),
                format!(
                    "[live] {key} = {:?} is not an address and UDP port such as \"{default}\"",
                    value.get_ref()
                ),
            )
        })
    }

    /// `[live]` for an installation of `balls` balls.
    pub(super) fn live(&self, raw: &RawLive, balls: usize) -> Result<LiveConfig, ConfigError> {
        let artnet_listen = self.live_listen(
            raw.artnet_listen.as_ref(),
            "artnet_listen",
            DEFAULT_ARTNET_LISTEN,
        )?;
        let sacn_listen =
            self.live_listen(raw.sacn_listen.as_ref(), "sacn_listen", DEFAULT_SACN_LISTEN)?;
        let sacn_interface = match &raw.sacn_interface {
            Some(interface) => interface.get_ref().trim().parse().map_err(|_| {
                self.at(
                    &interface.span(),
                    format!(
                        "[live] sacn_interface = {:?} is not an IPv4 address such as \
                         \"192.168.1.10\" (the interface's) or \"0.0.0.0\"",
                        interface.get_ref()
                    ),
                )
            })?,
            None => Ipv4Addr::UNSPECIFIED,
        };
        let hold_after_ms = match &raw.hold_after_ms {
            Some(hold) if !HOLD_AFTER_RANGE_MS.contains(hold.get_ref()) => {
                return Err(self.at(
                    &hold.span(),
                    format!(
                        "[live] hold_after_ms = {} must be from {} to {} ms",
                        hold.get_ref(),
                        HOLD_AFTER_RANGE_MS.start(),
                        HOLD_AFTER_RANGE_MS.end()
                    ),
                ));
            }
            Some(hold) => *hold.get_ref(),
            None => DEFAULT_HOLD_AFTER_MS,
        };
        let profile = match &raw.profile {
            Some(profile) => self.live_profile(profile.get_ref())?,
            None => Profile::default(),
        };
        let (start, matrix_span) = match &raw.matrix {
            Some(matrix) => {
                let at = matrix.get_ref();
                let missing = |key: &str| {
                    self.at(
                        &matrix.span(),
                        format!(
                            "[live] matrix needs a universe and an address, such as \
                             matrix = {{ universe = 1, address = 1 }} ({key} is missing)"
                        ),
                    )
                };
                let universe = at.universe.as_ref().ok_or_else(|| missing("universe"))?;
                let address = at.address.as_ref().ok_or_else(|| missing("address"))?;
                (
                    (
                        self.live_number(universe, "matrix universe", MAX_UNIVERSE)?,
                        self.live_number(address, "matrix address", 512)?,
                    ),
                    Some(matrix.span()),
                )
            }
            None => ((1, 1), None),
        };
        let mut patch = Patch::matrix(balls, profile, start.0, start.1).map_err(|problem| {
            self.wrong(
                matrix_span.as_ref(),
                format!("[live] matrix: {}", problem_words(&problem)),
            )
        })?;
        // Where each overridden ball's entry stands, for its problems.
        let mut placed: Vec<Option<std::ops::Range<usize>>> = vec![None; balls];
        for entry in &raw.ball {
            let span = entry.span();
            let one = entry.get_ref();
            let ball = one.ball.as_ref().ok_or_else(|| {
                self.at(
                    &span,
                    "[[live.ball]] needs the ball's number (ball = 0 is the first ball, row by \
                     row as in a show)"
                        .to_owned(),
                )
            })?;
            let index = *ball.get_ref();
            if index >= balls {
                return Err(self.at(
                    &ball.span(),
                    format!(
                        "[[live.ball]] ball = {index}: the installation has balls 0–{}",
                        balls.saturating_sub(1)
                    ),
                ));
            }
            if placed[index].is_some() {
                return Err(self.at(
                    &ball.span(),
                    format!("[[live.ball]] ball = {index} is patched twice"),
                ));
            }
            let default = patch.balls[index];
            let universe = one
                .universe
                .as_ref()
                .map(|universe| self.live_number(universe, "universe", MAX_UNIVERSE))
                .transpose()?
                .unwrap_or(default.universe);
            let address = one
                .address
                .as_ref()
                .map(|address| self.live_number(address, "address", 512))
                .transpose()?
                .unwrap_or(default.address);
            let own = one
                .profile
                .as_ref()
                .map(|profile| self.live_profile(profile.get_ref()))
                .transpose()?;
            patch.balls[index] = PatchEntry {
                universe,
                address,
                profile: own,
            };
            placed[index] = Some(span);
        }
        let mut problems: Vec<ConfigError> = patch
            .problems(balls)
            .iter()
            .map(|problem| {
                self.wrong(
                    problem_ball(problem)
                        .and_then(|ball| placed.get(ball).cloned().flatten())
                        .or_else(|| matrix_span.clone())
                        .as_ref(),
                    format!("[live] {}", problem_words(problem)),
                )
            })
            .collect();
        // Every problem listed, in order: all but the last noted, the last returned.
        if let Some(last) = problems.pop() {
            for problem in problems {
                self.note(problem);
            }
            return Err(last);
        }
        Ok(LiveConfig {
            enabled: raw.enabled.as_ref().is_some_and(|on| *on.get_ref()),
            artnet: raw.artnet.as_ref().is_none_or(|on| *on.get_ref()),
            sacn: raw.sacn.as_ref().is_none_or(|on| *on.get_ref()),
            artnet_listen,
            sacn_listen,
            sacn_interface,
            hold_after_ms,
            patch,
            matrix_start: start,
        })
    }
}

/// The ball a problem is about.
fn problem_ball(problem: &PatchProblem) -> Option<usize> {
    match *problem {
        PatchProblem::BallCount { .. } => None,
        PatchProblem::Universe { ball, .. }
        | PatchProblem::Address { ball, .. }
        | PatchProblem::Footprint { ball, .. }
        | PatchProblem::Overlap { ball, .. }
        | PatchProblem::SpeedBits { ball, .. } => Some(ball),
    }
}

/// A problem as `floatball check` words it (the shared text, with the ball's number
/// as the file writes it).
fn problem_words(problem: &PatchProblem) -> String {
    problem.to_string()
}

/// `text` (the file as it is) with `patch` written into `[live]`: `profile` (when not
/// the default, or already written), `matrix` from the start that leaves the fewest
/// balls apart (`current` — the file's — or the first ball's), and a `[[live.ball]]`
/// for each ball apart (the old ones replaced). Every other key and comment stays.
///
/// # Errors
/// [`EditError`]: `text` is not TOML, or `[live]` is not a table.
pub fn edit_patch(text: &str, patch: &Patch, current: (u16, u16)) -> Result<String, EditError> {
    let mut document: DocumentMut = text
        .parse()
        .map_err(|error: toml_edit::TomlError| EditError::NotToml(error.to_string()))?;
    let (start, apart) = compact(patch, current);
    if !document.contains_key("live") {
        document.insert("live", Item::Table(Table::new()));
    }
    let live = document
        .get_mut("live")
        .and_then(Item::as_table_mut)
        .ok_or(EditError::NotATable("[live]"))?;
    if patch.profile != Profile::default() || live.contains_key("profile") {
        live.insert("profile", toml_edit::value(profile_table(patch.profile)));
    }
    let mut matrix = InlineTable::new();
    matrix.insert("universe", Value::from(i64::from(start.0)));
    matrix.insert("address", Value::from(i64::from(start.1)));
    live.insert("matrix", toml_edit::value(matrix));
    live.remove("ball");
    if !apart.is_empty() {
        let mut balls = ArrayOfTables::new();
        for ball in apart {
            let entry = &patch.balls[ball];
            let mut table = Table::new();
            table.insert("ball", toml_edit::value(ball as i64));
            table.insert("universe", toml_edit::value(i64::from(entry.universe)));
            table.insert("address", toml_edit::value(i64::from(entry.address)));
            if let Some(profile) = entry.profile {
                table.insert("profile", toml_edit::value(profile_table(profile)));
            }
            balls.push(table);
        }
        live.insert("ball", Item::ArrayOfTables(balls));
    }
    Ok(document.to_string())
}

/// `{ speed_limit_bits = 8, enable = true, colour = false }`.
fn profile_table(profile: Profile) -> InlineTable {
    let mut table = InlineTable::new();
    if let Some(bits) = profile.speed_limit_bits {
        table.insert("speed_limit_bits", Value::from(i64::from(bits)));
    }
    table.insert("enable", Value::from(profile.enable));
    table.insert("colour", Value::from(profile.colour));
    table
}

/// The matrix start (of `current` and the first ball's place) that leaves the
/// fewest balls apart from [`Patch::matrix`], and those balls.
pub fn compact(patch: &Patch, current: (u16, u16)) -> ((u16, u16), Vec<usize>) {
    let first = patch
        .balls
        .first()
        .map_or(current, |entry| (entry.universe, entry.address));
    let mut best: Option<((u16, u16), Vec<usize>)> = None;
    for start in [first, current, (1, 1)] {
        let Ok(matrix) = Patch::matrix(patch.balls.len(), patch.profile, start.0, start.1) else {
            continue;
        };
        let apart: Vec<usize> = patch
            .balls
            .iter()
            .zip(&matrix.balls)
            .enumerate()
            .filter(|(_, (ball, from_matrix))| ball != from_matrix)
            .map(|(index, _)| index)
            .collect();
        if best
            .as_ref()
            .is_none_or(|(_, fewest)| apart.len() < fewest.len())
        {
            best = Some((start, apart));
        }
    }
    best.unwrap_or_else(|| (current, (0..patch.balls.len()).collect()))
}
