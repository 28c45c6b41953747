//! The document's vectors byte for byte, the refusals, and round trips.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use std::num::NonZeroU32;

use super::*;

/// The bytes of a hex dump as the document writes them (`55 aa 00 …`).
pub(super) fn hex(dump: &str) -> Vec<u8> {
    dump.split_whitespace()
        .map(|pair| u8::from_str_radix(pair, 16).unwrap())
        .collect()
}

/// `wire` decodes to `datagram`, and `datagram` encodes to `wire`.
fn assert_vector(wire: &str, datagram: &Datagram) {
    let wire = hex(wire);
    assert_eq!(
        Datagram::decode(&wire).as_ref(),
        Ok(datagram),
        "decoding {wire:02x?}"
    );
    assert_eq!(datagram.encode(), wire, "encoding {datagram:?}");
    assert_eq!(datagram.encoded_len(), wire.len());
}

/// The document's motion vectors (its section 3): every axis at 50 000 pulses, DO
/// `0x1234`, AO `0x5678 0xABCD`, sequence 1, broadcast; absolute frames with time code
/// 0 (the box's default), relative ones with 100 ms.
pub(super) fn document_motion_frame(mode: TimeMode, axes: AxisCount) -> Datagram {
    Datagram::Motion(MotionFrame {
        mode,
        route: Route::BROADCAST,
        sequence: 1,
        time_code: match mode {
            TimeMode::Absolute => TimeCode::BoxDefault,
            TimeMode::Relative => TimeCode::Ms(NonZeroU32::new(100).unwrap()),
        },
        positions_pulses: AxisPositions::uniform(axes, 50_000),
        digital: DigitalOutputs::from_bits(0x1234),
        analog: [0x5678, 0xABCD],
    })
}

#[test]
fn the_documents_six_motion_vectors() {
    let vectors = [
        (
            TimeMode::Absolute,
            AxisCount::Three,
            "55 aa 00 00 13 01 00 00 ff ff ff ff 00 00 00
             01 00 00 00 00 00 00 c3 50 00 00 c3 50 00 00 c3 50 12 34
             56 78 ab cd",
        ),
        (
            TimeMode::Relative,
            AxisCount::Three,
            "55 aa 00 00 14 01 00 00 ff ff ff ff 00 00 00
             01 00 00 00 64 00 00 c3 50 00 00 c3 50 00 00 c3 50 12 34
             56 78 ab cd",
        ),
        (
            TimeMode::Absolute,
            AxisCount::Six,
            "55 aa 00 00 13 01 00 01 ff ff ff ff 00 00 00
             01 00 00 00 00 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00
             c3 50 00 00 c3 50 00 00 c3 50 12 34 56 78 ab cd",
        ),
        (
            TimeMode::Relative,
            AxisCount::Six,
            "55 aa 00 00 14 01 00 01 ff ff ff ff 00 00 00
             01 00 00 00 64 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00
             c3 50 00 00 c3 50 00 00 c3 50 12 34 56 78 ab cd",
        ),
        (
            TimeMode::Absolute,
            AxisCount::Ten,
            "55 aa 00 00 13 01 00 02 ff ff ff ff 00 00 00
             01 00 00 00 00 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00 c3
             50 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00 c3
             50 00 00 c3 50 12 34 56 78 ab cd",
        ),
        (
            TimeMode::Relative,
            AxisCount::Ten,
            "55 aa 00 00 14 01 00 02 ff ff ff ff 00 00 00
             01 00 00 00 64 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00 c3
             50 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00 c3
             50 00 00 c3 50 12 34 56 78 ab cd",
        ),
    ];
    for (mode, axes, wire) in vectors {
        assert_vector(wire, &document_motion_frame(mode, axes));
    }
}

#[test]
fn the_documents_data_area_example() {
    // Section 2: six axes, absolute, time code 0, every axis at 0.
    let frame = Datagram::Motion(MotionFrame {
        mode: TimeMode::Absolute,
        route: Route::BROADCAST,
        sequence: 1,
        time_code: TimeCode::BoxDefault,
        positions_pulses: AxisPositions::Six([0; 6]),
        digital: DigitalOutputs::from_bits(0x1234),
        analog: [0x5678, 0xABCD],
    });
    assert_vector(
        "55 aa 00 00 13 01 00 01 ff ff ff ff 00 00 00
         01 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00
         00 00 00 00 00 00 00 00 00 00 12 34 56 78 ab cd",
        &frame,
    );
}

#[test]
fn the_documents_register_reads_and_reply() {
    let reads = [
        // DN10…DN1F.
        (
            ReadBank::Dn,
            0x0010,
            16,
            "55 aa 00 00 11 01 00 00 ff ff ff ff 00 10 00 10",
        ),
        // FN001, FN002.
        (
            ReadBank::Fn,
            0x0001,
            2,
            "55 aa 00 00 11 01 00 01 ff ff ff ff 00 01 00 02",
        ),
    ];
    for (bank, start, count, wire) in reads {
        let range = RegisterRange::new(start, count).unwrap();
        let read = RegisterRead {
            bank,
            route: Route::BROADCAST,
            range,
        };
        assert_vector(wire, &Datagram::Read(read));
    }
    // The reply: FN001 = FN002 = 0.
    let reply = RegisterReply {
        bank: ReadBank::Fn,
        route: Route::REPLY,
        block: RegisterBlock::new(0x0001, vec![0, 0]).unwrap(),
    };
    assert_eq!(reply.block.get(0x0002), Some(0));
    assert_eq!(reply.block.get(0x0003), None);
    assert_vector(
        "55 aa 00 00 11 02 00 01 00 00 00 00 00 01 00 02 00 00 00 00",
        &Datagram::ReadReply(reply),
    );
}

#[test]
fn the_documents_register_writes_are_the_named_operations() {
    let vectors = [
        // FN020…FN023 = 192.168.15.201, saved.
        (
            RegisterWrite::set_ip(Route::BROADCAST, FACTORY_IP),
            "55 aa 00 00 12 01 00 01 ff ff ff ff 00 20 00 04 00 c0 00 a8 00 0f 00 c9",
        ),
        (
            RegisterWrite::estop(Route::BROADCAST),
            "55 aa 00 00 12 01 00 00 ff ff ff ff 00 90 00 01 00 01",
        ),
        (
            RegisterWrite::release_estop(Route::BROADCAST),
            "55 aa 00 00 12 01 00 00 ff ff ff ff 00 90 00 01 00 00",
        ),
        (
            RegisterWrite::reset(Route::BROADCAST),
            "55 aa 00 00 12 01 00 02 ff ff ff ff 00 00 00 01 00 00",
        ),
        (
            RegisterWrite::effects(Route::BROADCAST, 0xFFFF),
            "55 aa 00 00 12 01 00 02 ff ff ff ff 00 01 00 01 ff ff",
        ),
    ];
    for (write, wire) in vectors {
        assert_vector(wire, &Datagram::Write(write));
    }
}

#[test]
fn the_documents_examples_of_fields() {
    // 192.168.15.201 → 0x0FC9; a replier of 0x0510 is 192.168.5.16.
    assert_eq!(BoxAddress::of_ip(FACTORY_IP), BoxAddress(0x0FC9));
    assert_eq!(BoxAddress::from_octets(5, 16), BoxAddress(0x0510));
    assert_eq!(BoxAddress(0x0510).octets(), [5, 16]);
    // Outputs 1, 3 and 4 → 0x000D.
    let outputs = [1, 3, 4]
        .into_iter()
        .try_fold(DigitalOutputs::NONE, |outputs, n| {
            outputs.with_output(n, true)
        })
        .unwrap();
    assert_eq!(outputs.bits(), 0x000D);
    assert!(outputs.is_on(3) && !outputs.is_on(2) && !outputs.is_on(13));
    assert_eq!(outputs.with_output(3, false).unwrap().bits(), 0x0009);
    assert_eq!(
        DigitalOutputs::ALL.with_output(13, true),
        Err(OutputError { output: 13 })
    );
    assert_eq!(DigitalOutputs::from_bits(0x1234).reserved_bits(), 0x1000);
    // 0 ms is the box's default, never a time.
    assert_eq!(TimeCode::from_ms(0), TimeCode::BoxDefault);
    assert_eq!(TimeCode::BoxDefault.wire_ms(), 0);
    assert_eq!(TimeCode::from_ms(100).wire_ms(), 100);
    // Frame lengths.
    let lens = AxisCount::ALL.map(AxisCount::frame_len);
    assert_eq!(lens, [38, 50, 66]);
    assert_eq!(
        AxisPositions::from_slice(&[1, 2, 3, 4]),
        Err(PositionsError { axes: 4 })
    );
    assert_eq!(
        AxisPositions::from_slice(&[-1; 6]).map(|p| p.axes()),
        Ok(AxisCount::Six)
    );
}

/// The e-stop datagram with `edit` applied.
fn estop_with(edit: impl FnOnce(&mut Vec<u8>)) -> Result<Datagram, DecodeError> {
    let mut wire = RegisterWrite::estop(Route::BROADCAST).encode();
    edit(&mut wire);
    Datagram::decode(&wire)
}

#[test]
fn malformed_datagrams_are_refused_with_what_is_wrong() {
    assert_eq!(
        estop_with(|w| w[0] = 0xAA),
        Err(DecodeError::BadMagic { found: 0xAAAA })
    );
    assert_eq!(
        estop_with(|w| w[3] = 1),
        Err(DecodeError::BadPassCode { found: 0x0001 })
    );
    assert_eq!(
        estop_with(|w| w[5] = 0x02),
        Err(DecodeError::UnknownFunction { code: 0x1202 })
    );
    assert_eq!(
        estop_with(|w| w[7] = 3),
        Err(DecodeError::UnknownChannel {
            function: Function::Write,
            channel: 3
        })
    );
    // A read takes DN or FN only.
    assert_eq!(
        estop_with(|w| {
            w[4] = 0x11;
            w[7] = 2;
        }),
        Err(DecodeError::UnknownChannel {
            function: Function::Read,
            channel: 2
        })
    );
    // A read carries no values.
    assert_eq!(
        estop_with(|w| w[4] = 0x11),
        Err(DecodeError::RegisterLength {
            function: Function::Read,
            count: 1,
            len: 18,
            expected: 16
        })
    );
    // A count of 2 with one value.
    assert_eq!(
        estop_with(|w| w[15] = 2),
        Err(DecodeError::RegisterLength {
            function: Function::Write,
            count: 2,
            len: 18,
            expected: 20
        })
    );
    assert_eq!(
        estop_with(|w| w[15] = 0),
        Err(DecodeError::Registers {
            function: Function::Write,
            source: RangeError::Empty
        })
    );
    assert_eq!(
        estop_with(|w| {
            w[12] = 0xFF;
            w[13] = 0xFF;
            w[15] = 2;
            w.extend([0, 0]);
        }),
        Err(DecodeError::Registers {
            function: Function::Write,
            source: RangeError::PastEnd {
                start: 0xFFFF,
                count: 2
            }
        })
    );
    // A 6-axis channel on a 3-axis frame's bytes, and motion channel 3.
    let mut wire = document_motion_frame(TimeMode::Relative, AxisCount::Three).encode();
    wire[7] = 1;
    assert_eq!(
        Datagram::decode(&wire),
        Err(DecodeError::MotionLength {
            axes: 6,
            channel: 1,
            len: 38,
            expected: 50
        })
    );
    wire[7] = 3;
    assert_eq!(
        Datagram::decode(&wire),
        Err(DecodeError::UnknownChannel {
            function: Function::MotionRelative,
            channel: 3
        })
    );
}

#[test]
fn every_cut_or_extended_datagram_is_refused() {
    let datagrams = [
        document_motion_frame(TimeMode::Absolute, AxisCount::Ten),
        Datagram::Write(RegisterWrite::set_ip(Route::BROADCAST, FACTORY_IP)),
        Datagram::Read(RegisterRead {
            bank: ReadBank::Dn,
            route: Route::BROADCAST,
            range: RegisterRange::new(0x10, 16).unwrap(),
        }),
    ];
    for datagram in datagrams {
        let mut wire = datagram.encode();
        for len in 0..wire.len() {
            let error = Datagram::decode(&wire[..len]).unwrap_err();
            if len < COMMON_HEADER_LEN {
                assert!(
                    matches!(error, DecodeError::Truncated { .. }),
                    "{len}: {error}"
                );
            }
            assert!(!error.to_string().is_empty());
        }
        wire.push(0);
        assert!(Datagram::decode(&wire).is_err());
    }
}

#[test]
fn errors_read_as_sentences_an_engineer_can_act_on() {
    let error = DecodeError::UnknownChannel {
        function: Function::MotionAbsolute,
        channel: 7,
    };
    assert_eq!(
        error.to_string(),
        "absolute-time motion frame (0x1301) with channel 0x0007: it takes channel 0 (3 axes), 1 (6 axes) or 2 (10 axes)"
    );
    let error = estop_with(|w| w[15] = 0).unwrap_err();
    assert_eq!(
        error.to_string(),
        "register write (0x1201): no registers: a read or write covers at least one"
    );
}

#[test]
fn register_ranges_stay_inside_the_address_space_and_one_datagram() {
    assert!(RegisterRange::new(0xFFFF, 1).is_ok());
    assert_eq!(
        RegisterRange::new(0xFFFF, 2),
        Err(RangeError::PastEnd {
            start: 0xFFFF,
            count: 2
        })
    );
    assert_eq!(RegisterRange::new(0, 0), Err(RangeError::Empty));
    assert!(RegisterRange::new(0, MAX_REGISTERS).is_ok());
    assert_eq!(
        RegisterBlock::new(0, vec![0; MAX_REGISTERS + 1]),
        Err(RangeError::TooMany {
            count: MAX_REGISTERS + 1
        })
    );
    let largest = RegisterReply {
        bank: ReadBank::Dn,
        route: Route::REPLY,
        block: RegisterBlock::new(0, vec![7; MAX_REGISTERS]).unwrap(),
    };
    assert!(largest.encoded_len() <= 65_507);
    assert_eq!(
        Datagram::decode(&largest.encode()),
        Ok(Datagram::ReadReply(largest))
    );
}

#[cfg(not(target_arch = "wasm32"))]
mod proptests {
    use proptest::prelude::*;

    use super::*;

    fn route() -> impl Strategy<Value = Route> {
        (any::<u16>(), any::<u16>()).prop_map(|(receiver, replier)| Route {
            receiver: BoxAddress(receiver),
            replier: BoxAddress(replier),
        })
    }

    fn block() -> impl Strategy<Value = RegisterBlock> {
        (any::<u16>(), proptest::collection::vec(any::<u16>(), 1..40))
            .prop_filter_map("inside the address space", |(start, values)| {
                RegisterBlock::new(start, values).ok()
            })
    }

    fn read_bank() -> impl Strategy<Value = ReadBank> {
        prop_oneof![Just(ReadBank::Dn), Just(ReadBank::Fn)]
    }

    fn motion() -> impl Strategy<Value = MotionFrame> {
        let positions = prop_oneof![
            any::<[i32; 3]>().prop_map(AxisPositions::Three),
            any::<[i32; 6]>().prop_map(AxisPositions::Six),
            any::<[i32; 10]>().prop_map(AxisPositions::Ten),
        ];
        let mode = prop_oneof![Just(TimeMode::Absolute), Just(TimeMode::Relative)];
        (mode, route(), any::<(u32, u32, u16, [u16; 2])>(), positions).prop_map(
            |(mode, route, (sequence, time_ms, digital, analog), positions_pulses)| MotionFrame {
                mode,
                route,
                sequence,
                time_code: TimeCode::from_ms(time_ms),
                positions_pulses,
                digital: DigitalOutputs::from_bits(digital),
                analog,
            },
        )
    }

    fn datagram() -> impl Strategy<Value = Datagram> {
        let write_bank = prop_oneof![
            Just(WriteBank::FnVolatile),
            Just(WriteBank::FnSaved),
            Just(WriteBank::Cx)
        ];
        prop_oneof![
            motion().prop_map(Datagram::Motion),
            (read_bank(), route(), block()).prop_map(|(bank, route, block)| {
                let range = RegisterRange::new(block.start(), block.values().len()).unwrap();
                Datagram::Read(RegisterRead { bank, route, range })
            }),
            (read_bank(), route(), block()).prop_map(|(bank, route, block)| {
                Datagram::ReadReply(RegisterReply { bank, route, block })
            }),
            (write_bank, route(), block()).prop_map(|(bank, route, block)| {
                Datagram::Write(RegisterWrite { bank, route, block })
            }),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2048))]

        /// decode(encode(d)) == d, at the length announced.
        #[test]
        fn decode_of_encode_is_identity(datagram in datagram()) {
            let wire = datagram.encode();
            prop_assert_eq!(wire.len(), datagram.encoded_len());
            prop_assert_eq!(&wire[..2], [0x55, 0xAA]);
            prop_assert_eq!(be_u16(&wire, 4), Some(datagram.function().code()));
            prop_assert_eq!(Datagram::decode(&wire), Ok(datagram));
        }

        /// Whatever bytes the decoder accepts encode back to exactly those bytes.
        #[test]
        fn what_decodes_encodes_back_to_the_same_bytes(
            function in proptest::sample::select(Function::ALL.to_vec()),
            channel in 0..4_u16,
            tail in proptest::collection::vec(any::<u8>(), 0..80),
        ) {
            let mut wire = vec![0x55, 0xAA, 0, 0];
            wire.extend(function.code().to_be_bytes());
            wire.extend(channel.to_be_bytes());
            wire.extend(tail);
            if let Ok(datagram) = Datagram::decode(&wire) {
                prop_assert_eq!(datagram.encode(), wire);
            }
        }
    }
}
