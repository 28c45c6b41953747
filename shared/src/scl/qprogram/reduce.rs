//! Choosing the moves: which candidate keyframes the program stops at, so that it fits
//! its lines and deviates from the show as little as possible.
//!
//! Every pair of candidates at most a window apart is an [`Edge`]: a rest-to-rest
//! move (or a wait, when both are at the same count) from the one to the other, with
//! its lines and its **cost**, the largest |show − program| over the edge's time,
//! sampled on the show's grid. A program is a path from the first candidate to the
//! last; its deviation is its costliest edge. [`bottleneck`] finds the smallest
//! deviation any path within the line budget reaches (a binary search over the edge
//! costs; the fewest lines a path under a threshold needs is a shortest path, and it
//! only falls as the threshold rises, so the search is exact for the edges it has);
//! [`refine`] then picks, among the paths under that deviation and within the budget,
//! the one closest to the show over its whole length (least Σ cost × duration), so a
//! show with room to spare keeps all its keyframes.

use super::keyframes::Samples;
use super::moves::{Trapezoid, solve_speed};
use crate::scl::units;

/// What the drive does along an edge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Step {
    /// Stay (`WT`): the two keyframes are at the same count.
    Wait {
        /// `WT` lines: one for every 320 s (the longest `WT`) or part of it.
        lines: usize,
    },
    /// An `FP` move whose cruise speed is `speed_counts_s`; `then_wait` when it is so
    /// slow that a whole step of `VE` could miss its time by more than
    /// [`super::KEEP_SPEED_S`] (or slower than the smallest `VE`): it then runs at the
    /// speed rounded up to a step, which is its `speed_counts_s`, and a `WT` makes up
    /// the difference.
    Move {
        /// The cruise speed, counts/s: exact, or rounded up to a step when it waits.
        speed_counts_s: f64,
        /// Whether a `WT` follows.
        then_wait: bool,
    },
}

/// How the lines of a move are counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Count {
    /// Every move writes its `VE`: what the writer writes at most.
    Surely,
    /// No move writes `VE` (nor `AC`, `DE`): what the writer writes when every move can
    /// keep the speed and acceleration of the one before (a periodic show); the
    /// writer's count must be checked.
    Hopefully,
}

impl Step {
    /// The lines the step writes: `WT` (one or more); or `DI`, `VE` (if `count` says so), `FP`
    /// (and `WT`).
    pub fn lines(self, count: Count) -> usize {
        let speed = usize::from(count == Count::Surely);
        match self {
            Self::Wait { lines } => lines,
            Self::Move { then_wait, .. } => 2 + speed + usize::from(then_wait),
        }
    }
}

/// One possible move, from candidate `from` to candidate `to` (indices into the
/// candidate list).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Edge {
    /// The candidate it starts at.
    pub from: usize,
    /// The candidate it ends at.
    pub to: usize,
    /// What the drive does.
    pub step: Step,
    /// The acceleration it moves at (an index into the accelerations tried).
    pub level: usize,
    /// The largest |show − program| along it, mm.
    pub cost_mm: f64,
}

/// The drive's limits for a trial: one acceleration (`AC` = `DE`) for the program.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Limits {
    /// `AC` and `DE`, counts/s².
    pub accel_counts_s2: f64,
    /// The highest `VE`, counts/s.
    pub max_speed_counts_s: f64,
    /// Counts per revolution (`EG`): the unit of `VE`.
    pub steps_per_rev: f64,
    /// Counts per mm.
    pub counts_per_mm: f64,
}

/// A move is planned to be made this much quicker than its keyframes are apart, s: the
/// compiler's clock may be up to [`super::KEEP_SPEED_S`] late when it writes it.
const CLOCK_SLACK_S: f64 = super::LATE_S + 0.001;

/// A move whose speed (rev/s) is below `duration_s ×` this might have no step of `VE`
/// that ends it within its window ([`super::KEEP_SPEED_S`] early to [`super::LATE_S`]
/// late: one step changes the time by at most `duration × step / speed`; with a tenth
/// to spare): it gets a `WT` after it.
const SLOW_REV_S_PER_S: f64 = units::VELOCITY.step / (0.9 * (super::KEEP_SPEED_S + super::LATE_S));

/// The step from one keyframe to another, or `None` when no move within the limits
/// makes it: `distance_counts` (not negative) in `duration_s`.
pub(crate) fn plan_step(distance_counts: f64, duration_s: f64, limits: &Limits) -> Option<Step> {
    if distance_counts == 0.0 {
        // One `WT` for every longest wait a drive takes (320 s) or part of one.
        let longest_s = units::WAIT.max_steps as f64 * units::WAIT.step;
        let lines = ((duration_s / longest_s).ceil() as usize).max(1);
        return (duration_s >= 0.0).then_some(Step::Wait { lines });
    }
    // Keep time in hand: the move before may have ended up to 5 ms late (`LATE_S`),
    // and the move must still be made in what is left.
    let speed = solve_speed(
        distance_counts,
        duration_s - CLOCK_SLACK_S,
        limits.accel_counts_s2,
    )?;
    if speed > limits.max_speed_counts_s {
        return None;
    }
    let speed = solve_speed(distance_counts, duration_s, limits.accel_counts_s2)?;
    let rev_s = speed / limits.steps_per_rev;
    let then_wait = rev_s < (duration_s * SLOW_REV_S_PER_S).max(units::VELOCITY.step * 2.0);
    if !then_wait {
        return Some(Step::Move {
            speed_counts_s: speed,
            then_wait,
        });
    }
    // As the writer runs it: the speed rounded up to a whole step, at least the
    // smallest `VE`.
    let steps = (rev_s / units::VELOCITY.step - 1e-9)
        .ceil()
        .max(units::VELOCITY.min_steps as f64);
    Some(Step::Move {
        speed_counts_s: steps * units::VELOCITY.step * limits.steps_per_rev,
        then_wait,
    })
}

/// Every edge at most `window` candidates long at the acceleration of `level`, grouped
/// by the candidate they end at (`result[to]`). `counts[i]` is candidate `i`'s position in counts; edges are costed
/// on every `stride`-th grid sample (and the edge's last one).
pub(crate) fn edges(
    samples: &Samples,
    candidates: &[usize],
    counts: &[i64],
    limits: &Limits,
    (level, window): (usize, usize),
    stride: usize,
) -> Vec<Vec<Edge>> {
    let mut incoming = vec![Vec::new(); candidates.len()];
    for to in 1..candidates.len() {
        for from in to.saturating_sub(window)..to {
            let (k0, k1) = (candidates[from], candidates[to]);
            let duration_s = (samples.times_ms[k1] - samples.times_ms[k0]) as f64 / 1000.0;
            let distance = (counts[to] - counts[from]).abs() as f64;
            let Some(step) = plan_step(distance, duration_s, limits) else {
                continue;
            };
            let cost_mm = cost(
                samples,
                (k0, k1),
                (counts[from], counts[to]),
                step,
                limits,
                stride,
            );
            incoming[to].push(Edge {
                from,
                to,
                step,
                level,
                cost_mm,
            });
        }
    }
    incoming
}

/// The largest |show − program| from grid sample `k0` to `k1`, the program moving
/// from `c0` to `c1` counts as `step` says, starting at sample `k0`'s time.
fn cost(
    samples: &Samples,
    (k0, k1): (usize, usize),
    (c0, c1): (i64, i64),
    step: Step,
    limits: &Limits,
    stride: usize,
) -> f64 {
    let from_mm = c0 as f64 / limits.counts_per_mm;
    let sign = if c1 >= c0 { 1.0 } else { -1.0 };
    let trapezoid = match step {
        Step::Wait { .. } => None,
        Step::Move { speed_counts_s, .. } => Some(Trapezoid {
            distance: (c1 - c0).abs() as f64,
            speed: speed_counts_s,
            accel: limits.accel_counts_s2,
            decel: limits.accel_counts_s2,
        }),
    };
    let t0_ms = samples.times_ms[k0];
    let mut worst: f64 = 0.0;
    let mut k = k0;
    loop {
        let program_mm = trapezoid.map_or(from_mm, |trapezoid| {
            let t_s = (samples.times_ms[k] - t0_ms) as f64 / 1000.0;
            from_mm + sign * trapezoid.travelled(t_s) / limits.counts_per_mm
        });
        worst = worst.max((samples.positions_mm[k] - program_mm).abs());
        if k >= k1 {
            break;
        }
        k = (k + stride).min(k1);
    }
    worst
}

/// The fewest lines of a path from candidate 0 to `to` using only edges costing at
/// most `threshold_mm` (`None` where no path reaches).
fn fewest_lines(incoming: &[Vec<Edge>], threshold_mm: f64, count: Count) -> Vec<Option<usize>> {
    let mut lines = vec![None; incoming.len()];
    if let Some(first) = lines.first_mut() {
        *first = Some(0);
    }
    for to in 1..incoming.len() {
        lines[to] = incoming[to]
            .iter()
            .filter(|edge| edge.cost_mm <= threshold_mm)
            .filter_map(|edge| {
                lines[edge.from].map(|before: usize| before + edge.step.lines(count))
            })
            .min();
    }
    lines
}

/// The first candidate that no path reaches at all, if any (the show asks for more
/// than the limits allow there).
pub(crate) fn unreachable(incoming: &[Vec<Edge>]) -> Option<usize> {
    fewest_lines(incoming, f64::INFINITY, Count::Surely)
        .iter()
        .position(Option::is_none)
}

/// The smallest deviation (mm) of a path to the last candidate within `budget_lines`,
/// or `None` when no path fits.
pub(crate) fn bottleneck(incoming: &[Vec<Edge>], budget_lines: usize, count: Count) -> Option<f64> {
    let fits = |threshold: f64| {
        fewest_lines(incoming, threshold, count)
            .last()
            .copied()
            .flatten()
            .is_some_and(|lines| lines <= budget_lines)
    };
    let mut costs: Vec<f64> = incoming.iter().flatten().map(|edge| edge.cost_mm).collect();
    if incoming.len() <= 1 {
        return Some(0.0);
    }
    costs.sort_by(f64::total_cmp);
    costs.dedup();
    // The smallest cost that fits: fits() only turns true as the threshold rises.
    let (mut low, mut high) = (0, costs.len());
    while low < high {
        let middle = low + (high - low) / 2;
        if fits(costs[middle]) {
            high = middle;
        } else {
            low = middle + 1;
        }
    }
    costs.get(low).copied()
}

/// Among the paths whose every edge costs at most `threshold_mm` and that fit
/// `budget_lines`, the one with the least Σ cost × duration (the closest to the show
/// over its length); its edges in order.
pub(crate) fn refine(
    incoming: &[Vec<Edge>],
    samples: &Samples,
    candidates: &[usize],
    threshold_mm: f64,
    budget_lines: usize,
    count: Count,
) -> Option<Vec<Edge>> {
    let nodes = incoming.len();
    if nodes <= 1 {
        return Some(Vec::new());
    }
    let width = budget_lines + 1;
    // best[node * width + lines]: the least score of a path to `node` with exactly
    // `lines` lines, and the edge that ends it.
    let mut best = vec![f64::INFINITY; nodes * width];
    // via[node * width + lines]: which of `incoming[node]` ends that path.
    let mut via = vec![u32::MAX; nodes * width];
    best[0] = 0.0;
    for (to, edges) in incoming.iter().enumerate().skip(1) {
        for (index, edge) in edges.iter().enumerate() {
            if edge.cost_mm > threshold_mm {
                continue;
            }
            let index = u32::try_from(index).unwrap_or(u32::MAX);
            let step_lines = edge.step.lines(count);
            let duration_ms = (samples.times_ms[candidates[edge.to]]
                - samples.times_ms[candidates[edge.from]]) as f64;
            let score = edge.cost_mm * duration_ms;
            for before in 0..width.saturating_sub(step_lines) {
                let start = best[edge.from * width + before];
                if start.is_finite() {
                    let slot = to * width + before + step_lines;
                    if start + score < best[slot] {
                        best[slot] = start + score;
                        via[slot] = index;
                    }
                }
            }
        }
    }
    let last = nodes - 1;
    let (mut lines, _) = (0..width)
        .map(|lines| (lines, best[last * width + lines]))
        .filter(|(_, score)| score.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let mut path = Vec::new();
    let mut node = last;
    while node != 0 {
        let edge = *incoming[node].get(via[node * width + lines] as usize)?;
        path.push(edge);
        lines -= edge.step.lines(count);
        node = edge.from;
    }
    path.reverse();
    Some(path)
}
