//! Every form of the console language, every refusal with its line and column, the
//! canonical text and the replies' text.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::*;
use crate::mbox::Encode;

/// The console's selected box: 192.168.15.201.
const BOX_201: BoxAddress = BoxAddress::from_octets(15, 201);

fn selected() -> Route {
    Route::to(BOX_201)
}

/// The one operation `text` parses to, with the selected box.
fn one(text: &str) -> Operation {
    let operations = parse(text, selected()).unwrap();
    assert_eq!(operations.len(), 1, "{text}: {operations:?}");
    operations.into_iter().next().unwrap()
}

fn read(bank: ReadBank, route: Route, start: u16, count: usize) -> Operation {
    Operation::Read(RegisterRead {
        bank,
        route,
        range: RegisterRange::new(start, count).unwrap(),
    })
}

fn write(bank: WriteBank, route: Route, start: u16, values: &[u16]) -> Operation {
    Operation::Write(RegisterWrite {
        bank,
        route,
        block: RegisterBlock::new(start, values.to_vec()).unwrap(),
    })
}

/// `text` is refused at `line`, `column` with `kind`.
fn refused(text: &str, line: u32, column: u32, kind: ConsoleErrorKind) {
    assert_eq!(
        parse(text, selected()),
        Err(ConsoleError { line, column, kind }),
        "{text:?}"
    );
}

#[test]
fn reads_name_bank_start_and_count() {
    let route = selected();
    assert_eq!(one("read FN 0x20 4"), read(ReadBank::Fn, route, 0x20, 4));
    assert_eq!(one("read DN 0x10 16"), read(ReadBank::Dn, route, 0x10, 16));
    assert_eq!(one("read FN 1 10"), read(ReadBank::Fn, route, 1, 10));
    assert_eq!(one("READ fn 0X1f 0x2"), read(ReadBank::Fn, route, 0x1F, 2));
    assert_eq!(
        one("read DN 0xFFFF 1"),
        read(ReadBank::Dn, route, 0xFFFF, 1)
    );
    // The document's read: DN10…DN1F, every box replies.
    assert_eq!(
        Datagram::from(one("@all read DN 0x10 16")),
        Datagram::Read(RegisterRead {
            bank: ReadBank::Dn,
            route: Route::BROADCAST,
            range: RegisterRange::new(0x10, 16).unwrap(),
        })
    );
}

#[test]
fn writes_and_saves_carry_one_value_a_register() {
    let route = selected();
    assert_eq!(
        one("write FN 0x0090 1"),
        write(WriteBank::FnVolatile, route, 0x90, &[1])
    );
    assert_eq!(
        one("write FN 0x20 192 168 15 201"),
        write(WriteBank::FnVolatile, route, 0x20, &[192, 168, 15, 201])
    );
    assert_eq!(
        one("save FN 0x20 192 168 15 201"),
        write(WriteBank::FnSaved, route, 0x20, &[192, 168, 15, 201])
    );
    assert_eq!(
        one("write CX 1 0xFFFF"),
        Operation::Write(RegisterWrite::effects(route, 0xFFFF))
    );
    assert_eq!(
        one("Write cx 0x0002 65535 0 0x0"),
        write(WriteBank::Cx, route, 2, &[0xFFFF, 0, 0])
    );
    assert_eq!(
        one("write FN 0xFFFF 7"),
        write(WriteBank::FnVolatile, route, 0xFFFF, &[7])
    );
}

#[test]
fn the_named_operations_are_the_codecs() {
    let route = selected();
    assert_eq!(one("estop"), Operation::Write(RegisterWrite::estop(route)));
    assert_eq!(
        one("release"),
        Operation::Write(RegisterWrite::release_estop(route))
    );
    assert_eq!(one("reset"), Operation::Write(RegisterWrite::reset(route)));
    assert_eq!(
        one("effects 0xFFFF"),
        Operation::Write(RegisterWrite::effects(route, 0xFFFF))
    );
    assert_eq!(
        one("EFFECTS 5"),
        Operation::Write(RegisterWrite::effects(route, 5))
    );
    assert_eq!(
        one("ip 192.168.15.210"),
        Operation::Write(RegisterWrite::set_ip(
            route,
            Ipv4Addr::new(192, 168, 15, 210)
        ))
    );
    // The same registers written longhand are the same datagrams.
    assert_eq!(one("write FN 0x90 1"), one("estop"));
    assert_eq!(one("write fn 144 0"), one("release"));
    assert_eq!(one("write CX 0 0"), one("reset"));
    assert_eq!(one("save FN 0x20 192 168 15 210"), one("ip 192.168.15.210"));
}

#[test]
fn a_target_names_the_box_that_executes_and_replies() {
    let estop = |route| Operation::Write(RegisterWrite::estop(route));
    let box_202 = BoxAddress::from_octets(15, 202);
    assert_eq!(one("@202 estop"), estop(Route::to(box_202)));
    assert_eq!(one("@0xCA estop"), estop(Route::to(box_202)));
    assert_eq!(one("@15.202 estop"), estop(Route::to(box_202)));
    assert_eq!(one("@192.168.15.202 estop"), estop(Route::to(box_202)));
    assert_eq!(
        one("@7.1 estop"),
        estop(Route::to(BoxAddress::from_octets(7, 1)))
    );
    assert_eq!(one("@all estop"), estop(Route::BROADCAST));
    assert_eq!(one("@ALL/None estop"), estop(Route::BROADCAST_SILENT));
    assert_eq!(one("@202/none estop"), estop(Route::silent(box_202)));
    assert_eq!(
        one("@all/201 estop"),
        estop(Route {
            receiver: BoxAddress::ALL,
            replier: BOX_201,
        })
    );
    assert_eq!(one("@none estop"), estop(Route::REPLY));
    // The brief's example: the box .201 reads FN001 and FN002.
    assert_eq!(
        one("@201 read FN 1 2"),
        read(ReadBank::Fn, Route::to(BOX_201), 1, 2)
    );
    // Without a target, the route is the caller's, whatever it is.
    assert_eq!(
        parse("reset", Route::BROADCAST_SILENT),
        Ok(vec![Operation::Write(RegisterWrite::reset(
            Route::BROADCAST_SILENT
        ))])
    );
    // Two octets or an IP address need no selected box.
    assert_eq!(
        parse("@15.202 reset", Route::BROADCAST),
        Ok(vec![Operation::Write(RegisterWrite::reset(Route::to(
            box_202
        )))])
    );
}

#[test]
fn a_text_holds_many_commands_and_comments() {
    let route = selected();
    let text = "# commission box .201\n\
                read FN 0x20 4 ; read DN 0x10 16   # both banks\r\n\
                \n\
                ;;  estop;release ;\n\
                \t@all reset # every box; none of this is a command\n\
                effects 0xFFFF";
    assert_eq!(
        parse(text, route),
        Ok(vec![
            read(ReadBank::Fn, route, 0x20, 4),
            read(ReadBank::Dn, route, 0x10, 16),
            Operation::Write(RegisterWrite::estop(route)),
            Operation::Write(RegisterWrite::release_estop(route)),
            Operation::Write(RegisterWrite::reset(Route::BROADCAST)),
            Operation::Write(RegisterWrite::effects(route, 0xFFFF)),
        ])
    );
    assert_eq!(parse("", route), Ok(vec![]));
    assert_eq!(parse(" ; # nothing\n\n", route), Ok(vec![]));
    assert_eq!(parse("estop#now", route).map(|ops| ops.len()), Ok(1));
}

#[test]
fn an_unknown_command_lists_the_known_ones() {
    for (text, line, column, found) in [
        ("stop", 1, 1, "stop"),
        ("estop\n  rd FN 1 1", 2, 3, "rd"),
        ("estop; 0x20", 1, 8, "0x20"),
        ("@all stop", 1, 6, "stop"),
        ("réad FN 1 1", 1, 1, "réad"),
    ] {
        let found = found.to_owned();
        refused(
            text,
            line,
            column,
            ConsoleErrorKind::UnknownCommand { found },
        );
    }
    let message = parse("stop", selected()).unwrap_err().to_string();
    assert_eq!(
        message,
        "line 1, column 1: unknown command `stop`: the console knows read, write, save, estop, release, reset, effects and ip"
    );
}

#[test]
fn a_bank_is_fn_dn_or_cx_and_fits_the_command() {
    refused(
        "read FX 0x20 4",
        1,
        6,
        ConsoleErrorKind::NotABank {
            found: "FX".to_owned(),
        },
    );
    assert_eq!(
        parse("read FX 0x20 4", selected())
            .unwrap_err()
            .kind
            .to_string(),
        "expected a register bank FN, DN or CX, found `FX`"
    );
    refused(
        "write 0x20 1",
        1,
        7,
        ConsoleErrorKind::NotABank {
            found: "0x20".to_owned(),
        },
    );
    refused(
        "read CX 0 1",
        1,
        6,
        ConsoleErrorKind::WrongBank {
            command: "read",
            bank: "CX",
            reason: "CX command registers cannot be read over UDP; read FN or DN",
        },
    );
    refused(
        "write dn 0x10 1",
        1,
        7,
        ConsoleErrorKind::WrongBank {
            command: "write",
            bank: "DN",
            reason: "DN parameters cannot be written; write FN or CX",
        },
    );
    refused(
        "save CX 1 1",
        1,
        6,
        ConsoleErrorKind::WrongBank {
            command: "save",
            bank: "CX",
            reason: "only FN parameters are saved; write CX … for command registers",
        },
    );
}

#[test]
fn a_missing_operand_is_reported_just_after_the_command() {
    let missing = |command, operand| ConsoleErrorKind::Missing { command, operand };
    refused("read", 1, 5, missing("read", Operand::Bank));
    refused("read FN", 1, 8, missing("read", Operand::Start));
    refused(
        "read FN 0x20   # four",
        1,
        13,
        missing("read", Operand::Count),
    );
    refused(
        "write FN 0x90;estop",
        1,
        14,
        missing("write", Operand::Value),
    );
    refused("save FN", 1, 8, missing("save", Operand::Start));
    refused("effects", 1, 8, missing("effects", Operand::Mask));
    refused("  ip ", 1, 5, missing("ip", Operand::Ip));
    assert_eq!(
        parse("read FN 0x20", selected()).unwrap_err().to_string(),
        format!(
            "line 1, column 13: `read` needs the number of registers here (one datagram reads 1 to {MAX_REGISTERS} registers)"
        )
    );
    refused(
        "@15.201",
        1,
        8,
        ConsoleErrorKind::MissingCommand {
            target: "@15.201".to_owned(),
        },
    );
}

#[test]
fn numbers_are_decimal_or_hex_and_fit_their_field() {
    fn nan(operand: Operand, found: &str) -> ConsoleErrorKind {
        let found = found.to_owned();
        ConsoleErrorKind::NotANumber { operand, found }
    }
    fn oor(operand: Operand, found: &str) -> ConsoleErrorKind {
        let found = found.to_owned();
        ConsoleErrorKind::OutOfRange { operand, found }
    }
    let huge = "99999999999999999999999";
    for (text, column, kind) in [
        ("read FN twenty 4", 9, nan(Operand::Start, "twenty")),
        ("read FN 0x 4", 9, nan(Operand::Start, "0x")),
        ("read FN 0x2G 4", 9, nan(Operand::Start, "0x2G")),
        ("read FN +1 4", 9, nan(Operand::Start, "+1")),
        ("read FN -1 4", 9, nan(Operand::Start, "-1")),
        ("read FN 1 ٣", 11, nan(Operand::Count, "٣")),
        ("effects all", 9, nan(Operand::Mask, "all")),
        ("read FN 0x10000 1", 9, oor(Operand::Start, "0x10000")),
        ("write FN 0x90 65536", 15, oor(Operand::Value, "65536")),
        (
            &format!("write FN 0 1 2 {huge}"),
            16,
            oor(Operand::Value, huge),
        ),
        ("effects 0x1FFFF", 9, oor(Operand::Mask, "0x1FFFF")),
        ("read DN 0 40000", 11, oor(Operand::Count, "40000")),
    ] {
        refused(text, 1, column, kind);
    }
    assert_eq!(
        parse("write FN 0x90 70000", selected())
            .unwrap_err()
            .kind
            .to_string(),
        "a value `70000` is out of range: a register holds 0 to 65535 (0xFFFF)"
    );
    refused("read FN 0x20 0", 1, 14, ConsoleErrorKind::ZeroCount);
    refused("read FN 0x20 0x0", 1, 14, ConsoleErrorKind::ZeroCount);
    assert_eq!(
        parse("read FN 0x20 0", selected()).unwrap_err().to_string(),
        "line 1, column 14: count 0: read at least one register"
    );
}

#[test]
fn ranges_stay_inside_the_address_space_and_one_datagram() {
    refused(
        "read FN 0xFFFF 2",
        1,
        16,
        ConsoleErrorKind::Range {
            source: RangeError::PastEnd {
                start: 0xFFFF,
                count: 2,
            },
        },
    );
    // The first value that would land past 0xFFFF.
    refused(
        "write FN 0xFFFE 1 2 3",
        1,
        21,
        ConsoleErrorKind::Range {
            source: RangeError::PastEnd {
                start: 0xFFFE,
                count: 3,
            },
        },
    );
    // One value more than a datagram carries.
    let mut text = String::from("write FN 0");
    for _ in 0..=MAX_REGISTERS {
        text.push_str(" 1");
    }
    let column = u32::try_from(text.len()).unwrap();
    refused(
        &text,
        1,
        column,
        ConsoleErrorKind::Range {
            source: RangeError::TooMany {
                count: MAX_REGISTERS + 1,
            },
        },
    );
    text.truncate(text.len() - 2);
    assert_eq!(
        parse(&text, selected()).map(|ops| Datagram::from(ops[0].clone()).encoded_len()),
        Ok(16 + 2 * MAX_REGISTERS)
    );
}

#[test]
fn trailing_words_ips_and_targets_are_refused_where_they_are() {
    for (text, column, command, found) in [
        ("estop now", 7, "estop", "now"),
        ("effects 1 2", 11, "effects", "2"),
        ("read FN 1 2 3", 13, "read", "3"),
        ("ip 10.0.0.1 10.0.0.2", 13, "ip", "10.0.0.2"),
    ] {
        let found = found.to_owned();
        refused(
            text,
            1,
            column,
            ConsoleErrorKind::Trailing { command, found },
        );
    }
    for (text, line, found) in [
        ("ip 192.168.15", 1, "192.168.15"),
        ("ip 192.168.15.256", 1, "192.168.15.256"),
        ("reset\nip box", 2, "box"),
    ] {
        let found = found.to_owned();
        refused(text, line, 4, ConsoleErrorKind::NotAnIp { found });
    }
    for (text, column, found) in [
        ("@ estop", 1, "@"),
        ("@box estop", 1, "@box"),
        ("  @1.2.3 estop", 3, "@1.2.3"),
        ("@15.201/ estop", 1, "@15.201/"),
        ("@1.2.3.999 estop", 1, "@1.2.3.999"),
    ] {
        let found = found.to_owned();
        refused(text, 1, column, ConsoleErrorKind::BadTarget { found });
    }
    refused(
        "@256 estop",
        1,
        1,
        ConsoleErrorKind::OutOfRange {
            operand: Operand::Octet,
            found: "256".to_owned(),
        },
    );
    assert_eq!(
        parse("@202 estop", Route::BROADCAST),
        Err(ConsoleError {
            line: 1,
            column: 1,
            kind: ConsoleErrorKind::NoSubnet { octet: 202 },
        })
    );
    assert_eq!(
        parse("@202 estop", Route::BROADCAST)
            .unwrap_err()
            .kind
            .to_string(),
        "`@202` gives the last octet only, and the selected box is not one box: give two octets, such as @15.202"
    );
}

#[test]
fn columns_count_characters_and_lines_count_from_one() {
    // Two-byte and four-byte characters before the mistake count as one column each.
    refused(
        "# ünïcode 🎈\nestop ; read FX 1 1",
        2,
        14,
        ConsoleErrorKind::NotABank {
            found: "FX".to_owned(),
        },
    );
    refused(
        "«» estop",
        1,
        1,
        ConsoleErrorKind::UnknownCommand {
            found: "«»".to_owned(),
        },
    );
    refused(
        "estop\r\nreset\r\nread",
        3,
        5,
        ConsoleErrorKind::Missing {
            command: "read",
            operand: Operand::Bank,
        },
    );
}

#[test]
fn the_canonical_text_names_the_route_and_the_operation() {
    let text = |input: &str| one(input).to_string();
    assert_eq!(text("read FN 0x20 4"), "@15.201 read FN 0x0020 4");
    assert_eq!(text("read dn 16 16"), "@15.201 read DN 0x0010 16");
    assert_eq!(text("write FN 0x20 1 2"), "@15.201 write FN 0x0020 1 2");
    assert_eq!(text("save fn 0x21 7"), "@15.201 save FN 0x0021 7");
    assert_eq!(text("write CX 2 0xFFFF"), "@15.201 write CX 0x0002 65535");
    assert_eq!(text("@all/none estop"), "@all/none estop");
    assert_eq!(text("write FN 0x90 1"), "@15.201 estop");
    assert_eq!(text("release"), "@15.201 release");
    assert_eq!(text("@1.2 reset"), "@1.2 reset");
    assert_eq!(text("write CX 1 65535"), "@15.201 effects 0xFFFF");
    assert_eq!(
        text("@192.168.15.202/none ip 10.0.0.7"),
        "@15.202/none ip 10.0.0.7"
    );
    // A saved write at FN020 with a value above 255 is no IP address.
    assert_eq!(
        text("save FN 0x20 1 2 3 256"),
        "@15.201 save FN 0x0020 1 2 3 256"
    );
    // Not saved, FN020–FN023 is a plain write.
    assert_eq!(
        text("write FN 0x20 10 0 0 7"),
        "@15.201 write FN 0x0020 10 0 0 7"
    );
    for input in [
        "read FN 0x20 4",
        "@all/none estop",
        "save FN 0x20 1 2 3 256",
        "@none reset",
        "ip 1.2.3.4",
    ] {
        let operation = one(input);
        assert_eq!(
            parse(&operation.to_string(), Route::BROADCAST),
            Ok(vec![operation])
        );
    }
}

#[test]
fn replies_read_as_registers_and_values() {
    let reply = |bank, start, values: &[u16]| RegisterReply {
        bank,
        route: Route::REPLY,
        block: RegisterBlock::new(start, values.to_vec()).unwrap(),
    };
    // (reply, one line, one register a line)
    for (reply, line, table) in [
        (
            reply(ReadBank::Fn, 0x20, &[192, 168, 15, 201]),
            "FN0020..FN0023 = 192 168 15 201",
            "FN0020 = 192 (0x00C0)\nFN0021 = 168 (0x00A8)\nFN0022 = 15 (0x000F)\nFN0023 = 201 (0x00C9)",
        ),
        (
            reply(ReadBank::Fn, 0x90, &[1]),
            "FN0090 = 1",
            "FN0090 = 1 (0x0001)",
        ),
        (
            reply(ReadBank::Dn, 0xFFFE, &[0xFFFF, 0]),
            "DNFFFE..DNFFFF = 65535 0",
            "DNFFFE = 65535 (0xFFFF)\nDNFFFF = 0 (0x0000)",
        ),
    ] {
        assert_eq!(render_reply(&reply, ReplyLayout::Line), line);
        assert_eq!(render_reply(&reply, ReplyLayout::Table), table);
        assert_eq!(render_reply(&reply, ReplyLayout::default()), line);
    }
    // The document's reply: FN001 = FN002 = 0.
    let document = Datagram::decode(&super::super::tests::hex(
        "55 aa 00 00 11 02 00 01 00 00 00 00 00 01 00 02 00 00 00 00",
    ));
    let Ok(Datagram::ReadReply(document)) = document else {
        panic!("{document:?}");
    };
    assert_eq!(
        render_reply(&document, ReplyLayout::Line),
        "FN0001..FN0002 = 0 0"
    );
}

/// The messages `docs/gateways.md` shows, word for word, and its example.
#[test]
fn the_documented_messages_are_the_parsers() {
    for (text, message) in [
        (
            "read FX 0x20 4",
            "line 1, column 6: expected a register bank FN, DN or CX, found `FX`",
        ),
        (
            "read FN 0x20 0",
            "line 1, column 14: count 0: read at least one register",
        ),
        (
            "estop\nwrite FN 0x90 70000",
            "line 2, column 15: a value `70000` is out of range: a register holds 0 to 65535 (0xFFFF)",
        ),
        (
            "stop",
            "line 1, column 1: unknown command `stop`: the console knows read, write, save, estop, release, reset, effects and ip",
        ),
        (
            "read CX 0 1",
            "line 1, column 6: `read` does not take CX: CX command registers cannot be read over UDP; read FN or DN",
        ),
    ] {
        assert_eq!(
            parse(text, selected()).map_err(|error| error.to_string()),
            Err(message.to_owned())
        );
    }
    let example = "# check box .201's address, then stop everything without waiting for answers\n\
                   @201 read FN 0x20 4\n\
                   @all/none estop\n";
    let echo: Vec<String> = parse(example, Route::to(BoxAddress::from_octets(15, 7)))
        .unwrap()
        .iter()
        .map(ToString::to_string)
        .collect();
    assert_eq!(echo, ["@15.201 read FN 0x0020 4", "@all/none estop"]);
}

#[cfg(not(target_arch = "wasm32"))]
mod proptests {
    use proptest::prelude::*;

    use super::*;

    fn address() -> impl Strategy<Value = BoxAddress> {
        prop_oneof![
            Just(BoxAddress::ALL),
            Just(BoxAddress::NO_REPLY),
            Just(BOX_201),
            any::<u16>().prop_map(BoxAddress),
        ]
    }

    fn route() -> impl Strategy<Value = Route> {
        (address(), address()).prop_map(|(receiver, replier)| Route { receiver, replier })
    }

    /// Any operation the console can send: reads, writes of any bank (short blocks,
    /// often at the named operations' registers) and the named operations.
    fn operation() -> impl Strategy<Value = Operation> {
        let start = prop_oneof![Just(0_u16), Just(1), Just(0x20), Just(0x90), any::<u16>()];
        let value = prop_oneof![Just(0_u16), Just(1), 0_u16..=255, any::<u16>()];
        let read = (route(), start.clone(), 1_usize..100, any::<bool>()).prop_filter_map(
            "inside the address space",
            |(route, start, count, fn_bank)| {
                let bank = if fn_bank { ReadBank::Fn } else { ReadBank::Dn };
                let range = RegisterRange::new(start, count).ok()?;
                Some(Operation::Read(RegisterRead { bank, route, range }))
            },
        );
        let bank = proptest::sample::select(vec![
            WriteBank::FnVolatile,
            WriteBank::FnSaved,
            WriteBank::Cx,
        ]);
        let write = (route(), bank, start, proptest::collection::vec(value, 1..8)).prop_filter_map(
            "inside the address space",
            |(route, bank, start, values)| {
                let block = RegisterBlock::new(start, values).ok()?;
                Some(Operation::Write(RegisterWrite { bank, route, block }))
            },
        );
        let named = (route(), any::<u16>(), any::<[u8; 4]>(), 0_u8..5).prop_map(
            |(route, mask, ip, which)| {
                Operation::Write(match which {
                    0 => RegisterWrite::estop(route),
                    1 => RegisterWrite::release_estop(route),
                    2 => RegisterWrite::reset(route),
                    3 => RegisterWrite::effects(route, mask),
                    _ => RegisterWrite::set_ip(route, Ipv4Addr::from(ip)),
                })
            },
        );
        prop_oneof![read, write, named]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2048))]

        /// parse(display(op)) == op, whatever the selected box.
        #[test]
        fn the_canonical_text_parses_back_to_the_operation(
            operation in operation(),
            selected in route(),
        ) {
            let text = operation.to_string();
            prop_assert_eq!(parse(&text, selected), Ok(vec![operation]), "{}", text);
        }

        /// Several canonical texts, joined by `;` or new lines with comments, parse to
        /// them all in order.
        #[test]
        fn canonical_texts_join_into_one(
            operations in proptest::collection::vec(operation(), 0..6),
            newline in any::<bool>(),
        ) {
            let separator = if newline { "  # note ; not a command\n" } else { " ; " };
            let text = operations
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(separator);
            prop_assert_eq!(parse(&text, Route::BROADCAST), Ok(operations));
        }

        /// Whatever the text, the parser answers; a refusal points inside it.
        #[test]
        fn no_text_panics_the_parser(text in "[ -~\t\n;#@.é🎈]{0,60}") {
            if let Err(error) = parse(&text, Route::to(BOX_201)) {
                let line = text.split('\n').nth(error.line as usize - 1);
                let line = line.map(|line| line.chars().count());
                prop_assert!(line.is_some(), "{:?}", error);
                prop_assert!(
                    (1..=line.unwrap_or(0) as u32 + 1).contains(&error.column),
                    "{:?}",
                    error
                );
            }
        }
    }
}

#[test]
fn only_reads_and_the_estop_are_inert_while_latched() {
    let inert = |text: &str| {
        parse(text, Route::BROADCAST)
            .unwrap()
            .iter()
            .all(Operation::is_inert)
    };
    assert!(inert("read FN 0x20 4"));
    assert!(inert("estop"));
    assert!(!inert("release"));
    assert!(!inert("reset"));
    assert!(!inert("write FN 0x90 1 2"), "two registers: not the e-stop");
    assert!(!inert("read FN 0x20 1\nrelease"));
}
