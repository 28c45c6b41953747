//! The patch: which DMX slots move which ball.
//!
//! Each ball has a [`Profile`] (its channels, in this order from its start address):
//! - position, 16 bits (coarse, fine), always: 0 = the top, 65535 = the installation's
//!   travel, linear in between;
//! - optionally a speed limit, 8 or 16 bits (`speed_limit_bits`): 0 = standing still,
//!   full = the installation's top speed, linear in between;
//! - optionally an enable channel (`enable`): 128 or more = enabled; a disabled ball
//!   holds (it decelerates to a stop and stays) whatever its position channels say;
//! - optionally a colour (`colour`), red, green and blue, for the preview and the
//!   recording.
//!
//! and a [`PatchEntry`]: universe (1..=63999, numbered as consoles show them: Art-Net
//! Port-Address 0:0:0 is universe 1, [`super::artnet::PortAddress::universe`];
//! Art-Net reaches universes 1..=32768) and start address (1..=512). A [`Patch`] is one
//! default profile and an entry per ball, in the show's row-major order, each entry
//! optionally with its own profile; it is (de)serialised with serde (`floatball.toml`,
//! the app).
//!
//! [`Patch::problems`] lists every [`PatchProblem`] (coded, for the app), and
//! [`Patch::matrix`] patches a whole matrix row by row from one universe and address:
//! balls follow each other, and a ball whose footprint would pass slot 512 starts the
//! next universe at address 1 (a footprint never straddles two universes), so 10,000
//! balls with a 2-channel profile take 40 universes (256 balls each, the last 16).
//! [`Patch::target`] turns a universe's slots into a ball's [`BallTarget`].

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::codes::{Code, Coded, Params};
use crate::params;

/// Slots in a universe.
pub const SLOTS: u16 = 512;
/// Highest universe (sACN's).
pub const MAX_UNIVERSE: u16 = 63999;

/// A ball's channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    /// A speed-limit channel of 8 or 16 bits, or none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_limit_bits: Option<u8>,
    /// An enable channel.
    #[serde(default)]
    pub enable: bool,
    /// Three colour channels (red, green, blue).
    #[serde(default)]
    pub colour: bool,
}

impl Profile {
    /// Channels of the speed limit (0, 1 or 2).
    const fn speed_channels(self) -> u16 {
        match self.speed_limit_bits {
            None => 0,
            Some(16) => 2,
            Some(_) => 1,
        }
    }

    /// How many slots a ball with this profile takes: 2 to 8.
    #[must_use]
    pub const fn footprint(self) -> u16 {
        2 + self.speed_channels() + self.enable as u16 + 3 * self.colour as u16
    }
}

/// Where a ball's channels start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PatchEntry {
    /// Universe, 1..=63999.
    pub universe: u16,
    /// Start address, 1..=512.
    pub address: u16,
    /// This ball's profile, if not the patch's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<Profile>,
}

/// Every ball's channels.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Patch {
    /// The profile of every ball without its own.
    #[serde(default)]
    pub profile: Profile,
    /// One entry per ball, row-major.
    pub balls: Vec<PatchEntry>,
}

/// What is wrong with a patch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum PatchProblem {
    /// The patch has another number of balls than the installation.
    #[error("the patch has {patched} balls, the installation {balls}")]
    BallCount {
        /// Entries in the patch.
        patched: usize,
        /// Balls installed.
        balls: usize,
    },
    /// A universe outside 1..=63999.
    #[error("ball {ball}: universe {universe} is outside 1-63999")]
    Universe {
        /// Row-major index of the ball.
        ball: usize,
        /// The universe.
        universe: u16,
    },
    /// A start address outside 1..=512.
    #[error("ball {ball}: address {address} is outside 1-512")]
    Address {
        /// Row-major index of the ball.
        ball: usize,
        /// The address.
        address: u16,
    },
    /// The ball's channels pass slot 512.
    #[error("ball {ball}: {footprint} channels from address {address} pass slot 512")]
    Footprint {
        /// Row-major index of the ball.
        ball: usize,
        /// The address.
        address: u16,
        /// Its channels.
        footprint: u16,
    },
    /// Two balls share slots.
    #[error(
        "ball {ball} and ball {other} share slots in universe {universe} from address {address}"
    )]
    Overlap {
        /// Row-major index of the ball.
        ball: usize,
        /// The ball it overlaps.
        other: usize,
        /// The universe.
        universe: u16,
        /// The first slot shared.
        address: u16,
    },
    /// A speed-limit channel of neither 8 nor 16 bits.
    #[error("ball {ball}: a speed limit of {bits} bits; 8 or 16 expected")]
    SpeedBits {
        /// Row-major index of the ball.
        ball: usize,
        /// The bits given.
        bits: u8,
    },
}

impl Coded for PatchProblem {
    fn code(&self) -> Code {
        match self {
            Self::BallCount { .. } => Code::PatchBallCount,
            Self::Universe { .. } => Code::PatchUniverse,
            Self::Address { .. } => Code::PatchAddress,
            Self::Footprint { .. } => Code::PatchFootprint,
            Self::Overlap { .. } => Code::PatchOverlap,
            Self::SpeedBits { .. } => Code::PatchSpeedBits,
        }
    }

    fn params(&self) -> Params {
        match *self {
            Self::BallCount { patched, balls } => params! {"patched" => patched, "balls" => balls},
            Self::Universe { ball, universe } => {
                params! {"ball" => ball, "universe" => universe, "max" => MAX_UNIVERSE}
            }
            Self::Address { ball, address } => params! {"ball" => ball, "address" => address},
            Self::Footprint {
                ball,
                address,
                footprint,
            } => params! {"ball" => ball, "address" => address, "footprint" => footprint},
            Self::Overlap {
                ball,
                other,
                universe,
                address,
            } => params! {
                "ball" => ball, "other" => other, "universe" => universe, "address" => address
            },
            Self::SpeedBits { ball, bits } => params! {"ball" => ball, "bits" => bits},
        }
    }
}

/// The installation's scale for DMX values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scale {
    /// Position 65535 is this far below the top, mm.
    pub travel_mm: f64,
    /// A full speed-limit channel is this speed, mm/s.
    pub max_speed_mm_s: f64,
}

/// What a ball's slots ask for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallTarget {
    /// Position, mm below the top, 0..=travel.
    pub position_mm: f64,
    /// Speed limit, mm/s, if the profile has the channel.
    pub speed_limit_mm_s: Option<f64>,
    /// Whether the ball follows (always, without an enable channel).
    pub enabled: bool,
    /// Colour, if the profile has it.
    pub rgb: Option<[u8; 3]>,
}

impl BallTarget {
    /// The motion filter's input: the position when enabled, none (hold) when not.
    #[must_use]
    pub fn filter_input(&self) -> Option<f64> {
        self.enabled.then_some(self.position_mm)
    }
}

impl Patch {
    /// The profile of ball `ball`'s entry.
    #[must_use]
    pub fn profile_of(&self, entry: &PatchEntry) -> Profile {
        entry.profile.unwrap_or(self.profile)
    }

    /// Patches `balls` balls, all with `profile`, row by row from `universe` and
    /// `address`: each ball after the previous one, the next universe from address 1
    /// when a ball would pass slot 512.
    ///
    /// # Errors
    /// The first [`PatchProblem`] of the start, the profile or a universe past 63999.
    pub fn matrix(
        balls: usize,
        profile: Profile,
        universe: u16,
        address: u16,
    ) -> Result<Self, PatchProblem> {
        if let Some(bits) = profile.speed_limit_bits
            && bits != 8
            && bits != 16
        {
            return Err(PatchProblem::SpeedBits { ball: 0, bits });
        }
        let footprint = profile.footprint();
        let (mut universe, mut address) = (universe, address);
        let mut entries = Vec::with_capacity(balls);
        if address == 0 || address > SLOTS {
            return Err(PatchProblem::Address { ball: 0, address });
        }
        for ball in 0..balls {
            if address + footprint - 1 > SLOTS {
                if ball == 0 {
                    return Err(PatchProblem::Footprint {
                        ball,
                        address,
                        footprint,
                    });
                }
                universe = universe.saturating_add(1);
                address = 1;
            }
            if universe == 0 || universe > MAX_UNIVERSE {
                return Err(PatchProblem::Universe { ball, universe });
            }
            entries.push(PatchEntry {
                universe,
                address,
                profile: None,
            });
            address += footprint;
        }
        Ok(Self {
            profile,
            balls: entries,
        })
    }

    /// Every problem of the patch for an installation of `balls` balls: ranges,
    /// footprints, overlaps (each overlapping ball once, with the ball before it).
    #[must_use]
    pub fn problems(&self, balls: usize) -> Vec<PatchProblem> {
        let mut problems = Vec::new();
        if self.balls.len() != balls {
            problems.push(PatchProblem::BallCount {
                patched: self.balls.len(),
                balls,
            });
        }
        // (universe, first slot, last slot, ball) of every entry in range.
        let mut spans: Vec<(u16, u16, u16, usize)> = Vec::with_capacity(self.balls.len());
        for (ball, entry) in self.balls.iter().enumerate() {
            let profile = self.profile_of(entry);
            if let Some(bits) = profile.speed_limit_bits
                && bits != 8
                && bits != 16
            {
                problems.push(PatchProblem::SpeedBits { ball, bits });
            }
            let mut usable = true;
            if entry.universe == 0 || entry.universe > MAX_UNIVERSE {
                problems.push(PatchProblem::Universe {
                    ball,
                    universe: entry.universe,
                });
                usable = false;
            }
            let footprint = profile.footprint();
            if entry.address == 0 || entry.address > SLOTS {
                problems.push(PatchProblem::Address {
                    ball,
                    address: entry.address,
                });
                usable = false;
            } else if entry.address + footprint - 1 > SLOTS {
                problems.push(PatchProblem::Footprint {
                    ball,
                    address: entry.address,
                    footprint,
                });
            }
            if usable {
                let last = (entry.address + footprint - 1).min(SLOTS);
                spans.push((entry.universe, entry.address, last, ball));
            }
        }
        spans.sort_unstable();
        let mut overlaps: Vec<PatchProblem> = Vec::new();
        // The span reaching furthest so far in this universe.
        let mut reach: Option<(u16, u16, usize)> = None;
        for &(universe, first, last, ball) in &spans {
            match reach {
                Some((reach_universe, reach_last, other))
                    if reach_universe == universe && first <= reach_last =>
                {
                    overlaps.push(PatchProblem::Overlap {
                        ball: ball.max(other),
                        other: ball.min(other),
                        universe,
                        address: first,
                    });
                    if last > reach_last {
                        reach = Some((universe, last, ball));
                    }
                }
                _ => reach = Some((universe, last, ball)),
            }
        }
        overlaps.sort_unstable_by_key(|problem| match problem {
            PatchProblem::Overlap { ball, .. } => *ball,
            _ => 0,
        });
        problems.extend(overlaps);
        problems
    }

    /// The universes the patch uses, in order, each once.
    #[must_use]
    pub fn universes(&self) -> Vec<u16> {
        let mut universes: Vec<u16> = self.balls.iter().map(|entry| entry.universe).collect();
        universes.sort_unstable();
        universes.dedup();
        universes
    }

    /// What ball `ball` asks for, given its universe's `slots` (as many as the source
    /// sent); `None` if the ball is not patched or the slots do not reach its
    /// channels.
    #[must_use]
    pub fn target(&self, ball: usize, slots: &[u8], scale: Scale) -> Option<BallTarget> {
        let entry = self.balls.get(ball)?;
        let profile = self.profile_of(entry);
        let first = usize::from(entry.address.checked_sub(1)?);
        let channels = slots.get(first..first + usize::from(profile.footprint()))?;
        let position = u16::from_be_bytes([channels[0], channels[1]]);
        let mut at = 2;
        let speed_limit_mm_s = match profile.speed_limit_bits {
            None => None,
            Some(16) => {
                at += 2;
                let value = u16::from_be_bytes([channels[2], channels[3]]);
                Some(f64::from(value) / 65535.0 * scale.max_speed_mm_s)
            }
            Some(_) => {
                at += 1;
                Some(f64::from(channels[2]) / 255.0 * scale.max_speed_mm_s)
            }
        };
        let enabled = if profile.enable {
            at += 1;
            channels[at - 1] >= 128
        } else {
            true
        };
        let rgb = profile
            .colour
            .then(|| [channels[at], channels[at + 1], channels[at + 2]]);
        Some(BallTarget {
            position_mm: f64::from(position) / 65535.0 * scale.travel_mm,
            speed_limit_mm_s,
            enabled,
            rgb,
        })
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    const SCALE: Scale = Scale {
        travel_mm: 7500.0,
        max_speed_mm_s: 2000.0,
    };

    #[test]
    fn ten_thousand_two_channel_balls_take_forty_universes() {
        let patch = Patch::matrix(10_000, Profile::default(), 1, 1).unwrap();
        assert_eq!(patch.balls.len(), 10_000);
        let universes = patch.universes();
        assert_eq!(universes.len(), 40);
        assert_eq!(universes, (1..=40).collect::<Vec<u16>>());
        assert_eq!(
            patch.balls[255],
            PatchEntry {
                universe: 1,
                address: 511,
                profile: None
            }
        );
        assert_eq!(patch.balls[256].universe, 2);
        assert_eq!(patch.balls[256].address, 1);
        assert_eq!(patch.balls[9999].universe, 40);
        assert_eq!(
            patch.balls[9999].address, 31,
            "the last universe holds 16 balls"
        );
        assert!(patch.problems(10_000).is_empty());
    }

    #[test]
    fn a_footprint_never_straddles_two_universes() {
        // 8 channels from address 100 of universe 3: 51 balls fit (the last at 500..=507),
        // the 52nd starts universe 4.
        let profile = Profile {
            speed_limit_bits: Some(16),
            enable: true,
            colour: true,
        };
        assert_eq!(profile.footprint(), 8);
        let patch = Patch::matrix(60, profile, 3, 100).unwrap();
        assert_eq!(patch.balls[50].universe, 3);
        assert_eq!(patch.balls[50].address, 500);
        assert_eq!(patch.balls[51].universe, 4);
        assert_eq!(patch.balls[51].address, 1);
        assert!(patch.problems(60).is_empty());
        for entry in &patch.balls {
            assert!(entry.address + 7 <= 512);
        }
        assert_eq!(
            Patch::matrix(1, profile, 1, 506),
            Err(PatchProblem::Footprint {
                ball: 0,
                address: 506,
                footprint: 8
            })
        );
        assert_eq!(
            Patch::matrix(300, Profile::default(), MAX_UNIVERSE, 1),
            Err(PatchProblem::Universe {
                ball: 256,
                universe: 64000
            })
        );
        assert_eq!(
            Patch::matrix(1, Profile::default(), 0, 1),
            Err(PatchProblem::Universe {
                ball: 0,
                universe: 0
            })
        );
        assert_eq!(
            Patch::matrix(1, Profile::default(), 1, 0),
            Err(PatchProblem::Address {
                ball: 0,
                address: 0
            })
        );
        let odd = Profile {
            speed_limit_bits: Some(12),
            ..Profile::default()
        };
        assert_eq!(
            Patch::matrix(1, odd, 1, 1),
            Err(PatchProblem::SpeedBits { ball: 0, bits: 12 })
        );
    }

    #[test]
    fn problems_are_found_and_coded() {
        let entry = |universe, address| PatchEntry {
            universe,
            address,
            profile: None,
        };
        let patch = Patch {
            profile: Profile {
                speed_limit_bits: None,
                enable: true,
                colour: false,
            },
            balls: vec![
                entry(1, 1),   // 1..=3
                entry(1, 3),   // overlaps ball 0 at 3
                entry(1, 511), // 511..=513: passes 512
                entry(0, 1),
                entry(2, 513),
                PatchEntry {
                    universe: 2,
                    address: 1,
                    profile: Some(Profile {
                        speed_limit_bits: Some(9),
                        ..Profile::default()
                    }),
                },
                entry(1, 200),
                entry(1, 100), // inside 100..=102, overlapped by ball 8
                entry(1, 101),
            ],
        };
        let problems = patch.problems(10);
        assert_eq!(
            problems,
            [
                PatchProblem::BallCount {
                    patched: 9,
                    balls: 10
                },
                PatchProblem::Footprint {
                    ball: 2,
                    address: 511,
                    footprint: 3
                },
                PatchProblem::Universe {
                    ball: 3,
                    universe: 0
                },
                PatchProblem::Address {
                    ball: 4,
                    address: 513
                },
                PatchProblem::SpeedBits { ball: 5, bits: 9 },
                PatchProblem::Overlap {
                    ball: 1,
                    other: 0,
                    universe: 1,
                    address: 3
                },
                PatchProblem::Overlap {
                    ball: 8,
                    other: 7,
                    universe: 1,
                    address: 101
                },
            ]
        );
        let codes: Vec<&str> = problems.iter().map(|p| p.code().as_str()).collect();
        assert_eq!(
            codes,
            [
                "patch_ball_count",
                "patch_footprint",
                "patch_universe",
                "patch_address",
                "patch_speed_bits",
                "patch_overlap",
                "patch_overlap"
            ]
        );
        for problem in &problems {
            let params = problem.params();
            for name in problem.code().params() {
                assert!(params.contains_key(*name), "{problem:?} lacks {name}");
            }
        }
    }

    #[test]
    fn slots_become_targets() {
        let profile = Profile {
            speed_limit_bits: Some(8),
            enable: true,
            colour: true,
        };
        let patch = Patch::matrix(2, profile, 1, 10).unwrap();
        let mut slots = [0u8; 30];
        slots[9..16].copy_from_slice(&[0xff, 0xff, 255, 200, 1, 2, 3]);
        slots[16..23].copy_from_slice(&[0x80, 0x00, 0, 127, 9, 9, 9]);
        let first = patch.target(0, &slots, SCALE).unwrap();
        assert_eq!(first.position_mm, 7500.0);
        assert_eq!(first.speed_limit_mm_s, Some(2000.0));
        assert!(first.enabled);
        assert_eq!(first.rgb, Some([1, 2, 3]));
        assert_eq!(first.filter_input(), Some(7500.0));
        let second = patch.target(1, &slots, SCALE).unwrap();
        assert!((second.position_mm - 32768.0 / 65535.0 * 7500.0).abs() < 1e-9);
        assert_eq!(second.speed_limit_mm_s, Some(0.0));
        assert!(!second.enabled, "127 is below 128");
        assert_eq!(second.filter_input(), None);
        // Too few slots sent for ball 1: no target.
        assert_eq!(patch.target(1, &slots[..22], SCALE), None);
        assert_eq!(patch.target(2, &slots, SCALE), None);
        // 16-bit speed limit; no enable channel: always enabled.
        let fine = Patch::matrix(
            1,
            Profile {
                speed_limit_bits: Some(16),
                ..Profile::default()
            },
            1,
            1,
        )
        .unwrap();
        let target = fine.target(0, &[0, 0, 0x80, 0x00], SCALE).unwrap();
        assert_eq!(target.position_mm, 0.0);
        assert!((target.speed_limit_mm_s.unwrap() - 32768.0 / 65535.0 * 2000.0).abs() < 1e-9);
        assert!(target.enabled);
        assert_eq!(target.rgb, None);
    }

    #[test]
    fn a_patch_round_trips_through_serde() {
        let mut patch = Patch::matrix(3, Profile::default(), 5, 1).unwrap();
        patch.balls[2].profile = Some(Profile {
            speed_limit_bits: Some(8),
            enable: true,
            colour: false,
        });
        let json = serde_json::to_string(&patch).unwrap();
        assert_eq!(
            json,
            r#"{"profile":{"enable":false,"colour":false},"balls":[{"universe":5,"address":1},{"universe":5,"address":3},{"universe":5,"address":5,"profile":{"speed_limit_bits":8,"enable":true,"colour":false}}]}"#
        );
        assert_eq!(serde_json::from_str::<Patch>(&json).unwrap(), patch);
        let short: Patch =
            serde_json::from_str(r#"{"balls":[{"universe":1,"address":1}]}"#).unwrap();
        assert_eq!(short.profile, Profile::default());
        assert!(serde_json::from_str::<Patch>(r#"{"balls":[],"extra":1}"#).is_err());
    }
}
