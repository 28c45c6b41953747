//! The checks of `floatball.toml`, through [`Config::parse`] as the bridge reads it.

use std::path::Path;
use std::time::Duration;

use floatball_shared::plan::DriveKind;
use floatball_shared::show::{Layout, Limits};
use floatball_shared::uim2503::ascii::Form;

use super::*;

fn parse(text: &str) -> Result<Config, ConfigError> {
    Config::parse(
        Path::new("data/floatball.toml"),
        text,
        &Overrides::default(),
    )
}

fn estop_bytes(config: &Config) -> Vec<u8> {
    let mut bytes = Vec::new();
    for instruction in &config.estop {
        instruction
            .encode_into(Form::Standard, &mut bytes)
            .expect("encodes");
    }
    bytes
}

#[test]
fn the_default_file_gives_the_defaults() {
    let config = parse(DEFAULT_FILE).expect("defaults parse");
    assert_eq!(config, parse("").expect("empty file"));
    assert_eq!(config.listen, "0.0.0.0:8080".parse().expect("addr"));
    assert_eq!(
        config.installation.limits.rows * config.installation.limits.cols,
        100
    );
    assert_eq!(config.installation.gateways.len(), 1);
    assert_eq!(config.installation.gateways[0].port, "sim");
    assert_eq!(config.installation.gateways[0].baud, DEFAULT_SIM_BAUD);
    assert_eq!(
        config.installation.stations_on(0),
        (1..=100).collect::<Vec<u8>>()
    );
    assert_eq!(estop_bytes(&config), b"*0;MO=0;");
    // A link opened without a configuration stops the same way.
    assert_eq!(
        crate::ports::uim2503::LinkConfig::new("sim", DEFAULT_SIM_BAUD)
            .estop
            .as_bytes(),
        estop_bytes(&config)
    );
    assert_eq!(config.uploads.max_bytes, 32 * 1024 * 1024);
    assert_eq!(config.uploads.max_duration, Duration::from_secs(30 * 60));
    assert_eq!(config.installation.limits, Limits::for_layout(10, 10));
}

#[test]
fn syntax_errors_name_the_file_line_and_column() {
    let error = parse("[matrix]\nrows = 10\ncols = ten\n").expect_err("bad value");
    let message = error.to_string();
    assert!(
        message.starts_with("data/floatball.toml line 3, column 8: "),
        "{message}"
    );
}

#[test]
fn unknown_keys_are_refused_with_their_line() {
    let message = parse("[matrix]\nrows = 10\ncolumns = 3\n")
        .expect_err("unknown key")
        .to_string();
    assert!(message.contains("line 3, column 1"), "{message}");
    assert!(message.contains("columns"), "{message}");
}

#[test]
fn a_baud_out_of_range_names_its_line() {
    let text = "[[gateway]]\nport = \"/dev/ttyUSB0\"\nbaud = 300\n";
    let message = parse(text).expect_err("baud").to_string();
    assert_eq!(
        message,
        "data/floatball.toml line 3, column 8: baud 300 is out of range (1200 to 921600)"
    );
}

#[test]
fn a_real_port_defaults_to_9600_baud_and_sim_to_115200() {
    let config = parse("[[gateway]]\nport = \"/dev/ttyUSB0\"\n").expect("config");
    assert_eq!(config.installation.gateways[0].baud, 9600);
    let overridden = Config::parse(
        Path::new("f"),
        "[[gateway]]\nport = \"/dev/ttyUSB0\"\n",
        &Overrides {
            listen: Some("127.0.0.1:0".parse().expect("addr")),
            gateway_ports: vec!["sim".into()],
        },
    )
    .expect("config");
    assert_eq!(overridden.installation.gateways[0].port, "sim");
    assert_eq!(overridden.installation.gateways[0].baud, 115_200);
    assert_eq!(overridden.listen.port(), 0);
}

#[test]
fn more_gateway_flags_than_gateways_are_refused() {
    let error = Config::parse(
        Path::new("f"),
        "",
        &Overrides {
            listen: None,
            gateway_ports: vec!["sim".into(), "sim".into()],
        },
    )
    .expect_err("two flags, one gateway");
    assert!(error.to_string().contains("2 --gateway flags"), "{error}");
}

#[test]
fn units_are_shared_among_gateways_row_major() {
    let text = "[matrix]\nrows = 15\ncols = 10\n\
                [[gateway]]\nport = \"sim\"\n\
                [[gateway]]\nport = \"sim\"\nfirst_station = 10\n";
    let config = parse(text).expect("config");
    assert_eq!(
        config.installation.stations_on(0),
        (1..=75).collect::<Vec<u8>>()
    );
    assert_eq!(
        config.installation.stations_on(1),
        (10..=84).collect::<Vec<u8>>()
    );
}

/// Every unit's (gateway, station), row-major.
fn addresses(text: &str) -> Vec<(usize, u8)> {
    parse(text)
        .expect("config")
        .installation
        .units
        .iter()
        .map(|address| (address.gateway, address.station))
        .collect()
}

#[test]
fn unit_addresses_stay_as_they_were() {
    // The default file: one gateway, stations 1 to 100.
    let default: Vec<(usize, u8)> = (1..=100).map(|station| (0, station)).collect();
    assert_eq!(addresses(DEFAULT_FILE), default);
    // Ten units shared by three gateways: 4, 3, 3, each from its first station.
    let text = "[matrix]\nrows = 2\ncols = 5\n\
                [[gateway]]\nport = \"sim\"\n\
                [[gateway]]\nport = \"sim\"\n\
                [[gateway]]\nport = \"sim\"\nfirst_station = 20\n";
    assert_eq!(
        addresses(text),
        [
            (0, 1),
            (0, 2),
            (0, 3),
            (0, 4),
            (1, 1),
            (1, 2),
            (1, 3),
            (2, 20),
            (2, 21),
            (2, 22)
        ]
    );
    // Counts and lists first, the rest shared among the others.
    let text = "[matrix]\nrows = 2\ncols = 5\n\
                [[gateway]]\nport = \"sim\"\nfirst_station = 5\nunits = 3\n\
                [[gateway]]\nport = \"sim\"\n\
                [[gateway]]\nport = \"sim\"\nstations = [9, 7]\nfirst_station = 40\n\
                [[gateway]]\nport = \"sim\"\nfirst_station = 50\n";
    assert_eq!(
        addresses(text),
        [
            (0, 5),
            (0, 6),
            (0, 7),
            (1, 1),
            (1, 2),
            (1, 3),
            (2, 9),
            (2, 7),
            (3, 50),
            (3, 51)
        ]
    );
    // A gateway left with nothing to share serves no unit.
    let text = "[matrix]\nrows = 1\ncols = 2\n\
                [[gateway]]\nport = \"sim\"\nunits = 2\n\
                [[gateway]]\nport = \"sim\"\n";
    assert_eq!(addresses(text), [(0, 1), (0, 2)]);
    // 150 units on two gateways: 75 each, the second from station 10.
    let text = "[matrix]\nrows = 15\ncols = 10\n\
                [[gateway]]\nport = \"sim\"\n\
                [[gateway]]\nport = \"sim\"\nfirst_station = 10\n";
    let two: Vec<(usize, u8)> = (1..=75)
        .map(|station| (0, station))
        .chain((10..=84).map(|station| (1, station)))
        .collect();
    assert_eq!(addresses(text), two);
}

#[test]
fn the_gateways_must_serve_every_unit_exactly() {
    let text = "[matrix]\nrows = 1\ncols = 3\n[[gateway]]\nport = \"sim\"\nunits = 2\n";
    assert_eq!(
        parse(text).expect_err("2 of 3").to_string(),
        "data/floatball.toml: the matrix has 1 × 3 = 3 units but the gateways serve 2; \
         adjust the gateways' units or stations (each gateway serves at most 100)"
    );
}

#[test]
fn too_many_units_for_the_gateways_is_refused() {
    let message = parse("[matrix]\nrows = 11\ncols = 10\n")
        .expect_err("110 units on one gateway")
        .to_string();
    assert!(
        message.starts_with("data/floatball.toml: gateway 1"),
        "{message}"
    );
    assert!(message.contains("110 units"), "{message}");
    assert!(message.contains("at most 100"), "{message}");
    let text = "[matrix]\nrows = 11\ncols = 10\n[[gateway]]\nport = \"sim\"\n";
    let message = parse(text).expect_err("110 units").to_string();
    assert!(
        message.starts_with("data/floatball.toml line 4, column 1: gateway 1"),
        "{message}"
    );
}

#[test]
fn explicit_stations_must_be_unique_and_in_range() {
    let duplicate =
        "[matrix]\nrows = 1\ncols = 3\n[[gateway]]\nport = \"sim\"\nstations = [5, 6, 5]\n";
    let message = parse(duplicate).expect_err("duplicate").to_string();
    assert_eq!(
        message,
        "data/floatball.toml line 6, column 19: gateway 1: station 5 is listed twice; two \
         units with one station number break the bus"
    );
    let range = "[matrix]\nrows = 1\ncols = 2\n[[gateway]]\nport = \"sim\"\nstations = [0, 6]\n";
    assert!(
        parse(range)
            .expect_err("station 0")
            .to_string()
            .contains("line 6, column 13")
    );
    let stations = "[matrix]\nrows = 1\ncols = 2\n[[gateway]]\nport = \"sim\"\nstations = [9, 7]\n";
    assert_eq!(
        parse(stations).expect("config").installation.stations_on(0),
        [9, 7]
    );
}

#[test]
fn stations_past_127_are_refused() {
    let text = "[[gateway]]\nport = \"sim\"\nfirst_station = 100\n";
    let message = parse(text).expect_err("100..199").to_string();
    assert!(message.contains("line 3"), "{message}");
    assert!(message.contains("stations 100 to 199"), "{message}");
}

#[test]
fn the_estop_is_checked_by_the_codec() {
    let message = parse("[safety]\nestop = \"MO=0\"\n")
        .expect_err("no ;")
        .to_string();
    assert!(
        message.starts_with("data/floatball.toml line 2, column 9: estop"),
        "{message}"
    );
    assert!(message.contains("`;`"), "{message}");
    let select = parse("[safety]\nestop = \"*5;MO=0;\"\n").expect_err("selects");
    assert!(select.to_string().contains("selects a station"), "{select}");
    let two = parse("[safety]\nestop = \"mo=0; SD=1000;\"\n").expect("two instructions");
    assert_eq!(estop_bytes(&two), b"*0;MO=0;SD=1000;");
}

#[test]
fn numbers_are_checked() {
    for (text, key) in [
        ("[matrix]\npitch_mm = -1.0\n", "pitch_mm"),
        ("[matrix]\nrows = 0\n", "rows"),
        ("[matrix]\nhome_mm = 8000.0\n", "home_mm"),
        ("[uploads]\nmax_bytes = 10\n", "max_bytes"),
        ("[uploads]\nmax_duration = \"25h\"\n", "max_duration"),
        (
            "[uploads]\nmax_duration = \"half an hour\"\n",
            "max_duration",
        ),
        ("[uploads]\nmax_duration = \"0s\"\n", "max_duration"),
        (
            "[safety]\napproach_speed_mm_s = 5000.0\n",
            "approach_speed_mm_s",
        ),
        ("listen = \"everywhere\"\n", "listen"),
        ("allowed_origins = [\"example.com\"]\n", "origin"),
    ] {
        let message = parse(text).expect_err(key).to_string();
        assert!(message.contains(key), "{text}: {message}");
        assert!(message.contains("line "), "{text}: {message}");
    }
}

#[test]
fn max_duration_reads_human_durations() {
    let config = parse("[uploads]\nmax_duration = \"1h 15m\"\n").expect("duration");
    assert_eq!(config.uploads.max_duration, Duration::from_secs(75 * 60));
}

#[test]
fn every_key_of_the_default_file_is_documented() {
    let docs = include_str!("../../../docs/configuration.md");
    let keys: Vec<&str> = DEFAULT_FILE
        .lines()
        .map(|line| line.trim_start_matches("# "))
        .filter_map(|line| line.split_once(" = ").map(|(key, _)| key))
        .filter(|key| key.chars().all(|c| c.is_ascii_lowercase() || c == '_'))
        .collect();
    assert!(keys.len() >= 17, "{keys:?}");
    for key in keys {
        assert!(
            docs.contains(&format!("| `{key}` |")),
            "{key} is not documented"
        );
    }
    for table in ["[matrix]", "[[gateway]]", "[safety]", "[uploads]"] {
        assert!(
            DEFAULT_FILE.contains(table) && docs.contains(table),
            "{table}"
        );
    }
}

#[test]
fn the_layout_carries_the_pitch() {
    let config = parse("[matrix]\nrows = 2\ncols = 3\npitch_mm = 750.0\n").expect("config");
    assert_eq!(
        config.installation.layout(),
        Layout {
            rows: 2,
            cols: 3,
            pitch_mm: 750.0
        }
    );
}

#[test]
fn a_gateway_kind_defaults_to_the_uim2503_and_unknown_kinds_are_refused() {
    let config = parse("[[gateway]]\nport = \"sim\"\n").expect("no kind");
    assert_eq!(config.installation.gateways[0].kind, DriveKind::Uim2503);
    let named = parse("[[gateway]]\nkind = \"uim2503\"\nport = \"sim\"\n").expect("kind");
    assert_eq!(named, config);
    let message = parse("[[gateway]]\nport = \"sim\"\nkind = \"uim342\"\n")
        .expect_err("unknown kind")
        .to_string();
    assert_eq!(
        message,
        "data/floatball.toml line 3, column 8: gateway 1: kind \"uim342\" is not a known kind \
         of drive; the known kinds are \"uim2503\", \"mbox\", \"scl\""
    );
}

const MBOX: &str = "[matrix]\nrows = 2\ncols = 10\n\
                    [mbox]\nhost_port = 0\nframe_period_ms = 10\ntime = \"absolute\"\n\
                    [[gateway]]\nkind = \"mbox\"\naddress = \"192.168.15.201:7408\"\n\
                    pulses_per_mm = 20.0\nsign = -1\noffset_pulses = 500\n\
                    [[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 10\n";

#[test]
fn mbox_boxes_are_gateways_whose_units_are_axes() {
    let config = parse(MBOX).expect("mbox");
    let mbox = config.mbox().expect("an MBOX installation");
    assert_eq!(mbox.host_port, 0);
    assert_eq!(mbox.frame_period, Duration::from_millis(10));
    assert_eq!(mbox.time, floatball_shared::mbox::TimeMode::Absolute);
    assert_eq!(
        mbox.boxes[0].target,
        MboxTarget::Address("192.168.15.201:7408".parse().expect("addr"))
    );
    assert_eq!(mbox.boxes[1].target, MboxTarget::Sim);
    let first = mbox.boxes[0].calibration;
    assert_eq!((first.axes, first.sign, first.offset_pulses), (10, -1, 500));
    assert_eq!(first.pulses_per_mm, 20.0);
    // The matrix's calibration unless configured.
    assert_eq!(mbox.boxes[1].calibration.pulses_per_mm, 100.0);
    let installation = &config.installation;
    assert!(
        installation
            .gateways
            .iter()
            .all(|g| g.kind == DriveKind::Mbox)
    );
    assert_eq!(installation.stations_on(1), (1..=10).collect::<Vec<u8>>());
    assert!(parse("").expect("defaults").mbox().is_none());
    let defaults = parse("[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\n[matrix]\nrows = 1\n")
        .expect("defaults");
    let mbox = defaults.mbox().cloned().expect("mbox");
    assert_eq!(mbox.host_port, DEFAULT_MBOX_HOST_PORT);
    assert_eq!(mbox.frame_period, DEFAULT_MBOX_PERIOD);
    assert_eq!(mbox.time, floatball_shared::mbox::TimeMode::Relative);
}

#[test]
fn mbox_mistakes_are_named_with_their_place() {
    let wrong = |from: &str, to: &str| {
        parse(&MBOX.replacen(from, to, 1))
            .expect_err(to)
            .to_string()
    };
    assert_eq!(
        wrong("axes = 10", "axes = 4"),
        "data/floatball.toml line 17, column 8: gateway 2: axes = 4 must be 3, 6 or 10"
    );
    assert_eq!(
        wrong("sign = -1", "sign = 2"),
        "data/floatball.toml line 12, column 8: gateway 1: sign = 2 must be 1 or -1"
    );
    assert_eq!(
        wrong("time = \"absolute\"", "time = \"later\""),
        "data/floatball.toml line 7, column 8: time = \"later\" must be \"relative\" or \"absolute\""
    );
    assert_eq!(
        wrong("192.168.15.201:7408", "box-one"),
        "data/floatball.toml line 10, column 11: gateway 1: \"box-one\" is not an MBOX box's \
         address and UDP port such as \"192.168.15.201:7408\", nor \"sim\""
    );
    assert_eq!(
        wrong("axes = 10", "axes = 3"),
        "data/floatball.toml line 14, column 1: gateway 2: axis 4 is beyond the box's 3 axes; \
         give it at most 3 units (or add a box)"
    );
    assert_eq!(
        wrong("port = \"sim\"\naxes", "kind2 = 1\naxes"),
        "data/floatball.toml line 16, column 1: unknown field `kind2`, expected one of `kind`, \
         `port`, `address`, `axes`, `pulses_per_mm`, `sign`, `offset_pulses`, `baud`, \
         `first_station`, `units`, `stations`, `addresses`, `escl`"
    );
    let mixed = parse(&format!(
        "{MBOX}[[gateway]]\nkind = \"uim2503\"\nport = \"sim\"\n"
    ))
    .expect_err("mixed")
    .to_string();
    assert_eq!(
        mixed,
        "data/floatball.toml line 19, column 8: gateway 3: kind \"uim2503\" after \"mbox\" \
         gateways: an installation is all UIM2503 gateways, all MBOX boxes or all MOONS' (SCL) \
         drives"
    );
    let serial = parse("[[gateway]]\nport = \"sim\"\naxes = 3\n")
        .expect_err("axes on a uim2503")
        .to_string();
    assert_eq!(
        serial,
        "data/floatball.toml line 3, column 8: gateway 1: axes is for MBOX boxes (kind = \"mbox\")"
    );
}

/// MOONS' drives: an RS-485 line of three listed drives and two eSCL drives.
const SCL: &str = "\
[matrix]
rows = 1
cols = 5
[scl]
trigger = \"1:2\"
programs = \"stored\"
poll_ms = 100
[[gateway]]
kind = \"scl\"
port = \"/dev/ttyUSB0\"
baud = 115200
addresses = \"123\"
[[gateway]]
kind = \"scl\"
escl = [\"192.168.0.11\", \"192.168.0.12:7000\"]
";

#[test]
fn scl_gateways_and_their_settings() {
    use floatball_shared::scl::{Address, InputCondition, IoPoint};
    let config = parse(SCL).expect("valid");
    assert!(config.mbox().is_none());
    let scl = config.scl().cloned().expect("an SCL installation");
    let address = |c| Address::new(c).expect("address");
    assert_eq!(
        scl.gateways,
        vec![
            SclGateway::Serial {
                port: "/dev/ttyUSB0".into(),
                baud: 115_200,
                addresses: vec![address('1'), address('2'), address('3')],
            },
            SclGateway::Escl(vec![
                "192.168.0.11:7775".parse().expect("addr"),
                "192.168.0.12:7000".parse().expect("addr"),
            ]),
        ]
    );
    assert_eq!(
        scl.trigger,
        Some((address('1'), IoPoint::new(2).expect("io")))
    );
    assert_eq!(
        scl.start,
        Some((IoPoint::new(3).expect("io"), InputCondition::Falling))
    );
    assert_eq!(scl.programs, SclPrograms::Stored);
    assert_eq!(scl.steps_per_rev, DEFAULT_STEPS_PER_REV);
    assert_eq!(scl.tolerance_mm, DEFAULT_TOLERANCE_MM);
    assert_eq!(scl.poll, Duration::from_millis(100));
    assert_eq!(scl.host_port, DEFAULT_SCL_HOST_PORT);
    let installation = &config.installation;
    assert!(
        installation
            .gateways
            .iter()
            .all(|g| g.kind == DriveKind::Scl)
    );
    assert_eq!(installation.stations_on(0), vec![1, 2, 3]);
    assert_eq!(installation.stations_on(1), vec![1, 2]);
    assert_eq!(installation.gateways[0].baud, 115_200);

    // Without addresses a line's drives take the characters in order, at 9600 baud;
    // without a trigger nothing waits for a start input (QX1 starts every drive).
    let plain =
        parse("[matrix]\nrows = 2\ncols = 2\n[[gateway]]\nkind = \"scl\"\nport = \"/dev/ttyS0\"\n")
            .expect("valid");
    let scl = plain.scl().cloned().expect("scl");
    assert_eq!(
        scl.gateways,
        vec![SclGateway::Serial {
            port: "/dev/ttyS0".into(),
            baud: 9600,
            addresses: default_addresses(4),
        }]
    );
    assert_eq!(
        default_addresses(4),
        vec![address('0'), address('1'), address('2'), address('3')]
    );
    assert_eq!((scl.trigger, scl.start), (None, None));
    assert_eq!(scl.programs, SclPrograms::Upload);
    assert_eq!(scl.poll, DEFAULT_SCL_POLL);
}

#[test]
fn scl_mistakes_are_named_with_their_place() {
    let wrong = |from: &str, to: &str| parse(&SCL.replacen(from, to, 1)).expect_err(to).to_string();
    // `programs = "stream"`: every show streamed into the drives' command buffers.
    let streamed =
        parse(&SCL.replacen("programs = \"stored\"", "programs = \"stream\"", 1)).expect("stream");
    let scl = streamed.scl().expect("scl");
    assert_eq!(scl.programs, SclPrograms::Stream);
    assert!(scl.programs.compiled());
    assert_eq!(
        scl.programs.streaming(),
        floatball_shared::scl::qprogram::Streaming::Always
    );
    assert_eq!(
        wrong("addresses = \"123\"", "addresses = \"12a\""),
        "data/floatball.toml line 12, column 16: gateway 1: 'a' is not a drive address; the \
         address characters are 0123456789\"#$&'()+,-./:;<=>"
    );
    assert_eq!(
        wrong("addresses = \"123\"", "addresses = \"121\""),
        "data/floatball.toml line 12, column 16: gateway 1: address '1' is given twice"
    );
    assert_eq!(
        wrong("trigger = \"1:2\"", "trigger = \"9:2\""),
        "data/floatball.toml line 5, column 11: trigger = \"9:2\": there is no drive '9' on \
         the first gateway entry"
    );
    assert_eq!(
        wrong("trigger = \"1:2\"", "trigger = \"1-2\""),
        "data/floatball.toml line 5, column 11: trigger = \"1-2\" must be a drive's address \
         character and one of its outputs, such as \"1:2\" (drive 1, output 2)"
    );
    assert_eq!(
        wrong("programs = \"stored\"", "programs = \"flash\""),
        "data/floatball.toml line 6, column 12: programs = \"flash\" must be \"upload\" \
         (Start writes the compiled programs, streaming the shows too long to store), \
         \"stream\" (Start streams every show) or \"stored\" (loaded with Q Programmer)"
    );
    assert_eq!(
        wrong("poll_ms = 100", "poll_ms = 5"),
        "data/floatball.toml line 7, column 11: poll_ms = 5 must be from 20 to 10000"
    );
    assert_eq!(
        wrong("poll_ms = 100", "start_condition = \"X\""),
        "data/floatball.toml line 7, column 19: start_condition = \"X\" must be \"H\" (high), \
         \"L\" (low), \"R\" (rising edge) or \"F\" (falling edge)"
    );
    assert_eq!(
        wrong("poll_ms = 100", "start_input = 12"),
        "data/floatball.toml line 7, column 15: start_input = 12 must be an input from 0 to 9"
    );
    assert_eq!(
        wrong("\"192.168.0.11\",", "\"drive-one\","),
        "data/floatball.toml line 15, column 9: gateway 2: \"drive-one\" is not a drive's IP \
         address such as \"192.168.0.11\" or \"192.168.0.11:7775\""
    );
    assert_eq!(
        wrong("baud = 115200", "baud = 115200\nescl = [\"10.0.0.1\"]"),
        "data/floatball.toml line 10, column 8: gateway 1: give MOONS' drives either port (an \
         RS-485 line) or escl (drives on UDP), not both"
    );
    assert_eq!(
        wrong("baud = 115200", "axes = 3"),
        "data/floatball.toml line 11, column 8: gateway 1: axes is not for MOONS' drives (kind = \
         \"scl\"); give port and addresses, or escl"
    );
    assert_eq!(
        wrong("port = \"/dev/ttyUSB0\"", "port = \"\""),
        "data/floatball.toml line 10, column 8: gateway 1: port \"\" must be a serial device \
         such as \"/dev/ttyUSB0\", or \"sim\" (simulated drives)"
    );
    // Simulated drives take neither a speed nor addresses.
    assert_eq!(
        wrong("port = \"/dev/ttyUSB0\"", "port = \"sim\""),
        "data/floatball.toml line 11, column 8: gateway 1: baud is not for simulated drives \
         (port = \"sim\"); give units"
    );
    assert_eq!(
        wrong("baud = 115200", "units = 4"),
        "data/floatball.toml line 11, column 9: gateway 1: units = 4 but 3 drives are listed; \
         leave units out"
    );
    let many = parse(
        "[matrix]\nrows = 1\ncols = 28\n[[gateway]]\nkind = \"scl\"\nport = \"/dev/ttyS0\"\n",
    )
    .expect_err("28 drives on a line")
    .to_string();
    assert!(many.contains("27"), "{many}");
    let on_uim = parse("[[gateway]]\nport = \"sim\"\naddresses = \"12\"\n")
        .expect_err("addresses on a uim2503")
        .to_string();
    assert_eq!(
        on_uim,
        "data/floatball.toml line 3, column 13: gateway 1: addresses and escl are for MOONS' \
         drives (kind = \"scl\")"
    );
}

#[test]
fn simulated_scl_drives_count_their_units() {
    let sim = "[[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n";
    let config = parse(&format!(
        "[matrix]\nrows = 2\ncols = 3\n[scl]\ntrigger = \"0:2\"\n{sim}{sim}"
    ))
    .expect("valid");
    let scl = config.scl().cloned().expect("scl");
    assert_eq!(
        scl.gateways,
        vec![SclGateway::Sim { drives: 3 }, SclGateway::Sim { drives: 3 }]
    );
    assert_eq!(config.installation.gateways[1].port, "sim");
    assert_eq!(config.installation.stations_on(1), vec![1, 2, 3]);
    // The trigger names a simulated drive of the first entry; the start input is the
    // one the simulator's default wire drives.
    let wire = crate::simulate::scl::parse_start_wire(crate::simulate::scl::DEFAULT_START_WIRE)
        .expect("the default wire");
    assert_eq!(scl.trigger, Some((wire.from, wire.output)));
    assert_eq!(scl.start.map(|(input, _)| input), Some(wire.input));

    let wrong = |extra: &str| {
        parse(&format!(
            "[matrix]\nrows = 1\ncols = 3\n[[gateway]]\nkind = \"scl\"\nport = \"sim\"\n{extra}\n"
        ))
        .expect_err(extra)
        .to_string()
    };
    assert_eq!(
        wrong("addresses = \"123\""),
        "data/floatball.toml line 7, column 13: gateway 1: addresses is not for simulated \
         drives (port = \"sim\"); give units"
    );
    assert_eq!(
        wrong("baud = 115200"),
        "data/floatball.toml line 7, column 8: gateway 1: baud is not for simulated drives \
         (port = \"sim\"); give units"
    );
    assert!(wrong("escl = [\"127.0.0.1\"]").contains("either port"));
    assert!(
        parse("[matrix]\nrows = 1\ncols = 3\n[scl]\ntrigger = \"3:2\"\n[[gateway]]\nkind = \"scl\"\nport = \"sim\"\n")
            .expect_err("no drive 3")
            .to_string()
            .contains("there is no drive '3'")
    );
}

#[test]
fn every_problem_is_listed_not_only_the_first() {
    let text = "listen = \"nowhere\"\n[matrix]\nrows = 0\nmax_speed_mm_s = -5.0\n\
                home_mm = 9000.0\n[[gateway]]\nport = \"sim\"\nstations = [1, 1]\n\
                [[gateway]]\nkind = \"uim342\"\n[safety]\nestop = \"\"\n\
                [uploads]\nmax_duration = \"forever\"\n";
    let problems = Config::parse_all(
        Path::new("data/floatball.toml"),
        text,
        &Overrides::default(),
    )
    .expect_err("wrong in many places");
    let messages: Vec<String> = problems.iter().map(ToString::to_string).collect();
    let all = messages.join("\n");
    for part in [
        "line 1, column 10: listen = \"nowhere\"",
        "line 3, column 8: rows = 0 must be from 1 to 1000",
        "line 4, column 18: max_speed_mm_s = -5 must be",
        "line 5, column 11: home_mm = 9000 must be from 0 to travel_mm",
        "line 10, column 8: gateway 2: kind \"uim342\"",
        "estop is empty",
        "max_duration = \"forever\"",
    ] {
        assert!(all.contains(part), "{part} is not in:\n{all}");
    }
    assert_eq!(problems.len(), 7, "{all}");
    // The gateways are known but one, so the units are not given out: no duplicate
    // reported against a list that may change.
    assert!(!all.contains("twice"), "{all}");
    // `parse` says them all too, one a line (the start, `floatball check`).
    let error = parse(text).expect_err("many").to_string();
    assert_eq!(error, all);
    assert_eq!(error.lines().count(), 7);
    // With every gateway known, an allocation problem is listed beside the others.
    let text = "[matrix]\nmax_speed_mm_s = 0.0\n[[gateway]]\nport = \"sim\"\nstations = [1, 1]\n";
    let problems = Config::parse_all(Path::new("f.toml"), text, &Overrides::default())
        .expect_err("two problems");
    assert_eq!(problems.len(), 2, "{problems:?}");
}

#[test]
fn network_ports_are_taken_and_bad_ones_refused_naming_the_forms() {
    let config = parse(
        "[matrix]\nrows = 2\ncols = 1\n[[gateway]]\nport = \"tcp://10.0.0.5:4001\"\nstations = [1]\n\
         [[gateway]]\nport = \"rfc2217://serial-box.local:4002\"\nbaud = 115200\nstations = [2]\n",
    )
    .expect("config");
    let gateways = &config.installation.gateways;
    assert_eq!(gateways[0].port, "tcp://10.0.0.5:4001");
    assert_eq!(
        gateways[0].baud, 9600,
        "the remote line's default, as a local one's"
    );
    assert_eq!(gateways[1].port, "rfc2217://serial-box.local:4002");
    assert_eq!(gateways[1].baud, 115_200);
    for (port, says) in [
        ("tcp://10.0.0.5", "needs a TCP port 1-65535"),
        ("tcp://:4001", "has no host"),
        ("rfc2217://host:0", "needs a TCP port 1-65535"),
        ("telnet://host:23", "only tcp:// (raw TCP) and rfc2217://"),
    ] {
        let error = parse(&format!("[[gateway]]\nport = \"{port}\"\n"))
            .expect_err(port)
            .to_string();
        assert!(
            error.contains(says) && error.contains("gateway 1"),
            "{port}: {error}"
        );
    }
    let error = parse("[[gateway]]\nport = \"\"\n")
        .expect_err("empty")
        .to_string();
    assert!(
        error.contains("tcp://host:port") && error.contains("rfc2217://host:port"),
        "{error}"
    );
}

#[test]
fn osc_is_off_unless_listen_is_given_and_its_switches_default_to_estop_only() {
    assert_eq!(parse("").expect("empty").osc, None);
    assert_eq!(
        parse("[osc]\nallow = [\"10.0.0.1\"]\n")
            .expect("no listen")
            .osc,
        None
    );
    let config =
        parse("[osc]\nlisten = \"0.0.0.0:9000\"\nallow = [\"192.168.1.20\", \"10.0.0.0/24\"]\n")
            .expect("osc");
    let osc = config.osc.expect("on");
    assert_eq!(osc.listen, "0.0.0.0:9000".parse().expect("addr"));
    assert_eq!(osc.allow.len(), 2);
    assert!(osc.allow[1].contains("10.0.0.7".parse().expect("ip")));
    assert!(osc.estop);
    assert!(!osc.motion);
    assert_eq!(osc.feedback, None);
    let osc = parse(
        "[osc]\nlisten = \"127.0.0.1:9000\"\nallow = [\"127.0.0.1\"]\nestop = false\n\
         motion = true\nfeedback = \"127.0.0.1:9001\"\n",
    )
    .expect("osc")
    .osc
    .expect("on");
    assert!(!osc.estop && osc.motion);
    assert_eq!(osc.feedback, Some("127.0.0.1:9001".parse().expect("addr")));
}

#[test]
fn wrong_osc_values_name_their_line() {
    for (text, expected) in [
        (
            "[osc]\nlisten = \"9000\"\nallow = [\"10.0.0.1\"]\n",
            "line 2, column 10: [osc] listen = \"9000\" is not an address and UDP port",
        ),
        (
            "[osc]\nlisten = \"0.0.0.0:9000\"\nallow = [\"10.0.0.1\", \"pc.local\"]\n",
            "line 3, column 22: [osc] allow: \"pc.local\" is not an address",
        ),
        (
            "[osc]\nlisten = \"0.0.0.0:9000\"\n",
            "line 2, column 10: [osc] allow lists no sender",
        ),
        (
            "[osc]\nlisten = \"0.0.0.0:9000\"\nallow = [\"10.0.0.1\"]\nfeedback = \"0.0.0.0:9001\"\n",
            "line 4, column 12: [osc] feedback = \"0.0.0.0:9001\" must name the address",
        ),
        (
            "[osc]\nlisten = \"0.0.0.0:9000\"\nallow = [\"10.0.0.1\"]\nmotion = \"yes\"\n",
            "line 4, column 10",
        ),
        (
            "[osc]\nlisten = \"0.0.0.0:9000\"\nallow = [\"127.0.0.1\"]\nfeedback = \"127.0.0.1:9000\"\n",
            "line 4, column 12: [osc] feedback = \"127.0.0.1:9000\" is the bridge's own OSC port",
        ),
        ("[osc]\nport = 9000\n", "line 2, column 1"),
    ] {
        let message = parse(text).expect_err(text).to_string();
        assert!(message.contains(expected), "{text}: {message}");
    }
}

#[test]
fn live_is_off_and_patches_the_matrix_from_universe_1_address_1_unless_told() {
    use floatball_shared::live::patch::{Patch, Profile};

    let config = parse("").expect("empty");
    assert!(!config.live.enabled);
    assert!(config.live.artnet && config.live.sacn);
    assert_eq!(config.live.hold_after_ms, live::DEFAULT_HOLD_AFTER_MS);
    assert_eq!(
        config.live.patch,
        Patch::matrix(100, Profile::default(), 1, 1).expect("matrix")
    );
    assert_eq!(
        config.live.summary(),
        "live input off (Art-Net and sACN; hold after 1000 ms): 100 balls patched on 1 \
         universe(s), universe 1; profile 16-bit position (2 channels)"
    );
    // 100 × 100 balls with the profile of a DMX winch, from universe 5 address 11,
    // and two balls apart, one with its own profile.
    let text = "[matrix]\nrows = 100\ncols = 100\n\n[live]\nenabled = true\nsacn = false\n\
                hold_after_ms = 250\nprofile = { speed_limit_bits = 16, enable = true }\n\
                matrix = { universe = 5, address = 11 }\n\n[[live.ball]]\nball = 9999\n\
                universe = 300\naddress = 1\n\n[[live.ball]]\nball = 17\nuniverse = 200\n\
                address = 7\nprofile = { colour = true }\n";
    let live = parse(&format!("{text}{}", hundred_gateways()))
        .expect("patched")
        .live;
    let profile = Profile {
        speed_limit_bits: Some(16),
        enable: true,
        colour: false,
    };
    let mut expected = Patch::matrix(10_000, profile, 5, 11).expect("matrix");
    expected.balls[9999].universe = 300;
    expected.balls[9999].address = 1;
    expected.balls[17].universe = 200;
    expected.balls[17].address = 7;
    expected.balls[17].profile = Some(Profile {
        colour: true,
        ..Profile::default()
    });
    assert_eq!(live.patch, expected);
    assert!(live.enabled && live.artnet && !live.sacn);
    assert_eq!(live.hold_after_ms, 250);
    assert_eq!(live.matrix_start, (5, 11));
    assert!(
        live.summary().contains(
            "10000 balls patched on 101 universe(s), universes 5–300; profile 16-bit position \
             + 16-bit speed limit + enable (5 channels) (1 with their own profile)"
        ),
        "{}",
        live.summary()
    );
}

#[test]
fn wrong_live_values_name_their_line_and_the_patch_is_checked_against_the_installation() {
    for (text, expected) in [
        (
            "[live]\nhold_after_ms = 10\n",
            "line 2, column 17: [live] hold_after_ms = 10 must be from 100 to 60000 ms",
        ),
        (
            "[live]\nprofile = { speed_limit_bits = 12 }\n",
            "line 2, column 32: [live] speed_limit_bits = 12 must be 8 or 16",
        ),
        (
            "[live]\nmatrix = { universe = 0, address = 1 }\n",
            "line 2, column 23: [live] matrix universe = 0 is outside 1–63999",
        ),
        (
            "[live]\nmatrix = { universe = 1 }\n",
            "line 2, column 10: [live] matrix needs a universe and an address",
        ),
        (
            "[live]\nmatrix = { universe = 1, address = 512 }\n",
            "line 2, column 10: [live] matrix: ball 0: 2 channels from address 512 pass slot 512",
        ),
        (
            "[live]\nmatrix = { universe = 63999, address = 1 }\n[matrix]\nrows = 20\ncols = 20\n",
            "line 2, column 10: [live] matrix: ball 256: universe 64000 is outside 1-63999",
        ),
        (
            "[[live.ball]]\nball = 100\nuniverse = 2\n",
            "line 2, column 8: [[live.ball]] ball = 100: the installation has balls 0–99",
        ),
        (
            "[[live.ball]]\nuniverse = 2\n",
            "line 1, column 1: [[live.ball]] needs the ball's number",
        ),
        (
            "[[live.ball]]\nball = 3\n[[live.ball]]\nball = 3\n",
            "line 4, column 8: [[live.ball]] ball = 3 is patched twice",
        ),
        (
            "[[live.ball]]\nball = 3\naddress = 513\n",
            "line 3, column 11: [live] address = 513 is outside 1–512",
        ),
        // Ball 5 moved onto ball 4's slots: found by the patch's own check, named at
        // the ball's entry.
        (
            "[[live.ball]]\nball = 5\naddress = 8\n",
            "line 1, column 1: [live] ball 5 and ball 3 share slots in universe 1 from address 8",
        ),
        ("[live]\nprotocol = \"artnet\"\n", "line 2, column 1"),
        ("[live]\nenabled = \"yes\"\n", "line 2, column 11"),
    ] {
        let message = parse(text).expect_err(text).to_string();
        assert!(message.contains(expected), "{text}: {message}");
    }
}

#[test]
fn a_patch_is_written_back_compactly_and_reads_back_as_it_was() {
    use floatball_shared::live::patch::{Patch, Profile};

    let text = "# the installer's words\n[matrix]\nrows = 100\ncols = 100 # a big one\n\n\
                [live]\nenabled = true # on\nmatrix = { universe = 1, address = 1 }\n\n\
                [[live.ball]]\nball = 3\nuniverse = 500\n";
    let profile = Profile {
        speed_limit_bits: Some(8),
        enable: false,
        colour: false,
    };
    let mut patch = Patch::matrix(10_000, profile, 7, 4).expect("matrix");
    patch.balls[42].universe = 1000;
    patch.balls[42].address = 1;
    patch.balls[43].profile = Some(Profile {
        speed_limit_bits: None,
        enable: true,
        colour: true,
    });
    patch.balls[43].universe = 1001;
    patch.balls[43].address = 1;
    let written = live::edit_patch(text, &patch, (1, 1)).expect("edited");
    assert!(
        written.starts_with("# the installer's words\n"),
        "{written}"
    );
    assert!(written.contains("cols = 100 # a big one"), "{written}");
    assert!(written.contains("enabled = true # on"), "{written}");
    assert!(
        written.contains("matrix = { universe = 7, address = 4 }"),
        "{written}"
    );
    assert!(!written.contains("universe = 500"), "{written}");
    assert_eq!(written.matches("[[live.ball]]").count(), 2, "{written}");
    assert!(written.lines().count() < 40, "{written}");
    let config = parse(&format!("{written}{}", hundred_gateways())).expect("reads back");
    assert_eq!(config.live.patch, patch);
    assert!(config.live.enabled);
    // Into a file without [live]: the table is added.
    let plain = Patch::matrix(100, Profile::default(), 3, 1).expect("matrix");
    let written = live::edit_patch("[matrix]\nrows = 10\n", &plain, (1, 1)).expect("edited");
    assert_eq!(
        written,
        "[matrix]\nrows = 10\n\n[live]\nmatrix = { universe = 3, address = 1 }\n"
    );
    assert_eq!(parse(&written).expect("reads back").live.patch, plain);
}

/// 100 simulated gateways: room for 10,000 balls.
fn hundred_gateways() -> String {
    "\n[[gateway]]\nport = \"sim\"\n".repeat(100)
}

#[test]
fn timecode_is_off_unless_a_source_is_given_and_checked() {
    use floatball_shared::timecode::chase::OnLoss;
    assert_eq!(parse("").expect("empty").timecode, None);
    let config = parse("[timecode]\nsource = \"artnet\"\nstart = \"10:00:00:00\"\n")
        .expect("artnet")
        .timecode
        .expect("on");
    assert_eq!(
        config.source,
        TimecodeSource::ArtNet("0.0.0.0:6454".parse().unwrap())
    );
    assert_eq!(config.start_ms, Some(36_000_000));
    assert_eq!(config.chase.on_loss, OnLoss::Hold);
    assert_eq!(config.chase.lead_ms, timecode::DEFAULT_LEAD_MS);
    let mtc = parse(
        "[timecode]\nsource = \"mtc\"\ndevice = \"/dev/snd/midiC1D0\"\nrate = \"29.97df\"\n\
         on_loss = \"stop\"\nloss_ms = 500\n",
    )
    .expect("mtc")
    .timecode
    .expect("on");
    assert_eq!(mtc.source.name(), "mtc");
    assert_eq!(mtc.chase.on_loss, OnLoss::Stop);
    assert_eq!(mtc.chase.loss_ms, 500);
    for (wrong, says) in [
        ("source = \"ltc\"\n", "line 2"),
        ("source = \"mtc\"\n", "needs device"),
        ("source = \"artnet\"\nrate = \"29\"\n", "line 3"),
        ("source = \"artnet\"\nstart = \"10:00:00:25\"\n", "line 3"),
        ("source = \"artnet\"\non_loss = \"pause\"\n", "line 3"),
        ("source = \"artnet\"\nloss_ms = 10\n", "line 3"),
        ("source = \"artnet\"\nlisten = \"6454\"\n", "line 3"),
    ] {
        let message = parse(&format!("[timecode]\n{wrong}"))
            .expect_err(wrong)
            .to_string();
        assert!(message.contains(says), "{wrong}: {message}");
    }
}

#[test]
fn live_receives_on_the_art_net_and_sacn_ports_unless_told() {
    let config = parse("").expect("empty");
    assert_eq!(config.live.artnet_listen, live::DEFAULT_ARTNET_LISTEN);
    assert_eq!(config.live.artnet_listen.to_string(), "0.0.0.0:6454");
    assert_eq!(config.live.sacn_listen.to_string(), "0.0.0.0:5568");
    assert!(config.live.sacn_interface.is_unspecified());
    let config = parse(
        "[live]\nartnet_listen = \"10.0.0.2:6454\"\nsacn_listen = \"10.0.0.2:5568\"\n\
         sacn_interface = \"10.0.0.2\"\n",
    )
    .expect("addresses");
    assert_eq!(config.live.artnet_listen.to_string(), "10.0.0.2:6454");
    assert_eq!(config.live.sacn_listen.to_string(), "10.0.0.2:5568");
    assert_eq!(config.live.sacn_interface.to_string(), "10.0.0.2");
    for (wrong, says) in [
        ("artnet_listen = \"6454\"\n", "line 2"),
        ("sacn_listen = \"somewhere\"\n", "line 2"),
        ("sacn_interface = \"eth0\"\n", "line 2"),
        ("enabled = true\nsacn_interface = \"::1\"\n", "line 3"),
    ] {
        let message = parse(&format!("[live]\n{wrong}"))
            .expect_err(wrong)
            .to_string();
        assert!(message.contains(says), "{wrong}: {message}");
    }
}
