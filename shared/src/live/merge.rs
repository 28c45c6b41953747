//! The merge of several sources per universe, sans-IO: every decoded `ArtDmx` and
//! sACN data packet goes in with the time it arrived (`now_ms`, a parameter, never read
//! here), and per universe one source's slots come out.
//!
//! The rule (issue 38: "highest sACN priority, then latest takes precedence"):
//! - a source is an Art-Net sender (its IPv4 address) or an sACN source (its CID), per
//!   universe; Art-Net has no priority and counts as sACN's default, 100;
//! - of the live sources of a universe, the one with the highest priority wins; among
//!   equal priorities, the one whose accepted packet arrived last wins (it keeps the
//!   universe until another source of that priority sends), so a backup console
//!   sending the same priority takes over with its first packet;
//! - a source silent for longer than the timeout (E1.31's network data loss, 2.5 s,
//!   unless configured; Art-Net senders alike) drops out, and an sACN source drops out
//!   at once with its first "stream terminated" packet (whose data is not used);
//! - sACN packets out of sequence (E1.31 §6.7.2, [`sacn::sequence_accepts`]), preview
//!   packets and packets whose start code is not 0 are not used; Art-Net's sequence
//!   number is not checked (0 means "not sequenced" and consoles differ);
//! - only the universes given to [`Merge::new`] (the patched ones) are kept, at most
//!   [`MAX_SOURCES`] sources each: memory stays bounded whatever arrives.

use std::collections::BTreeMap;

use super::artnet::ArtDmx;
use super::sacn::{self, DataPacket};

/// Most sources kept per universe; more are refused until one drops out.
pub const MAX_SOURCES: usize = 8;

/// Where slots come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SourceId {
    /// An Art-Net sender, by its IPv4 address.
    ArtNet([u8; 4]),
    /// An sACN source, by its CID.
    Sacn([u8; 16]),
}

/// What became of a packet fed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fed {
    /// Its slots are the source's latest.
    Accepted,
    /// A universe that is not patched: ignored.
    NotPatched,
    /// sACN: out of sequence, dropped.
    OutOfSequence,
    /// sACN: preview data, not for output.
    Preview,
    /// A start code other than 0 (text, RDM, ...): ignored.
    StartCode,
    /// sACN: the source terminated its stream and left the universe.
    Terminated,
    /// The universe already has [`MAX_SOURCES`] live sources.
    TooManySources,
}

#[derive(Debug, Clone)]
struct Source {
    id: SourceId,
    priority: u8,
    sequence: Option<u8>,
    received_ms: u64,
    arrival: u64,
    len: usize,
    slots: [u8; 512],
}

/// The current winner of a universe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Winner<'a> {
    /// Who sends it.
    pub source: SourceId,
    /// Its priority.
    pub priority: u8,
    /// Its slots (as many as it sent, up to 512).
    pub slots: &'a [u8],
}

/// Sources per patched universe and the winner of each.
#[derive(Debug, Clone)]
pub struct Merge {
    universes: BTreeMap<u16, Vec<Source>>,
    timeout_ms: u64,
    arrivals: u64,
}

impl Merge {
    /// A merge keeping `universes` (the patched ones), dropping sources silent for
    /// more than `timeout_ms` ([`sacn::NETWORK_DATA_LOSS_MS`] is E1.31's).
    pub fn new(universes: impl IntoIterator<Item = u16>, timeout_ms: u64) -> Self {
        Self {
            universes: universes
                .into_iter()
                .map(|universe| (universe, Vec::new()))
                .collect(),
            timeout_ms,
            arrivals: 0,
        }
    }

    /// Feeds an `ArtDmx` from `from` (its sender's address), arrived at `now_ms`.
    pub fn artnet(&mut self, from: [u8; 4], dmx: &ArtDmx<'_>, now_ms: u64) -> Fed {
        self.receive(
            SourceId::ArtNet(from),
            dmx.port_address.universe(),
            sacn::DEFAULT_PRIORITY,
            None,
            dmx.data,
            now_ms,
        )
    }

    /// Feeds an sACN data packet arrived at `now_ms`.
    pub fn sacn(&mut self, packet: &DataPacket<'_>, now_ms: u64) -> Fed {
        let source = SourceId::Sacn(packet.cid);
        if packet.options.terminated {
            if let Some(sources) = self.universes.get_mut(&packet.universe) {
                sources.retain(|known| known.id != source);
            }
            return Fed::Terminated;
        }
        if packet.options.preview {
            return Fed::Preview;
        }
        if packet.start_code != 0 {
            return Fed::StartCode;
        }
        self.receive(
            source,
            packet.universe,
            packet.priority,
            Some(packet.sequence),
            packet.data,
            now_ms,
        )
    }

    /// Takes `slots` from `source` for `universe`.
    fn receive(
        &mut self,
        source: SourceId,
        universe: u16,
        priority: u8,
        sequence: Option<u8>,
        slots: &[u8],
        now_ms: u64,
    ) -> Fed {
        let timeout_ms = self.timeout_ms;
        let Some(sources) = self.universes.get_mut(&universe) else {
            return Fed::NotPatched;
        };
        let index = match sources.iter().position(|known| known.id == source) {
            Some(index) => {
                let known = &sources[index];
                let lost = now_ms.saturating_sub(known.received_ms) > timeout_ms;
                if let (Some(last), Some(new), false) = (known.sequence, sequence, lost)
                    && !sacn::sequence_accepts(last, new)
                {
                    return Fed::OutOfSequence;
                }
                index
            }
            None => {
                sources.retain(|known| now_ms.saturating_sub(known.received_ms) <= timeout_ms);
                if sources.len() >= MAX_SOURCES {
                    return Fed::TooManySources;
                }
                sources.push(Source {
                    id: source,
                    priority,
                    sequence,
                    received_ms: now_ms,
                    arrival: 0,
                    len: 0,
                    slots: [0; 512],
                });
                sources.len() - 1
            }
        };
        self.arrivals += 1;
        let known = &mut sources[index];
        let len = slots.len().min(512);
        known.slots[..len].copy_from_slice(&slots[..len]);
        known.len = len;
        known.priority = priority;
        known.sequence = sequence;
        known.received_ms = now_ms;
        known.arrival = self.arrivals;
        Fed::Accepted
    }

    /// Drops the sources silent for longer than the timeout at `now_ms`; returns how
    /// many dropped out.
    pub fn expire(&mut self, now_ms: u64) -> usize {
        let timeout_ms = self.timeout_ms;
        let mut dropped = 0;
        for sources in self.universes.values_mut() {
            let before = sources.len();
            sources.retain(|known| now_ms.saturating_sub(known.received_ms) <= timeout_ms);
            dropped += before - sources.len();
        }
        dropped
    }

    /// The winner of `universe` at `now_ms` (sources silent for longer than the timeout
    /// do not count, whether or not [`Merge::expire`] has run), if any source is live.
    #[must_use]
    pub fn winner(&self, universe: u16, now_ms: u64) -> Option<Winner<'_>> {
        self.universes
            .get(&universe)?
            .iter()
            .filter(|known| now_ms.saturating_sub(known.received_ms) <= self.timeout_ms)
            .max_by_key(|known| (known.priority, known.arrival))
            .map(|known| Winner {
                source: known.id,
                priority: known.priority,
                slots: &known.slots[..known.len],
            })
    }

    /// The winning slots of `universe` at `now_ms`.
    #[must_use]
    pub fn slots(&self, universe: u16, now_ms: u64) -> Option<&[u8]> {
        self.winner(universe, now_ms).map(|winner| winner.slots)
    }

    /// The patched universes, in order.
    pub fn universes(&self) -> impl Iterator<Item = u16> + '_ {
        self.universes.keys().copied()
    }

    /// How many sources `universe` holds (live or not yet expired).
    #[must_use]
    pub fn source_count(&self, universe: u16) -> usize {
        self.universes.get(&universe).map_or(0, Vec::len)
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::artnet::{self, PortAddress};
    use super::super::sacn::{Options, Packet};
    use super::*;

    const A: [u8; 16] = [1; 16];
    const B: [u8; 16] = [2; 16];
    const CONSOLE: [u8; 4] = [10, 0, 0, 5];

    fn sacn_packet(cid: [u8; 16], priority: u8, sequence: u8, data: &[u8]) -> DataPacket<'_> {
        DataPacket {
            cid,
            source_name: b"test",
            priority,
            sync_address: 0,
            sequence,
            options: Options::default(),
            universe: 1,
            start_code: 0,
            data,
        }
    }

    fn artdmx(data: &[u8]) -> ArtDmx<'_> {
        ArtDmx {
            sequence: 0,
            physical: 0,
            port_address: PortAddress::of_universe(1).unwrap(),
            data,
        }
    }

    #[test]
    fn the_highest_priority_wins_then_the_latest() {
        let mut merge = Merge::new([1], sacn::NETWORK_DATA_LOSS_MS);
        assert_eq!(merge.sacn(&sacn_packet(A, 100, 0, &[1]), 0), Fed::Accepted);
        assert_eq!(merge.slots(1, 0), Some(&[1u8][..]));
        assert_eq!(merge.sacn(&sacn_packet(B, 150, 0, &[2]), 10), Fed::Accepted);
        assert_eq!(merge.slots(1, 10), Some(&[2u8][..]));
        // A keeps sending at 100: B still wins on priority.
        assert_eq!(merge.sacn(&sacn_packet(A, 100, 1, &[3]), 20), Fed::Accepted);
        assert_eq!(merge.slots(1, 20), Some(&[2u8][..]));
        // Art-Net counts as 100: equal to A, the latest of the two; below B.
        assert_eq!(merge.artnet(CONSOLE, &artdmx(&[4, 4]), 30), Fed::Accepted);
        assert_eq!(merge.slots(1, 30), Some(&[2u8][..]));
        // B terminates: of A and the Art-Net console (both 100), the latest wins.
        let mut end = sacn_packet(B, 150, 1, &[9]);
        end.options.terminated = true;
        assert_eq!(merge.sacn(&end, 40), Fed::Terminated);
        assert_eq!(merge.source_count(1), 2);
        let winner = merge.winner(1, 40).unwrap();
        assert_eq!(winner.source, SourceId::ArtNet(CONSOLE));
        assert_eq!(winner.slots, &[4, 4]);
        assert_eq!(merge.sacn(&sacn_packet(A, 100, 2, &[5]), 50), Fed::Accepted);
        assert_eq!(merge.slots(1, 50), Some(&[5u8][..]));
    }

    #[test]
    fn silent_sources_drop_out_after_the_timeout() {
        let mut merge = Merge::new([1], 2500);
        merge.sacn(&sacn_packet(A, 200, 0, &[1]), 0);
        merge.sacn(&sacn_packet(B, 50, 0, &[2]), 1000);
        assert_eq!(merge.slots(1, 2500), Some(&[1u8][..]), "2.5 s: still live");
        assert_eq!(
            merge.slots(1, 2501),
            Some(&[2u8][..]),
            "A lost, B takes over"
        );
        assert_eq!(merge.slots(1, 3501), None, "both lost");
        assert_eq!(merge.expire(2501), 1);
        assert_eq!(merge.source_count(1), 1);
        assert_eq!(merge.expire(3501), 1);
        assert_eq!(merge.source_count(1), 0);
        // A source back after a loss starts a new sequence.
        assert_eq!(
            merge.sacn(&sacn_packet(A, 100, 7, &[3]), 10_000),
            Fed::Accepted
        );
        assert_eq!(
            merge.sacn(&sacn_packet(A, 100, 3, &[4]), 12_501),
            Fed::Accepted
        );
    }

    #[test]
    fn out_of_sequence_preview_and_other_start_codes_are_not_used() {
        let mut merge = Merge::new([1], 2500);
        assert_eq!(merge.sacn(&sacn_packet(A, 100, 10, &[1]), 0), Fed::Accepted);
        assert_eq!(
            merge.sacn(&sacn_packet(A, 100, 9, &[2]), 1),
            Fed::OutOfSequence
        );
        assert_eq!(
            merge.sacn(&sacn_packet(A, 100, 10, &[2]), 1),
            Fed::OutOfSequence
        );
        assert_eq!(merge.slots(1, 1), Some(&[1u8][..]));
        assert_eq!(
            merge.sacn(&sacn_packet(A, 100, 246, &[3]), 2),
            Fed::Accepted
        );
        let mut preview = sacn_packet(A, 100, 247, &[4]);
        preview.options.preview = true;
        assert_eq!(merge.sacn(&preview, 3), Fed::Preview);
        let mut text = sacn_packet(A, 100, 248, &[4]);
        text.start_code = 0x17;
        assert_eq!(merge.sacn(&text, 3), Fed::StartCode);
        assert_eq!(merge.slots(1, 3), Some(&[3u8][..]));
        let mut other = sacn_packet(A, 100, 0, &[1]);
        other.universe = 2;
        assert_eq!(merge.sacn(&other, 3), Fed::NotPatched);
        assert_eq!(merge.slots(2, 3), None);
    }

    #[test]
    fn sources_are_bounded_per_universe() {
        let mut merge = Merge::new([1], 2500);
        for i in 0..MAX_SOURCES as u8 {
            assert_eq!(
                merge.artnet([10, 0, 0, i], &artdmx(&[i, 0]), 0),
                Fed::Accepted
            );
        }
        assert_eq!(
            merge.artnet([10, 0, 1, 0], &artdmx(&[9, 0]), 0),
            Fed::TooManySources
        );
        assert_eq!(merge.slots(1, 0), Some(&[MAX_SOURCES as u8 - 1, 0][..]));
        // Once they are lost, a new one gets in.
        assert_eq!(
            merge.artnet([10, 0, 1, 0], &artdmx(&[9, 0]), 2501),
            Fed::Accepted
        );
        assert_eq!(merge.source_count(1), 1);
    }

    #[test]
    fn decoded_packets_go_straight_in() {
        let mut merge = Merge::new([0x124], 2500);
        let bytes = artnet::encode_dmx(1, PortAddress::new(1, 2, 3).unwrap(), &[7, 8]);
        let Ok(artnet::Packet::Dmx(dmx)) = artnet::decode(&bytes) else {
            panic!()
        };
        assert_eq!(merge.artnet(CONSOLE, &dmx, 0), Fed::Accepted);
        assert_eq!(merge.slots(0x124, 0), Some(&[7u8, 8][..]));
        let mut packet = sacn_packet(A, 120, 0, &[1, 2, 3]);
        packet.universe = 0x124;
        let bytes = sacn::encode_data(&packet);
        let Ok(Packet::Data(decoded)) = sacn::decode(&bytes) else {
            panic!()
        };
        assert_eq!(merge.sacn(&decoded, 1), Fed::Accepted);
        assert_eq!(merge.slots(0x124, 1), Some(&[1u8, 2, 3][..]));
        assert_eq!(merge.universes().collect::<Vec<_>>(), [0x124]);
    }
}
