//! Motion in whole counts: the PVT rows a unit accepts for a motion given in real
//! numbers (the live filter's states, a show's rows in mm).
//!
//! A unit runs a row as a cubic (Hermite) from where the last row ended to the row's
//! `QP`/`QV` ([`Row::segment_from`]), and stops with LIMIT (error 0x41) the moment
//! that cubic leaves `0…travel`, however little (the upper limit switch at 0), and
//! with OVERLOAD when it asks for more speed or acceleration than the unit has.
//! Rounding a row's position and velocity to whole counts each on its own is not
//! enough near an end of the travel: a ball braking into 0 whose last-but-one state
//! is 0.4 counts below the top, still rising at 74 counts/s, becomes the row end
//! (0, −74), and the last row, from there to (0, 0), dips 0.12 counts past the top.
//!
//! - [`Envelope`]: what the unit accepts — the travel in whole counts (its far end
//!   rounded towards the top when it is no whole count), the top speed and
//!   acceleration.
//! - [`Envelope::end_is_safe`]: a row end from which a row of the same duration can
//!   go on inside the travel whatever it is asked next, and to which a row can come
//!   inside it: its Bernstein control points `p ± v·T/3` are inside (`T` the row's
//!   duration), in whole numbers — a cubic stays within the hull of its control
//!   points, so a row between two safe ends never leaves the travel, exactly (no float
//!   noise). The motion the live filter makes satisfies it with room to spare except
//!   within about 1.5 counts of an end (braking or starting on its step grid: speed ≤
//!   2·distance/T), where half a count of rounding can break it.
//! - [`live_row`]: the row towards a live filter's state: its position rounded down
//!   or up and the velocity chosen so that the end is safe, the acceleration at both
//!   ends of the cubic and its speed within the limits, nearest to the state (by the
//!   acceleration each count of difference makes). Away from the ends that is the
//!   state rounded, count by count.
//! - [`keep_inside`]: a planned show's rows: each rounded on its own as before, unless
//!   its cubic (or the next row's) would leave the travel; then, with one row of
//!   look-ahead, the nearest row end that keeps both inside, within the limits if any
//!   does. A show reaching an end was planned with the same dip as live rows (a take
//!   recorded live that brakes into the top stopped its unit with LIMIT).

use crate::motion::Segment;
use crate::plan::Installation;

use super::Row;

/// Float noise allowed on the limits when a row is checked (relative); the unit
/// allows 1e-9 ([`crate::uim2503::sim`]), so a row passed here passes there.
const LIMIT_SLACK: f64 = 1e-12;

/// Float noise allowed on a cubic's lowest and highest point, counts (the unit allows
/// 1e-6): a row whose control points are inside is inside exactly, and is taken
/// without it.
const INSIDE_SLACK_COUNTS: f64 = 1e-9;

/// What a unit accepts, in counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Envelope {
    /// The top of the travel, counts (0).
    pub low_counts: i32,
    /// The lowest point of the travel in whole counts (rounded towards the top).
    pub high_counts: i32,
    /// Top speed, counts/s.
    pub max_speed_counts_s: f64,
    /// Top acceleration, counts/s².
    pub max_accel_counts_s2: f64,
}

/// A row's end as written: where a row leaves the ball and how fast.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct End {
    /// Position, counts.
    pub position_counts: i32,
    /// Velocity, counts/s.
    pub velocity_counts_s: i32,
}

impl End {
    /// At rest at `position_counts`.
    #[must_use]
    pub const fn at_rest(position_counts: i32) -> Self {
        Self {
            position_counts,
            velocity_counts_s: 0,
        }
    }

    /// Where `row` leaves the ball.
    #[must_use]
    pub const fn of(row: &Row) -> Self {
        Self {
            position_counts: row.position_counts,
            velocity_counts_s: row.velocity_counts_s,
        }
    }
}

impl Envelope {
    /// The installation's travel and limits in counts.
    #[must_use]
    pub fn of(installation: &Installation) -> Self {
        let per_mm = installation.counts_per_mm;
        let limits = installation.limits;
        let travel_counts = limits.travel_mm * per_mm;
        let (low, high) = if travel_counts >= 0.0 {
            (0.0, travel_counts)
        } else {
            (travel_counts, 0.0)
        };
        let whole = |counts: f64| counts.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32;
        Self {
            // Inwards, with room for float noise on a whole number of counts.
            low_counts: whole((low - 1e-9).ceil()),
            high_counts: whole((high + 1e-9).floor()),
            max_speed_counts_s: (limits.max_speed_mm_s * per_mm).abs(),
            max_accel_counts_s2: (limits.max_accel_mm_s2 * per_mm).abs(),
        }
    }

    /// The largest speed, counts/s, a row end of `duration_ms` may have at
    /// `position_counts` and be safe ([`Envelope::end_is_safe`]); `None` outside the
    /// travel.
    #[must_use]
    pub fn safe_speed_counts_s(&self, position_counts: i32, duration_ms: u8) -> Option<i64> {
        let position = i64::from(position_counts);
        let room =
            (position - i64::from(self.low_counts)).min(i64::from(self.high_counts) - position);
        // |v|·T/3 ≤ room, T = ms/1000: |v|·ms ≤ 3000·room.
        (room >= 0).then(|| 3000 * room / i64::from(duration_ms.max(1)))
    }

    /// Whether `end` is safe for rows of `duration_ms`: both Bernstein control
    /// points it gives a row, `p ± v·T/3`, inside the travel (in whole numbers).
    #[must_use]
    pub fn end_is_safe(&self, end: End, duration_ms: u8) -> bool {
        self.safe_speed_counts_s(end.position_counts, duration_ms)
            .is_some_and(|safe| i64::from(end.velocity_counts_s).abs() <= safe)
    }

    /// Whether `row` from `from` stays inside the travel along its whole cubic (as
    /// the unit checks it: its lowest and highest point).
    #[must_use]
    pub fn row_inside(&self, from: End, row: &Row) -> bool {
        if self.hull_inside(from, row) {
            return true;
        }
        let range = segment(from, row).position_range();
        range.min.value >= f64::from(self.low_counts) - INSIDE_SLACK_COUNTS
            && range.max.value <= f64::from(self.high_counts) + INSIDE_SLACK_COUNTS
    }

    /// Whether every Bernstein control point of `row` from `from` is inside the
    /// travel (in whole numbers): then its cubic is, exactly.
    fn hull_inside(&self, from: End, row: &Row) -> bool {
        let ms = i64::from(row.duration_ms);
        let (low, high) = (
            3000 * i64::from(self.low_counts),
            3000 * i64::from(self.high_counts),
        );
        // 3000·(p ± v·T/3) with T = ms/1000.
        let first = 3000 * i64::from(from.position_counts) + i64::from(from.velocity_counts_s) * ms;
        let second = 3000 * i64::from(row.position_counts) - i64::from(row.velocity_counts_s) * ms;
        [
            3000 * i64::from(from.position_counts),
            first,
            second,
            3000 * i64::from(row.position_counts),
        ]
        .iter()
        .all(|point| (low..=high).contains(point))
    }

    /// Whether `row` from `from` asks for no more speed nor acceleration than the
    /// unit has, anywhere along its cubic.
    #[must_use]
    pub fn row_within_limits(&self, from: End, row: &Row) -> bool {
        self.excess(from, row) <= 0.0
    }

    /// How far `row` from `from` goes beyond the limits, as a share of them (the
    /// larger of speed and acceleration; ≤ 0 within them).
    fn excess(&self, from: End, row: &Row) -> f64 {
        let segment = segment(from, row);
        let share = |value: f64, limit: f64| value / limit.max(f64::MIN_POSITIVE) - 1.0;
        share(segment.peak_speed().value, self.max_speed_counts_s)
            .max(share(
                segment.peak_acceleration().value,
                self.max_accel_counts_s2,
            ))
            .max(-1.0)
            - LIMIT_SLACK
    }
}

/// The cubic a unit runs for `row` from `from`.
fn segment(from: End, row: &Row) -> Segment {
    row.segment_from(
        f64::from(from.position_counts),
        f64::from(from.velocity_counts_s),
    )
}

/// The row of `duration_ms` from `from` (where the last row written left the ball,
/// a safe end) towards the state `position_counts`, `velocity_counts_s` (the live
/// filter's, in counts): the whole-count row nearest to it whose end is safe
/// ([`Envelope::end_is_safe`]) and whose cubic keeps the limits — so no row leaves
/// the travel, and every next row can stay inside too. Away from the ends it is the
/// state rounded. When nothing nearby keeps the limits (the filter leaves room for
/// rounding, so this is not expected) the safe row that exceeds them least.
#[must_use]
pub fn live_row(
    envelope: &Envelope,
    from: End,
    position_counts: f64,
    velocity_counts_s: f64,
    duration_ms: u8,
) -> Row {
    let wanted = Wanted::new(envelope, position_counts, velocity_counts_s, duration_ms);
    nearest(envelope, from, &wanted, true, |row, key| {
        envelope
            .end_is_safe(End::of(row), row.duration_ms)
            .then_some(key)
    })
    .map(|(_, row)| row)
    .unwrap_or(Row {
        // Not reached: at rest at the position rounded is always a safe end.
        position_counts: from.position_counts,
        velocity_counts_s: 0,
        duration_ms: wanted.duration_ms,
    })
}

/// A unit's planned rows, from rest at `start_counts`, each `rows[i]` the show's row
/// rounded on its own and `exact(i)` its end unrounded (position, counts; velocity,
/// counts/s): a row whose cubic would leave the travel, or after which the next one
/// would, gets the nearest end instead that keeps both inside (one row of
/// look-ahead: the end and the next row's nearest end that goes on inside from it,
/// chosen together), within the limits if any does. Rows that stay inside are left
/// as they are, so a show away from the ends plans exactly as before. Returns how
/// many rows were changed.
///
/// Not applied to planned shows yet: the planner is part of the web app's first
/// load, which has no room left under its budget for this (issue 48 first makes
/// room); until then a planned show braking into an end can still dip past it by a
/// fraction of a count (found with issue 47, tested here).
pub fn keep_inside(
    envelope: &Envelope,
    start_counts: i32,
    rows: &mut [Row],
    exact: impl Fn(usize) -> (f64, f64),
) -> usize {
    let mut changed = 0;
    let mut from = End::at_rest(start_counts);
    for index in 0..rows.len() {
        let next = rows.get(index + 1).copied();
        let row = rows[index];
        let fine = envelope.row_inside(from, &row)
            && next.is_none_or(|next| envelope.row_inside(End::of(&row), &next));
        if !fine {
            let (position, velocity) = exact(index);
            let wanted = Wanted::new(envelope, position, velocity, row.duration_ms);
            let next_wanted = next.map(|next| {
                let (position, velocity) = exact(index + 1);
                Wanted::new(envelope, position, velocity, next.duration_ms)
            });
            let found = nearest(envelope, from, &wanted, false, |candidate, key| {
                if !envelope.row_inside(from, candidate) {
                    return None;
                }
                let Some(next) = next_wanted.as_ref() else {
                    return Some(key);
                };
                let end = End::of(candidate);
                let (after, _) = nearest(envelope, end, next, false, |after, key| {
                    envelope.row_inside(end, after).then_some(key)
                })?;
                Some((key.0.max(after.0), key.1 + after.1))
            })
            .map(|(_, row)| row);
            if let Some(found) = found
                && found != row
            {
                rows[index] = found;
                changed += 1;
            }
        }
        from = End::of(&rows[index]);
    }
    changed
}

/// A row end wanted, in counts, clamped into the travel.
#[derive(Debug, Clone, Copy)]
struct Wanted {
    position_counts: f64,
    velocity_counts_s: f64,
    duration_ms: u8,
    t_s: f64,
}

impl Wanted {
    fn new(
        envelope: &Envelope,
        position_counts: f64,
        velocity_counts_s: f64,
        duration_ms: u8,
    ) -> Self {
        let duration_ms = duration_ms.max(1);
        let low = f64::from(envelope.low_counts);
        let high = f64::from(envelope.high_counts);
        Self {
            position_counts: if position_counts.is_finite() {
                position_counts.clamp(low, high)
            } else {
                low
            },
            velocity_counts_s: if velocity_counts_s.is_finite() {
                velocity_counts_s
            } else {
                0.0
            },
            duration_ms,
            t_s: f64::from(duration_ms) / 1000.0,
        }
    }

    /// What a row's difference from the wanted end costs: the acceleration it adds
    /// at the row's ends, counts/s² (6/T² a count of position, 4/T a count/s).
    fn cost(&self, row: &Row) -> f64 {
        let t_s = self.t_s;
        (f64::from(row.position_counts) - self.position_counts).abs() * 6.0 / (t_s * t_s)
            + (f64::from(row.velocity_counts_s) - self.velocity_counts_s).abs() * 4.0 / t_s
    }
}

/// How a candidate row ranks, lowest first: how far it goes beyond the limits (0
/// within them), then its [`Wanted::cost`].
type Key = (f64, f64);

/// The row from `from` nearest to `wanted` (its position rounded, down or up, and a
/// few velocities: [`velocities`]) by the key `score` gives it (`None`: not taken;
/// it is handed the row's own [`Key`]), with that key; `None` when `score` takes
/// none. `safe_only`: velocities only within what keeps the end safe.
fn nearest(
    envelope: &Envelope,
    from: End,
    wanted: &Wanted,
    safe_only: bool,
    score: impl Fn(&Row, Key) -> Option<Key>,
) -> Option<(Key, Row)> {
    let low = f64::from(envelope.low_counts);
    let high = f64::from(envelope.high_counts);
    let x = wanted.position_counts;
    let mut best: Option<(Key, Row)> = None;
    let mut tried: [Option<i32>; 3] = [None; 3];
    for (slot, position) in [x.round(), x.floor(), x.ceil()].into_iter().enumerate() {
        let position = position.clamp(low, high) as i32;
        if tried.contains(&Some(position)) {
            continue;
        }
        tried[slot] = Some(position);
        let Some(safe) = envelope.safe_speed_counts_s(position, wanted.duration_ms) else {
            continue;
        };
        let top = envelope.max_speed_counts_s.floor() as i64;
        let bound = if safe_only { safe.min(top) } else { top };
        for velocity in velocities(envelope, from, position, wanted, safe.min(top), bound) {
            let row = Row {
                position_counts: position,
                velocity_counts_s: velocity,
                duration_ms: wanted.duration_ms,
            };
            let own = (envelope.excess(from, &row).max(0.0), wanted.cost(&row));
            if best.as_ref().is_some_and(|(best, _)| own >= *best) {
                // A score is never better than the row's own key.
                continue;
            }
            if let Some(key) = score(&row, own)
                && best.as_ref().is_none_or(|(best, _)| key < *best)
            {
                best = Some((key, row));
            }
        }
    }
    best
}

/// The velocities worth trying for a row from `from` to `position`, each within
/// `±bound`: the wanted one rounded, and within `±safe` too; the nearest ones that
/// keep the acceleration at both ends of the cubic; those that ask for the least
/// acceleration; at rest.
fn velocities(
    envelope: &Envelope,
    from: End,
    position: i32,
    wanted: &Wanted,
    safe: i64,
    bound: i64,
) -> Vec<i32> {
    let t_s = wanted.t_s;
    let bound = bound.max(0) as f64;
    let safe = (safe.max(0) as f64).min(bound);
    let u = wanted.velocity_counts_s;
    let a = envelope.max_accel_counts_s2;
    let dp = f64::from(position) - f64::from(from.position_counts);
    let v0 = f64::from(from.velocity_counts_s);
    // The acceleration at the start is k0 − 2·v/T, at the end k1 + 4·v/T.
    let k0 = (6.0 * dp / t_s - 4.0 * v0) / t_s;
    let k1 = (-6.0 * dp / t_s + 2.0 * v0) / t_s;
    let low = ((k0 - a) * t_s / 2.0).max((-a - k1) * t_s / 4.0);
    let high = ((k0 + a) * t_s / 2.0).min((a - k1) * t_s / 4.0);
    let mut tries = vec![u.round(), u.round().clamp(-safe, safe), 0.0];
    if low <= high {
        let (low, high) = (low.ceil(), high.floor().max(low.ceil()));
        tries.extend([u.round().clamp(low, high), low, high]);
        for limit in [safe, -safe] {
            tries.push(limit.clamp(low, high));
        }
    }
    // The least acceleration: where both ends ask for the same (a parabola), or one
    // for none.
    for v in [(k0 - k1) * t_s / 6.0, k0 * t_s / 2.0, -k1 * t_s / 4.0] {
        tries.extend([v.floor(), v.ceil()]);
    }
    let mut out: Vec<i32> = tries
        .into_iter()
        .filter(|v| v.is_finite())
        .map(|v| v.clamp(-bound, bound) as i32)
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::live::filter::{BallState, FilterLimits, MotionFilter};
    use crate::player::Drive;
    use crate::uim2503::player::{PlayerConfig, Uim2503Drive};

    /// 1 × `cols` units on one 115,200-baud gateway: a `travel_mm` travel at
    /// `counts_per_mm`, `accel_mm_s2` and 500 mm/s.
    fn installation(
        cols: u32,
        travel_mm: f64,
        counts_per_mm: f64,
        accel_mm_s2: f64,
    ) -> Installation {
        let mut installation = Installation::demo(1, cols, &[115_200]).unwrap();
        installation.counts_per_mm = counts_per_mm;
        installation.limits.travel_mm = travel_mm;
        installation.limits.max_speed_mm_s = 500.0;
        installation.limits.max_accel_mm_s2 = accel_mm_s2;
        installation
    }

    /// The filter live mode runs on `installation`'s units.
    fn live_filter(installation: &Installation) -> MotionFilter {
        let drive = Uim2503Drive::new(PlayerConfig {
            installation: installation.clone(),
        });
        MotionFilter::new(drive.live_setup().unwrap().limits).unwrap()
    }

    /// A live row checked as the unit checks it, and the end it leaves safe.
    fn assert_accepted(envelope: &Envelope, from: End, row: &Row) {
        assert!(
            envelope.row_inside(from, row),
            "{from:?} → {row:?} leaves the travel"
        );
        assert!(envelope.hull_inside(from, row), "{from:?} → {row:?}");
        let range = segment(from, row).position_range();
        assert!(
            range.min.value >= f64::from(envelope.low_counts) - 1e-9
                && range.max.value <= f64::from(envelope.high_counts) + 1e-9,
            "{from:?} → {row:?}: {range:?}"
        );
        assert!(
            envelope.row_within_limits(from, row),
            "{from:?} → {row:?} over the limits"
        );
        assert!(
            envelope.end_is_safe(End::of(row), row.duration_ms),
            "{row:?}"
        );
    }

    #[test]
    fn a_state_rounded_on_its_own_near_the_top_dips_past_it_and_a_live_row_does_not() {
        // The matrix: 1000 mm, 100 counts/mm, 500 mm/s, 2000 mm/s², 11 ms rows.
        let installation = installation(3, 1000.0, 100.0, 2000.0);
        let filter = live_filter(&installation);
        let envelope = Envelope::of(&installation);
        assert_eq!((envelope.low_counts, envelope.high_counts), (0, 100_000));
        let ms = u8::try_from(filter.limits().dt_ms).unwrap();
        assert_eq!(ms, 11);
        // From 20 mm to the top (and from 120 mm to the bottom): the last-but-one
        // state is a fraction of a count from the end, still moving towards it.
        for (start_mm, end_mm) in [(20.0, 0.0), (120.0, 1000.0)] {
            let mut state = BallState::at_rest(start_mm);
            let rest = End::at_rest((start_mm * 100.0) as i32);
            let (mut plain_from, mut live_from) = (rest, rest);
            let mut dipped = None;
            for _ in 0..300 {
                filter.step(&mut state, Some(end_mm), None);
                let (x, u) = (state.position_mm * 100.0, state.velocity_mm_s * 100.0);
                let plain = Row {
                    position_counts: x.round() as i32,
                    velocity_counts_s: u.round() as i32,
                    duration_ms: ms,
                };
                if !envelope.row_inside(plain_from, &plain) && dipped.is_none() {
                    dipped = Some((plain_from, plain));
                }
                plain_from = End::of(&plain);
                let row = live_row(&envelope, live_from, x, u, ms);
                assert_accepted(&envelope, live_from, &row);
                live_from = End::of(&row);
            }
            let (from, row) = dipped.expect("rounded on its own, a row dips past the end");
            assert_eq!(from.position_counts, row.position_counts);
            assert_ne!(from.velocity_counts_s, 0);
            // At the end, to the count.
            assert_eq!(live_from, End::at_rest((end_mm * 100.0) as i32));
        }
    }

    /// Live rows for random fader moves, jumps onto and near the ends, input lost and
    /// speed-limit channels, on matrices with fine and coarse calibrations and low and
    /// high accelerations: every row inside the travel along its cubic (exactly: its
    /// control points are), within the limits, its end safe; at rest on a target, the
    /// target rounded.
    #[test]
    fn live_rows_keep_the_travel_and_the_limits_for_any_input() {
        let mut seed = 0x5eed_u64;
        let mut random = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for (cols, travel_mm, per_mm, accel_mm_s2) in [
            (3, 1000.0, 100.0, 2000.0),
            (1, 1000.0, 100.0, 500.0),
            (20, 7500.0, 100.0, 4000.0),
            (4, 3000.0, 10.0, 2000.0),
            (2, 999.996, 1000.0, 40_000.0),
        ] {
            let installation = installation(cols, travel_mm, per_mm, accel_mm_s2);
            let filter = live_filter(&installation);
            let limits: FilterLimits = filter.limits();
            let ms = u8::try_from(limits.dt_ms).unwrap();
            let envelope = Envelope::of(&installation);
            let mut rows = 0;
            for _ in 0..30 {
                let start_mm = random() * travel_mm;
                let mut state = BallState::at_rest(start_mm);
                let mut from = End::at_rest((start_mm * per_mm).round() as i32);
                let (mut target, mut lost, mut speed_limit) = (start_mm, false, None);
                for step in 0..1500 {
                    if step % 100 == 0 {
                        let pick = random();
                        target = if pick < 0.3 {
                            0.0
                        } else if pick < 0.6 {
                            travel_mm
                        } else if pick < 0.7 {
                            random() * 0.05
                        } else if pick < 0.8 {
                            travel_mm - random() * 0.05
                        } else {
                            random() * travel_mm
                        };
                        lost = random() < 0.05;
                        speed_limit = (random() < 0.2).then(|| random() * 500.0);
                    }
                    filter.step(&mut state, (!lost).then_some(target), speed_limit);
                    let row = live_row(
                        &envelope,
                        from,
                        state.position_mm * per_mm,
                        state.velocity_mm_s * per_mm,
                        ms,
                    );
                    assert_accepted(&envelope, from, &row);
                    if !lost && state == BallState::at_rest(target) {
                        let counts = (target * per_mm).round().clamp(
                            f64::from(envelope.low_counts),
                            f64::from(envelope.high_counts),
                        );
                        assert_eq!(row.position_counts, counts as i32, "{state:?}");
                        assert_eq!(row.velocity_counts_s, 0);
                    }
                    from = End::of(&row);
                    rows += 1;
                }
            }
            assert_eq!(rows, 45_000);
        }
    }

    #[test]
    fn a_travel_of_no_whole_counts_ends_at_its_last_whole_count() {
        let envelope = Envelope::of(&installation(1, 999.996, 100.0, 2000.0));
        assert_eq!((envelope.low_counts, envelope.high_counts), (0, 99_999));
        // A fader at full asks for 99,999.6 counts: the rows stop at 99,999.
        let row = live_row(&envelope, End::at_rest(99_999), 99_999.6, 0.0, 10);
        assert_eq!((row.position_counts, row.velocity_counts_s), (99_999, 0));
        assert!(!envelope.end_is_safe(End::at_rest(100_000), 10));
        // A moving end is safe only with room for a third of a row's motion.
        assert!(envelope.end_is_safe(
            End {
                position_counts: 10,
                velocity_counts_s: -3000
            },
            10
        ));
        assert!(!envelope.end_is_safe(
            End {
                position_counts: 10,
                velocity_counts_s: -3001
            },
            10
        ));
        assert!(!envelope.end_is_safe(
            End {
                position_counts: 0,
                velocity_counts_s: 1
            },
            10
        ));
    }

    #[test]
    fn show_rows_are_kept_as_rounded_unless_a_cubic_would_leave_the_travel() {
        let installation = installation(3, 1000.0, 100.0, 2000.0);
        let envelope = Envelope::of(&installation);
        let filter = live_filter(&installation);
        let ms = u8::try_from(filter.limits().dt_ms).unwrap();
        // A ball braking into the top from 20 mm, the filter's steps as rows, each
        // rounded on its own (as a show's rows are planned).
        let mut state = BallState::at_rest(20.0);
        let mut exact = Vec::new();
        for _ in 0..100 {
            filter.step(&mut state, Some(0.0), None);
            exact.push((state.position_mm * 100.0, state.velocity_mm_s * 100.0));
        }
        let plain: Vec<Row> = exact
            .iter()
            .map(|&(x, u)| Row {
                position_counts: x.round() as i32,
                velocity_counts_s: u.round() as i32,
                duration_ms: ms,
            })
            .collect();
        let all_inside = |rows: &[Row]| {
            let mut from = End::at_rest(2000);
            rows.iter().all(|row| {
                let inside = envelope.row_inside(from, row);
                from = End::of(row);
                inside
            })
        };
        assert!(
            !all_inside(&plain),
            "rounded on its own, a row dips past the top"
        );
        let mut rows = plain.clone();
        let changed = keep_inside(&envelope, 2000, &mut rows, |index| exact[index]);
        assert_eq!(changed, 1);
        assert!(all_inside(&rows));
        let mut from = End::at_rest(2000);
        for (row, plain) in rows.iter().zip(&plain) {
            assert!(envelope.row_within_limits(from, row), "{from:?} → {row:?}");
            // One count or a few counts/s from where it was.
            assert!((row.position_counts - plain.position_counts).abs() <= 1);
            from = End::of(row);
        }
        assert_eq!(rows.last().map(End::of), Some(End::at_rest(0)));
        // Away from the ends nothing changes.
        let middle: Vec<Row> = plain
            .iter()
            .map(|row| Row {
                position_counts: row.position_counts + 50_000,
                ..*row
            })
            .collect();
        let mut rows = middle.clone();
        let changed = keep_inside(&envelope, 52_000, &mut rows, |index| {
            (exact[index].0 + 50_000.0, exact[index].1)
        });
        assert_eq!((changed, rows), (0, middle));
    }

    /// A show that turns round exactly at the bottom of the travel in the middle of a
    /// row (a take recorded live whose ball braked onto the end and left it at the
    /// same acceleration: one row): rounded on its own, the row's apex can pass the
    /// end; the end before it is moved instead (by less than a count), and the rows
    /// keep the limits.
    #[test]
    fn a_show_turning_round_at_an_end_mid_row_stays_inside() {
        let installation = installation(1, 1000.0, 100.0, 2000.0);
        let envelope = Envelope::of(&installation);
        // 1500 mm/s²: from rest at 94,000 counts down for 200 ms, then up at the
        // same rate, turning round exactly at 100,000 counts 400 ms in, braking from
        // 700 ms on to rest at 86,500 counts at 1000 ms.
        let a = 150_000.0;
        let state = |t_s: f64| {
            if t_s <= 0.2 {
                (94_000.0 + a * t_s * t_s / 2.0, a * t_s)
            } else if t_s <= 0.7 {
                let from_apex = t_s - 0.4;
                (100_000.0 - a * from_apex * from_apex / 2.0, -a * from_apex)
            } else {
                let left = 1.0 - t_s.min(1.0);
                (86_500.0 + a * left * left / 2.0, -a * left)
            }
        };
        let mut dipped = 0;
        for apex_row_ms in 201..=255_u32 {
            let apex_end_ms = 200 + apex_row_ms;
            let ends_ms = [200, apex_end_ms, (apex_end_ms + 700) / 2, 700, 850, 1000];
            let mut exact = Vec::new();
            let mut plain = Vec::new();
            let mut last_ms = 0;
            for &end_ms in &ends_ms {
                let (x, u) = state(f64::from(end_ms) / 1000.0);
                exact.push((x, u));
                plain.push(Row {
                    position_counts: x.round() as i32,
                    velocity_counts_s: u.round() as i32,
                    duration_ms: u8::try_from(end_ms - last_ms).unwrap_or(u8::MAX),
                });
                last_ms = end_ms;
            }
            let mut from = End::at_rest(94_000);
            let mut inside = true;
            for row in &plain {
                inside &= envelope.row_inside(from, row);
                from = End::of(row);
            }
            dipped += usize::from(!inside);
            let mut rows = plain.clone();
            keep_inside(&envelope, 94_000, &mut rows, |index| exact[index]);
            let mut from = End::at_rest(94_000);
            for (row, plain) in rows.iter().zip(&plain) {
                assert!(
                    envelope.row_inside(from, row),
                    "{apex_row_ms}: {from:?} → {row:?}"
                );
                assert!(
                    envelope.row_within_limits(from, row),
                    "{apex_row_ms}: {from:?} → {row:?}"
                );
                assert!((row.position_counts - plain.position_counts).abs() <= 1);
                from = End::of(row);
            }
            assert_eq!(from, End::at_rest(86_500));
        }
        assert!(dipped > 0, "rounded on their own, some rows pass the end");
    }
}
