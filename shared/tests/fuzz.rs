//! The fuzz targets ([`targets`]) briefly, as part of the test suite: a few seeds each,
//! a few megabytes per target in all. The long runs are
//! `cargo bench -p floatball-shared --bench fuzz -- --bytes 10000000` (or
//! `cargo xtask fuzz`).
#![cfg(not(target_arch = "wasm32"))]

#[path = "fuzz/targets.rs"]
mod targets;

use proptest::prelude::*;

/// Bytes per case: small enough for a debug build, long enough for several roll calls.
const CASE_BYTES: usize = 512 * 1024;

proptest! {
    #![proptest_config(ProptestConfig { cases: 8, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn the_instruction_reader_survives_noise_and_resynchronises(seed in any::<u64>()) {
        targets::reader(seed, CASE_BYTES);
    }

    #[test]
    fn the_simulated_gateway_answers_a_roll_call_after_any_noise(seed in any::<u64>()) {
        targets::gateway(seed, CASE_BYTES);
    }

    #[test]
    fn the_feedback_decoder_survives_noise_and_resynchronises(seed in any::<u64>()) {
        targets::decoder(seed, CASE_BYTES);
    }

    #[test]
    fn the_console_parser_survives_noise(seed in any::<u64>()) {
        targets::console(seed, CASE_BYTES);
    }

    #[test]
    fn the_mbox_decoder_survives_any_datagram(seed in any::<u64>()) {
        targets::mbox(seed, CASE_BYTES);
    }

    #[test]
    fn the_mbox_console_parser_survives_noise_and_prints_back_what_it_accepts(seed in any::<u64>()) {
        targets::mbox_console(seed, CASE_BYTES);
    }

    #[test]
    fn the_scl_parsers_survive_noise_and_print_back_what_they_accept(seed in any::<u64>()) {
        targets::scl(seed, CASE_BYTES);
    }

    #[test]
    fn the_scl_twin_survives_noise_and_answers_its_roll_calls(seed in any::<u64>()) {
        targets::scl_twin(seed, CASE_BYTES / 4);
    }

    #[test]
    fn the_artnet_decoder_survives_any_datagram(seed in any::<u64>()) {
        targets::artnet(seed, CASE_BYTES);
    }

    #[test]
    fn the_sacn_decoder_survives_any_datagram(seed in any::<u64>()) {
        targets::sacn(seed, CASE_BYTES);
    }

    #[test]
    fn the_live_merge_keeps_its_rule_for_any_packets(seed in any::<u64>()) {
        targets::live_merge(seed, CASE_BYTES);
    }
}

/// The Art-Net and sACN targets reach every refusal and acceptance, the merge target
/// every outcome.
#[test]
fn the_live_targets_reach_every_outcome() {
    assert_reaches(
        &targets::artnet(1, CASE_BYTES),
        &[
            "dmx",
            "polls",
            "other op codes",
            "truncated",
            "bad id",
            "old version",
            "bad length",
            "bad net",
        ],
    );
    assert_reaches(
        &targets::sacn(1, CASE_BYTES),
        &[
            "data",
            "discovery",
            "truncated",
            "too long",
            "bad preamble",
            "bad identifier",
            "bad length",
            "bad root vector",
            "bad framing vector",
            "bad dmp",
            "bad count",
            "bad priority",
            "bad universe",
        ],
    );
    assert_reaches(
        &targets::live_merge(1, CASE_BYTES),
        &[
            "accepted",
            "terminated",
            "not patched",
            "out of sequence",
            "preview",
            "start code",
            "refused",
        ],
    );
}

/// The SCL target accepts and refuses scripts, answers and datagrams alike, so that
/// both paths are exercised.
#[test]
fn the_scl_target_reaches_acceptance_and_refusal() {
    assert_reaches(
        &targets::scl(1, CASE_BYTES),
        &[
            "scripts accepted",
            "scripts refused",
            "answers accepted",
            "answers refused",
            "datagrams accepted",
            "datagrams refused",
        ],
    );
}

/// The twin target reaches answers and roll calls.
#[test]
fn the_scl_twin_target_answers_and_rolls_calls() {
    assert_reaches(
        &targets::scl_twin(1, CASE_BYTES / 4),
        &["answer lines", "roll calls"],
    );
}

/// Every kind of gateway (four configurations by seed) at a fixed seed, so that each is
/// always covered.
#[test]
fn every_gateway_kind_answers_its_roll_calls() {
    for seed in 0..4 {
        let report = targets::gateway(seed, CASE_BYTES);
        let roll_calls = report
            .counts
            .iter()
            .find(|(name, _)| *name == "roll calls")
            .map_or(0, |&(_, count)| count);
        assert!(roll_calls > 0, "seed {seed}: {report:?}");
    }
}

/// Every kind of refusal and acceptance occurs in the MBOX target's stream.
#[test]
fn the_mbox_target_reaches_every_refusal() {
    assert_reaches(
        &targets::mbox(1, CASE_BYTES),
        &[
            "accepted",
            "truncated",
            "bad magic",
            "bad pass code",
            "unknown function",
            "unknown channel",
            "motion length",
            "register length",
            "register range",
        ],
    );
}

/// The MBOX console target accepts texts and reaches every refusal.
#[test]
fn the_mbox_console_target_reaches_every_refusal() {
    let report = targets::mbox_console(1, CASE_BYTES);
    assert_reaches(&report, &["texts accepted", "operations"]);
    assert_reaches(&report, &targets::CONSOLE_REFUSALS);
}

/// Every one of `kinds` was counted at least once in `report`.
fn assert_reaches(report: &targets::Report, kinds: &[&str]) {
    for kind in kinds {
        assert!(
            report
                .counts
                .iter()
                .any(|&(name, count)| name == *kind && count > 0),
            "{kind}: {report:?}"
        );
    }
}
