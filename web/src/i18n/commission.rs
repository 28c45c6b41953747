//! The Commissioning page's sentences with values in them (its fixed strings are
//! [`super::Text`] variants): a gateway's title, a roll call's summary, a unit's fault
//! in words, what identify and a line-speed change did.

use floatball_shared::api::{BaudChanged, GatewayKind, Identifying, RollCall, UnitFault};
use floatball_shared::uim2503::feedback::UnitError;

use super::Lang;

impl Lang {
    /// A gateway's heading: its number from 1, its port and, for other families, its
    /// kind.
    pub fn gateway_title(self, index: usize, port: &str, kind: GatewayKind) -> String {
        let family = match kind {
            GatewayKind::Uim2503 => "",
            GatewayKind::Mbox => " · MBOX",
            GatewayKind::Scl => " · SCL",
        };
        match self {
            Lang::Zh => format!("网关 {} · {port}{family}", index + 1),
            Lang::En => format!("Gateway {} · {port}{family}", index + 1),
        }
    }

    /// How many units a roll call found and how long it took.
    pub fn roll_call_summary(self, roll: &RollCall) -> String {
        let units = roll.units.len();
        let seconds = roll.took_ms as f64 / 1000.0;
        match self {
            Lang::Zh => format!("找到 {units} 个单元（用时 {seconds:.1} 秒）"),
            Lang::En => format!("{units} units answered (in {seconds:.1} s)"),
        }
    }

    /// A unit's last error in words (the `ER` frame decoded through its code).
    pub fn unit_fault(self, fault: &UnitFault) -> String {
        self.error_of(&UnitError {
            error: fault.error,
            code: fault.code,
            index: fault.index,
        })
    }

    /// A list of stations: `5, 7, 12`.
    pub fn station_list(self, stations: &[u8]) -> String {
        let separator = match self {
            Lang::Zh => "、",
            Lang::En => ", ",
        };
        stations
            .iter()
            .map(u8::to_string)
            .collect::<Vec<_>>()
            .join(separator)
    }

    /// Units were given stations; a new roll call follows.
    pub fn assigned(self, count: usize) -> String {
        match self {
            Lang::Zh => format!("已为 {count} 个单元分配站号"),
            Lang::En => format!("{count} units were given their stations"),
        }
    }

    /// A ball moves after Identify: which, how far, and what to do next.
    pub fn identifying(self, moving: &Identifying) -> String {
        let (station, distance_mm) = (moving.station, moving.distance_mm);
        match self {
            Lang::Zh => format!(
                "站号 {station} 的球下移 {distance_mm:.0} mm 再返回：请点按它在网格中的格子"
            ),
            Lang::En => format!(
                "The ball of station {station} moves {distance_mm:.0} mm down and back: tap its cell in the grid"
            ),
        }
    }

    /// A cell's label for screen readers: its row and column and its station.
    pub fn cell_label(self, row: usize, col: usize, station: u8) -> String {
        match self {
            Lang::Zh => format!("第 {} 行第 {} 列，站号 {station}", row + 1, col + 1),
            Lang::En => format!("row {}, column {}: station {station}", row + 1, col + 1),
        }
    }

    /// How many cells were placed by tapping, of how many.
    pub fn placed_cells(self, placed: usize, total: usize) -> String {
        match self {
            Lang::Zh => format!("已放置 {placed} / {total} 个格子"),
            Lang::En => format!("{placed} of {total} cells placed"),
        }
    }

    /// The line's speed now.
    pub fn line_speed(self, baud: Option<u32>) -> String {
        match (self, baud) {
            (Lang::Zh, Some(baud)) => format!("当前 {baud} 波特"),
            (Lang::En, Some(baud)) => format!("now {baud} baud"),
            (Lang::Zh, None) => "当前速率未知".to_owned(),
            (Lang::En, None) => "speed unknown".to_owned(),
        }
    }

    /// The guided line-speed change succeeded.
    pub fn baud_changed(self, changed: &BaudChanged) -> String {
        let seconds = changed.took_ms as f64 / 1000.0;
        let (from, to) = (changed.from_baud, changed.baud);
        match self {
            Lang::Zh => format!(
                "网关已以 {to} 波特应答（原为 {from} 波特，用时 {seconds:.1} 秒），配置已更新"
            ),
            Lang::En => format!(
                "The gateway answers at {to} baud (was {from} baud; after {seconds:.1} s); the configuration says so"
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use wasm_bindgen_test::wasm_bindgen_test;

    use super::*;

    #[wasm_bindgen_test(unsupported = test)]
    fn faults_read_in_words_in_both_languages() {
        let fault = UnitFault {
            station: 7,
            error: 0x40,
            code: 0,
            index: 0,
        };
        let zh = Lang::Zh.unit_fault(&fault);
        let en = Lang::En.unit_fault(&fault);
        assert!(en.contains("cannot follow") && en.contains("0x40"), "{en}");
        assert!(zh.contains("跟不上") && zh.contains("0x40"), "{zh}");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn sentences_carry_their_values() {
        let changed = BaudChanged {
            from_baud: 9600,
            baud: 115_200,
            took_ms: 1_260,
        };
        assert!(Lang::En.baud_changed(&changed).contains("115200 baud"));
        assert!(Lang::Zh.baud_changed(&changed).contains("1.3 秒"));
        assert_eq!(Lang::En.station_list(&[5, 7]), "5, 7");
        assert_eq!(Lang::Zh.station_list(&[5, 7]), "5、7");
        assert_eq!(
            Lang::En.gateway_title(0, "sim", GatewayKind::Uim2503),
            "Gateway 1 · sim"
        );
        let moving = Identifying {
            station: 12,
            distance_mm: 300.0,
            duration_ms: 4000,
        };
        assert!(
            Lang::En
                .identifying(&moving)
                .contains("station 12 moves 300 mm")
        );
        assert_eq!(Lang::En.cell_label(0, 2, 3), "row 1, column 3: station 3");
    }
}
