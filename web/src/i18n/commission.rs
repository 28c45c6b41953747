//! The Commissioning page's words, which come with its chunk: its fixed strings
//! ([`CommissionText`]) and its sentences with values in them: a gateway's title, a
//! roll call's summary, a unit's fault in words, what identify and a line-speed
//! change did.

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

texts! {
    /// The Commissioning page's fixed strings: they come with its chunk.
    CommissionText;
    /// What the page is for.
    CommissionIntro => "找到每个单元，给它站号和它在网格中的位置。演出运行时这里的操作会被拒绝。", "Find every unit, give it its station and its place in the grid. While a show plays, the controller refuses what this page asks.";
    /// The installation could not be read (the reason follows).
    InstallationUnreadable => "无法读取安装配置：", "The installation could not be read:";
    /// A gateway whose units cannot be called (MBOX, MOONS').
    NotUim2503 => "只有 UIM2503 网关可以点名、分配站号和识别。", "Roll call, stations and identify are for UIM2503 gateways.";
    /// Ask every unit on the gateway.
    RollCall => "点名", "Roll call";
    /// Before the first roll call.
    NoRollCallYet => "尚未点名：点“点名”查找这个网关上的每个单元。", "No roll call yet: Roll call finds every unit on this gateway.";
    /// Column: station.
    Station => "站号", "Station";
    /// Column: position.
    Position => "位置", "Position";
    /// Column: how long ago it last answered.
    LastAnswer => "最后应答", "Last answer";
    /// Flag: more than one unit on this station.
    FlagDuplicated => "站号重复", "shared station";
    /// Flag: the station is not configured on this gateway.
    FlagUnexpected => "未配置", "not configured";
    /// Flag: the unit reported an error.
    FlagFault => "报错", "error";
    /// Stations several units answer on (a list follows).
    DuplicatedStations => "多个单元共用的站号：", "Stations several units answer on:";
    /// Configured stations nobody answered on (a list follows).
    MissingStations => "已配置但无应答的站号：", "Configured stations nobody answered on:";
    /// Stations that answered but are not configured (a list follows).
    UnexpectedStations => "有应答但未配置的站号：", "Stations that answered but are not configured:";
    /// A roll call with nothing wrong.
    RollCallClean => "每个配置的站号都有且只有一个单元应答。", "Every configured station answered, one unit each.";
    /// Give the units the gateway's stations by serial number.
    AssignAll => "按网格顺序全部分配", "Assign all in grid order";
    /// What "assign all" does.
    AssignAllNote => "序列号从小到大的单元依次获得本网关按单元格顺序配置的站号，然后重新点名。", "Units by ascending serial number get this gateway's configured stations in cell order; then a new roll call.";
    /// Give one unit the station typed.
    Assign => "分配", "Assign";
    /// The field of a unit's new station.
    NewStation => "新站号", "New station";
    /// A station that cannot be used.
    BadStation => "站号必须是 1 到 127 的整数", "A station is a whole number from 1 to 127";
    /// Move one ball down and back.
    Identify => "识别", "Identify";
    /// The field of how far Identify moves a ball (empty: the controller's default).
    IdentifyDistance => "识别时下移距离 (mm)", "Identify moves down (mm)";
    /// The identify distance is not a positive number.
    BadDistance => "距离必须是大于 0 的毫米数，留空则用默认值", "The distance is a number of mm above 0; leave it empty for the default";
    /// The grid's heading.
    GridSeenFromBelow => "网格（从下往上看）", "The grid, seen from below";
    /// How the grid works.
    GridHint => "点某个单元的“识别”，看哪个球在动，再点按它在网格中的格子。点按格子会让配置在那里的球移动。", "Tap a unit's Identify, watch which ball moves, then tap its cell in the grid. Tapping a cell moves the ball configured there.";
    /// Store the gateway's stations in the installation.
    SaveMapping => "保存映射", "Save mapping";
    /// The mapping was stored.
    MappingSaved => "映射已保存并已生效", "Mapping saved and applied";
    /// The gateway's line speed.
    LineSpeed => "线路速率", "Line speed";
    /// Start the guided line-speed change.
    ChangeLineSpeed => "更改速率", "Change line speed";
    /// What the guided change does, before it starts.
    BaudPowerCycle => "应用会向网关发送 BDR 命令。真实网关要在断电再上电后才使用新速率：开始后请关掉网关电源再打开，应用会等待它以新速率应答。模拟网关会自行重启。失败时恢复原速率。", "The app sends the gateway BDR. A real gateway takes the new speed only after a restart: once this starts, switch the gateway off and on again while the app waits for it to answer at the new speed. A simulated gateway restarts by itself. If it does not answer, the old speed is restored.";
    /// Confirm the line-speed change.
    StartBaudChange => "开始更改", "Start the change";
    /// While the app waits for the gateway.
    BaudWaiting => "现在请将网关断电再上电。正在等待网关以新速率应答…", "Switch the gateway off and on now. Waiting for it to answer at the new speed…";
}
