//! The seed's command lines, the Host Command Reference's examples, the refusals, and
//! round trips.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::*;

/// The seed's example programs, as far as its text gives them (its listings are
/// pictures): feed to length, feed to position, feed to sensor, the two loops, the
/// jump, the call between segments and multitasking.
pub(super) const SEED_PROGRAMS: [&str; 9] = [
    // Feed to length: wait for a falling edge on input 3, then 4 turns at 20 rev/s.
    "WI3F\nAC25\nDE25\nVE20\nDI80000\nFL",
    // Feed to position: the same, wait 1 s, back to absolute 0 at 20 rev/s.
    "WI3F\nVE20\nDI80000\nFP\nWT1\nDI0\nFP",
    // Feed to sensor: 5 rev/s clockwise until input 7 is high, stop 8000 counts later,
    // wait 1 s, back to 0 at 20 rev/s.
    "WI3F\nVE5\nDI8000\nFS7H\nWT1\nVE20\nDI0\nFP",
    // Set position: the encoder's zero, and 2.5 turns of a 2000-count encoder.
    "SP0\nSP5000\nDI32000\nDI-32000\nDI-8000",
    // Looping with QG: move, wait 0.5 s, back to line 1.
    "FL\nWT0.5\nQG1",
    // Looping with QR: register 3 holds 5; repeat from line 2 that many times.
    "RX35\nFL\nWT0.5\nQR32",
    // Jumping: AC 300, DE 450, VE 18.5, 0.25 s between moves; while input 5 is low
    // (active) jump to line 10 and turn counter-clockwise, else fall through to line 7
    // and turn clockwise; then back to line 1.
    "AC300\nDE450\nVE18.5\nWT0.25\nTI5L\nQJT10\nDI20000\nFL\nQG1\nDI-20000\nFL\nQG1",
    // Calling: segment 1 calls segment 2, which toggles Y1 and Y2 and returns.
    "QC2\nSO1L\nWT0.25\nSO2L\nWT0.25\nSO2H\nWT0.25\nSO1H\nQC",
    // Multitasking: the output is set 0.5 s into the move, not after it.
    "MT1\nFL\nWT0.5\nSO1L\nMT0",
];

#[test]
fn the_seed_programs_parse_and_encode_back() {
    for program in SEED_PROGRAMS {
        let requests = parse_script(program).unwrap();
        assert_eq!(requests.len(), program.lines().count(), "{program}");
        let text: Vec<String> = requests.iter().map(ToString::to_string).collect();
        assert_eq!(text.join("\n"), program);
        for request in &requests {
            let wire = request.to_wire();
            assert_eq!(wire.last(), Some(&CR));
            assert_eq!(
                Request::parse(std::str::from_utf8(&wire).unwrap()).as_ref(),
                Ok(request)
            );
        }
    }
}

fn command(line: &str) -> Command {
    Request::parse(line).unwrap().command
}

fn register(c: char) -> Register {
    Register::new(c).unwrap()
}

#[test]
fn commands_carry_their_parameters_typed() {
    assert_eq!(
        command("VE18.5"),
        Command::Velocity {
            rev_s: Decimal::new(185, 1)
        }
    );
    assert_eq!(
        command("WT0.25"),
        Command::WaitTime {
            s: Decimal::new(25, 2).unwrap()
        }
    );
    assert_eq!(
        command("DI-32000"),
        Command::Distance {
            counts: Some(-32_000)
        }
    );
    assert_eq!(
        command("FS7H"),
        Command::FeedToSensor {
            input: IoPoint::new(7).unwrap(),
            condition: InputCondition::High
        }
    );
    assert_eq!(
        command("WI3F"),
        Command::WaitForInput {
            input: IoPoint::new(3).unwrap(),
            condition: InputCondition::Falling
        }
    );
    assert_eq!(
        command("QJT15"),
        Command::QueueJump {
            condition: JumpCondition::True,
            line: QLine::new(15).unwrap()
        }
    );
    assert_eq!(
        command("QR32"),
        Command::QueueRepeat {
            count_register: register('3'),
            line: QLine::new(2).unwrap()
        }
    );
    assert_eq!(
        command("RX35"),
        Command::RegisterLoad {
            register: register('3'),
            value: 5
        }
    );
    assert_eq!(
        command("TR15"),
        Command::TestRegister {
            register: register('1'),
            value: 5
        }
    );
    assert_eq!(
        command("R-D1"),
        Command::RegisterMath {
            op: MathOp::Subtract,
            first: register('D'),
            second: register('1')
        }
    );
    assert_eq!(command("QC"), Command::QueueCall { segment: None });
    assert_eq!(
        command("QX12"),
        Command::QueueExecute {
            segment: Segment::new(12).unwrap()
        }
    );
    assert_eq!(command("MT1"), Command::Multitasking { on: Some(true) });
    assert_eq!(command("SK"), Command::StopKill);
    for op in MathOp::ALL {
        let line = format!("R{}1:", op.symbol());
        let parsed = command(&line);
        assert_eq!(parsed.mnemonic(), &line[..2]);
        assert_eq!(parsed.to_string(), line);
    }
    for mnemonic in Command::MNEMONICS {
        // Every mnemonic is known to the parser (with or without a parameter).
        let error = Request::parse(mnemonic).err();
        assert!(
            !matches!(
                error,
                Some(ParseError {
                    kind: ParseErrorKind::UnknownMnemonic { .. },
                    ..
                })
            ),
            "{mnemonic}: {error:?}"
        );
    }
}

#[test]
fn a_command_without_its_value_is_the_query() {
    for (line, query) in [
        ("VE", Command::Velocity { rev_s: None }),
        ("AC", Command::Acceleration { rev_s2: None }),
        ("DE", Command::Deceleration { rev_s2: None }),
        ("DI", Command::Distance { counts: None }),
        (
            "EG",
            Command::ElectronicGearing {
                steps_per_rev: None,
            },
        ),
        ("SP", Command::SetPosition { counts: None }),
        ("EP", Command::EncoderPosition { counts: None }),
        ("MT", Command::Multitasking { on: None }),
        ("IP", Command::ImmediatePosition),
        ("SC", Command::StatusCode),
        ("AL", Command::AlarmCode),
    ] {
        assert_eq!(command(line), query);
        assert!(query.is_query(), "{line}");
        assert_eq!(
            Request::new(query).to_wire(),
            format!("{line}\r").into_bytes()
        );
    }
    assert!(!command("VE1").is_query());
    assert!(!command("SK").is_query());
}

#[test]
fn addresses_go_before_the_command() {
    let request = Request::parse("1DI8000\r").unwrap();
    assert_eq!(request.address, Address::new('1'));
    assert_eq!(request.command, Command::Distance { counts: Some(8000) });
    assert_eq!(request.to_wire(), b"1DI8000\r");
    for c in Address::CHARACTERS.chars() {
        let line = format!("{c}SK");
        assert_eq!(Request::parse(&line).unwrap().to_string(), line);
    }
    for c in ['A', 'z', '%', '*', '?', '!', '@', '~', ' '] {
        assert_eq!(Address::new(c), None, "{c:?}");
    }
}

/// `text` is refused at `line`:`column` with an error whose kind `is`.
fn refused(text: &str, line: u32, column: u32, is: fn(&ParseErrorKind) -> bool) {
    let error = parse_script(text).unwrap_err();
    assert_eq!(
        (error.line, error.column),
        (line, column),
        "{text:?}: {error}"
    );
    assert!(is(&error.kind), "{text:?}: {error}");
    assert!(!error.to_string().is_empty());
}

#[test]
fn bad_lines_are_refused_with_line_and_column() {
    use ParseErrorKind as K;
    refused("VE-1", 1, 3, |k| matches!(k, K::OutOfRange { .. }));
    refused("XX5", 1, 1, |k| matches!(k, K::UnknownMnemonic { .. }));
    refused("di100", 1, 1, |k| matches!(k, K::BadAddress { .. }));
    refused("FS7X", 1, 4, |k| matches!(k, K::BadParameter { .. }));
    refused("FS", 1, 3, |k| matches!(k, K::MissingParameter { .. }));
    refused("QG63", 1, 3, |k| matches!(k, K::OutOfRange { .. }));
    refused("QG0", 1, 3, |k| matches!(k, K::OutOfRange { .. }));
    refused("QX13", 1, 3, |k| matches!(k, K::OutOfRange { .. }));
    refused("DI007", 1, 3, |k| matches!(k, K::BadParameter { .. }));
    refused("DI+7", 1, 3, |k| matches!(k, K::BadParameter { .. }));
    refused("DI-0", 1, 3, |k| matches!(k, K::BadParameter { .. }));
    refused("DI1.5", 1, 3, |k| matches!(k, K::BadParameter { .. }));
    refused("DI2147483648", 1, 3, |k| matches!(k, K::OutOfRange { .. }));
    refused("VE.5", 1, 3, |k| matches!(k, K::BadParameter { .. }));
    refused("VE5.", 1, 3, |k| matches!(k, K::BadParameter { .. }));
    refused("WT", 1, 3, |k| matches!(k, K::MissingParameter { .. }));
    refused("FL5", 1, 3, |k| matches!(k, K::Trailing { .. }));
    refused("MT2", 1, 3, |k| matches!(k, K::BadParameter { .. }));
    refused("MT10", 1, 4, |k| matches!(k, K::Trailing { .. }));
    refused("R%12", 1, 1, |k| matches!(k, K::UnknownMnemonic { .. }));
    refused("R+1", 1, 4, |k| {
        matches!(k, K::BadParameter { .. } | K::MissingParameter { .. })
    });
    refused("RX{5", 1, 3, |k| matches!(k, K::BadParameter { .. }));
    refused("1", 1, 2, |k| matches!(k, K::MissingMnemonic));
    refused("!FL", 1, 1, |k| matches!(k, K::BadAddress { .. }));
    refused("VE1 0", 1, 3, |k| matches!(k, K::BadParameter { .. }));
    refused("VE２", 1, 3, |k| matches!(k, K::NotAscii { found: '２' }));
    refused("FL\r\nVE1\n\n  \tQGx", 4, 6, |k| {
        matches!(k, K::BadParameter { .. })
    });
    refused("FL\rFP\rF", 3, 1, |k| {
        matches!(k, K::UnknownMnemonic { .. })
    });
}

#[test]
fn answers_are_read_with_their_address() {
    for (text, address, answer) in [
        ("%", None, Answer::Executed),
        ("*", None, Answer::Buffered),
        ("?", None, Answer::Refused { code: None }),
        ("?5", None, Answer::Refused { code: Some(5) }),
        ("1%", Address::new('1'), Answer::Executed),
        ("1*", Address::new('1'), Answer::Buffered),
        ("1?5", Address::new('1'), Answer::Refused { code: Some(5) }),
        (
            "IP=-1200",
            None,
            Answer::Value {
                name: "IP".into(),
                value: "-1200".into(),
            },
        ),
        (
            "3SC=0009",
            Address::new('3'),
            Answer::Value {
                name: "SC".into(),
                value: "0009".into(),
            },
        ),
        (
            "RLh=149",
            None,
            Answer::Value {
                name: "RLh".into(),
                value: "149".into(),
            },
        ),
    ] {
        let reply = Reply::parse(&format!("{text}\r")).unwrap();
        assert_eq!(reply, Reply { address, answer }, "{text}");
        assert_eq!(reply.to_string(), text);
        assert_eq!(reply.to_wire(), format!("{text}\r").into_bytes());
    }
    assert_eq!(
        Reply::parse("IP=-1200").unwrap().answer.value_i64(),
        Some(-1200)
    );
    assert_eq!(
        Reply::parse("SC=0009").unwrap().answer.value_hex_u16(),
        Some(9)
    );
    assert_eq!(Reply::parse("%").unwrap().answer.value_i64(), None);
    for bad in [
        "", "&", "IP", "ip=3", "?x", "?05", "1", "I=3", "IP=", "%%", "!%", "VE=1\r\r",
    ] {
        assert!(Reply::parse(bad).is_err(), "{bad:?}");
    }
}

#[test]
fn escl_datagrams_carry_the_header_the_text_and_a_carriage_return() {
    // The Host Command Reference's example: "RV" out, "RV=103" back.
    let reply = Reply::from_escl(&[0, 7, 82, 86, 61, 49, 48, 51, 13]).unwrap();
    assert_eq!(
        reply.answer,
        Answer::Value {
            name: "RV".into(),
            value: "103".into()
        }
    );
    assert_eq!(reply.to_escl(), [0, 7, 82, 86, 61, 49, 48, 51, 13]);
    let request = Request::new(Command::Distance {
        counts: Some(32_000),
    });
    assert_eq!(request.to_escl(), b"\x00\x07DI32000\r");
    assert_eq!(Request::from_escl(b"\x00\x07DI32000\r"), Ok(request));
    assert_eq!(escl::HEADER, [0x00, 0x07]);
    assert_eq!(escl::UDP_PORT, 7775);
    for (bad, expected) in [
        (&b""[..], EsclError::Truncated { len: 0 }),
        (b"\x00", EsclError::Truncated { len: 1 }),
        (b"\x00\x07", EsclError::Truncated { len: 2 }),
        (b"\x00\x08SK\r", EsclError::BadHeader { found: [0, 8] }),
        (b"\x00\x07SK", EsclError::NotOneLine),
        (b"\x00\x07SK\rSK\r", EsclError::NotOneLine),
        (b"\x00\x07 SK\r", EsclError::NotOneLine),
    ] {
        assert_eq!(Request::from_escl(bad), Err(expected), "{bad:?}");
    }
    assert!(matches!(
        Request::from_escl(b"\x00\x07S\xffK\r"),
        Err(EsclError::Text(ParseError {
            column: 2,
            kind: ParseErrorKind::NotAscii { .. },
            ..
        }))
    ));
}

#[test]
fn queue_load_and_upload_name_a_segment_and_upload_zero_is_the_queue() {
    // HCR p. 216: `QL` alone loads from the host; `QL3` from segment 3.
    assert_eq!(command("QL"), Command::QueueLoad { segment: None });
    assert_eq!(
        command("QL3"),
        Command::QueueLoad {
            segment: Segment::new(3)
        }
    );
    assert_eq!(command("QU0"), Command::QueueUpload { segment: None });
    assert_eq!(
        command("QU12"),
        Command::QueueUpload {
            segment: Segment::new(12).unwrap().into()
        }
    );
    for line in [
        "QL", "QL12", "QU0", "QU1", "QU12", "1QL", "=QU0", "1QS2", "QE",
    ] {
        assert_eq!(Request::parse(line).unwrap().to_string(), line);
    }
    assert!(!command("QU0").is_query());
    use ParseErrorKind as K;
    // `QW` is no MOONS' command (HCR: none such): unknown.
    refused("QW1", 1, 1, |k| matches!(k, K::UnknownMnemonic { .. }));
    refused("QL0", 1, 3, |k| matches!(k, K::OutOfRange { .. }));
    refused("QL13", 1, 3, |k| matches!(k, K::OutOfRange { .. }));
    refused("QU13", 1, 3, |k| matches!(k, K::OutOfRange { .. }));
    refused("QU", 1, 3, |k| matches!(k, K::MissingParameter { .. }));
    refused("QU00", 1, 3, |k| matches!(k, K::BadParameter { .. }));
    refused("QU-1", 1, 3, |k| matches!(k, K::OutOfRange { .. }));
}

#[test]
fn a_queue_upload_is_a_header_with_lines_plus_one_then_the_lines() {
    // HCR p. 172: "QU##" where ## = the number of lines in the segment + 1.
    let program = parse_script("WI3F\nVE20\nDI80000\nFL").unwrap();
    let upload = QueueUpload::Lines(program.iter().map(|r| r.command).collect());
    assert_eq!(upload.lines(), ["QU5", "WI3F", "VE20", "DI80000", "FL"]);
    assert_eq!(upload.to_wire(None), b"QU5\rWI3F\rVE20\rDI80000\rFL\r");
    assert_eq!(
        upload.to_wire(Address::new('2')),
        b"2QU5\r2WI3F\r2VE20\r2DI80000\r2FL\r"
    );
    assert_eq!(
        QueueUpload::parse(&["2QU5\r", "2WI3F", "2VE20", "2DI80000", "2FL\r"]),
        Ok((Address::new('2'), upload.clone()))
    );
    assert_eq!(
        QueueUpload::parse_header("QU5\r"),
        Ok((None, UploadHeader::Lines(4)))
    );
    assert_eq!(
        QueueUpload::parse(&["QU1"]),
        Ok((None, QueueUpload::Lines(Vec::new())))
    );
    for (text, refusal) in [
        ("QU0", QueueUpload::NoSegment),
        ("QU-1", QueueUpload::ProgramRunning),
        ("QU-2", QueueUpload::UploadInProgress),
        ("QU-3", QueueUpload::PasswordProtected),
    ] {
        assert_eq!(
            QueueUpload::parse_header(text),
            Ok((None, UploadHeader::Nothing))
        );
        assert_eq!(QueueUpload::parse(&[text]), Ok((None, refusal.clone())));
        assert_eq!(refusal.lines(), [text]);
    }
    use ParseErrorKind as K;
    for (lines, line, is) in [
        (
            &["QU-4"][..],
            1,
            (|k| matches!(k, K::OutOfRange { .. })) as fn(&K) -> bool,
        ),
        (&["QU64"], 1, |k| matches!(k, K::OutOfRange { .. })),
        (&["QV3"], 1, |k| matches!(k, K::BadAnswer)),
        (&[], 1, |k| matches!(k, K::BadAnswer)),
        (&["QU3", "FL"], 3, |k| {
            matches!(
                k,
                K::UploadLength {
                    announced: 2,
                    found: 1
                }
            )
        }),
        (&["QU2", "FL", "FP"], 3, |k| {
            matches!(k, K::UploadLength { .. })
        }),
        (&["QU0", "FL"], 2, |k| matches!(k, K::UploadLength { .. })),
        (&["1QU2", "2FL"], 2, |k| matches!(k, K::BadAnswer)),
        (&["QU2", "XX"], 2, |k| {
            matches!(k, K::UnknownMnemonic { .. })
        }),
    ] {
        let error = QueueUpload::parse(lines).unwrap_err();
        assert_eq!(error.line, line, "{lines:?}: {error}");
        assert!(is(&error.kind), "{lines:?}: {error}");
    }
}

#[test]
fn decimals_print_as_scl_writes_them() {
    for (mantissa, scale, text) in [
        (5, 1, "0.5"),
        (-5, 2, "-0.05"),
        (185, 1, "18.5"),
        (200, 1, "20.0"),
        (20, 0, "20"),
        (i64::MAX, 9, "9223372036.854775807"),
    ] {
        let decimal = Decimal::new(mantissa, scale).unwrap();
        assert_eq!(decimal.to_string(), text);
        let line = format!("WT{text}");
        if mantissa >= 0 {
            assert_eq!(command(&line), Command::WaitTime { s: decimal });
        }
    }
    assert_eq!(Decimal::new(1, 10), None);
    assert_eq!(Decimal::new(i64::MIN, 0), None);
    assert!((Decimal::new(185, 1).unwrap().to_f64() - 18.5).abs() < 1e-12);
    assert_eq!(Decimal::from_int(-3).to_string(), "-3");
}

#[cfg(not(target_arch = "wasm32"))]
mod proptests {
    use proptest::prelude::*;

    use super::*;

    fn register() -> impl Strategy<Value = Register> {
        (b'0'..=b'z').prop_filter_map("register", |b| Register::new(char::from(b)))
    }

    fn decimal() -> impl Strategy<Value = Decimal> {
        (0..=i64::MAX, 0..=Decimal::MAX_SCALE)
            .prop_filter_map("decimal", |(m, s)| Decimal::new(m >> (m % 64), s))
    }

    fn point() -> impl Strategy<Value = IoPoint> {
        (0..=9_u8).prop_filter_map("point", IoPoint::new)
    }

    fn q_line() -> impl Strategy<Value = QLine> {
        (1..=62_u8).prop_filter_map("line", QLine::new)
    }

    fn segment() -> impl Strategy<Value = Segment> {
        (1..=12_u8).prop_filter_map("segment", Segment::new)
    }

    fn condition() -> impl Strategy<Value = InputCondition> {
        proptest::sample::select(InputCondition::ALL.to_vec())
    }

    fn level() -> impl Strategy<Value = Level> {
        proptest::sample::select(vec![Level::High, Level::Low])
    }

    fn command() -> impl Strategy<Value = Command> {
        prop_oneof![
            proptest::sample::select(vec![
                Command::FeedToLength,
                Command::FeedToPosition,
                Command::ImmediatePosition,
                Command::QueueExecuteLoaded,
                Command::StopKill,
                Command::Stop,
                Command::WaitOnMove,
                Command::BufferStatus,
                Command::Pause,
                Command::Continue,
                Command::MotorEnable,
                Command::MotorDisable,
                Command::StatusCode,
                Command::AlarmCode,
                Command::AlarmReset,
            ]),
            (point(), condition())
                .prop_map(|(input, condition)| Command::FeedToSensor { input, condition }),
            (point(), condition())
                .prop_map(|(input, condition)| Command::WaitForInput { input, condition }),
            proptest::option::of(any::<i32>()).prop_map(|counts| Command::Distance { counts }),
            proptest::option::of(any::<i32>()).prop_map(|counts| Command::SetPosition { counts }),
            proptest::option::of(any::<i32>())
                .prop_map(|counts| Command::EncoderPosition { counts }),
            proptest::option::of(decimal()).prop_map(|rev_s| Command::Velocity { rev_s }),
            proptest::option::of(decimal()).prop_map(|rev_s2| Command::Acceleration { rev_s2 }),
            proptest::option::of(decimal()).prop_map(|rev_s2| Command::Deceleration { rev_s2 }),
            proptest::option::of(any::<u32>())
                .prop_map(|steps_per_rev| Command::ElectronicGearing { steps_per_rev }),
            decimal().prop_map(|s| Command::WaitTime { s }),
            q_line().prop_map(|line| Command::QueueGoto { line }),
            (register(), q_line()).prop_map(|(count_register, line)| Command::QueueRepeat {
                count_register,
                line
            }),
            (
                proptest::sample::select(JumpCondition::ALL.to_vec()),
                q_line()
            )
                .prop_map(|(condition, line)| Command::QueueJump { condition, line }),
            proptest::option::of(segment()).prop_map(|segment| Command::QueueCall { segment }),
            proptest::option::of(segment()).prop_map(|segment| Command::QueueLoad { segment }),
            segment().prop_map(|segment| Command::QueueSave { segment }),
            segment().prop_map(|segment| Command::QueueExecute { segment }),
            decimal().prop_map(|rev_s| Command::ChangeSpeed { rev_s }),
            proptest::sample::select(vec![StopRate::Decel, StopRate::Max])
                .prop_map(|rate| Command::StopMove { rate }),
            (register(), proptest::option::of(any::<i32>()))
                .prop_map(|(register, value)| Command::RegisterLoadImmediate { register, value }),
            proptest::option::of(segment()).prop_map(|segment| Command::QueueUpload { segment }),
            (point(), level()).prop_map(|(input, level)| Command::TestInput { input, level }),
            (point(), level()).prop_map(|(output, level)| Command::SetOutput { output, level }),
            (register(), any::<i32>())
                .prop_map(|(register, value)| Command::TestRegister { register, value }),
            (register(), any::<i32>())
                .prop_map(|(register, value)| Command::RegisterLoad { register, value }),
            (register(), register())
                .prop_map(|(first, second)| Command::CompareRegisters { first, second }),
            (register(), register()).prop_map(|(destination, source)| Command::RegisterMove {
                destination,
                source
            }),
            (
                proptest::sample::select(MathOp::ALL.to_vec()),
                register(),
                register()
            )
                .prop_map(|(op, first, second)| Command::RegisterMath {
                    op,
                    first,
                    second
                }),
            proptest::option::of(any::<bool>()).prop_map(|on| Command::Multitasking { on }),
        ]
    }

    fn address() -> impl Strategy<Value = Option<Address>> {
        proptest::option::of(
            proptest::sample::select(Address::CHARACTERS.chars().collect::<Vec<_>>())
                .prop_filter_map("address", Address::new),
        )
    }

    fn request() -> impl Strategy<Value = Request> {
        (address(), command()).prop_map(|(address, command)| Request { address, command })
    }

    fn reply() -> impl Strategy<Value = Reply> {
        let answer = prop_oneof![
            Just(Answer::Executed),
            Just(Answer::Buffered),
            proptest::option::of(any::<u16>()).prop_map(|code| Answer::Refused { code }),
            ("[A-Z]{2}[A-Za-z0-9]{0,2}", "[ -~]{1,12}")
                .prop_map(|(name, value)| Answer::Value { name, value }),
        ];
        (address(), answer).prop_map(|(address, answer)| Reply { address, answer })
    }

    proptest! {
        #[test]
        fn every_request_reads_back_from_its_text_and_its_datagram(request in request()) {
            let text = request.to_string();
            prop_assert_eq!(Request::parse(&text), Ok(request));
            let wire = request.to_wire();
            prop_assert_eq!(Request::parse(std::str::from_utf8(&wire).unwrap()), Ok(request));
            prop_assert_eq!(Request::from_escl(&request.to_escl()), Ok(request));
        }

        #[test]
        fn every_reply_reads_back_from_its_text_and_its_datagram(reply in reply()) {
            prop_assert_eq!(Reply::parse(&reply.to_string()), Ok(reply.clone()));
            prop_assert_eq!(Reply::from_escl(&reply.to_escl()), Ok(reply));
        }

        #[test]
        fn a_script_of_requests_reads_back(requests in proptest::collection::vec(request(), 0..20)) {
            let text: Vec<String> = requests.iter().map(ToString::to_string).collect();
            prop_assert_eq!(parse_script(&text.join("\r\n")), Ok(requests));
        }

        #[test]
        fn every_queue_upload_reads_back_from_its_wire_form(
            address in address(),
            commands in proptest::collection::vec(command(), 0..=62),
            refusal in 0..5_u8,
        ) {
            let upload = match refusal {
                1 => QueueUpload::NoSegment,
                2 => QueueUpload::ProgramRunning,
                3 => QueueUpload::UploadInProgress,
                4 => QueueUpload::PasswordProtected,
                _ => QueueUpload::Lines(commands),
            };
            let wire = String::from_utf8(upload.to_wire(address)).unwrap();
            let lines: Vec<&str> = wire.split_inclusive('\r').collect();
            prop_assert_eq!(QueueUpload::parse(&lines), Ok((address, upload)));
        }

        #[test]
        fn any_text_is_read_or_refused_and_what_is_read_prints_back(text in "[ -~\t\r\n²]{0,40}") {
            let line = text.strip_suffix('\r').unwrap_or(&text);
            if let Ok(request) = Request::parse(&text) {
                prop_assert_eq!(request.to_string(), line.trim_matches([' ', '\t']));
            }
            if let Ok(reply) = Reply::parse(&text) {
                prop_assert_eq!(reply.to_string(), line);
            }
            if let Err(error) = parse_script(&text) {
                prop_assert!(error.line >= 1 && error.column >= 1);
            }
        }

        #[test]
        fn any_datagram_is_read_or_refused_and_what_is_read_encodes_back(
            bytes in proptest::collection::vec(any::<u8>(), 0..24),
            plausible in any::<bool>(),
        ) {
            let mut datagram = if plausible { vec![0, 7] } else { Vec::new() };
            datagram.extend(bytes);
            if let Ok(request) = Request::from_escl(&datagram) {
                prop_assert_eq!(request.to_escl(), datagram.clone());
            }
            if let Ok(reply) = Reply::from_escl(&datagram) {
                prop_assert_eq!(reply.to_escl(), datagram);
            }
        }
    }
}
