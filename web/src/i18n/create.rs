//! The Create page's fixed strings ([`CreateText`]) and its words that come from the
//! show-creation catalogue ([`floatball_shared::create::PATTERNS`]): each pattern's
//! name and help, each parameter's label, each choice's word, in both languages
//! (English is the catalogue's own); the notes of what was changed to keep within
//! the limits, and why a show cannot be made. A test checks that every pattern,
//! parameter and choice of the catalogue has its Chinese here.

use floatball_shared::create::{Change, CreateError, Note, ParamSpec, number};

use super::Lang;

/// Chinese name and help of each pattern.
const PATTERNS_ZH: &[(&str, &str, &str)] = &[
    ("wave", "波浪", "正弦波浪横穿整个矩阵。"),
    ("ripple", "涟漪", "从一点向外扩散的圆环，越远越弱。"),
    ("rain", "雨滴", "雨滴随机落下，每一滴把附近的球按下片刻。"),
    ("plane", "倾斜平面", "一个倾斜的平面，倾斜方向绕中心旋转。"),
    ("breathe", "呼吸", "整个表面缓慢起伏，中间拱起。"),
    ("noise", "起伏地形", "平滑的山丘和洼地，缓缓漂移和变化。"),
    (
        "text",
        "文字",
        "用凸起或凹下的球组成文字或点阵，静止或滚动。",
    ),
    (
        "image",
        "图片",
        "把 PNG 或 JPEG 图片变成高度：亮处高，暗处低。",
    ),
];

/// Chinese label of each parameter, by key (the same key means the same in every
/// pattern).
const PARAMS_ZH: &[(&str, &str)] = &[
    ("amplitude_mm", "幅度"),
    ("angle_deg", "倾角"),
    ("balls_per_pixel", "每点用球数"),
    ("base_mm", "底面高度"),
    ("bitmap", "自定义点阵"),
    ("centre_mm", "中间高度"),
    ("change_hz", "变化快慢"),
    ("damping_per_m", "衰减"),
    ("depth_mm", "深度"),
    ("direction", "方向"),
    ("dome_mm", "中间拱起"),
    ("drift_m_s", "漂移速度"),
    ("drop_s", "每滴时长"),
    ("drops_per_s", "每秒雨滴数"),
    ("fit", "适配"),
    ("high_mm", "最高位置"),
    ("image", "图片"),
    ("invert", "反转"),
    ("low_mm", "最低位置"),
    ("motion", "动作幅度"),
    ("period_s", "周期"),
    ("radius_m", "半径"),
    ("reveal_s", "显现时间"),
    ("scale_m", "尺度"),
    ("scroll_m_s", "滚动速度"),
    ("seed", "随机种子"),
    ("size_mm", "大小"),
    ("slope_mm_m", "坡度"),
    ("speed_m_s", "速度"),
    ("style", "样式"),
    ("text", "文字"),
    ("turns_per_min", "每分钟转数"),
    ("wavelength_m", "波长"),
    ("x_m", "中心 X"),
    ("y_m", "中心 Y"),
];

/// Chinese of each choice's word.
const CHOICES_ZH: &[(&str, &str)] = &[
    ("right", "向右"),
    ("left", "向左"),
    ("back", "向后"),
    ("front", "向前"),
    ("raised", "凸起"),
    ("lowered", "凹下"),
    ("contain", "完整显示"),
    ("cover", "铺满"),
    ("no", "否"),
    ("yes", "是"),
];

fn lookup<'a>(table: &'a [(&str, &str)], key: &str) -> Option<&'a str> {
    table.iter().find(|(k, _)| *k == key).map(|(_, zh)| *zh)
}

/// A pattern's name (`label`) or help for people: the catalogue's English, or its
/// Chinese; the name itself for a pattern the catalogue does not know.
fn pattern_words(lang: Lang, name: &str, label: bool) -> String {
    let zh = PATTERNS_ZH.iter().find(|(n, _, _)| *n == name);
    match (lang, zh, floatball_shared::create::pattern(name)) {
        (Lang::Zh, Some((_, zh_label, zh_help)), _) => {
            (*if label { zh_label } else { zh_help }).to_owned()
        }
        (_, _, Some(spec)) => (if label { spec.label } else { spec.help }).to_owned(),
        _ if label => name.to_owned(),
        _ => String::new(),
    }
}

/// A pattern's name for people.
pub fn pattern(lang: Lang, name: &str) -> String {
    pattern_words(lang, name, true)
}

/// What a pattern does, in one sentence.
pub fn pattern_help(lang: Lang, name: &str) -> String {
    pattern_words(lang, name, false)
}

/// A parameter's label.
pub fn param(lang: Lang, _pattern: &str, spec: &ParamSpec) -> String {
    match lang {
        Lang::Zh => lookup(PARAMS_ZH, spec.key).unwrap_or(spec.label).to_owned(),
        Lang::En => spec.label.to_owned(),
    }
}

/// A choice's word.
pub fn choice(lang: Lang, word: &str) -> String {
    match lang {
        Lang::Zh => lookup(CHOICES_ZH, word).unwrap_or(word).to_owned(),
        Lang::En => word.to_owned(),
    }
}

/// The label of `key` in `pattern` (a parameter, or a segment's own duration or
/// blend).
fn key_label(lang: Lang, pattern: &str, key: &str) -> String {
    match (key, lang) {
        ("duration_s", Lang::Zh) => "时长".to_owned(),
        ("duration_s", Lang::En) => "duration".to_owned(),
        ("transition_s", Lang::Zh) => "过渡".to_owned(),
        ("transition_s", Lang::En) => "blend".to_owned(),
        _ => floatball_shared::create::pattern(pattern)
            .and_then(|spec| spec.param(key))
            .map_or_else(
                || match lang {
                    Lang::Zh => lookup(PARAMS_ZH, key).unwrap_or(key).to_owned(),
                    Lang::En => key.to_owned(),
                },
                |spec| param(lang, pattern, spec),
            ),
    }
}

/// What was changed to keep within the limits, and which parameter to change.
pub fn note(lang: Lang, note: &Note) -> String {
    let label = key_label(lang, &note.pattern, &note.key);
    let pattern = pattern(lang, &note.pattern);
    let segment = note.segment + 1;
    match (&note.change, lang) {
        (Change::Number { from, to, unit }, Lang::Zh) => format!(
            "第 {segment} 段（{pattern}）：{label} 已从 {} 改为 {} {unit}，以保持在限值之内；要更大的动作，请调整这一项或其他参数。",
            number(*from),
            number(*to)
        ),
        (Change::Number { from, to, unit }, Lang::En) => format!(
            "segment {segment} ({pattern}): {label} changed from {} to {} {unit} {}",
            number(*from),
            number(*to),
            note.reason
        ),
        (Change::NotInFont { chars }, Lang::Zh) => format!(
            "第 {segment} 段（{pattern}）：{label} 中的“{chars}”不在内置字库中，显示为 ?；请用“{}”参数绘制它们（由 # 与 . 组成的行）。",
            key_label(lang, &note.pattern, "bitmap")
        ),
        (Change::NotInFont { chars }, Lang::En) => format!(
            "segment {segment} ({pattern}): {label}: {chars} not in the built-in font, drawn as ? (draw them with the {} parameter: lines of # and .)",
            key_label(lang, &note.pattern, "bitmap")
        ),
        (Change::Cropped { across, deep }, Lang::Zh) => format!(
            "第 {segment} 段（{pattern}）：{label}{}，只显示中间部分；请减小“{}”、缩短文字，或让它滚动。",
            cropped_sides(lang, *across, *deep),
            key_label(lang, &note.pattern, "balls_per_pixel")
        ),
        (Change::Cropped { across, deep }, Lang::En) => format!(
            "segment {segment} ({pattern}): {label}: {}, only its middle is shown (choose a smaller {}, a shorter text, or scroll it)",
            cropped_sides(lang, *across, *deep),
            key_label(lang, &note.pattern, "balls_per_pixel")
        ),
        (Change::Empty, Lang::Zh) => format!(
            "第 {segment} 段（{pattern}）：{label} 没有可显示的内容，矩阵保持平整；请输入文字或绘制“{}”。",
            key_label(lang, &note.pattern, "bitmap")
        ),
        (Change::Empty, Lang::En) => format!(
            "segment {segment} ({pattern}): {label}: nothing to draw, the matrix stays flat (type a text, or draw a {})",
            key_label(lang, &note.pattern, "bitmap")
        ),
    }
}

/// The sides of a text that do not fit the matrix (balls needed, balls it has), in
/// `lang`: across first, then deep.
fn cropped_sides(lang: Lang, across: Option<(u32, u32)>, deep: Option<(u32, u32)>) -> String {
    let side = |(needed, has): (u32, u32), is_across: bool| match (lang, is_across) {
        (Lang::Zh, true) => format!("需要横向 {needed} 个球，矩阵只有 {has} 个"),
        (Lang::Zh, false) => format!("需要纵向 {needed} 个球，矩阵只有 {has} 个"),
        (Lang::En, true) => format!("{needed} balls across on a matrix {has} across"),
        (Lang::En, false) => format!("{needed} balls deep on a matrix {has} deep"),
    };
    let sides: Vec<String> = across
        .map(|sides| side(sides, true))
        .into_iter()
        .chain(deep.map(|sides| side(sides, false)))
        .collect();
    sides.join(if lang == Lang::Zh { "；" } else { " and " })
}

/// Why a show cannot be made.
pub fn error(lang: Lang, error: &CreateError) -> String {
    if lang == Lang::En {
        return error.to_string();
    }
    match error {
        CreateError::UnknownPattern { name, known } => {
            format!("没有名为“{name}”的图案；可用的图案：{known}")
        }
        CreateError::UnknownParam {
            pattern,
            key,
            known,
        } => {
            format!("图案“{pattern}”没有参数“{key}”；它的参数：{known}")
        }
        CreateError::WrongType { pattern, key, .. } => {
            format!("图案“{pattern}”的参数“{key}”的值不合适")
        }
        CreateError::Picture { message, .. } => {
            format!("无法读取这张图片（{message}）；请使用 PNG 或 JPEG 文件")
        }
        CreateError::TooLarge {
            bytes, max_bytes, ..
        } => format!("文件有 {bytes} 字节，最多允许 {max_bytes} 字节；请换一个较小的文件"),
        CreateError::EmptyTimeline => "时间线上没有片段；请至少添加一个图案".to_owned(),
        CreateError::TooManySegments { segments, max } => {
            format!("时间线有 {segments} 个片段，最多 {max} 个；请删除一些")
        }
        CreateError::TooLong { seconds, max_s } => {
            format!(
                "节目将长达 {} 秒，最多 {} 秒；请缩短片段",
                number(*seconds),
                number(*max_s)
            )
        }
        CreateError::Duration {
            segment,
            key,
            value,
            min_s,
            max_s,
        } => format!(
            "第 {segment} 段：{} 为 {} 秒，应在 {} 到 {} 秒之间",
            key_label(lang, "", key),
            number(*value),
            number(*min_s),
            number(*max_s)
        ),
        CreateError::EmptyGrid { rows, cols } => {
            format!("{rows} × {cols} 的矩阵无法容纳节目；至少需要一行一列，间距和行程须为正数")
        }
        CreateError::Recipe { message } => format!("配方无效：{message}"),
        CreateError::TooManyRows { rows, balls, max } => format!(
            "节目每个球有 {rows} 行、共 {balls} 个球，合计 {} 行；最多 {max} 行：请缩短节目、加长每行时间（row_ms）或减少球数",
            *rows as u64 * *balls as u64
        ),
    }
}

#[cfg(test)]
mod tests {
    use floatball_shared::create::{PATTERNS, ParamKind};
    use wasm_bindgen_test::wasm_bindgen_test;

    use super::*;

    #[wasm_bindgen_test(unsupported = test)]
    fn every_pattern_parameter_and_choice_has_its_chinese() {
        for spec in PATTERNS {
            assert!(
                PATTERNS_ZH.iter().any(|(name, _, _)| *name == spec.name),
                "pattern {}",
                spec.name
            );
            assert_ne!(pattern(Lang::Zh, spec.name), spec.label);
            for param in spec.params {
                assert!(
                    lookup(PARAMS_ZH, param.key).is_some(),
                    "parameter {} of {}",
                    param.key,
                    spec.name
                );
                if let ParamKind::Choice { options, .. } = param.kind {
                    for option in options {
                        assert!(
                            lookup(CHOICES_ZH, option).is_some(),
                            "choice {option} of {}",
                            param.key
                        );
                    }
                }
            }
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn notes_name_the_segment_the_parameter_and_the_values_in_both_languages() {
        let note = Note::number(
            1,
            "wave",
            "speed_m_s",
            (6.0, 2.4),
            "m/s",
            "so balls stay within 2000 mm/s".into(),
        );
        assert_eq!(
            super::note(Lang::En, &note),
            "segment 2 (Wave): Speed changed from 6 to 2.4 m/s so balls stay within 2000 mm/s"
        );
        let zh = super::note(Lang::Zh, &note);
        assert!(
            zh.contains("第 2 段（波浪）：速度 已从 6 改为 2.4 m/s"),
            "{zh}"
        );
        let note = Note {
            segment: 0,
            pattern: "text".into(),
            key: "text".into(),
            change: Change::NotInFont {
                chars: "字幕".into(),
            },
            reason: String::new(),
        };
        assert_eq!(
            super::note(Lang::En, &note),
            "segment 1 (Text): Text: 字幕 not in the built-in font, drawn as ? (draw them with the Bitmap parameter: lines of # and .)"
        );
        let zh = super::note(Lang::Zh, &note);
        assert!(
            zh.contains("“字幕”不在内置字库中") && zh.contains("“自定义点阵”参数"),
            "{zh}"
        );
        let mut note = Note {
            segment: 2,
            pattern: "text".into(),
            key: "text".into(),
            change: Change::Cropped {
                across: Some((38, 10)),
                deep: Some((14, 10)),
            },
            reason: String::new(),
        };
        assert_eq!(
            super::note(Lang::En, &note),
            "segment 3 (Text): Text: 38 balls across on a matrix 10 across and 14 balls deep on a matrix 10 deep, only its middle is shown (choose a smaller Letter size, a shorter text, or scroll it)"
        );
        let zh = super::note(Lang::Zh, &note);
        assert!(
            zh.contains("需要横向 38 个球，矩阵只有 10 个；需要纵向 14 个球")
                && zh.contains("只显示中间部分"),
            "{zh}"
        );
        note.change = Change::Cropped {
            across: None,
            deep: Some((7, 5)),
        };
        assert!(
            !super::note(Lang::En, &note).contains("across"),
            "{}",
            super::note(Lang::En, &note)
        );
        note.change = Change::Empty;
        assert_eq!(
            super::note(Lang::En, &note),
            "segment 3 (Text): Text: nothing to draw, the matrix stays flat (type a text, or draw a Bitmap)"
        );
        assert!(
            super::note(Lang::Zh, &note).contains("矩阵保持平整"),
            "{}",
            super::note(Lang::Zh, &note)
        );
        assert!(error(Lang::Zh, &CreateError::EmptyTimeline).contains("时间线"));
        assert_eq!(
            error(Lang::En, &CreateError::EmptyTimeline),
            CreateError::EmptyTimeline.to_string()
        );
    }
}

texts! {
    /// The Create page's fixed strings: they come with its chunk.
    CreateText;
    /// The Create page's pattern choice.
    Pattern => "图案", "Pattern";
    /// The Create page's list of segments.
    Timeline => "时间线", "Timeline";
    /// Add a segment after the chosen one.
    AddSegment => "添加片段", "Add a segment";
    /// A segment's own length.
    SegmentDuration => "时长 (s)", "Duration (s)";
    /// The blend into the next segment.
    SegmentTransition => "过渡到下一段 (s)", "Blend into the next (s)";
    /// The generated show's name.
    ShowNameLabel => "节目名称", "Show name";
    /// Keep the generated show in the browser's local files.
    SaveToLocalFiles => "保存到本地文件", "Save to local files";
    /// The show was kept in the local files.
    SavedToLocalFiles => "已保存到本地文件", "Saved to the local files";
    /// Send the generated show to the controller.
    UploadToController => "上传到控制器", "Upload to the controller";
    /// Offer the recipe as a download.
    DownloadRecipe => "下载配方", "Download the recipe";
    /// Open a recipe file.
    OpenRecipe => "打开配方", "Open a recipe";
    /// A recipe file that cannot be used.
    RecipeUnreadable => "无法使用这个配方：", "This recipe cannot be used:";
    /// How long the last change took to generate and show.
    GeneratedIn => "生成用时", "Generated in";
    /// The heading of what was changed to stay within the limits.
    ClampedHeading => "为保持在限值之内已作调整：", "Changed to stay within the limits:";
    /// The grid made for while connected.
    MadeForInstallation => "按控制器的装置生成（行列、间距、行程、速度和加速度限值）", "Made for the controller's installation (grid, pitch, travel, speed and acceleration limits)";
    /// The grid made for while offline.
    MadeForDefaultGrid => "离线：按下面的矩阵和默认限值生成", "Offline: made for the matrix below and the default limits";
    /// Rows of balls (offline grid).
    GridRows => "行数", "Rows";
    /// Balls in each row (offline grid).
    GridCols => "列数", "Columns";
    /// No picture picked yet.
    NoPicture => "尚未选择图片", "No picture chosen";
    /// The planner's verdict heading on the Create page.
    BandwidthVerdict => "线路带宽", "Line bandwidth";
    /// The show could not be generated.
    CannotGenerate => "无法生成：", "Cannot generate:";
    /// A new draft.
    NewRecipe => "重新开始", "Start again";
}
