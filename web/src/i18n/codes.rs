//! The bridge's and the shared parsers' error codes in both languages: one template
//! per [`Code`], `{name}` standing for a parameter. Where an error happened (line and
//! column, ball and time) is put before the template by [`super::Lang::coded`], so the
//! templates hold only what is particular to each code. Parameters marked "in English"
//! in [`Code`] are technical words the parsers give; the 中文 texts say the same
//! without relying on them where they can.

use floatball_shared::codes::Code;

/// `(code, 中文, English)` for every code; the test in `i18n.rs` fails when a code of
/// [`Code::ALL`] is missing here.
pub(super) const ERROR_TEXTS: &[(Code, &str, &str)] = &[
    // ---- HTTP in general ----
    (
        Code::NotFound,
        "控制器没有这个接口",
        "There is no such API call",
    ),
    (
        Code::MethodNotAllowed,
        "这个接口不接受此方法",
        "This API call does not take that method",
    ),
    (
        Code::BodyTooLarge,
        "请求太大：最多 {limit_bytes} 字节",
        "The request is too large: at most {limit_bytes} bytes",
    ),
    (
        Code::UnsupportedMediaType,
        "请求的内容类型不被接受",
        "The request's Content-Type is not accepted",
    ),
    (
        Code::BadJson,
        "请求内容不是有效的 {what}：{reason}",
        "The body is not a valid {what}: {reason}",
    ),
    (
        Code::RequestRefused,
        "控制器拒绝了请求（HTTP {status}）",
        "The controller refused the request (HTTP {status})",
    ),
    (
        Code::Internal,
        "控制器内部出错：{what}",
        "The controller failed inside: {what}",
    ),
    // ---- sessions ----
    (Code::LoginRequired, "请先登录", "Log in first"),
    (
        Code::SessionExpired,
        "登录已失效，请重新登录",
        "Your login has expired; please log in again",
    ),
    (Code::WrongPassword, "密码错误", "Wrong password"),
    (
        Code::TooManyAttempts,
        "登录失败次数过多，请 {retry_after_s} 秒后再试",
        "Too many failed logins; try again in {retry_after_s} s",
    ),
    (
        Code::LoginBusy,
        "控制器正忙于核对其他密码，请 {retry_after_s} 秒后再试",
        "The controller is busy checking other passwords; try again in {retry_after_s} s",
    ),
    (
        Code::MustChangePassword,
        "请先修改初始密码",
        "Change the factory password first",
    ),
    (
        Code::WrongCurrentPassword,
        "当前密码错误",
        "The current password is wrong",
    ),
    (
        Code::PasswordTooShort,
        "新密码太短：至少 {min} 个字符",
        "The new password is too short: at least {min} characters",
    ),
    (
        Code::PasswordTooLong,
        "新密码太长：最多 {max_bytes} 字节",
        "The new password is too long: at most {max_bytes} bytes",
    ),
    (
        Code::PasswordIsDefault,
        "新密码不能是初始密码 {default}",
        "The new password must not be the factory password {default}",
    ),
    (
        Code::OriginNotAllowed,
        "此网页的来源不允许连接控制器（floatball.toml 的 allowed_origins）",
        "This page's origin may not connect to the controller (allowed_origins in floatball.toml)",
    ),
    // ---- shows and uploads ----
    (
        Code::BadShowName,
        "文件名不可用：{reason}",
        "The file name is not allowed: {reason}",
    ),
    (
        Code::ShowNotFound,
        "控制器上没有文件“{name}”",
        "The controller has no file \"{name}\"",
    ),
    (
        Code::ShowUnreadable,
        "控制器上的文件“{name}”无法读取",
        "The file \"{name}\" on the controller cannot be read: {reason}",
    ),
    (
        Code::ShowInPlaylist,
        "“{name}”在配置中，请先从配置中移除",
        "\"{name}\" is in the playlist; remove it from the playlist first",
    ),
    (
        Code::UploadIncomplete,
        "文件没有完整上传，请重试",
        "The upload was not received whole; try again",
    ),
    (
        Code::NotUtf8,
        "文件不是 UTF-8 文本（第 {byte} 字节）",
        "The file is not UTF-8 text (byte {byte})",
    ),
    (
        Code::ShowFileUnreadable,
        "无法读取这个动作文件",
        "The show file cannot be read",
    ),
    (
        Code::CsvUnreadable,
        "无法导入这个 CSV 关键帧文件",
        "The CSV keyframes cannot be imported",
    ),
    (
        Code::ShowEmpty,
        "动作为空：没有运动",
        "The show is empty: it has no motion",
    ),
    (
        Code::ShowTooLong,
        "动作超过了时长上限 {limit_ms} 毫秒",
        "The show is longer than the limit of {limit_ms} ms",
    ),
    (
        Code::ShowTooLarge,
        "动作超过了大小上限 {limit_bytes} 字节",
        "The show is larger than the limit of {limit_bytes} bytes",
    ),
    (
        Code::ShowUnfit,
        "动作不适合本装置：{count} 个问题",
        "The show does not fit this installation: {count} problems",
    ),
    (
        Code::OutputBox,
        "动作含有控制盒 {box} 的输出，但本装置有 {boxes} 个控制盒",
        "The show has outputs for box {box} but the installation has {boxes} boxes",
    ),
    (
        Code::MoreProblems,
        "……另有 {count} 个问题",
        "… and {count} more problems",
    ),
    (
        Code::CsvNeedsMotion,
        "CSV 动作至少需要两个关键帧，最后一个晚于 0 毫秒",
        "A CSV show needs at least two keyframes, the last after 0 ms",
    ),
    (
        Code::JsonNeedsMotion,
        "每个球的 rows 都是空的",
        "Every ball's \"rows\" is empty",
    ),
    (
        Code::ShowLasts,
        "动作时长 {duration_ms} 毫秒",
        "The show lasts {duration_ms} ms",
    ),
    (
        Code::ShowTakes,
        "保存后动作占 {bytes} 字节",
        "As stored the show takes {bytes} bytes",
    ),
    // ---- validation ----
    (
        Code::AboveTop,
        "位置 {position_mm} 毫米高于顶部（0 毫米），球会撞到上限位开关",
        "position {position_mm} mm is above the top (0 mm); the ball would hit the upper limit switch",
    ),
    (
        Code::BelowTravel,
        "位置 {position_mm} 毫米低于最低点（行程 {travel_mm} 毫米）",
        "position {position_mm} mm is below the lowest point (travel {travel_mm} mm)",
    ),
    (
        Code::TooFast,
        "速度 {speed_mm_s} 毫米/秒超过上限 {limit_mm_s} 毫米/秒",
        "speed {speed_mm_s} mm/s exceeds the limit of {limit_mm_s} mm/s",
    ),
    (
        Code::TooHardAcceleration,
        "加速度 {accel_mm_s2} 毫米/秒² 超过上限 {limit_mm_s2} 毫米/秒²",
        "acceleration {accel_mm_s2} mm/s² exceeds the limit of {limit_mm_s2} mm/s²",
    ),
    (
        Code::RowDuration,
        "第 {row} 行持续 {duration_ms} 毫秒；每行必须为 {min_ms} 到 {max_ms} 毫秒",
        "row {row} of the track lasts {duration_ms} ms; a row must last {min_ms} to {max_ms} ms",
    ),
    (
        Code::TrackDuration,
        "轨迹长 {duration_s} 秒，但动作长 {show_duration_s} 秒；每个球的轨迹必须与动作等长",
        "the track lasts {duration_s} s but the show lasts {show_duration_s} s; every ball's track must last as long as the show",
    ),
    (
        Code::EndsMoving,
        "轨迹结束时仍以 {velocity_mm_s} 毫米/秒运动；必须静止结束（速度 0）",
        "the track ends moving at {velocity_mm_s} mm/s; it must end at rest (velocity 0)",
    ),
    (
        Code::WrongLayout,
        "动作为 {show_rows} 行 × {show_cols} 列，但本装置为 {rows} 行 × {cols} 列",
        "the show is made for {show_rows} rows × {show_cols} columns but the installation has {rows} rows × {cols} columns",
    ),
    // ---- native show files ----
    (
        Code::ShowInvalid,
        "动作文件无效：{message}",
        "the show file is not valid: {message}",
    ),
    (
        Code::ShowWrongFormat,
        "这不是 Floatball 动作文件（format 为“{found}”）",
        "this is not a Floatball show file (\"format\" is \"{found}\")",
    ),
    (
        Code::ShowUnsupportedVersion,
        "动作文件为格式版本 {found}，本程序只能读取版本 {version}；请升级 Floatball",
        "the show file is format version {found}, but this Floatball reads version {version}; update Floatball",
    ),
    (
        Code::ShowEmptyLayout,
        "布局至少需要一行一列，且 pitch_mm 为正数",
        "the layout needs at least one row and one column and a positive pitch_mm",
    ),
    (
        Code::ShowTrackCount,
        "动作有 {tracks} 条轨迹，但布局为 {rows} × {cols}",
        "the show has {tracks} tracks but its layout is {rows} × {cols}",
    ),
    (
        Code::ShowNotFinite,
        "轨迹 {track}：位置或速度不是有限数",
        "track {track}: a position or velocity is not a finite number",
    ),
    (
        Code::ShowOutput,
        "控制盒 {box} 的输出无法播放",
        "the outputs of box {box} cannot be played: {detail}",
    ),
    (
        Code::ShowColourOrder,
        "轨迹 {track}：颜色关键帧 {index} 不晚于前一个",
        "track {track}: colour keyframe {index} is not later than the one before",
    ),
    // ---- CSV ----
    (
        Code::CsvEmpty,
        "文件是空的；第一行必须是表头“time_ms,u0,u1,…”",
        "the file is empty; it must start with a header line \"time_ms,u0,u1,…\"",
    ),
    (
        Code::CsvNoHeader,
        "布局行之后缺少表头“time_ms,u0,u1,…”",
        "the header line \"time_ms,u0,u1,…\" is missing after the layout line",
    ),
    (
        Code::CsvMisplacedComment,
        "以 # 开头的行只能是第一行的布局行“# rows=R cols=C pitch_mm=P”",
        "a line starting with # is only allowed first, as the layout \"# rows=R cols=C pitch_mm=P\"",
    ),
    (
        Code::CsvLayoutWord,
        "无法理解“{text}”；布局行为“# rows=R cols=C pitch_mm=P”",
        "\"{text}\" is not understood; the layout line reads \"# rows=R cols=C pitch_mm=P\"",
    ),
    (
        Code::CsvLayoutValue,
        "{key} 的值“{text}”无效",
        "{key} has an invalid value \"{text}\"",
    ),
    (
        Code::CsvLayoutMissing,
        "布局行缺少 {key}=…",
        "the layout line has no {key}=…",
    ),
    (
        Code::CsvHeaderName,
        "表头列为“{found}”，应为“{expected}”",
        "the header column is \"{found}\" but must be \"{expected}\"",
    ),
    (
        Code::CsvNoUnits,
        "表头没有球的列；应为“time_ms,u0,u1,…”",
        "the header names no balls; it must be \"time_ms,u0,u1,…\"",
    ),
    (
        Code::CsvLayoutMismatch,
        "文件有 {units} 个球列，但布局为 {rows} 行 × {cols} 列",
        "the file has {units} ball columns but the layout is {rows} rows × {cols} columns",
    ),
    (
        Code::CsvFieldCount,
        "此行有 {found} 个字段，表头有 {expected} 个",
        "this line has {found} fields but the header has {expected}",
    ),
    (
        Code::CsvNotANumber,
        "“{text}”不是数字",
        "\"{text}\" is not a number",
    ),
    (
        Code::CsvNoKeyframes,
        "表头之后没有关键帧",
        "there are no keyframes after the header",
    ),
    (
        Code::CsvFirstTimeNotZero,
        "第一个关键帧在 {time_ms} 毫秒；必须在 0",
        "the first keyframe is at {time_ms} ms; it must be at 0",
    ),
    (
        Code::CsvTimeNotIncreasing,
        "时间 {time_ms} 毫秒不晚于第 {previous_line} 行的 {previous_ms} 毫秒",
        "time {time_ms} ms is not after {previous_ms} ms on line {previous_line}",
    ),
    (
        Code::CsvGapTooShort,
        "此关键帧距第 {previous_line} 行仅 {gap_ms} 毫秒；关键帧至少相隔 {min_ms} 毫秒",
        "this keyframe is only {gap_ms} ms after the one on line {previous_line}; keyframes must be at least {min_ms} ms apart",
    ),
    (
        Code::CsvTooLate,
        "时间 {time_ms} 毫秒超过了最长 24 小时",
        "time {time_ms} ms is later than the longest show accepted (24 hours)",
    ),
    (
        Code::CsvTooLong,
        "时间 {time_ms} 毫秒超过了此处允许的最长动作（{max_ms} 毫秒）",
        "time {time_ms} ms is later than the longest show accepted here ({max_ms} ms)",
    ),
    (
        Code::CsvTooManyRows,
        "动作共有 {rows} 行，超过 {max_rows}；请减少球数或缩短动作",
        "the show would have {rows} rows in all, more than {max_rows}; use fewer balls or a shorter show",
    ),
    (
        Code::CsvConvertedTooLarge,
        "转换后动作将占 {bytes} 字节，超过上限 {max_bytes} 字节",
        "converted the show would take {bytes} bytes, more than the limit of {max_bytes} bytes",
    ),
    // ---- Start, Reset, Home ----
    (
        Code::PlaylistEmpty,
        "配置为空：请先添加动作",
        "The playlist is empty: add a show first",
    ),
    (
        Code::EntryUnreadable,
        "配置第 {entry} 项（“{show}”）无法读取",
        "Playlist entry {entry} (\"{show}\") cannot be read: {reason}",
    ),
    (
        Code::EntryInvalid,
        "第 {entry} 项（“{show}”）无法运行：{reason}",
        "Entry {entry} (\"{show}\") cannot run: {reason}",
    ),
    (
        Code::EntryInfeasible,
        "第 {entry} 项（“{show}”）无法运行：{reason}。建议：{fixes}",
        "Entry {entry} (\"{show}\") cannot run: {reason}. To make it run: {fixes}",
    ),
    (
        Code::GatewayNotConnected,
        "网关 {gateway} 未连接",
        "Gateway {gateway} is not connected",
    ),
    (
        Code::PlayerBusy,
        "矩阵正在运行配置；请先急停或重置",
        "The matrix is already running a playlist; press E-stop or Reset first",
    ),
    (
        Code::Superseded,
        "请求之后按下了急停；矩阵保持停止",
        "The E-stop was pressed after this request; the matrix stays stopped",
    ),
    (
        Code::PlayerGone,
        "播放器没有运行（控制器正在关闭）",
        "The player is not running (the controller is shutting down)",
    ),
    // ---- the WebSocket and the console ----
    (
        Code::BadMessage,
        "控制器无法理解这条消息",
        "The controller did not understand the message: {reason}",
    ),
    (
        Code::BinaryFrame,
        "只接受包含 JSON 的文本消息",
        "Only text frames holding JSON messages are understood",
    ),
    (
        Code::FeedbackDropped,
        "丢失了 {count} 个反馈帧：此设备读取太慢",
        "{count} feedback frames were dropped: this device reads too slowly",
    ),
    (
        Code::MustChangePasswordFirst,
        "请先修改初始密码（1234），再控制矩阵或发送指令",
        "Change the factory password (1234) before controlling the matrix or sending instructions",
    ),
    (
        Code::NoSuchGateway,
        "没有网关 {gateway}；网关编号为 0 到 {last}",
        "There is no gateway {gateway}; gateways are numbered 0 to {last}",
    ),
    (
        Code::EmptyLine,
        "这一行没有指令",
        "The line holds no instruction",
    ),
    (
        Code::EstopLatched,
        "急停已锁定：在开始、重置或回零之前只能发送查询；这一行未发送",
        "The E-stop is latched: only queries can be sent until Start, Reset or Home; this line was not sent",
    ),
    (
        Code::ConsoleBusy,
        "等待发往网关的指令太多；这一行未发送",
        "Too many console lines are waiting for the gateway; this one was not sent",
    ),
    (
        Code::ConsoleLineSpeed,
        "控制台不能设置线路速率（BDR={baud}）：请在“调试 → 线路速率”中更改，网桥会随网关一起切换；这一行未发送",
        "The console cannot set the line speed (BDR={baud}): change it in Commissioning → Line speed, which keeps the bridge in step with the gateway; this line was not sent",
    ),
    (
        Code::LineNotSent,
        "这一行未发送：{reason}",
        "The line was not sent: {reason}",
    ),
    (
        Code::NoSuchDrive,
        "网关 {gateway} 上没有驱动器 {drive}",
        "There is no drive {drive} on gateway {gateway}",
    ),
    (
        Code::DriveAddressNeeded,
        "{request}：请在前面写驱动器地址（网关 {gateway} 有 {drives} 个驱动器）",
        "{request}: put the drive's address first (gateway {gateway} has {drives} drives)",
    ),
    (
        Code::EstopUnreached,
        "急停暂未送达：{gateways}（连接恢复后立即发送）",
        "The E-stop did not reach: {gateways} (it is sent first thing when they come back)",
    ),
    // ---- UIM2503 instructions ----
    (
        Code::AsciiNotAscii,
        "{found} 不在 ASCII 1–127 之内，网关只接受这些字符（全角字符请改为半角）",
        "{found} is outside ASCII 1–127, the only characters the gateway accepts",
    ),
    (
        Code::AsciiBrace,
        "指令中不允许使用 `{found}`（手册 §6.1）",
        "`{found}` is forbidden in instructions (manual §6.1)",
    ),
    (
        Code::AsciiUnexpected,
        "此处不能是 {found}（应为：{expected}）；每条指令必须以 ; 结束",
        "expected {expected}, found {found}",
    ),
    (
        Code::AsciiOddHexDigits,
        "{instruction} 的十六进制操作数有 {digits} 位；位数必须为偶数（`0A` 而不是 `A`）",
        "the hexadecimal operand of {instruction} has {digits} digits; it needs an even number (`0A`, not `A`)",
    ),
    (
        Code::AsciiNumberTooLarge,
        "{field} 太大",
        "{field} is too large",
    ),
    (
        Code::AsciiOutOfRange,
        "{field} 必须在 {min}–{max} 之间，实为 {value}",
        "{field} must be {min}–{max}, found {value}",
    ),
    (
        Code::AsciiUnexpectedIndex,
        "{mnemonic} 不带下标",
        "{mnemonic} takes no index",
    ),
    (
        Code::AsciiMissingIndex,
        "{mnemonic} 需要下标：`{mnemonic}[X]`",
        "{mnemonic} needs an index: `{mnemonic}[X]`",
    ),
    (
        Code::AsciiOperandWithoutIndex,
        "{mnemonic} 只有带下标时才能带操作数：`{mnemonic}[X]=…;`",
        "{mnemonic} takes an operand only with an index: `{mnemonic}[X]=…;`",
    ),
    (
        Code::AsciiMissingOperand,
        "{instruction} 缺少操作数",
        "{instruction} needs an operand",
    ),
    (
        Code::AsciiTooLong,
        "这条指令含 `;` 共 {length} 个字符；网关最多接受 {max} 个",
        "this instruction is {length} characters including `;`; the gateway accepts at most {max}",
    ),
    (
        Code::AsciiNotEncodable,
        "这条指令无法发送：{reason}",
        "The instruction cannot be sent: {reason}",
    ),
    // ---- SCL ----
    (
        Code::SclNotAscii,
        "{found} 不是可打印的 ASCII 字符；SCL 是纯 ASCII 文本",
        "{found} is not printable ASCII; SCL is plain ASCII text",
    ),
    (
        Code::SclMissingMnemonic,
        "地址之后应为指令（两个大写字母，如 FL 或 DI）",
        "expected a command (two capital letters, such as FL or DI) after the address",
    ),
    (
        Code::SclUnknownMnemonic,
        "未知指令 {mnemonic}；指令为大写（FL、FP、FS、DI、VE、AC、DE…）",
        "unknown command {mnemonic}; mnemonics are upper case (FL, FP, FS, DI, VE, AC, DE, …)",
    ),
    (
        Code::SclBadAddress,
        "{found} 不能作为 RS-485 地址：地址为数字或 \" # $ & ' ( ) + , - . / : ; < = > 之一",
        "{found} cannot be an RS-485 address: an address is a digit or one of \" # $ & ' ( ) + , - . / : ; < = >",
    ),
    (
        Code::SclMissingParameter,
        "{mnemonic} 此处缺少参数（{expected}）",
        "{mnemonic} needs {expected} here",
    ),
    (
        Code::SclBadParameter,
        "{mnemonic}：参数“{found}”不合适（应为 {expected}）",
        "{mnemonic}: expected {expected}, found \"{found}\"",
    ),
    (
        Code::SclOutOfRange,
        "{mnemonic}：{found} 超出范围（{range}）",
        "{mnemonic}: {found} is out of range ({range})",
    ),
    (
        Code::SclTrailing,
        "完整的 {mnemonic} 指令之后多出“{found}”",
        "unexpected \"{found}\" after a complete {mnemonic} command",
    ),
    (
        Code::SclUploadLength,
        "程序上传：头部声明 {announced} 行，实际 {found} 行",
        "queue upload: the header announces {announced} lines, {found} follow",
    ),
    (
        Code::SclBadAnswer,
        "不是驱动器应答：应为 %、*、?（带代码）或如 IP=1000 的应答",
        "not a drive answer: expected %, *, ? (with its code) or a reply such as IP=1000",
    ),
    // ---- MBOX console ----
    (
        Code::MboxUnknownCommand,
        "未知命令 `{found}`：控制台支持 read、write、save、estop、release、reset、effects 和 ip",
        "unknown command `{found}`: the console knows read, write, save, estop, release, reset, effects and ip",
    ),
    (
        Code::MboxMissingCommand,
        "`{target}` 之后应为命令：read、write、save、estop、release、reset、effects 或 ip",
        "expected a command after `{target}`: read, write, save, estop, release, reset, effects or ip",
    ),
    (
        Code::MboxMissing,
        "`{command}` 此处缺少内容（{operand}）",
        "`{command}` needs {operand} here",
    ),
    (
        Code::MboxNotABank,
        "应为寄存器区 FN、DN 或 CX，实为 `{found}`",
        "expected a register bank FN, DN or CX, found `{found}`",
    ),
    (
        Code::MboxWrongBank,
        "`{command}` 不能用于 {bank}（{reason}）",
        "`{command}` does not take {bank}: {reason}",
    ),
    (
        Code::MboxNotANumber,
        "应为数字（十进制或 0x 十六进制），实为 `{found}`",
        "expected {operand} as a number (decimal or 0x hex), found `{found}`",
    ),
    (
        Code::MboxOutOfRange,
        "`{found}` 超出范围（{operand}）",
        "{operand} `{found}` is out of range",
    ),
    (
        Code::MboxZeroCount,
        "数量为 0：至少读取一个寄存器",
        "count 0: read at least one register",
    ),
    (
        Code::MboxRange,
        "寄存器范围无效：{reason}",
        "the register range is refused: {reason}",
    ),
    (
        Code::MboxTrailing,
        "多出 `{found}`：`{command}` 已完整（命令之间用换行或 ; 分隔）",
        "unexpected `{found}`: `{command}` is complete without it (commands are separated by a new line or `;`)",
    ),
    (
        Code::MboxNotAnIp,
        "应为 IP 地址，如 192.168.15.210，实为 `{found}`",
        "expected an IP address such as 192.168.15.210, found `{found}`",
    ),
    (
        Code::MboxBadTarget,
        "@ 之后应为控制盒：all、末位如 201、两段如 15.201 或 IP 地址；实为 `{found}`",
        "expected a box after `@`: all, a last octet such as 201, two octets such as 15.201 or an IP address; found `{found}`",
    ),
    (
        Code::MboxNoSubnet,
        "`@{octet}` 只给了末位，而所选的不是单个控制盒：请写两段，如 @15.{octet}",
        "`@{octet}` gives the last octet only, and the selected box is not one box: give two octets, such as @15.{octet}",
    ),
    // ---- unit errors ----
    (
        Code::UnitSyntax,
        "网关无法读取这条指令（错误 {error}）",
        "the gateway could not read the instruction (error {error})",
    ),
    (
        Code::UnitData,
        "数值超出范围或不一致（错误 {error}）",
        "value out of range or inconsistent (error {error})",
    ),
    (
        Code::UnitIndex,
        "下标超出范围（错误 {error}）",
        "index out of range (error {error})",
    ),
    (
        Code::UnitWhileMoving,
        "电机运动时不允许（错误 {error}）",
        "not allowed while the motor moves (error {error})",
    ),
    (
        Code::UnitMotorOff,
        "电机驱动器已关闭（错误 {error}）",
        "the motor driver is off (error {error})",
    ),
    (
        Code::UnitOverload,
        "单元跟不上 PVT 行（速度或加速度）（错误 {error}）",
        "the unit cannot follow the PVT row (speed or acceleration) (error {error})",
    ),
    (
        Code::UnitLimit,
        "球到达了行程端点（错误 {error}）",
        "the ball reached the end of its travel (error {error})",
    ),
    (
        Code::UnitUnknown,
        "未知错误（错误 {error}）",
        "unknown error (error {error})",
    ),
    // ---- the playlist ----
    (
        Code::PlaylistLocked,
        "播放或移动时不能修改配置条目",
        "The playlist's entries cannot change while a show plays or balls move",
    ),
    (
        Code::PlaylistInvalid,
        "配置无效",
        "The playlist is not valid",
    ),
    (
        Code::PlaylistTooManyEntries,
        "配置有 {entries} 个条目；最多 {max} 个",
        "the playlist has {entries} entries; at most {max} are allowed",
    ),
    (
        Code::PlaylistUnknownShow,
        "第 {entry} 项：没有名为“{show}”的动作",
        "entry {entry}: there is no show named \"{show}\"",
    ),
    (
        Code::EntryCycles,
        "第 {entry} 项：周期 {cycles} 无效；必须为 1 到 {max}",
        "entry {entry}: cycles is {cycles}; it must be from 1 to {max}",
    ),
    (
        Code::EntryDelay,
        "第 {entry} 项：延时 {delay_ms} 毫秒无效；最多 {max_ms} 毫秒（一天）",
        "entry {entry}: delay_ms is {delay_ms}; it must be at most {max_ms} (one day)",
    ),
    (
        Code::DefaultCycles,
        "默认周期 {cycles} 无效；必须为 1 到 {max}",
        "default_cycles is {cycles}; it must be from 1 to {max}",
    ),
    (
        Code::DefaultDelay,
        "默认延时 {delay_ms} 毫秒无效；最多 {max_ms} 毫秒（一天）",
        "default_delay_ms is {delay_ms}; it must be at most {max_ms} (one day)",
    ),
    // ---- engineering calls ----
    (
        Code::BadQuery,
        "查询参数错误：{reason}",
        "Bad query: {reason}",
    ),
    (
        Code::NoSuchUnit,
        "动作“{name}”有 {units} 个球：没有球 {unit}（第一个为 0）",
        "The show \"{name}\" has {units} balls: no unit {unit} (the first is 0)",
    ),
    (
        Code::QprogramRefused,
        "无法编译 Q 程序：{reason}",
        "The Q program cannot be compiled: {reason}",
    ),
    (
        Code::NoMboxBoxes,
        "本装置没有 MBOX 控制盒",
        "This installation has no MBOX boxes",
    ),
    // ---- plan verdicts ----
    (
        Code::LineStarved,
        "网关 {gateway}（{baud} 波特）供不上它的 {units} 个单元：“{show}”每秒需要 {needed_bytes_per_s} 字节，线路只能传 {available_bytes_per_s} 字节，即使预载满 {preload_rows} 行，单元的行缓冲也会在动作开始 {dry_at_s} 秒后用尽",
        "gateway {gateway} ({baud} baud) cannot keep its {units} units fed: \"{show}\" streams {needed_bytes_per_s} B/s while the line carries {available_bytes_per_s} B/s, so the units' row buffers run dry {dry_at_s} s into the show even with a full {preload_rows}-row preload",
    ),
    (
        Code::LineStarvedDuring,
        "网关 {gateway}（{baud} 波特）供不上它的 {units} 个单元：“{show}”每秒需要 {needed_bytes_per_s} 字节，线路只能传 {available_bytes_per_s} 字节，即使预载满 {preload_rows} 行，单元的行缓冲也会在动作中用尽",
        "gateway {gateway} ({baud} baud) cannot keep its {units} units fed: \"{show}\" streams {needed_bytes_per_s} B/s while the line carries {available_bytes_per_s} B/s, so the units' row buffers run dry during the show even with a full {preload_rows}-row preload",
    ),
    (
        Code::BallCount,
        "动作有 {show_balls} 个球，但本装置有 {units} 个",
        "the show has {show_balls} balls but the installation has {units}",
    ),
    (
        Code::OutOfCounts,
        "{value_mm} 毫米在 {counts_per_mm} 计数/毫米下超出单元的计数范围",
        "{value_mm} mm does not fit in counts at {counts_per_mm} counts/mm",
    ),
    (
        Code::UnitCount,
        "装置列出 {listed} 个单元，但矩阵有 {expected} 个",
        "the installation lists {listed} units for a matrix of {expected}",
    ),
    (
        Code::FixFasterLine,
        "把线路提高到 {baud} 波特（在网关上设 BDR={baud};，再在 floatball.toml 中设 `baud = {baud}`）",
        "raise the line to {baud} baud (BDR={baud}; on the gateway, then `baud = {baud}` in floatball.toml)",
    ),
    (
        Code::FixNoBaudEnough,
        "单靠提高波特率（最高 {max_baud}）不够",
        "no baud rate up to {max_baud} is enough on its own",
    ),
    (
        Code::FixFewerUnits,
        "在 {baud} 波特下每个网关最多接 {units_per_gateway} 个单元（这 {units} 个需要 {gateways} 个网关）",
        "put at most {units_per_gateway} of these units on each gateway at {baud} baud ({gateways} gateways for these {units})",
    ),
    (
        Code::FixLongerRows,
        "每行至少 {row_ms} 毫秒（这个动作的行平均 {mean_row_ms} 毫秒）",
        "use rows of at least {row_ms} ms (this show's rows last {mean_row_ms} ms on average)",
    ),
    (
        Code::FixFewerRows,
        "或把动作缩短到每个球最多 {rows} 行，使它在开始前完全载入",
        "or shorten the show to at most {rows} rows per ball so it loads completely before it starts",
    ),
    (
        Code::FixTolerance,
        "把 [scl] tolerance_mm 提高到至少 {tolerance_mm} 毫米（各球最大偏差为 {deviation_mm} 毫米），或让动作的移动更少、更平缓",
        "raise [scl] tolerance_mm to {tolerance_mm} mm or more (the largest deviation of any ball is {deviation_mm} mm), or give the show fewer, gentler moves",
    ),
    // ---- Q programs ----
    (
        Code::QprogramTooFar,
        "程序会偏离动作 {deviation_mm} 毫米，超过容差 {tolerance_mm} 毫米（动作的移动太多，驱动器的 12 段各 62 行装不下，或有点到点移动跟不紧的移动）",
        "the program would be {deviation_mm} mm off the show, more than the tolerance of {tolerance_mm} mm (the show has too many moves for a drive's 12 segments of 62 lines, or moves that a rest-to-rest move cannot follow closely)",
    ),
    (
        Code::QprogramTooFast,
        "球到不了它的位置：点到点移动需要超过 {max_speed_mm_s} 毫米/秒或 {max_accel_mm_s2} 毫米/秒²",
        "the ball cannot be at its position: a move from rest to rest would need more than {max_speed_mm_s} mm/s or {max_accel_mm_s2} mm/s²",
    ),
    (
        Code::QprogramOutOfRange,
        "位置 {position_mm} 毫米超出驱动器的范围",
        "the position {position_mm} mm is out of the drive's range",
    ),
    (
        Code::QprogramTooManyLines,
        "程序需要 {lines} 行，超过驱动器的 {limit} 行",
        "the program needs {lines} lines, more than a drive's {limit}",
    ),
    (
        Code::QprogramSetting,
        "Q 程序设置 {field} 必须为 {must}",
        "the Q program setting {field} must be {must}",
    ),
    // ---- install ----
    (
        Code::InstallationInvalid,
        "安装设置有 {problems} 个问题，未保存",
        "The installation has {problems} problem(s) and was not saved",
    ),
    (
        Code::InstallationProblem,
        "安装设置：{reason}",
        "Installation: {reason}",
    ),
    (
        Code::InstallationBusy,
        "矩阵正在{state}：只能在空闲时更改安装设置或线速",
        "The matrix is {state}: the installation and line speeds change only while it is idle",
    ),
    (
        Code::InstallationNotLive,
        "MBOX 控制盒和 MOONS' 驱动器的网关只能在 floatball.toml 中更改，并在重启后生效",
        "The gateways of MBOX boxes and MOONS' drives change only in floatball.toml, at a restart",
    ),
    (
        Code::InstallationNotSaved,
        "无法保存 floatball.toml：{reason}",
        "floatball.toml could not be saved: {reason}",
    ),
    (
        Code::BaudNotAllowed,
        "网关不支持 {baud} 波特；可用：{allowed}",
        "The gateway does not take {baud} baud; it takes {allowed}",
    ),
    // ---- line ----
    (
        Code::BaudOutOfRange,
        "网关不支持 {baud} 波特的线路速度（{min}–{max}）",
        "{baud} baud is not a line speed the gateway takes ({min}–{max})",
    ),
    (
        Code::BaudNotAnswering,
        "网关 {gateway} 在 {waited_ms} 毫秒内没有以 {baud} 波特应答；线路已恢复为 {from_baud} 波特",
        "Gateway {gateway} did not answer at {baud} baud within {waited_ms} ms; the line is back at {from_baud} baud",
    ),
    (
        Code::BaudPortRefused,
        "网关 {gateway} 的串口无法以 {baud} 波特运行：{reason}",
        "The port of gateway {gateway} cannot run at {baud} baud: {reason}",
    ),
    // ---- arm ----
    (
        Code::PreloadLong,
        "网关 {gateway} 在 {baud} 波特下开始前要预载 {preload_bytes} 字节，需 {preload_s} 秒（{preload_min} 分钟）；在 {faster_baud} 波特下只需 {faster_preload_s} 秒（更改线路速度：在网关上设 BDR={faster_baud};，再在 floatball.toml 中设 `baud = {faster_baud}`）",
        "gateway {gateway} preloads {preload_bytes} bytes in {preload_s} s ({preload_min} min) at {baud} baud before the show can start; at {faster_baud} baud it takes {faster_preload_s} s (change the line speed: BDR={faster_baud}; on the gateway, then `baud = {faster_baud}` in floatball.toml)",
    ),
    (
        Code::PreloadLongFastest,
        "网关 {gateway} 即使在最快的 {baud} 波特下，开始前也要预载 {preload_bytes} 字节，需 {preload_s} 秒（{preload_min} 分钟）；作为播放列表的第一项，它会在矩阵空闲时预先载入",
        "gateway {gateway} preloads {preload_bytes} bytes in {preload_s} s ({preload_min} min) at {baud} baud before the show can start, even at the fastest rate; as the playlist's first entry it is loaded while the matrix is idle",
    ),
    // ---- commission ----
    (
        Code::CommissionNotUim2503,
        "网关 {gateway} 不是 UIM2503 网关；只有 UFQ750 单元需要调试",
        "Gateway {gateway} is not a UIM2503 gateway; only UFQ750 units are commissioned",
    ),
    (
        Code::CommissionNotIdle,
        "矩阵正在{state}：调试要等到矩阵空闲",
        "The matrix is {state}: commissioning waits until it is idle",
    ),
    (
        Code::CommissionInProgress,
        "另一个调试操作正在使用网关 {gateway}；完成后再试",
        "Another commissioning call is using gateway {gateway}; try again when it is done",
    ),
    (
        Code::CommissionBadStation,
        "站号 {station} 不是单元的站号；站号为 1–127",
        "Station {station} is not a unit's station; stations are 1–127",
    ),
    (
        Code::CommissionBadDistance,
        "识别距离必须是正的毫米数，收到 {distance_mm}",
        "The identify distance must be a positive number of mm, found {distance_mm}",
    ),
    (
        Code::CommissionStationSilent,
        "网关 {gateway} 的站号 {station} 没有单元应答",
        "No unit answers on station {station} of gateway {gateway}",
    ),
    (
        Code::CommissionStationShared,
        "网关 {gateway} 的站号 {station} 上有 {units} 个单元应答；请先给它们各自的站号",
        "{units} units answer on station {station} of gateway {gateway}; give them their own stations first",
    ),
    (
        Code::CommissionNoAssignments,
        "请求没有分配任何单元",
        "The request assigns no unit",
    ),
    (
        Code::CommissionSerialTwice,
        "序列号 {serial} 被分配了两次",
        "Serial {serial} is assigned twice",
    ),
    (
        Code::CommissionStationTwice,
        "站号 {station} 被分配给了两个单元",
        "Station {station} is given to two units",
    ),
    (
        Code::CommissionSerialTooLong,
        "序列号 {serial} 太长：`SN[X]=s/n;` 最多 {max} 个字符",
        "Serial {serial} is too long: `SN[X]=s/n;` holds at most {max} characters",
    ),
];
