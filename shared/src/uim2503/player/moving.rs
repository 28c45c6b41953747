//! The moving phase: point-to-point moves of every ball — the approach to a show's
//! start positions and homing — timed with the [`Trapezoid`] model, then confirmed by
//! asking each unit where it is (`PA;`) until every ball has answered its target.

use super::{Command, Phase, Step, Uim2503Drive};
use crate::line::Line;
use crate::motion::Trapezoid;
use crate::uim2503::ascii::Batch;
use crate::uim2503::plan::Plan;
use crate::uim2503::stream;

/// Time allowed for answers to position queries before asking again, µs (at least;
/// more on a slow line).
const CONFIRM_WAIT_US: u64 = 500_000;

/// When the balls' positions were unknown, the first question comes this soon.
const FIRST_QUERY_UNKNOWN_US: u64 = 300_000;

/// How long after the modelled arrival a ball may still not be there, µs.
const ARRIVAL_GRACE_US: u64 = 10_000_000;

/// Slack added to modelled move times, µs.
const MOVE_MARGIN_US: u64 = 50_000;

impl Uim2503Drive {
    /// Every ball to `plan`'s start; `false` when every ball is there already.
    pub(super) fn begin_approach_move(&mut self, now_us: u64, plan: &Plan) -> bool {
        let targets: Vec<i32> = plan.units.iter().map(|unit| unit.start_counts).collect();
        if self
            .believed
            .iter()
            .zip(&targets)
            .all(|(believed, target)| *believed == Some(*target))
        {
            return false;
        }
        self.begin_move(now_us, targets);
        true
    }

    pub(super) fn begin_home_move(&mut self, now_us: u64) {
        let home = self
            .config
            .installation
            .counts(self.config.installation.home_mm)
            .unwrap_or(0);
        let targets = vec![home; self.config.installation.units.len()];
        self.begin_move(now_us, targets);
    }

    fn begin_move(&mut self, now_us: u64, targets: Vec<i32>) {
        // A move's own questions confirm it from here on.
        self.after_live = None;
        let installation = &self.config.installation;
        let speed = installation
            .counts(installation.approach_speed_mm_s)
            .unwrap_or(1)
            .max(1);
        let accel = (installation.limits.max_accel_mm_s2 * installation.counts_per_mm).max(1.0);
        let travel = installation.limits.travel_mm * installation.counts_per_mm;
        let mut move_s: f64 = 0.0;
        for (believed, &target) in self.believed.iter().zip(&targets) {
            // Unknown positions: assume the farthest end of the travel.
            let from = believed.map_or_else(
                || {
                    if f64::from(target) < travel / 2.0 {
                        travel
                    } else {
                        0.0
                    }
                },
                f64::from,
            );
            let trapezoid = Trapezoid::new(from, 0.0, f64::from(target), f64::from(speed), accel);
            move_s = move_s.max(trapezoid.duration_s());
        }
        let mut line_us = 0u64;
        let runs = self.runs_for_move(&targets);
        for (gateway, line, batch) in runs {
            line_us = line_us.max(line.time_us(batch.len()));
            self.commands.push(Command::Bulk { gateway, batch });
        }
        let arrive_us = now_us + line_us + (move_s * 1e6).ceil() as u64 + MOVE_MARGIN_US;
        // Known positions: ask once the model says they are there. Unknown: ask early
        // and again until every ball answers its target.
        let all_known = self.believed.iter().all(Option::is_some);
        let next_query_us = if all_known {
            arrive_us
        } else {
            now_us + line_us + FIRST_QUERY_UNKNOWN_US
        };
        self.believed
            .iter_mut()
            .for_each(|position| *position = None);
        let unit_count = targets.len();
        self.step = Step::Moving {
            targets,
            began_us: now_us,
            arrive_us,
            next_query_us,
            queried: false,
            confirmed: vec![false; unit_count],
        };
        self.progress = 0.0;
    }

    /// The move batches per gateway, with its line: `SP`, every `PA` (one broadcast
    /// when shared), `BG`.
    fn runs_for_move(&self, targets: &[i32]) -> Vec<(usize, Line, Batch)> {
        let installation = &self.config.installation;
        let speed = installation
            .counts(installation.approach_speed_mm_s)
            .unwrap_or(1)
            .max(1);
        installation
            .gateways
            .iter()
            .enumerate()
            .filter_map(|(gateway, spec)| {
                let stations: Vec<(u8, i32)> = installation
                    .units_on(gateway)
                    .map(|unit| (installation.units[unit].station, targets[unit]))
                    .collect();
                (!stations.is_empty()).then(|| {
                    let line = Line::new(spec.baud);
                    (gateway, line, stream::move_to(speed, &stations))
                })
            })
            .collect()
    }

    /// Where the move stands: over when every ball answered its target, failed when
    /// one is still not there long after the modelled arrival.
    pub(super) fn poll_moving(&mut self, now_us: u64) -> Phase {
        let Step::Moving {
            targets,
            began_us,
            arrive_us,
            next_query_us,
            queried,
            confirmed,
        } = &mut self.step
        else {
            return Phase::Pending;
        };
        let span = arrive_us.saturating_sub(*began_us).max(1);
        self.progress = (now_us.saturating_sub(*began_us) as f64 / span as f64).min(1.0);
        if confirmed.iter().all(|&done| done) {
            let targets = std::mem::take(targets);
            self.believed = targets.into_iter().map(Some).collect();
            self.progress = 1.0;
            self.step = Step::Idle;
            return Phase::Done { at_us: now_us };
        }
        if now_us < *next_query_us {
            return Phase::Pending;
        }
        if now_us > *arrive_us + ARRIVAL_GRACE_US {
            let missing: Vec<usize> = confirmed
                .iter()
                .enumerate()
                .filter(|(_, done)| !**done)
                .map(|(unit, _)| unit)
                .collect();
            let count = missing.len();
            let first = missing
                .first()
                .map(|&unit| self.describe_unit(unit))
                .unwrap_or_default();
            return Phase::Failed(format!(
                "{count} ball(s) did not reach their position, first {first}; the matrix was stopped"
            ));
        }
        *queried = true;
        let confirmed = confirmed.clone();
        let installation = &self.config.installation;
        let mut slowest_us = 0;
        for (gateway, spec) in installation.gateways.iter().enumerate() {
            let stations: Vec<u8> = installation
                .units_on(gateway)
                .filter(|&unit| !confirmed[unit])
                .map(|unit| installation.units[unit].station)
                .collect();
            if !stations.is_empty() {
                let batch = stream::where_are(&stations);
                // Questions and answers both cross the line: leave room for them.
                slowest_us = slowest_us.max(3 * Line::new(spec.baud).time_us(batch.len() * 2));
                self.commands.push(Command::Bulk { gateway, batch });
            }
        }
        if let Step::Moving { next_query_us, .. } = &mut self.step {
            *next_query_us = now_us + CONFIRM_WAIT_US.max(slowest_us);
        }
        Phase::Pending
    }
}
