//! The patch of live input as the Patch page shows and edits it (`GET` / `PUT
//! /api/live/patch`), built on the shared [`Patch`]:
//!
//! - [`whole_matrix`]: "patch the whole matrix from universe U, address N, row by
//!   row" in one tap ([`Patch::matrix`] for the grid's balls);
//! - [`universe_ranges`]: what each universe holds (balls, their first and last, the
//!   slots used) — the summary that stays short at 10,000 balls (40 universes);
//! - [`page_rows`]: one page of the ball table ([`PAGE_ROWS`] balls), never all of
//!   them;
//! - [`with_profile`]: the draft with another default profile.

use floatball_shared::live::patch::{Patch, PatchProblem, Profile};

/// Balls on one page of the ball table.
pub const PAGE_ROWS: usize = 100;

/// The whole grid of `rows` × `cols` balls patched row by row from `universe` and
/// `address`, every ball with `profile`.
///
/// # Errors
/// The first [`PatchProblem`] of the start, the profile, or a universe past 63999.
pub fn whole_matrix(
    rows: u32,
    cols: u32,
    profile: Profile,
    universe: u16,
    address: u16,
) -> Result<Patch, PatchProblem> {
    Patch::matrix(rows as usize * cols as usize, profile, universe, address)
}

/// `patch` with `profile` as its default (the balls with their own keep theirs).
#[must_use]
pub fn with_profile(patch: &Patch, profile: Profile) -> Patch {
    Patch {
        profile,
        balls: patch.balls.clone(),
    }
}

/// What one universe holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UniverseRange {
    /// The universe.
    pub universe: u16,
    /// How many balls start in it.
    pub balls: usize,
    /// The first of them (row-major index).
    pub first_ball: usize,
    /// The last of them.
    pub last_ball: usize,
    /// The lowest start address.
    pub first_slot: u16,
    /// The highest slot a ball's channels reach.
    pub last_slot: u16,
}

/// Every universe the patch uses, in order, with what it holds.
#[must_use]
pub fn universe_ranges(patch: &Patch) -> Vec<UniverseRange> {
    let mut ranges: std::collections::BTreeMap<u16, UniverseRange> =
        std::collections::BTreeMap::new();
    for (ball, entry) in patch.balls.iter().enumerate() {
        let last = entry
            .address
            .saturating_add(patch.profile_of(entry).footprint())
            .saturating_sub(1);
        ranges
            .entry(entry.universe)
            .and_modify(|range| {
                range.balls += 1;
                range.last_ball = ball;
                range.first_slot = range.first_slot.min(entry.address);
                range.last_slot = range.last_slot.max(last);
            })
            .or_insert(UniverseRange {
                universe: entry.universe,
                balls: 1,
                first_ball: ball,
                last_ball: ball,
                first_slot: entry.address,
                last_slot: last,
            });
    }
    ranges.into_values().collect()
}

/// One ball in the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BallRow {
    /// Row-major index.
    pub ball: usize,
    /// Row, from 1.
    pub row: usize,
    /// Column, from 1.
    pub col: usize,
    /// Universe.
    pub universe: u16,
    /// Start address.
    pub address: u16,
    /// Its profile.
    pub profile: Profile,
    /// Whether the profile is its own, not the patch's.
    pub own: bool,
}

/// How many pages the ball table has.
#[must_use]
pub fn pages(patch: &Patch) -> usize {
    patch.balls.len().div_ceil(PAGE_ROWS).max(1)
}

/// Page `page` (from 0) of the ball table of a grid `cols` wide: at most
/// [`PAGE_ROWS`] balls.
#[must_use]
pub fn page_rows(patch: &Patch, cols: u32, page: usize) -> Vec<BallRow> {
    let cols = (cols as usize).max(1);
    patch
        .balls
        .iter()
        .enumerate()
        .skip(page * PAGE_ROWS)
        .take(PAGE_ROWS)
        .map(|(ball, entry)| BallRow {
            ball,
            row: ball / cols + 1,
            col: ball % cols + 1,
            universe: entry.universe,
            address: entry.address,
            profile: patch.profile_of(entry),
            own: entry.profile.is_some(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    #[wasm_bindgen_test(unsupported = test)]
    fn ten_thousand_balls_summarise_as_forty_universes() {
        let patch = whole_matrix(100, 100, Profile::default(), 1, 1).unwrap();
        let ranges = universe_ranges(&patch);
        assert_eq!(ranges.len(), 40);
        assert_eq!(
            ranges[0],
            UniverseRange {
                universe: 1,
                balls: 256,
                first_ball: 0,
                last_ball: 255,
                first_slot: 1,
                last_slot: 512
            }
        );
        assert_eq!(ranges[39].balls, 16);
        assert_eq!(ranges[39].last_slot, 32);
        assert_eq!(pages(&patch), 100);
        let last = page_rows(&patch, 100, 99);
        assert_eq!(last.len(), 100);
        assert_eq!(
            (last[99].row, last[99].col, last[99].ball),
            (100, 100, 9999)
        );
        assert!(page_rows(&patch, 100, 100).is_empty());
    }
}
