//! The Patch page's sentences with values in them (its fixed strings are
//! [`super::Text`] variants): a profile's channels, the live settings read from the
//! file, the patch's summary, a ball's place and the table's page.

use floatball_shared::api::LivePatch;
use floatball_shared::live::patch::Profile;

use super::Lang;

texts! {
    /// The Patch page's fixed strings: they come with its chunk.
    PatchText;
    /// The patch could not be loaded.
    PatchUnavailable => "无法读取配接表（需要登录并连接控制器）", "The patch cannot be loaded (log in and connect to the controller)";
    /// The profile card's heading.
    PatchProfile => "通道配置", "Profile";
    /// The speed-limit channel's choice.
    PatchSpeedLimit => "限速通道", "Speed-limit channel";
    /// No speed-limit channel.
    PatchSpeedNone => "无", "None";
    /// An 8-bit speed-limit channel.
    PatchSpeed8 => "8 位", "8-bit";
    /// A 16-bit speed-limit channel.
    PatchSpeed16 => "16 位", "16-bit";
    /// The enable channel's checkbox.
    PatchEnable => "使能通道", "Enable channel";
    /// The colour channels' checkbox.
    PatchColour => "颜色通道（红、绿、蓝）", "Colour channels (red, green, blue)";
    /// The whole-matrix card's heading.
    PatchWholeMatrix => "整体配接", "Whole matrix";
    /// The universe field.
    PatchUniverse => "域", "Universe";
    /// The address field.
    PatchAddress => "地址", "Address";
    /// The one-tap button.
    PatchWholeMatrixButton => "从该域和地址起逐行配接整个矩阵", "Patch the whole matrix from this universe and address, row by row";
    /// The universes card's heading.
    PatchUniverses => "使用的域", "Universes in use";
    /// The ball table's heading.
    PatchBalls => "各球", "Balls";
    /// Column: ball.
    PatchBall => "球", "Ball";
    /// Column: row, column.
    PatchRowCol => "行, 列", "Row, col";
    /// Column: the balls of a universe.
    PatchBallsIn => "球", "Balls";
    /// Column: slots.
    PatchSlots => "通道", "Slots";
    /// The previous page of the table.
    PatchPrevious => "上一页", "Previous";
    /// The next page of the table.
    PatchNext => "下一页", "Next";
    /// The save button.
    PatchSave => "保存配接表", "Save the patch";
    /// Saved.
    PatchSaved => "配接表已保存", "Patch saved";
    /// Problems the app finds before saving.
    PatchProblems => "配接表有以下问题：", "The patch has these problems:";
    /// The receivers come later.
    PatchLater => "Art-Net 与 sACN 接收器和实时模式将在下一步提供；配接表现在即可保存和检查。", "The Art-Net and sACN receivers and live mode come in a later step; the patch is saved and checked now.";
    /// A ball's own profile in the table.
    PatchOwnProfile => "（单独）", " (its own)";
}

impl Lang {
    /// A profile's channels in their order from the start address, and how many.
    pub fn profile_channels(self, profile: Profile) -> String {
        let zh = self == Lang::Zh;
        let mut channels: Vec<&str> = if zh {
            vec!["位置（高）", "位置（低）"]
        } else {
            vec!["position (coarse)", "position (fine)"]
        };
        match profile.speed_limit_bits {
            Some(16) if zh => channels.extend(["限速（高）", "限速（低）"]),
            Some(16) => channels.extend(["speed limit (coarse)", "speed limit (fine)"]),
            Some(_) if zh => channels.push("限速"),
            Some(_) => channels.push("speed limit"),
            None => {}
        }
        if profile.enable {
            channels.push(if zh { "使能" } else { "enable" });
        }
        if profile.colour {
            channels.extend(if zh {
                ["红", "绿", "蓝"]
            } else {
                ["red", "green", "blue"]
            });
        }
        let count = profile.footprint();
        if zh {
            format!("{count} 个通道：{}", channels.join("、"))
        } else {
            format!("{count} channels: {}", channels.join(", "))
        }
    }

    /// The `[live]` settings read from `floatball.toml`.
    pub fn live_settings(self, live: &LivePatch) -> String {
        let protocols: Vec<&str> = [(live.artnet, "Art-Net"), (live.sacn, "sACN")]
            .into_iter()
            .filter_map(|(on, name)| on.then_some(name))
            .collect();
        let protocols = protocols.join(" + ");
        let hold = live.hold_after_ms;
        match (self, live.enabled) {
            (Lang::Zh, true) => format!("实时输入：开 · {protocols} · 信号中断 {hold} ms 后保持"),
            (Lang::Zh, false) => {
                format!(
                    "实时输入：关（floatball.toml 中的 [live] enabled）· {protocols} · 信号中断 {hold} ms 后保持"
                )
            }
            (Lang::En, true) => {
                format!("Live input on · {protocols} · hold after {hold} ms of lost input")
            }
            (Lang::En, false) => format!(
                "Live input off ([live] enabled in floatball.toml) · {protocols} · hold after {hold} ms of lost input"
            ),
        }
    }

    /// How many balls are patched on how many universes.
    pub fn patch_summary(self, balls: usize, universes: usize) -> String {
        match self {
            Lang::Zh => format!("{balls} 个球，使用 {universes} 个域"),
            Lang::En => format!("{balls} balls on {universes} universe(s)"),
        }
    }

    /// A ball's place: `r, c` (from 1).
    pub fn ball_place(self, ball: usize, cols: u32) -> String {
        let cols = (cols as usize).max(1);
        format!("{}, {}", ball / cols + 1, ball % cols + 1)
    }

    /// The table's page, from 1.
    pub fn table_page(self, page: usize, pages: usize) -> String {
        match self {
            Lang::Zh => format!("第 {page} / {pages} 页"),
            Lang::En => format!("Page {page} of {pages}"),
        }
    }
}
