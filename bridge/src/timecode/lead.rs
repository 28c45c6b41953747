//! The lead of a chase's Start estimated from the plan, for the first cue after
//! start-up (before any lead was measured): [`estimate_ms`] — the approach from where
//! the balls are (home first when the player does not know: after start-up, after an
//! e-stop) to where the entry's show is at the time asked for, plus what the family
//! loads before its common start ([`floatball_shared::timecode::lead`]):
//!
//! - UIM2503: the table's preload (the rows the planner preloads of the show cut at
//!   that time) through each gateway's line at its baud rate, and the start's lead
//!   (100 ms); nothing when that entry is armed already (loaded while idle);
//! - MBOX: the settle frames after each move;
//! - MOONS' drives: the approach only (a Q program's upload is not modelled).
//!
//! A locate's lead is estimated the same way from wherever the show under way may
//! have the balls (a locate ends the show without homing: each ball's farthest point
//! of its track from where it must go). The chase corrects them with what the measured
//! leads teach it.

use floatball_shared::plan::Installation;
use floatball_shared::show::{Sampler, Show};
use floatball_shared::timecode::lead::{Motion, row_bytes, table_load_ms};
use floatball_shared::uim2503::plan::{Plan, PlanOptions};
use floatball_shared::uim2503::player::START_LEAD_US;
use floatball_shared::uim2503::pvt::TABLE_ROWS;
use floatball_shared::uim2503::stream;

use crate::config::Family;
use crate::state::AppState;
use crate::store::ShowName;

/// Settle frames a move of the MBOX drive ends with (`floatball_shared::mbox::drive`).
const MBOX_SETTLE_FRAMES: u64 = floatball_shared::mbox::drive::SETTLE_FRAMES;

/// The estimated leads of a Start of playlist entry `entry` (0-based) at show time
/// `time_ms`, and of a locate into it (from wherever the show has the balls, no
/// arming), ms; `None` when the entry or its show is not there.
pub fn estimate_ms(state: &AppState, entry: usize, time_ms: u64) -> Option<(u64, u64)> {
    let playlist = state.playlist().get();
    let name = &playlist.entries.get(entry)?.show;
    let show = state.shows().load(&ShowName::parse(name).ok()?).ok()?;
    let playback = state.playback();
    let installation = playback.installation();
    let armed = state
        .subscribe_status()
        .borrow()
        .armed
        .as_ref()
        .is_some_and(|armed| armed.entry == entry && armed.show == *name);
    let family = match &state.config().family {
        Family::Uim2503 if armed && time_ms == 0 => Load::Nothing,
        Family::Uim2503 => Load::Table,
        Family::Mbox(mbox) => Load::Settle {
            period_ms: mbox.frame_period.as_secs_f64() * 1_000.0,
        },
        Family::Scl(_) => Load::Nothing,
    };
    let locate_family =
        if family == Load::Nothing && matches!(state.config().family, Family::Uim2503) {
            Load::Table
        } else {
            family
        };
    let from = if playback.needs_home() {
        From::Unknown
    } else {
        From::Home
    };
    Some((
        estimate(&installation, &show, time_ms, from, family),
        estimate(
            &installation,
            &show,
            time_ms,
            From::InTheShow,
            locate_family,
        ),
    ))
}

/// Where the balls are when the approach begins.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum From {
    /// At home (after a Home, or the start-up homing).
    Home,
    /// Unknown: the Start homes first.
    Unknown,
    /// Somewhere the show under way has them (a locate).
    InTheShow,
}

/// What a family does between the approach and the start.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Load {
    /// Nothing timed (MOONS' programs; an armed UIM2503 table).
    Nothing,
    /// UIM2503: the table's preload through the lines.
    Table,
    /// MBOX: the settle frames after each move, of this period.
    Settle { period_ms: f64 },
}

fn estimate(installation: &Installation, show: &Show, time_ms: u64, from: From, load: Load) -> u64 {
    // Homing from unknown positions: MBOX boxes cannot say where they are, so their
    // drive gives it the whole travel; UIM2503 units and MOONS' drives move from where
    // they are — somewhere the show took them, at most its farthest from home.
    let home_span_mm = if matches!(load, Load::Settle { .. }) {
        installation.limits.travel_mm
    } else {
        show.tracks
            .iter()
            .flat_map(|track| {
                std::iter::once(track.start_mm).chain(track.rows.iter().map(|row| row.position_mm))
            })
            .map(|mm| (mm - installation.home_mm).abs())
            .fold(0.0, f64::max)
    };
    // MBOX boxes are given each move's time and take it at one speed.
    let accel_mm_s2 = if matches!(load, Load::Settle { .. }) {
        f64::INFINITY
    } else {
        installation.limits.max_accel_mm_s2
    };
    let motion = Motion {
        speed_mm_s: installation.approach_speed_mm_s,
        accel_mm_s2,
        travel_mm: home_span_mm,
        home_mm: installation.home_mm,
    };
    let mut sampler = Sampler::new(show);
    let mut to = vec![0.0f32; sampler.unit_count()];
    sampler.sample(time_ms as f64, &mut to, None);
    let to_mm: Vec<f64> = to.iter().map(|&mm| f64::from(mm)).collect();
    let approach_ms = match from {
        From::Home => motion.approach_ms(Some(&vec![installation.home_mm; to_mm.len()]), &to_mm),
        From::Unknown => motion.approach_ms(None, &to_mm),
        // Each ball from its track's farthest point from where it must go.
        From::InTheShow => {
            let farthest_mm = show
                .tracks
                .iter()
                .zip(&to_mm)
                .map(|(track, to)| {
                    std::iter::once(track.start_mm)
                        .chain(track.rows.iter().map(|row| row.position_mm))
                        .map(|mm| (mm - to).abs())
                        .fold(0.0, f64::max)
                })
                .fold(0.0, f64::max);
            motion.move_ms(farthest_mm)
        }
    };
    let moves = if from == From::Unknown { 2.0 } else { 1.0 };
    let load_ms = match load {
        Load::Nothing => 0.0,
        Load::Settle { period_ms } => moves * MBOX_SETTLE_FRAMES as f64 * period_ms + period_ms,
        Load::Table => table_ms(installation, show, time_ms) + START_LEAD_US as f64 / 1_000.0,
    };
    (approach_ms + load_ms).round() as u64
}

/// Each gateway's preload from `time_ms` through its line, the slowest's, ms: the
/// rows the planner preloads (all of a show that fits the table, a streamed one's
/// chosen depth) of the show cut at that time, as the player would plan it; a show the
/// planner refuses, every unit's first 256 rows.
fn table_ms(installation: &Installation, show: &Show, time_ms: u64) -> f64 {
    let cut = match show.from_time(time_ms, crate::control::run_up_accel_mm_s2(installation)) {
        Some(cut) => cut.show,
        None => return 0.0,
    };
    if let Ok(plan) = Plan::new(&cut, installation, PlanOptions::default()) {
        return table_load_ms(plan.gateways.iter().map(|run| {
            let bytes = stream::rows(&plan, run, 0, run.preload_rows)
                .as_bytes()
                .len();
            (installation.gateways[run.gateway].baud, bytes)
        }));
    }
    full_table_ms(installation, show, time_ms)
}

/// Every unit's first 256 rows from `time_ms` through its gateway's line, the
/// slowest's, ms.
fn full_table_ms(installation: &Installation, show: &Show, time_ms: u64) -> f64 {
    let counts_per_mm = installation.counts_per_mm;
    let gateways = (0..installation.gateways.len()).map(|gateway| {
        let bytes: usize = installation
            .units_on(gateway)
            .filter_map(|unit| show.tracks.get(unit))
            .map(|track| {
                // The rows from the one under way at `time_ms`.
                let mut start_ms = 0u64;
                let rows = track.rows.iter().skip_while(|row| {
                    let end_ms = start_ms + u64::from(row.duration_ms);
                    let before = end_ms <= time_ms;
                    start_ms = end_ms;
                    before
                });
                // `*N;` and each row's QP, QV, QT.
                4 + rows
                    .take(TABLE_ROWS)
                    .enumerate()
                    .map(|(index, row)| {
                        row_bytes(
                            index,
                            (row.position_mm * counts_per_mm).round() as i64,
                            (row.velocity_mm_s * counts_per_mm).round() as i64,
                            row.duration_ms,
                        )
                    })
                    .sum::<usize>()
            })
            .sum();
        (installation.gateways[gateway].baud, bytes)
    });
    table_load_ms(gateways)
}

#[cfg(test)]
mod tests {
    use super::*;
    use floatball_shared::show::demo;

    #[test]
    fn the_estimate_adds_the_approach_and_what_the_family_loads() {
        let mut installation = Installation::demo(1, 3, &[115_200]).unwrap();
        installation.approach_speed_mm_s = 1_000.0;
        let show = demo::wave(1, 3, 600, 100);
        let nothing = estimate(&installation, &show, 0, From::Home, Load::Nothing);
        let homing = estimate(&installation, &show, 0, From::Unknown, Load::Nothing);
        // Unknown positions add a move home from the show's farthest point.
        let farthest_mm = show
            .tracks
            .iter()
            .flat_map(|track| {
                std::iter::once(track.start_mm).chain(track.rows.iter().map(|row| row.position_mm))
            })
            .map(|mm| (mm - installation.home_mm).abs())
            .fold(0.0, f64::max);
        let motion = Motion {
            speed_mm_s: 1_000.0,
            accel_mm_s2: installation.limits.max_accel_mm_s2,
            travel_mm: farthest_mm,
            home_mm: installation.home_mm,
        };
        assert_eq!(homing - nothing, motion.move_ms(farthest_mm).round() as u64);
        // A locate goes from wherever the show has the balls: one move, at most
        // across each ball's track, never a homing.
        let locate = estimate(&installation, &show, 0, From::InTheShow, Load::Nothing);
        assert!(locate < homing, "{locate} vs {homing} ms");
        assert!(locate <= motion.move_ms(farthest_mm * 2.0).round() as u64);
        // MBOX boxes home across the whole travel.
        let settle = Load::Settle { period_ms: 20.0 };
        let mbox_homing = estimate(&installation, &show, 0, From::Unknown, settle);
        let mbox = estimate(&installation, &show, 0, From::Home, settle);
        let travel = (installation.limits.travel_mm / 1_000.0 * 1_000.0).round() as u64;
        assert_eq!(mbox_homing - mbox, travel + 100);
        // A full table of 256 rows of three units at 115200 baud: about 30 bytes a
        // row, 2 to 3 s.
        let full = full_table_ms(&installation, &show, 0);
        assert!((1_900.0..3_200.0).contains(&full), "{full} ms");
        // The planner streams this 60 s show: it preloads less than the table, and
        // the estimate is what it preloads, and the start's 100 ms.
        let plan = Plan::new(&show, &installation, PlanOptions::default()).unwrap();
        let run = &plan.gateways[0];
        assert!(run.preload_rows < 256, "{}", run.preload_rows);
        let bytes = stream::rows(&plan, run, 0, run.preload_rows)
            .as_bytes()
            .len();
        let preload_ms = floatball_shared::line::Line::new(115_200).time_us(bytes) / 1_000;
        let table = estimate(&installation, &show, 0, From::Home, Load::Table) - nothing;
        assert!(
            table.abs_diff(preload_ms + 100) <= 1,
            "{table} vs {preload_ms} + 100 ms"
        );
        // Late in the show fewer rows are left to preload.
        let late = full_table_ms(&installation, &show, 55_000);
        assert!(late < full / 2.0, "{late} ms");
        // From inside the show: the preload of the cut the player plays (run-ups at
        // half the top acceleration, not the default), and the start's 100 ms.
        let cut = show
            .from_time(30_050, crate::control::run_up_accel_mm_s2(&installation))
            .unwrap()
            .show;
        let plan = Plan::new(&cut, &installation, PlanOptions::default()).unwrap();
        let run = &plan.gateways[0];
        let bytes = stream::rows(&plan, run, 0, run.preload_rows)
            .as_bytes()
            .len();
        let preload_ms = floatball_shared::line::Line::new(115_200).time_us(bytes) / 1_000;
        let inside = estimate(&installation, &show, 30_050, From::Home, Load::Table)
            - estimate(&installation, &show, 30_050, From::Home, Load::Nothing);
        assert!(
            inside.abs_diff(preload_ms + 100) <= 1,
            "{inside} vs {preload_ms} + 100 ms"
        );
        // MBOX: the approach at one speed (no ramps), five frames of 20 ms after it,
        // and a period.
        let to_mm = show
            .tracks
            .iter()
            .map(|track| (track.start_mm - installation.home_mm).abs())
            .fold(0.0, f64::max);
        let at_speed = (to_mm / 1_000.0 * 1_000.0).round() as u64;
        assert_eq!(mbox, at_speed + 120);
    }
}
