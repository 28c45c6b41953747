//! Writing `floatball.toml` from an [`InstallationInfo`] (`PUT /api/installation`, a
//! gateway's new line speed) without losing what the installer wrote: `toml_edit`
//! changes only the keys whose value changes and keeps every comment, every other
//! key and the order of the file.
//!
//! - `[matrix]`: rows, cols, pitch, travel, calibration, limits and home;
//!   `[safety] approach_speed_mm_s`.
//! - `[[gateway]]`, UIM2503 gateways: `kind` (only when already written or not
//!   `uim2503`), `port`, `baud` (when already written or not the port's default), and
//!   the stations: `first_station` and `units` when they are consecutive, else a
//!   `stations = [...]` list (the other form is removed). Tables are added or removed
//!   at the end to match the number of gateways.
//! - MBOX boxes and MOONS' drives' entries are left as they are: their tables hold
//!   more than [`InstallationInfo`] says (addresses, axes, calibration), so the caller
//!   refuses a change to them ([`gateways_changed`]).
//!
//! A key is written when it is in the file already or its new value differs from
//! what the bridge runs with (for a key left out: its default), so a file that
//! leaves defaults out still does.
//!
//! The caller checks the text this returns with [`super::Config::parse_all`] before it
//! saves it ([`crate::durable::write_atomic`]).

use floatball_shared::api::{GatewayKind, InstallationGateway, InstallationInfo};
use floatball_shared::plan::installation::{DriveKind, SIM_PORT};
use toml_edit::{Array, ArrayOfTables, DocumentMut, Item, Table, TableLike, Value};

use super::{DEFAULT_SERIAL_BAUD, DEFAULT_SIM_BAUD};

/// Why the file cannot be edited.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EditError {
    /// The file on disk is not TOML (edited by hand since the start?).
    #[error("floatball.toml cannot be read as TOML: {0}")]
    NotToml(String),
    /// A key the edit must write holds something that is not a table.
    #[error("floatball.toml: {0} is not a table")]
    NotATable(&'static str),
}

/// Whether `new` changes the gateways of an installation of MBOX boxes or MOONS'
/// drives (`current`): those are not written ([`installation`]), so such a change is
/// refused by the caller. UIM2503 installations: always `false`.
#[must_use]
pub fn gateways_changed(current: &InstallationInfo, new: &InstallationInfo) -> bool {
    let fixed = current
        .gateways
        .iter()
        .chain(&new.gateways)
        .any(|gateway| gateway.kind != GatewayKind::Uim2503);
    fixed && current.gateways != new.gateways
}

/// `text` (the file as it is) with `new` written in; `current` is what the bridge
/// runs with now.
///
/// # Errors
/// [`EditError`]: `text` is not TOML, or a section the edit writes is not a table.
pub fn installation(
    text: &str,
    current: &InstallationInfo,
    new: &InstallationInfo,
) -> Result<String, EditError> {
    let mut document: DocumentMut = text
        .parse()
        .map_err(|error: toml_edit::TomlError| EditError::NotToml(error.to_string()))?;
    let had: Vec<bool> = ["matrix", "safety", "gateway"]
        .iter()
        .map(|key| document.contains_key(key))
        .collect();
    let matrix = section(&mut document, "matrix")?;
    let integers = [
        ("rows", current.rows, new.rows),
        ("cols", current.cols, new.cols),
    ];
    for (key, was, now) in integers {
        set(matrix, key, was != now, Value::from(i64::from(now)));
    }
    let floats = [
        ("pitch_mm", current.pitch_mm, new.pitch_mm),
        ("travel_mm", current.travel_mm, new.travel_mm),
        ("counts_per_mm", current.counts_per_mm, new.counts_per_mm),
        ("max_speed_mm_s", current.max_speed_mm_s, new.max_speed_mm_s),
        (
            "max_accel_mm_s2",
            current.max_accel_mm_s2,
            new.max_accel_mm_s2,
        ),
        ("home_mm", current.home_mm, new.home_mm),
    ];
    for (key, was, now) in floats {
        set(
            matrix,
            key,
            was.to_bits() != now.to_bits(),
            Value::from(now),
        );
    }
    let safety = section(&mut document, "safety")?;
    set(
        safety,
        "approach_speed_mm_s",
        current.approach_speed_mm_s.to_bits() != new.approach_speed_mm_s.to_bits(),
        Value::from(new.approach_speed_mm_s),
    );
    let fixed = current
        .gateways
        .iter()
        .any(|gateway| gateway.kind != GatewayKind::Uim2503);
    let implicit_kept = !document.contains_key("gateway") && new.gateways == current.gateways;
    if !fixed && !implicit_kept {
        gateways(&mut document, current, new)?;
    }
    // A section made for nothing stays out.
    for (key, had) in ["matrix", "safety", "gateway"].into_iter().zip(had) {
        let empty = document.get(key).is_some_and(|item| {
            item.as_table_like().is_some_and(TableLike::is_empty)
                || item
                    .as_array_of_tables()
                    .is_some_and(ArrayOfTables::is_empty)
        });
        if !had && empty {
            document.remove(key);
        }
    }
    Ok(document.to_string())
}

/// `text` with gateway `gateway`'s `baud` set (a UIM2503 gateway's new line speed).
///
/// # Errors
/// As [`installation`].
pub fn baud(
    text: &str,
    current: &InstallationInfo,
    gateway: usize,
    baud: u32,
) -> Result<String, EditError> {
    let mut new = current.clone();
    if let Some(one) = new.gateways.get_mut(gateway) {
        one.baud = Some(baud);
    }
    installation(text, current, &new)
}

/// The table `name` of the document, made if missing.
fn section<'a>(
    document: &'a mut DocumentMut,
    name: &'static str,
) -> Result<&'a mut dyn TableLike, EditError> {
    document
        .entry(name)
        .or_insert_with(|| Item::Table(Table::new()))
        .as_table_like_mut()
        .ok_or(EditError::NotATable(name))
}

/// Writes `value` at `key` when the key is in the table already or `changed`; an
/// existing value keeps its place and its comments.
fn set(table: &mut dyn TableLike, key: &str, changed: bool, mut value: Value) {
    match table.get_mut(key) {
        Some(item) => {
            if let Some(old) = item.as_value() {
                *value.decor_mut() = old.decor().clone();
            }
            *item = Item::Value(value);
        }
        None if changed => {
            table.insert(key, Item::Value(value));
        }
        None => {}
    }
}

/// The `[[gateway]]` tables of a UIM2503 installation made to say `new`'s gateways.
fn gateways(
    document: &mut DocumentMut,
    current: &InstallationInfo,
    new: &InstallationInfo,
) -> Result<(), EditError> {
    let tables = document
        .entry("gateway")
        .or_insert_with(|| Item::ArrayOfTables(ArrayOfTables::new()))
        .as_array_of_tables_mut()
        .ok_or(EditError::NotATable("gateway"))?;
    while tables.len() > new.gateways.len() {
        tables.remove(tables.len() - 1);
    }
    for (index, gateway) in new.gateways.iter().enumerate() {
        let fresh = tables.get(index).is_none();
        if fresh {
            tables.push(Table::new());
        }
        let Some(table) = tables.get_mut(index) else {
            continue;
        };
        // The only gateway serving every unit needs no count (its default share).
        let sole = new.gateways.len() == 1 && gateway.stations.len() == new.unit_count();
        let was = current.gateways.get(index).filter(|_| !fresh);
        gateway_table(table, was, gateway, sole);
    }
    Ok(())
}

/// One `[[gateway]]` table made to say `new`; `was` is what the bridge runs with
/// (`None`: a new table); `sole`: the installation's only gateway, serving every
/// unit (no `units` needed).
fn gateway_table(
    table: &mut Table,
    was: Option<&InstallationGateway>,
    new: &InstallationGateway,
    sole: bool,
) {
    let kind = GatewayKind::Uim2503;
    set(
        table,
        "kind",
        new.kind != kind,
        Value::from(kind_name(new.kind)),
    );
    set(
        table,
        "port",
        was.is_none_or(|was| was.port != new.port),
        Value::from(new.port.as_str()),
    );
    let default_baud = if new.port == SIM_PORT {
        DEFAULT_SIM_BAUD
    } else {
        DEFAULT_SERIAL_BAUD
    };
    let baud = new.baud.unwrap_or(default_baud);
    set(
        table,
        "baud",
        baud != default_baud,
        Value::from(i64::from(baud)),
    );
    // A key of the other form goes, its comments go to the key written instead.
    match consecutive(&new.stations) {
        Some((first, units)) => {
            let comments = take(table, "stations");
            set(
                table,
                "first_station",
                first != 1 || !comments.is_empty(),
                Value::from(i64::from(first)),
            );
            give(table, "first_station", &comments);
            set(
                table,
                "units",
                !sole,
                Value::from(i64::try_from(units).unwrap_or(i64::MAX)),
            );
        }
        None => {
            let comments = take(table, "first_station") + &take(table, "units");
            let list: Array = new.stations.iter().map(|&s| i64::from(s)).collect();
            set(table, "stations", true, Value::Array(list));
            give(table, "stations", &comments);
        }
    }
}

/// Removes `key` from `table`, returning the comments above it.
fn take(table: &mut Table, key: &str) -> String {
    let comments = table
        .key(key)
        .and_then(|key| key.leaf_decor().prefix())
        .and_then(|prefix| prefix.as_str())
        .unwrap_or_default()
        .to_owned();
    table.remove(key);
    comments
}

/// Puts `comments` above `key` (before its own).
fn give(table: &mut Table, key: &str, comments: &str) {
    if comments.is_empty() {
        return;
    }
    if let Some(mut key) = table.key_mut(key) {
        let own = key
            .leaf_decor()
            .prefix()
            .and_then(|prefix| prefix.as_str())
            .unwrap_or_default()
            .to_owned();
        key.leaf_decor_mut().set_prefix(format!("{comments}{own}"));
    }
}

/// A gateway kind as `kind = "…"` names it.
fn kind_name(kind: GatewayKind) -> &'static str {
    match kind {
        GatewayKind::Uim2503 => DriveKind::Uim2503.name(),
        GatewayKind::Mbox => DriveKind::Mbox.name(),
        GatewayKind::Scl => DriveKind::Scl.name(),
    }
}

/// `(first station, units)` when `stations` count up by one from the first.
fn consecutive(stations: &[u8]) -> Option<(u8, usize)> {
    let first = *stations.first()?;
    stations
        .iter()
        .enumerate()
        .all(|(index, &station)| usize::from(station) == usize::from(first) + index)
        .then_some((first, stations.len()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Config, DEFAULT_FILE, Overrides};
    use std::path::Path;

    fn info(text: &str) -> InstallationInfo {
        let config =
            Config::parse(Path::new("t.toml"), text, &Overrides::default()).expect("a valid file");
        crate::install::info(&config.installation)
    }

    #[test]
    fn an_unchanged_installation_leaves_the_file_as_it_was() {
        let current = info(DEFAULT_FILE);
        let text = installation(DEFAULT_FILE, &current, &current).expect("edit");
        assert_eq!(text, DEFAULT_FILE);
        let sparse = "# mine\n[matrix]\nrows = 2 # two rows\ncols = 3\n";
        let current = info(sparse);
        assert_eq!(
            installation(sparse, &current, &current).expect("edit"),
            sparse
        );
    }

    #[test]
    fn changed_values_are_written_in_place_keeping_comments_and_other_keys() {
        let text = "# the hall\nlisten = \"127.0.0.1:9\"\n[matrix]\nrows = 2 # two rows\n\
                    cols = 3\n\n[uploads]\nmax_duration = \"1h\"\n";
        let current = info(text);
        let mut new = current.clone();
        new.rows = 3;
        new.max_speed_mm_s = 1500.0;
        new.approach_speed_mm_s = 100.0;
        new.gateways[0].stations = (1..=9).collect();
        let edited = installation(text, &current, &new).expect("edit");
        assert!(edited.contains("# the hall\n"), "{edited}");
        assert!(edited.contains("rows = 3 # two rows\n"), "{edited}");
        assert!(edited.contains("max_speed_mm_s = 1500.0"), "{edited}");
        assert!(edited.contains("max_duration = \"1h\""), "{edited}");
        assert!(edited.contains("approach_speed_mm_s = 100.0"), "{edited}");
        // Keys left at their default stay out.
        assert!(!edited.contains("travel_mm"), "{edited}");
        assert_eq!(info(&edited), new);
    }

    #[test]
    fn stations_out_of_order_become_a_list_and_back() {
        let current = info(DEFAULT_FILE);
        let mut new = current.clone();
        new.gateways[0].stations.swap(0, 1);
        let listed = installation(DEFAULT_FILE, &current, &new).expect("edit");
        assert!(listed.contains("stations = [2, 1, 3, 4,"), "{listed}");
        assert!(!listed.contains("\nfirst_station"), "{listed}");
        // The comment about the list is kept.
        assert!(listed.contains("# stations = [1, 2, 3]"), "{listed}");
        assert!(listed.contains("# baud = 9600\n"), "{listed}");
        assert!(listed.contains("# Station number of"), "{listed}");
        assert_eq!(info(&listed), new);
        let back = installation(&listed, &new, &current).expect("edit");
        assert!(!back.contains("\nstations ="), "{back}");
        assert!(back.contains("first_station = 1"), "{back}");
        assert!(back.contains("# Station number of"), "{back}");
        assert_eq!(info(&back), current);
    }

    #[test]
    fn gateways_are_added_and_removed_at_the_end() {
        let current = info(DEFAULT_FILE);
        let mut two = current.clone();
        two.gateways[0].stations = (1..=50).collect();
        two.gateways.push(InstallationGateway {
            kind: GatewayKind::Uim2503,
            port: "/dev/ttyUSB1".into(),
            baud: Some(57_600),
            stations: (1..=50).collect(),
        });
        let text = installation(DEFAULT_FILE, &current, &two).expect("edit");
        assert!(text.contains("port = \"/dev/ttyUSB1\""), "{text}");
        assert!(text.contains("baud = 57600"), "{text}");
        assert_eq!(info(&text), two);
        let one = installation(&text, &two, &current).expect("edit");
        assert!(!one.contains("ttyUSB1"), "{one}");
        assert_eq!(info(&one), current);
    }

    #[test]
    fn network_ports_are_written_and_read_back() {
        let current = info(DEFAULT_FILE);
        let mut two = current.clone();
        two.gateways[0].stations = (1..=50).collect();
        for port in ["tcp://192.168.1.50:4001", "rfc2217://[fd00::5]:4002"] {
            two.gateways.truncate(1);
            two.gateways.push(InstallationGateway {
                kind: GatewayKind::Uim2503,
                port: port.into(),
                baud: Some(115_200),
                stations: (1..=50).collect(),
            });
            let text = installation(DEFAULT_FILE, &current, &two).expect("edit");
            assert!(text.contains(&format!("port = \"{port}\"")), "{text}");
            assert_eq!(info(&text), two);
        }
    }

    #[test]
    fn a_baud_is_written_and_a_default_one_left_out() {
        let current = info(DEFAULT_FILE);
        let text = baud(DEFAULT_FILE, &current, 0, 9600).expect("edit");
        assert!(text.contains("\nbaud = 9600\n"), "{text}");
        assert!(text.contains("# baud = 9600\n"), "{text}");
        assert_eq!(info(&text).gateways[0].baud, Some(9600));
        assert_eq!(
            baud(DEFAULT_FILE, &current, 0, DEFAULT_SIM_BAUD).expect("edit"),
            DEFAULT_FILE
        );
    }

    #[test]
    fn a_file_that_is_not_toml_is_refused() {
        let current = info(DEFAULT_FILE);
        assert!(matches!(
            installation("[matrix\n", &current, &current),
            Err(EditError::NotToml(_))
        ));
        assert_eq!(
            installation("matrix = 3\n", &current, &current),
            Err(EditError::NotATable("matrix"))
        );
    }

    #[test]
    fn mbox_gateways_are_not_written_and_their_change_is_seen() {
        let text = "[matrix]\nrows = 1\ncols = 3\n[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n";
        let current = info(text);
        let mut new = current.clone();
        new.max_speed_mm_s = 1000.0;
        assert!(!gateways_changed(&current, &new));
        let edited = installation(text, &current, &new).expect("edit");
        assert!(edited.ends_with("axes = 3\n"), "{edited}");
        new.gateways[0].stations = vec![3, 2, 1];
        assert!(gateways_changed(&current, &new));
    }
}
