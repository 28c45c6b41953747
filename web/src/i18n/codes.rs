//! The 中文 texts of the bridge's and the shared parsers' error codes: one template per
//! [`Code`], `{name}` standing for a parameter. The English template of each code is
//! the shared crate's ([`Code::english`]), the one the bridge words its errors with.
//! Where an error happened (line and column, ball and time) is put before the template
//! by [`super::Lang::coded`], so the templates hold only what is particular to each
//! code. Parameters marked "in English" in [`Code`] are technical words the parsers
//! give; the 中文 texts say the same without relying on them where they can.

use floatball_shared::codes::Code;

/// `(code, 中文)` for every code; the test in `i18n.rs` fails when a code of
/// [`Code::ALL`] is missing here.
pub(super) const ERROR_TEXTS: &[(Code, &str)] = &[
    // ---- HTTP in general ----
    (Code::NotFound, "控制器没有这个接口"),
    (Code::MethodNotAllowed, "这个接口不接受此方法"),
    (Code::BodyTooLarge, "请求太大：最多 {limit_bytes} 字节"),
    (Code::UnsupportedMediaType, "请求的内容类型不被接受"),
    (Code::BadJson, "请求内容不是有效的 {what}：{reason}"),
    (Code::RequestRefused, "控制器拒绝了请求（HTTP {status}）"),
    (Code::Internal, "控制器内部出错：{what}"),
    // ---- sessions ----
    (Code::LoginRequired, "请先登录"),
    (Code::SessionExpired, "登录已失效，请重新登录"),
    (Code::WrongPassword, "密码错误"),
    (
        Code::TooManyAttempts,
        "登录失败次数过多，请 {retry_after_s} 秒后再试",
    ),
    (
        Code::LoginBusy,
        "控制器正忙于核对其他密码，请 {retry_after_s} 秒后再试",
    ),
    (Code::MustChangePassword, "请先修改初始密码"),
    (Code::WrongCurrentPassword, "当前密码错误"),
    (Code::PasswordTooShort, "新密码太短：至少 {min} 个字符"),
    (Code::PasswordTooLong, "新密码太长：最多 {max_bytes} 字节"),
    (Code::PasswordIsDefault, "新密码不能是初始密码 {default}"),
    (
        Code::OriginNotAllowed,
        "此网页的来源不允许连接控制器（floatball.toml 的 allowed_origins）",
    ),
    // ---- shows and uploads ----
    (Code::BadShowName, "文件名不可用：{reason}"),
    (Code::ShowNotFound, "控制器上没有文件“{name}”"),
    (Code::ShowUnreadable, "控制器上的文件“{name}”无法读取"),
    (Code::ShowInPlaylist, "“{name}”在配置中，请先从配置中移除"),
    (Code::UploadIncomplete, "文件没有完整上传，请重试"),
    (Code::NotUtf8, "文件不是 UTF-8 文本（第 {byte} 字节）"),
    (Code::ShowFileUnreadable, "无法读取这个动作文件"),
    (Code::CsvUnreadable, "无法导入这个 CSV 关键帧文件"),
    (Code::ShowEmpty, "动作为空：没有运动"),
    (Code::ShowTooLong, "动作超过了时长上限 {limit_ms} 毫秒"),
    (Code::ShowTooLarge, "动作超过了大小上限 {limit_bytes} 字节"),
    (Code::ShowUnfit, "动作不适合本装置：{count} 个问题"),
    (
        Code::OutputBox,
        "动作含有控制盒 {box} 的输出，但本装置有 {boxes} 个控制盒",
    ),
    (Code::MoreProblems, "……另有 {count} 个问题"),
    (
        Code::CsvNeedsMotion,
        "CSV 动作至少需要两个关键帧，最后一个晚于 0 毫秒",
    ),
    (Code::JsonNeedsMotion, "每个球的 rows 都是空的"),
    (Code::ShowLasts, "动作时长 {duration_ms} 毫秒"),
    (Code::ShowTakes, "保存后动作占 {bytes} 字节"),
    // ---- validation ----
    (
        Code::AboveTop,
        "位置 {position_mm} 毫米高于顶部（0 毫米），球会撞到上限位开关",
    ),
    (
        Code::BelowTravel,
        "位置 {position_mm} 毫米低于最低点（行程 {travel_mm} 毫米）",
    ),
    (
        Code::TooFast,
        "速度 {speed_mm_s} 毫米/秒超过上限 {limit_mm_s} 毫米/秒",
    ),
    (
        Code::TooHardAcceleration,
        "加速度 {accel_mm_s2} 毫米/秒² 超过上限 {limit_mm_s2} 毫米/秒²",
    ),
    (
        Code::RowDuration,
        "第 {row} 行持续 {duration_ms} 毫秒；每行必须为 {min_ms} 到 {max_ms} 毫秒",
    ),
    (
        Code::TrackDuration,
        "轨迹长 {duration_s} 秒，但动作长 {show_duration_s} 秒；每个球的轨迹必须与动作等长",
    ),
    (
        Code::EndsMoving,
        "轨迹结束时仍以 {velocity_mm_s} 毫米/秒运动；必须静止结束（速度 0）",
    ),
    (
        Code::WrongLayout,
        "动作为 {show_rows} 行 × {show_cols} 列，但本装置为 {rows} 行 × {cols} 列",
    ),
    // ---- native show files ----
    (Code::ShowInvalid, "动作文件无效：{message}"),
    (
        Code::ShowWrongFormat,
        "这不是 Floatball 动作文件（format 为“{found}”）",
    ),
    (
        Code::ShowUnsupportedVersion,
        "动作文件为格式版本 {found}，本程序只能读取版本 {version}；请升级 Floatball",
    ),
    (
        Code::ShowEmptyLayout,
        "布局至少需要一行一列，且 pitch_mm 为正数",
    ),
    (
        Code::ShowTrackCount,
        "动作有 {tracks} 条轨迹，但布局为 {rows} × {cols}",
    ),
    (Code::ShowNotFinite, "轨迹 {track}：位置或速度不是有限数"),
    (Code::ShowOutput, "控制盒 {box} 的输出无法播放"),
    (
        Code::ShowColourOrder,
        "轨迹 {track}：颜色关键帧 {index} 不晚于前一个",
    ),
    // ---- CSV ----
    (
        Code::CsvEmpty,
        "文件是空的；第一行必须是表头“time_ms,u0,u1,…”",
    ),
    (Code::CsvNoHeader, "布局行之后缺少表头“time_ms,u0,u1,…”"),
    (
        Code::CsvMisplacedComment,
        "以 # 开头的行只能是第一行的布局行“# rows=R cols=C pitch_mm=P”",
    ),
    (
        Code::CsvLayoutWord,
        "无法理解“{text}”；布局行为“# rows=R cols=C pitch_mm=P”",
    ),
    (Code::CsvLayoutValue, "{key} 的值“{text}”无效"),
    (Code::CsvLayoutMissing, "布局行缺少 {key}=…"),
    (Code::CsvHeaderName, "表头列为“{found}”，应为“{expected}”"),
    (Code::CsvNoUnits, "表头没有球的列；应为“time_ms,u0,u1,…”"),
    (
        Code::CsvLayoutMismatch,
        "文件有 {units} 个球列，但布局为 {rows} 行 × {cols} 列",
    ),
    (
        Code::CsvFieldCount,
        "此行有 {found} 个字段，表头有 {expected} 个",
    ),
    (Code::CsvNotANumber, "“{text}”不是数字"),
    (Code::CsvNoKeyframes, "表头之后没有关键帧"),
    (
        Code::CsvFirstTimeNotZero,
        "第一个关键帧在 {time_ms} 毫秒；必须在 0",
    ),
    (
        Code::CsvTimeNotIncreasing,
        "时间 {time_ms} 毫秒不晚于第 {previous_line} 行的 {previous_ms} 毫秒",
    ),
    (
        Code::CsvGapTooShort,
        "此关键帧距第 {previous_line} 行仅 {gap_ms} 毫秒；关键帧至少相隔 {min_ms} 毫秒",
    ),
    (Code::CsvTooLate, "时间 {time_ms} 毫秒超过了最长 24 小时"),
    (
        Code::CsvTooLong,
        "时间 {time_ms} 毫秒超过了此处允许的最长动作（{max_ms} 毫秒）",
    ),
    (
        Code::CsvTooManyRows,
        "动作共有 {rows} 行，超过 {max_rows}；请减少球数或缩短动作",
    ),
    (
        Code::CsvConvertedTooLarge,
        "转换后动作将占 {bytes} 字节，超过上限 {max_bytes} 字节",
    ),
    // ---- Start, Reset, Home ----
    (Code::PlaylistEmpty, "配置为空：请先添加动作"),
    (
        Code::EntryUnreadable,
        "配置第 {entry} 项（“{show}”）无法读取",
    ),
    (
        Code::EntryInvalid,
        "第 {entry} 项（“{show}”）无法运行：{reason}",
    ),
    (
        Code::EntryInfeasible,
        "第 {entry} 项（“{show}”）无法运行：{reason}。建议：{fixes}",
    ),
    (Code::GatewayNotConnected, "网关 {gateway} 未连接"),
    (Code::PlayerBusy, "矩阵正在运行配置；请先急停或重置"),
    (
        Code::StartNoSuchEntry,
        "没有第 {entry} 项：播放列表共有 {entries} 项",
    ),
    (
        Code::StartPastTheEnd,
        "第 {entry} 项无法从 {time_ms} 毫秒开始：其演出在 {duration_ms} 毫秒结束",
    ),
    (
        Code::StartNoCut,
        "第 {entry} 项无法从某个时间开始：驱动器播放其存储的程序；请从头开始，或让控制器上传程序",
    ),
    (Code::LiveUnsupported, "{family} 不支持实时模式"),
    (
        Code::LiveLineTooSlow,
        "实时模式：网关 {gateway} 的线路为其 {units} 个单元写一行需要 {row_ms} 毫秒，超过一行最长的 {max_ms} 毫秒",
    ),
    (Code::RecordNotLive, "录制需要实时模式且球正在跟随输入"),
    (
        Code::RecordStep,
        "{dt_ms} 毫秒的实时周期无法录制：每行须为 {min_ms}-{max_ms} 毫秒",
    ),
    (
        Code::LiveEstopLatched,
        "急停锁定时无法进入实时模式：请先按开始、复位或回零（进入实时模式不会解除急停）",
    ),
    (
        Code::LiveOff,
        "实时输入已关闭：请在配置的 [live] 部分设置 enabled = true",
    ),
    (
        Code::RecordNameTaken,
        "已有名为“{name}”的演出：请为录制另取一个名字",
    ),
    (Code::RecordNothing, "没有正在进行的录制（急停会丢弃录制）"),
    (Code::Superseded, "请求之后按下了急停；矩阵保持停止"),
    (Code::PlayerGone, "播放器没有运行（控制器正在关闭）"),
    // ---- the WebSocket and the console ----
    (Code::BadMessage, "控制器无法理解这条消息"),
    (Code::BinaryFrame, "只接受包含 JSON 的文本消息"),
    (
        Code::FeedbackDropped,
        "丢失了 {count} 个反馈帧：此设备读取太慢",
    ),
    (
        Code::MustChangePasswordFirst,
        "请先修改初始密码（1234），再控制矩阵或发送指令",
    ),
    (
        Code::NoSuchGateway,
        "没有网关 {gateway}；网关编号为 0 到 {last}",
    ),
    (Code::EmptyLine, "这一行没有指令"),
    (
        Code::EstopLatched,
        "急停已锁定：在开始、重置或回零之前只能发送查询；这一行未发送",
    ),
    (Code::ConsoleBusy, "等待发往网关的指令太多；这一行未发送"),
    (
        Code::ConsoleLineSpeed,
        "控制台不能设置线路速率（BDR={baud}）：请在“调试 → 线路速率”中更改，网桥会随网关一起切换；这一行未发送",
    ),
    (Code::LineNotSent, "这一行未发送：{reason}"),
    (Code::NoSuchDrive, "网关 {gateway} 上没有驱动器 {drive}"),
    (
        Code::DriveAddressNeeded,
        "{request}：请在前面写驱动器地址（网关 {gateway} 有 {drives} 个驱动器）",
    ),
    (
        Code::EstopUnreached,
        "急停暂未送达：{gateways}（连接恢复后立即发送）",
    ),
    // ---- UIM2503 instructions ----
    (
        Code::AsciiNotAscii,
        "{found} 不在 ASCII 1–127 之内，网关只接受这些字符（全角字符请改为半角）",
    ),
    (Code::AsciiBrace, "指令中不允许使用 `{found}`（手册 §6.1）"),
    (
        Code::AsciiUnexpected,
        "此处不能是 {found}（应为：{expected}）；每条指令必须以 ; 结束",
    ),
    (
        Code::AsciiOddHexDigits,
        "{instruction} 的十六进制操作数有 {digits} 位；位数必须为偶数（`0A` 而不是 `A`）",
    ),
    (Code::AsciiNumberTooLarge, "{field} 太大"),
    (
        Code::AsciiOutOfRange,
        "{field} 必须在 {min}–{max} 之间，实为 {value}",
    ),
    (Code::AsciiUnexpectedIndex, "{mnemonic} 不带下标"),
    (
        Code::AsciiMissingIndex,
        "{mnemonic} 需要下标：`{mnemonic}[X]`",
    ),
    (
        Code::AsciiOperandWithoutIndex,
        "{mnemonic} 只有带下标时才能带操作数：`{mnemonic}[X]=…;`",
    ),
    (Code::AsciiMissingOperand, "{instruction} 缺少操作数"),
    (
        Code::AsciiTooLong,
        "这条指令含 `;` 共 {length} 个字符；网关最多接受 {max} 个",
    ),
    (Code::AsciiNotEncodable, "这条指令无法发送：{reason}"),
    // ---- SCL ----
    (
        Code::SclNotAscii,
        "{found} 不是可打印的 ASCII 字符；SCL 是纯 ASCII 文本",
    ),
    (
        Code::SclMissingMnemonic,
        "地址之后应为指令（两个大写字母，如 FL 或 DI）",
    ),
    (
        Code::SclUnknownMnemonic,
        "未知指令 {mnemonic}；指令为大写（FL、FP、FS、DI、VE、AC、DE…）",
    ),
    (
        Code::SclBadAddress,
        "{found} 不能作为 RS-485 地址：地址为数字或 \" # $ & ' ( ) + , - . / : ; < = > 之一",
    ),
    (
        Code::SclMissingParameter,
        "{mnemonic} 此处缺少参数（{expected}）",
    ),
    (
        Code::SclBadParameter,
        "{mnemonic}：参数“{found}”不合适（应为 {expected}）",
    ),
    (
        Code::SclOutOfRange,
        "{mnemonic}：{found} 超出范围（{range}）",
    ),
    (Code::SclTrailing, "完整的 {mnemonic} 指令之后多出“{found}”"),
    (
        Code::SclUploadLength,
        "程序上传：头部声明 {announced} 行，实际 {found} 行",
    ),
    (
        Code::SclBadAnswer,
        "不是驱动器应答：应为 %、*、?（带代码）或如 IP=1000 的应答",
    ),
    // ---- MBOX console ----
    (
        Code::MboxUnknownCommand,
        "未知命令 `{found}`：控制台支持 read、write、save、estop、release、reset、effects 和 ip",
    ),
    (
        Code::MboxMissingCommand,
        "`{target}` 之后应为命令：read、write、save、estop、release、reset、effects 或 ip",
    ),
    (Code::MboxMissing, "`{command}` 此处缺少内容（{operand}）"),
    (
        Code::MboxNotABank,
        "应为寄存器区 FN、DN 或 CX，实为 `{found}`",
    ),
    (
        Code::MboxWrongBank,
        "`{command}` 不能用于 {bank}（{reason}）",
    ),
    (
        Code::MboxNotANumber,
        "应为数字（十进制或 0x 十六进制），实为 `{found}`",
    ),
    (Code::MboxOutOfRange, "`{found}` 超出范围（{operand}）"),
    (Code::MboxZeroCount, "数量为 0：至少读取一个寄存器"),
    (Code::MboxRange, "寄存器范围无效：{reason}"),
    (
        Code::MboxTrailing,
        "多出 `{found}`：`{command}` 已完整（命令之间用换行或 ; 分隔）",
    ),
    (
        Code::MboxNotAnIp,
        "应为 IP 地址，如 192.168.15.210，实为 `{found}`",
    ),
    (
        Code::MboxBadTarget,
        "@ 之后应为控制盒：all、末位如 201、两段如 15.201 或 IP 地址；实为 `{found}`",
    ),
    (
        Code::MboxNoSubnet,
        "`@{octet}` 只给了末位，而所选的不是单个控制盒：请写两段，如 @15.{octet}",
    ),
    // ---- unit errors ----
    (Code::UnitSyntax, "网关无法读取这条指令（错误 {error}）"),
    (Code::UnitData, "数值超出范围或不一致（错误 {error}）"),
    (Code::UnitIndex, "下标超出范围（错误 {error}）"),
    (Code::UnitWhileMoving, "电机运动时不允许（错误 {error}）"),
    (Code::UnitMotorOff, "电机驱动器已关闭（错误 {error}）"),
    (
        Code::UnitOverload,
        "单元跟不上 PVT 行（速度或加速度）（错误 {error}）",
    ),
    (Code::UnitLimit, "球到达了行程端点（错误 {error}）"),
    (Code::UnitUnknown, "未知错误（错误 {error}）"),
    // ---- the playlist ----
    (Code::PlaylistLocked, "播放或移动时不能修改配置条目"),
    (Code::PlaylistInvalid, "配置无效"),
    (
        Code::PlaylistTooManyEntries,
        "配置有 {entries} 个条目；最多 {max} 个",
    ),
    (
        Code::PlaylistUnknownShow,
        "第 {entry} 项：没有名为“{show}”的动作",
    ),
    (
        Code::EntryCycles,
        "第 {entry} 项：周期 {cycles} 无效；必须为 1 到 {max}",
    ),
    (
        Code::EntryDelay,
        "第 {entry} 项：延时 {delay_ms} 毫秒无效；最多 {max_ms} 毫秒（一天）",
    ),
    (
        Code::DefaultCycles,
        "默认周期 {cycles} 无效；必须为 1 到 {max}",
    ),
    (
        Code::DefaultDelay,
        "默认延时 {delay_ms} 毫秒无效；最多 {max_ms} 毫秒（一天）",
    ),
    (
        Code::EntryTimecode,
        "第 {entry} 项：时间码起点“{timecode}”无效；格式为 10:00:00:00（时:分:秒:帧）",
    ),
    // ---- engineering calls ----
    (Code::BadQuery, "查询参数错误：{reason}"),
    (
        Code::NoSuchUnit,
        "动作“{name}”有 {units} 个球：没有球 {unit}（第一个为 0）",
    ),
    (Code::QprogramRefused, "无法编译 Q 程序：{reason}"),
    (Code::NoMboxBoxes, "本装置没有 MBOX 控制盒"),
    // ---- plan verdicts ----
    (
        Code::LineStarved,
        "网关 {gateway}（{baud} 波特）供不上它的 {units} 个单元：“{show}”每秒需要 {needed_bytes_per_s} 字节，线路只能传 {available_bytes_per_s} 字节，即使预载满 {preload_rows} 行，单元的行缓冲也会在动作开始 {dry_at_s} 秒后用尽",
    ),
    (
        Code::LineStarvedDuring,
        "网关 {gateway}（{baud} 波特）供不上它的 {units} 个单元：“{show}”每秒需要 {needed_bytes_per_s} 字节，线路只能传 {available_bytes_per_s} 字节，即使预载满 {preload_rows} 行，单元的行缓冲也会在动作中用尽",
    ),
    (
        Code::BallCount,
        "动作有 {show_balls} 个球，但本装置有 {units} 个",
    ),
    (
        Code::OutOfCounts,
        "{value_mm} 毫米在 {counts_per_mm} 计数/毫米下超出单元的计数范围",
    ),
    (
        Code::UnitCount,
        "装置列出 {listed} 个单元，但矩阵有 {expected} 个",
    ),
    (
        Code::FixFasterLine,
        "把线路提高到 {baud} 波特（调试 → 线路速率）",
    ),
    (
        Code::FixNoBaudEnough,
        "单靠提高波特率（最高 {max_baud}）不够",
    ),
    (
        Code::FixFewerUnits,
        "在 {baud} 波特下每个网关最多接 {units_per_gateway} 个单元（这 {units} 个需要 {gateways} 个网关）",
    ),
    (
        Code::FixLongerRows,
        "每行至少 {row_ms} 毫秒（这个动作的行平均 {mean_row_ms} 毫秒）",
    ),
    (
        Code::FixFewerRows,
        "或把动作缩短到每个球最多 {rows} 行，使它在开始前完全载入",
    ),
    (
        Code::FixTolerance,
        "把 [scl] tolerance_mm 提高到至少 {tolerance_mm} 毫米（各球最大偏差为 {deviation_mm} 毫米），或让动作的移动更少、更平缓",
    ),
    // ---- Q programs ----
    (
        Code::QprogramTooFar,
        "程序会偏离动作 {deviation_mm} 毫米，超过容差 {tolerance_mm} 毫米（动作的移动太多，驱动器的 12 段各 62 行装不下，或有点到点移动跟不紧的移动）",
    ),
    (
        Code::QprogramTooFast,
        "球到不了它的位置：点到点移动需要超过 {max_speed_mm_s} 毫米/秒或 {max_accel_mm_s2} 毫米/秒²",
    ),
    (
        Code::QprogramOutOfRange,
        "位置 {position_mm} 毫米超出驱动器的范围",
    ),
    (
        Code::QprogramTooManyLines,
        "程序需要 {lines} 行，超过驱动器的 {limit} 行",
    ),
    (Code::QprogramSetting, "Q 程序设置 {field} 必须为 {must}"),
    // ---- install ----
    (
        Code::InstallationInvalid,
        "安装设置有 {problems} 个问题，未保存",
    ),
    (Code::InstallationProblem, "安装设置：{reason}"),
    (
        Code::InstallationBusy,
        "矩阵正在{state}：只能在空闲时更改安装设置或线速",
    ),
    (
        Code::InstallationNotLive,
        "MBOX 控制盒和 MOONS' 驱动器的网关只能在 floatball.toml 中更改，并在重启后生效",
    ),
    (
        Code::InstallationNotSaved,
        "无法保存 floatball.toml：{reason}",
    ),
    (
        Code::BaudNotAllowed,
        "网关不支持 {baud} 波特；可用：{allowed}",
    ),
    // ---- line ----
    (
        Code::BaudOutOfRange,
        "网关不支持 {baud} 波特的线路速度（{min}–{max}）",
    ),
    (
        Code::BaudNotAnswering,
        "网关 {gateway} 在 {waited_ms} 毫秒内没有以 {baud} 波特应答；线路已恢复为 {from_baud} 波特",
    ),
    (
        Code::BaudPortRefused,
        "网关 {gateway} 的串口无法以 {baud} 波特运行：{reason}",
    ),
    // ---- arm ----
    (
        Code::PreloadLong,
        "网关 {gateway} 在 {baud} 波特下开始前要预载 {preload_bytes} 字节，需 {preload_s} 秒（{preload_min} 分钟）；在 {faster_baud} 波特下只需 {faster_preload_s} 秒（在“调试 → 线路速率”中把线路速度改为 {faster_baud}）",
    ),
    (
        Code::PreloadLongFastest,
        "网关 {gateway} 即使在最快的 {baud} 波特下，开始前也要预载 {preload_bytes} 字节，需 {preload_s} 秒（{preload_min} 分钟）；作为播放列表的第一项，它会在矩阵空闲时预先载入",
    ),
    // ---- commission ----
    (
        Code::CommissionNotUim2503,
        "网关 {gateway} 不是 UIM2503 网关；只有 UFQ750 单元需要调试",
    ),
    (
        Code::CommissionNotIdle,
        "矩阵正在{state}：调试要等到矩阵空闲",
    ),
    (
        Code::CommissionInProgress,
        "另一个调试操作正在使用网关 {gateway}；完成后再试",
    ),
    (
        Code::CommissionBadStation,
        "站号 {station} 不是单元的站号；站号为 1–127",
    ),
    (
        Code::CommissionBadDistance,
        "识别距离必须是正的毫米数，收到 {distance_mm}",
    ),
    (
        Code::CommissionStationSilent,
        "网关 {gateway} 的站号 {station} 没有单元应答",
    ),
    (
        Code::CommissionStationShared,
        "网关 {gateway} 的站号 {station} 上有 {units} 个单元应答；请先给它们各自的站号",
    ),
    (Code::CommissionNoAssignments, "请求没有分配任何单元"),
    (Code::CommissionSerialTwice, "序列号 {serial} 被分配了两次"),
    (
        Code::CommissionStationTwice,
        "站号 {station} 被分配给了两个单元",
    ),
    (
        Code::CommissionSerialTooLong,
        "序列号 {serial} 太长：`SN[X]=s/n;` 最多 {max} 个字符",
    ),
    // ---- live input: the patch ----
    (
        Code::PatchBallCount,
        "配接表有 {patched} 个球；装置有 {balls} 个球",
    ),
    (Code::PatchUniverse, "球 {ball}：域 {universe} 超出 1–{max}"),
    (Code::PatchAddress, "球 {ball}：地址 {address} 超出 1–512"),
    (
        Code::PatchFootprint,
        "球 {ball}：从地址 {address} 起的 {footprint} 个通道超过了第 512 个通道",
    ),
    (
        Code::PatchOverlap,
        "球 {ball} 与球 {other} 在域 {universe} 从地址 {address} 起共用通道",
    ),
    (
        Code::PatchSpeedBits,
        "球 {ball}：限速通道为 {bits} 位；应为 8 或 16 位",
    ),
    // ---- the schedule ----
    (Code::ScheduleInvalid, "时间表无效"),
    (
        Code::ScheduleUnknownTimeZone,
        "未知时区“{zone}”：请填写 IANA 名称，例如 Europe/Zurich、Asia/Shanghai 或 UTC",
    ),
    (
        Code::ScheduleEndNotAfterStart,
        "{day}，时段 {window}：结束时间 {end} 不晚于开始时间 {start}",
    ),
    (
        Code::ScheduleWindowsOverlap,
        "{day}：时段 {first} 和 {second} 重叠",
    ),
    (
        Code::ScheduleEveryOutOfRange,
        "{day}，时段 {window}：每 {minutes} 分钟超出范围（{min}–{max}）",
    ),
    (
        Code::ScheduleTooManyWindows,
        "{day} 有 {windows} 个时段；最多允许 {max} 个",
    ),
    (
        Code::ScheduleTooManyExceptions,
        "时间表有 {exceptions} 个例外日期；最多允许 {max} 个",
    ),
    (Code::ScheduleExceptionTwice, "{date} 有两个例外"),
    (
        Code::ScheduleStartedLoop,
        "已开始播放列表，循环播放到时段结束",
    ),
    (
        Code::ScheduleStartedEvery,
        "已开始播放列表一次（每 {minutes} 分钟）",
    ),
    (
        Code::ScheduleNotIdle,
        "未开始：矩阵状态为 {state}，不是空闲",
    ),
    (
        Code::ScheduleInError,
        "未开始：矩阵出错（{error}）；只有操作员可以清除",
    ),
    (
        Code::ScheduleEstopLatched,
        "未开始：急停已锁定；只有操作员在应用中可以解除",
    ),
    (
        Code::ScheduleLinkDown,
        "未开始：网关 {gateway} 的连接状态为 {link}",
    ),
    (
        Code::ScheduleUnitsMissing,
        "未开始：网关 {gateway} 缺少单元（站号 {stations}）",
    ),
    (Code::ScheduleStartRefused, "未开始：{reason}"),
    (Code::ScheduleEnded, "时段结束：小球已回原点，电机已关闭"),
    (
        Code::ScheduleEndedMotorsOn,
        "时段结束：小球已回原点（电机保持通电：此类驱动没有控制器可发送的关闭电机指令）",
    ),
    (
        Code::ScheduleEndLatched,
        "时段结束，但小球没有回原点：急停已锁定",
    ),
    (
        Code::ScheduleEndRefused,
        "时段结束，但小球没有回原点：{reason}",
    ),
    (Code::PatchInvalid, "配接表有 {problems} 个问题，未保存"),
    (Code::PatchBusy, "矩阵正在{state}：只能在空闲时更改配接表"),
];
