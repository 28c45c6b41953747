//! Live input (issue 38): a lighting console or media server moves the balls over
//! Art-Net or sACN, through a motion filter that keeps every installation limit, and
//! the filtered motion can be recorded as a show. Everything here is sans-IO: bytes
//! come in as datagrams, time is a parameter (`now_ms`, the filter's fixed step), so
//! the same code runs in the bridge, in the app and in tests.
//!
//! - [`artnet`]: Art-Net 4's `ArtDmx` and `ArtPoll` decoded, the `ArtPollReply` that
//!   makes consoles discover the bridge;
//! - [`sacn`]: E1.31 data packets decoded (discovery and sync recognised and ignored),
//!   multicast groups, the sequence-number rule;
//! - [`merge`]: several sources per universe: highest priority, then latest; sources
//!   lost or terminated drop out;
//! - [`patch`]: each ball's universe, address and profile (16-bit position, speed
//!   limit, enable, colour); a whole matrix patched in one call; slots → targets;
//! - [`filter`]: the time-optimal motion filter within speed, acceleration and travel,
//!   and the approach to the first live positions;
//! - [`record`]: the filtered motion collected into a show that validates by
//!   construction.
//!
//! The data flow per step: datagrams → [`artnet::decode`] / [`sacn::decode`] →
//! [`merge::Merge`] → [`patch::Patch::target`] per ball → [`filter::MotionFilter::step`]
//! → the drives (and [`record::Recorder`]).

pub mod artnet;
pub mod filter;
pub mod merge;
pub mod patch;
pub mod record;
pub mod sacn;
