//! From a show's [`Track`] (PVT rows, evaluated with the one [`crate::motion::Segment`])
//! to what the compiler works on: the ball's position on a fine time grid
//! ([`Samples`], every [`GRID_MS`]) and the candidate keyframes a move may end at
//! ([`candidates`]): the start and the end, every turning point, the two ends of every
//! rest, and a sample at least every [`SAMPLE_EVERY_MS`] in between.

use crate::show::Track;

/// The time grid the show is sampled on, and the deviation measured, ms (coarser for
/// a show so long that it would take more than [`MAX_SAMPLES`]).
pub(crate) const GRID_MS: u64 = 1;

/// The most samples of a show (20 MB): a show longer than 20 minutes is sampled every
/// 2 ms or more.
const MAX_SAMPLES: u64 = 1_200_000;

/// The most candidate keyframes: a drive holds at most 335 moves, and the choice costs
/// memory and time as their square. Beyond, every k-th is kept.
const MAX_CANDIDATES: usize = 1200;

/// Along a long stretch without a turning point, a candidate keyframe at least this
/// often, ms.
pub(crate) const SAMPLE_EVERY_MS: u64 = 1000;

/// Positions closer than this are the same (a rest), mm.
const SAME_MM: f64 = 1e-6;

/// The show's position every [`GRID_MS`], and at its very end.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Samples {
    /// The times, ms: 0, [`GRID_MS`], …, the track's duration.
    pub times_ms: Vec<u64>,
    /// The ball's position at each time, mm below the top.
    pub positions_mm: Vec<f64>,
}

/// Samples `track` on the grid.
pub(crate) fn sample(track: &Track) -> Samples {
    let duration_ms = track.duration_ms();
    let grid_ms = GRID_MS.max(duration_ms.div_ceil(MAX_SAMPLES));
    let count = usize::try_from(duration_ms / grid_ms).unwrap_or(0) + 2;
    let mut times_ms = Vec::with_capacity(count);
    let mut positions_mm = Vec::with_capacity(count);
    let mut rows = track.segments().peekable();
    let mut t_ms = 0;
    loop {
        // The row that holds `t_ms` (a row ends where the next one starts).
        while let Some((start_ms, segment)) = rows.peek() {
            let end_ms = start_ms + (segment.duration_s * 1000.0).round() as u64;
            if end_ms < t_ms || (end_ms == t_ms && t_ms < duration_ms) {
                rows.next();
            } else {
                break;
            }
        }
        let position_mm = match rows.peek() {
            None => track
                .rows
                .last()
                .map_or(track.start_mm, |row| row.position_mm),
            Some((start_ms, segment)) => {
                let tau_s = (t_ms - start_ms) as f64 / 1000.0;
                if tau_s >= segment.duration_s {
                    segment.p1
                } else {
                    segment.position(tau_s)
                }
            }
        };
        times_ms.push(t_ms);
        positions_mm.push(position_mm);
        if t_ms >= duration_ms {
            break;
        }
        t_ms = (t_ms + grid_ms).min(duration_ms);
    }
    Samples {
        times_ms,
        positions_mm,
    }
}

/// The direction of travel from sample `k` to `k + 1`: −1, 0 (at rest) or 1.
fn direction(positions_mm: &[f64], k: usize) -> i8 {
    let step = positions_mm[k + 1] - positions_mm[k];
    if step > SAME_MM {
        1
    } else if step < -SAME_MM {
        -1
    } else {
        0
    }
}

/// The indices (into `samples`) of the candidate keyframes, in order: the first and
/// the last sample, every sample where the direction of travel changes (a turning
/// point, or a rest that starts or ends), and along the way one at least every
/// [`SAMPLE_EVERY_MS`]. Beyond [`MAX_CANDIDATES`], the ones along the way go first,
/// then every k-th of the others is kept.
pub(crate) fn candidates(samples: &Samples) -> Vec<usize> {
    let positions = &samples.positions_mm;
    let last = positions.len().saturating_sub(1);
    // (sample, whether it turns)
    let mut chosen = vec![(0, true)];
    let mut since = 0;
    for k in 1..last {
        let turns = direction(positions, k - 1) != direction(positions, k);
        if turns || samples.times_ms[k] - samples.times_ms[since] >= SAMPLE_EVERY_MS {
            chosen.push((k, turns));
            since = k;
        }
    }
    if last > 0 {
        chosen.push((last, true));
    }
    if chosen.len() > MAX_CANDIDATES {
        chosen.retain(|&(_, turns)| turns);
    }
    let every = chosen.len().div_ceil(MAX_CANDIDATES);
    let end = chosen.len().saturating_sub(1);
    chosen
        .iter()
        .enumerate()
        .filter(|&(index, _)| every <= 1 || index % every == 0 || index == end)
        .map(|(_, &(k, _))| k)
        .collect()
}
