//! The app's two languages and every string a user sees.
//!
//! Fixed strings are [`Text`] variants, translated by [`Lang::t`]; strings with a
//! value in them are methods of [`Lang`]. Errors from the bridge and from the shared
//! parsers come as a code and parameters ([`floatball_shared::codes`]) and are
//! rendered by [`Lang::coded`] from the shared English templates ([`Code::english`])
//! and the 中文 ones in [`codes`]; the bridge's English text is shown only for a code
//! this app does not know (a newer or older bridge).

mod codes;

use floatball_shared::api::{
    ApiError, LinkState, PlanReport, PlayerState, Problem, QProgramListing,
};
use floatball_shared::codes::{Code, Coded, Params, fill};

use crate::client::Failure;
use crate::playlist::InputError;

/// A language of the user interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Lang {
    /// 中文 (the vendor app's language).
    #[default]
    Zh,
    /// English.
    En,
}

macro_rules! texts {
    ($(#[$enum_doc:meta])* $enum:ident; $($(#[$doc:meta])* $name:ident => $zh:literal, $en:literal;)*) => {
        $(#[$enum_doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum $enum {
            $($(#[$doc])* $name,)*
        }

        impl $enum {
            /// Every string, for tests that check both languages.
            pub const ALL: &'static [$enum] = &[$($enum::$name),*];
        }

        impl $crate::i18n::Words for $enum {
            fn pair(self) -> (&'static str, &'static str) {
                match self {
                    $($enum::$name => ($zh, $en),)*
                }
            }
        }
    };
}

/// A fixed string in both languages (中文, English). [`Text`] holds those of the
/// first load; a page in a chunk of its own keeps its own table (e.g.
/// [`ScheduleText`], [`PatchText`], [`CommissionText`], [`CreateText`],
/// [`PasswordText`]), so its strings come with its chunk.
pub trait Words: Copy + Send + Sync + 'static {
    /// The string in Chinese and in English.
    fn pair(self) -> (&'static str, &'static str);
}

mod commission;
pub mod create;
mod live;
mod password;
mod patch;
mod schedule;

pub use commission::CommissionText;
pub use create::CreateText;
pub use live::LiveText;
pub use password::PasswordText;
pub use patch::PatchText;
pub use schedule::ScheduleText;

texts! {
    /// A fixed user-visible string of the first load.
    Text;
    /// The top bar when the bridge is reachable.
    Connected => "已连接", "Connected";
    /// The top bar when it is not.
    NotConnected => "未连接", "Not connected";
    /// The language switch's label: the *other* language's name.
    SwitchLanguage => "English", "中文";
    /// The emergency stop button.
    Estop => "急停", "E-STOP";
    /// The e-stop was handed to the socket.
    EstopSent => "急停已发送", "E-stop sent";
    /// The bridge reports the matrix stopped after an e-stop.
    EstopStopped => "已停止", "Stopped";
    /// The e-stop could not be sent.
    EstopNotSent => "未发送：无连接", "NOT sent: no connection";
    /// Navigation: Files.
    NavFiles => "文件管理", "Files";
    /// Navigation: Preview.
    NavPreview => "预览", "Preview";
    /// Navigation: Control.
    NavControl => "控制", "Control";
    /// Navigation: Console.
    NavConsole => "控制台", "Console";
    /// Control's second tab: Settings.
    NavSettings => "设置", "Settings";
    /// Login page title.
    LoginTitle => "登录", "Log in";
    /// Label of the address field.
    Address => "控制器地址", "Controller address";
    /// Label of the password field.
    Password => "密码", "Password";
    /// The login button.
    LoginButton => "登录", "Log in";
    /// While the login request runs.
    Working => "请稍候…", "Please wait…";
    /// 401 on login.
    WrongPassword => "密码错误", "Wrong password";
    /// 401 on a call with a token.
    SessionExpired => "登录已失效，请重新登录", "Your login has expired; please log in again";
    /// Logged in; the address follows.
    LoggedInTo => "已登录到", "Logged in to";
    /// The logout button.
    Logout => "退出登录", "Log out";
    /// 403: change the password first.
    MustChangePasswordFirst => "请先修改初始密码", "Change the factory password first";
    /// Files: the local tab.
    LocalFiles => "本地文件", "Local files";
    /// Files: the controller tab.
    ControllerFiles => "浮球文件", "Controller files";
    /// Add files from the device.
    AddFiles => "添加文件", "Add files";
    /// Upload to the controller.
    Upload => "上传", "Upload";
    /// Download from the controller.
    Download => "下载", "Download";
    /// Open the preview.
    Preview => "预览", "Preview";
    /// Delete.
    Delete => "删除", "Delete";
    /// Delete, second tap.
    ConfirmDelete => "确认删除？", "Really delete?";
    /// Save a local file to the device.
    SaveToDevice => "保存到设备", "Save to device";
    /// Heading: a ball's Q program (MOONS' drives).
    QProgram => "Q 程序（鸣志驱动器）", "Q program (MOONS' drives)";
    /// Field: which ball.
    Ball => "球号 (uN)", "Ball (uN)";
    /// Compile and show one ball's Q program.
    ShowQProgram => "查看程序", "Show program";
    /// The ball field holds no number.
    BallNumberWanted => "请输入球号：0 或更大的整数", "Enter a ball number: a whole number from 0";
    /// Reload the list.
    Refresh => "刷新", "Refresh";
    /// Column: name.
    Name => "名称", "Name";
    /// Column: number of balls.
    Units => "球数", "Balls";
    /// Column: duration.
    Duration => "时长", "Duration";
    /// Column: size.
    Size => "大小", "Size";
    /// No local files yet.
    NoLocalFiles => "还没有本地文件。点“添加文件”，从设备中选择 CSV 或 JSON 动作文件。", "No local files yet. Tap “Add files” to pick CSV or JSON show files from this device.";
    /// No files on the controller.
    NoControllerFiles => "控制器上还没有文件。", "There are no files on the controller yet.";
    /// The controller is still indexing its library after a start.
    LibraryIndexing => "控制器正在读取浮球文件，列表还不完整……", "The controller is still reading its files; the list is not complete yet…";
    /// Not connected: what works.
    OfflineHint => "未连接：不能上传和下载，本地文件仍可预览。", "Not connected: upload and download are unavailable; local files can still be previewed.";
    /// Upload finished.
    Uploaded => "已上传", "Uploaded";
    /// Download finished.
    Downloaded => "已下载到本地文件", "Downloaded to the local files";
    /// 422 on upload: the list of problems follows.
    UploadRefused => "控制器拒绝了这个文件：", "The controller refused this file:";
    /// 413.
    TooLarge => "文件超过了控制器的大小限制", "The file is over the controller's size limit";
    /// Local storage failed.
    StorageFailed => "浏览器存储出错", "The browser's storage failed";
    /// Preview: pick a show.
    ChooseShow => "选择动作文件", "Choose a show";
    /// Preview: nothing chosen.
    NoShowSelected => "没有选择动作文件。", "No show selected.";
    /// Preview: loading a controller file.
    Loading => "加载中…", "Loading…";
    /// A page's code could not be downloaded (offline, or an old copy after an update).
    ChunkFailed => "无法加载此页面（网络断开或应用已更新）。", "This page could not be loaded (offline, or the app was updated).";
    /// A part of a page (a panel, a form) could not be downloaded.
    PartFailed => "无法加载这一部分（网络断开或应用已更新）。", "This part could not be loaded (offline, or the app was updated).";
    /// Try loading the page's code again.
    Retry => "重试", "Retry";
    /// Load the app again (its page names the files of the version now served).
    ReloadApp => "重新载入应用", "Reload the app";
    /// The Preview: the check of a show against the limits could not be loaded.
    CheckFailed => "无法检查此节目是否超出限制（网络断开或应用已更新）。", "The show could not be checked against the limits (offline, or the app was updated).";
    /// The console's instruction checker could not be downloaded.
    CheckerFailed => "无法加载指令检查程序（网络断开或应用已更新）。", "The instruction checker could not be loaded (offline, or the app was updated).";
    /// The CSV reader (for a local file's preview) could not be downloaded.
    CsvReaderFailed => "无法加载 CSV 读取程序（网络断开或应用已更新）：请重新载入应用。", "The CSV reader could not be loaded (offline, or the app was updated): reload the app.";
    /// The console's instruction checker is being downloaded.
    CheckerLoading => "正在加载指令检查程序…", "Loading the instruction checker…";
    /// Preview: restart.
    Restart => "重新播放", "Restart";
    /// Preview: step back.
    StepBack => "后退", "Step back";
    /// Preview: pause.
    Pause => "暂停", "Pause";
    /// Preview: play.
    Play => "播放", "Play";
    /// Preview: step forward.
    StepForward => "前进", "Step forward";
    /// Preview: the time slider.
    ShowTime => "时间", "Time";
    /// Preview: the show passes validation.
    WithinLimits => "在默认限制之内（行程、速度、加速度）", "Within the default limits (travel, speed, acceleration)";
    /// Preview: validation problems follow.
    BeyondLimits => "超出默认限制：", "Beyond the default limits:";
    /// Preview: the file cannot be read.
    CannotRead => "无法读取这个文件：", "This file cannot be read:";
    /// Preview: the 3D view.
    View3d => "三维", "3D";
    /// Preview: the 2D view from above.
    TopView => "俯视", "Top view";
    /// Preview: back to the default camera.
    ResetView => "复位视角", "Reset view";
    /// Preview: the playback speed.
    PlaybackSpeed => "播放速度", "Speed";
    /// Preview: follow the matrix's show time.
    Live => "实时", "Live";
    /// Preview: why live mode is off.
    LiveHint => "矩阵运行这个动作时，可实时跟随它的进度。", "Live follows the matrix while it plays this show.";
    /// Preview: the browser has no WebGL2.
    NoWebGl => "此浏览器不支持 WebGL2，显示俯视图。", "This browser has no WebGL2: showing the top view.";
    /// Preview: how to move the 3D view.
    GestureHint => "拖动旋转，双指或滚轮缩放，双指或右键拖动平移；点一个球查看它的曲线。", "Drag to turn, pinch or wheel to zoom, two fingers or the right button to pan; tap a ball for its plot.";
    /// Preview: the plot's upper panel.
    PlotPosition => "位置（毫米，距顶部）", "Position (mm below the top)";
    /// Preview: the plot's lower panel.
    PlotVelocity => "速度（毫米/秒，向下为正）", "Velocity (mm/s, + = down)";
    /// Preview: close the plot.
    Close => "关闭", "Close";
    /// Preview: the ball keeps every limit.
    BallWithinLimits => "这个球在限制之内。", "This ball stays within the limits.";
    /// Performance panel: heading and the button that opens it.
    Performance => "性能", "Performance";
    /// Performance panel: what it does.
    PerfExplain => "用合成动作测量本设备每帧计算和绘制所需的时间。", "Measures how long this device takes to evaluate and to draw one frame of synthetic shows.";
    /// Performance panel: start.
    PerfRun => "开始测量", "Measure";
    /// Performance panel: column.
    PerfEvalMs => "计算（毫秒）", "Evaluate (ms)";
    /// Performance panel: column.
    PerfFrameMs => "每帧（毫秒）", "Frame (ms)";
    /// Performance panel: column.
    PerfFps => "帧率", "Frames/s";
    /// Control: the playlist.
    Playlist => "配置", "Playlist";
    /// Control: add an entry.
    Add => "添加", "Add";
    /// Control: move up.
    MoveUp => "上移", "Move up";
    /// Control: move down.
    MoveDown => "下移", "Move down";
    /// Control: edit.
    Edit => "编辑", "Edit";
    /// Control: delay in seconds.
    DelayS => "延时（秒）", "Delay (s)";
    /// Control: cycles.
    Cycles => "周期", "Cycles";
    /// Apply a form.
    Apply => "应用", "Apply";
    /// Close a form.
    Cancel => "取消", "Cancel";
    /// Start the playlist.
    Start => "开始", "Start";
    /// Reset: home and start over.
    Reset => "重置", "Reset";
    /// Control: where Start and Reset begin, the entry.
    StartEntry => "从第几项", "From entry";
    /// Control: where Start and Reset begin, the time inside the entry's show.
    StartTime => "从时间（分:秒）", "At time (m:ss)";
    /// Control: open the Preview where a Start from the entry and time typed begins.
    PreviewFrom => "预览起点", "Preview from there";
    /// Control: an entry or time beside Start that cannot be read.
    BadStartFrom => "起始项须为从 1 开始的整数，时间须为 分:秒 或 秒（如 1:30 或 90）", "The entry must be a whole number from 1 and the time m:ss or seconds (e.g. 1:30 or 90)";
    /// Control's edit panel: an entry's timecode start.
    TimecodeStart => "时间码起点（时:分:秒:帧，可空）", "Timecode start (HH:MM:SS:FF, optional)";
    /// Control: the timecode chase's card title.
    TimecodeTitle => "时间码跟随", "Timecode chase";
    /// Control: the offset of the show from the timecode.
    TimecodeOffset => "演出与时间码之差", "Show − timecode";
    /// Control: the chase's lead (from a start until the show is at its time).
    TimecodeLead => "提前量", "Lead";
    /// Control: the drift of the units' clock against the timecode.
    TimecodeDrift => "漂移", "Drift";
    /// Chase state: no timecode has arrived.
    ChaseNoTimecode => "无时间码", "No timecode";
    /// Chase state: waiting for a cue.
    ChaseWaiting => "等待起点", "Waiting for a cue";
    /// Chase state: a start was issued.
    ChaseCued => "已起动，等待演出", "Cued: starting";
    /// Chase state: in step.
    ChaseChasing => "跟随中", "Chasing";
    /// Chase state: a locate was issued.
    ChaseLocating => "定位中", "Locating";
    /// Chase state: the timecode was lost, the show plays on.
    ChaseHolding => "时间码丢失：继续演出", "Timecode lost: playing on";
    /// Chase state: the timecode was lost, the matrix stopped.
    ChaseStopped => "时间码丢失：已停止", "Timecode lost: stopped";
    /// Chase state: the timecode was lost while nothing played.
    ChaseLost => "时间码丢失", "Timecode lost";
    /// Empty playlist.
    EmptyPlaylist => "配置为空。点“添加”选择浮球文件。", "The playlist is empty. Tap “Add” to pick controller files.";
    /// Pick a show to add.
    PickShow => "选择要添加的浮球文件", "Pick a controller file to add";
    /// Nothing checked for an action that needs checks.
    CheckFirst => "请先勾选条目", "Check entries first";
    /// Settings: default delay.
    DefaultDelayS => "默认延时（秒）", "Default delay (s)";
    /// Settings: default cycles.
    DefaultCycles => "默认周期", "Default cycles";
    /// Settings: loop.
    LoopPlaylist => "循环播放配置", "Loop the playlist";
    /// Settings saved.
    Saved => "已保存", "Saved";
    /// Status: heading.
    StatusTitle => "状态", "Status";
    /// Status: player state.
    State => "状态", "State";
    /// Status: playlist entry.
    Entry => "条目", "Entry";
    /// Status: show.
    ShowLabel => "动作", "Show";
    /// Status: cycle.
    Cycle => "周期", "Cycle";
    /// Status: gateways.
    Gateways => "网关", "Gateways";
    /// Status: last error.
    LastError => "最近错误", "Last error";
    /// Status while not connected.
    StatusUnavailable => "未连接：没有实时状态。", "Not connected: no live status.";
    /// Bandwidth report: heading.
    PlanTitle => "带宽检查", "Bandwidth check";
    /// Bandwidth report: can run.
    PlanFeasible => "可以运行", "can run";
    /// Bandwidth report: cannot run.
    PlanInfeasible => "不能运行", "cannot run";
    /// Bandwidth report: no planner on this bridge.
    PlanUnavailable => "暂无报告", "not available";
    /// Bandwidth report: being fetched.
    PlanPending => "检查中…", "checking…";
    /// Bandwidth report: what would help.
    PlanFixes => "建议：", "To fix:";
    /// A refused request reported over the WebSocket.
    BridgeSays => "控制器：", "Controller:";
    /// Console: the input.
    Instructions => "指令", "Instructions";
    /// Console: send.
    Send => "发送", "Send";
    /// Console: gateway choice.
    Gateway => "网关", "Gateway";
    /// Console: every gateway.
    AllGateways => "全部网关", "All gateways";
    /// Console: feedback heading.
    Feedback => "反馈帧", "Feedback frames";
    /// Console: no frames yet.
    NoFeedback => "还没有收到反馈帧。", "No feedback frames yet.";
    /// Console: clear the list.
    Clear => "清除", "Clear";
    /// Console: sent lines heading.
    SentLines => "已发送", "Sent";
    /// Console: the instruction syntax hint.
    ConsoleHint => "每行一条或多条指令，例如 *5;PV; 。# 之后为注释。", "One or more instructions per line, e.g. *5;PV; — # starts a comment.";
    /// Console on MBOX boxes: the syntax hint.
    MboxConsoleHint => "每行一条或多条（以 ; 分隔）控制盒命令，例如 read FN 0x20 4 。# 之后为注释。", "One or more box commands per line (separated by ;), e.g. read FN 0x20 4 — # starts a comment.";
    /// What to type on MOONS' drives.
    SclConsoleHint => "每行一条 SCL 指令，驱动器地址在前，例如 0IP （问 0 号驱动器的位置）。", "One SCL command per line, the drive's address first, e.g. 0IP (ask drive 0 its position).";
    /// Console on MBOX boxes: the help's title.
    MboxHelpTitle => "控制盒命令", "Box commands";
    /// Console on MBOX boxes: the help (one command a line).
    MboxHelp => "read FN|DN 起始 数量 — 读寄存器（地址按十六进制，FN020 = 0x20）\nwrite FN|CX 起始 值… — 写寄存器（FN 不保存）\nsave FN 起始 值… — 写并保存 FN 参数\nestop / release — FN 0x0090 = 1 / 0（急停锁定时 release 被拒绝：请用复位、启动或回零）\nreset — CX 0 = 0；effects 掩码 — CX 1 = 掩码\nip A.B.C.D — 设置控制盒的 IP（保存）\n@201、@15.201、@all、@all/none — 指定执行与应答的控制盒", "read FN|DN start count — read registers (addresses in hex: FN020 = 0x20)\nwrite FN|CX start value… — write registers (FN not saved)\nsave FN start value… — write FN parameters, saved\nestop / release — FN 0x0090 = 1 / 0 (release is refused while the E-stop is latched: use Reset, Start or Home)\nreset — CX 0 = 0; effects mask — CX 1 = mask\nip A.B.C.D — set the box's IP address (saved)\n@201, @15.201, @all, @all/none — the box that executes and the one that replies";
    /// Title of the SCL help.
    SclHelpTitle => "SCL 指令（鸣志驱动器）", "SCL commands (MOONS' drives)";
    /// The SCL commands a commissioning engineer needs, one a line.
    SclHelp => "0IP、0SC、0AL — 问 0 号驱动器的位置、状态字、报警字\n0ME / 0MD — 使能 / 断开电机；0AR — 复位报警\n0SP0 — 把当前位置设为 0（计数）\n0VE2.5、0AC10、0DE10、0DI20000、0FL — 以 2.5 转/秒 相对移动 20000 计数；FP 为绝对移动\n0SK — 停止并清空缓存；0ST — 停止运动\n0QX1 — 执行已存的第 1 段程序；0QU1 — 读回第 1 段\n地址：0–9 及 \" # $ & ' ( ) + , - . / : ; < = >（按配置）；网关选择决定发往哪条线", "0IP, 0SC, 0AL — ask drive 0 its position, status word, alarm word\n0ME / 0MD — enable / disable the motor; 0AR — reset the alarm\n0SP0 — call the present position 0 (counts)\n0VE2.5, 0AC10, 0DE10, 0DI20000, 0FL — move 20000 counts from here at 2.5 rev/s; FP moves to an absolute position\n0SK — stop and empty the buffer; 0ST — stop the motion\n0QX1 — run stored segment 1; 0QU1 — read segment 1 back\nAddresses: 0–9 and \" # $ & ' ( ) + , - . / : ; < = > (as configured); the gateway picked is the line it goes to";
    /// Console on MBOX boxes: replies heading.
    MboxReplies => "控制盒应答", "Box replies";
    /// Console on MBOX boxes: no replies yet.
    NoMboxReplies => "还没有收到控制盒应答。", "No replies from the boxes yet.";
    /// Heading of the drives' answers to console lines (MOONS' drives).
    SclAnswers => "驱动器应答", "Drive answers";
    /// No answers yet (MOONS' drives).
    NoSclAnswers => "还没有应答。发送一条指令，例如 0IP 。", "No answers yet. Send a command, e.g. 0IP.";
    /// Gateway status of an MBOX box: datagrams a second.
    PacketsPerS => "包/秒", "packets/s";
    /// Gateway status of an MBOX box: motion frames sent late.
    LateFrames => "迟发帧", "late frames";
    /// Gateway status of an MBOX box: polls left unanswered.
    MissedReplies => "未应答", "missed replies";
    /// Status: drives reporting an alarm (MOONS' drives).
    Alarms => "报警", "alarms";
    /// Player state: idle.
    StateIdle => "空闲", "idle";
    /// Player state: waiting out an entry's delay.
    StateWaiting => "等待中", "waiting";
    /// Player state: approaching.
    StateApproaching => "就位中", "approaching";
    /// Player state: loading.
    StateLoading => "加载中", "loading";
    /// Player state: playing.
    StatePlaying => "运行中", "playing";
    /// Player state: stopped.
    StateStopped => "已停止", "stopped";
    /// Player state: homing.
    StateHoming => "回原点", "homing";
    /// Player state: error.
    StateError => "错误", "error";
    /// Link state: up.
    LinkUp => "正常", "up";
    /// Link state: connecting.
    LinkConnecting => "连接中", "connecting";
    /// Link state: down.
    LinkDown => "断开", "down";
    LinkNotAnswering => "无应答", "not answering";
    /// A delay that cannot be used.
    BadDelay => "延时必须是 0 到 86400 之间的秒数", "The delay must be a number of seconds from 0 to 86400";
    /// Cycles that cannot be used.
    BadCycles => "周期必须是 1 到 1000000 之间的整数", "Cycles must be a whole number from 1 to 1000000";
    /// 404.
    NotFound => "控制器上没有这个文件", "The controller has no such file";
    // ---- files ----
    /// Files: picked files that were not added; one line each follows.
    FilesNotAdded => "以下文件没有添加：", "These files were not added:";
    /// A long problem list: show every problem.
    ShowAll => "全部显示", "Show all";
    /// A long problem list: back to the first few.
    ShowFewer => "收起", "Show fewer";
    /// A file was deleted; its name follows.
    Deleted => "已删除", "Deleted";
    /// The playlist was stored on the controller.
    PlaylistSaved => "配置已保存", "Playlist saved";
    /// Login: the app logs in by itself when the wait is over.
    LoginWhenWaitEnds => "等待结束后将自动登录。", "The app logs in by itself when the wait is over.";
    /// The success toasts' region, for screen readers.
    Notifications => "通知", "Notifications";
    // ---- layout ----
    /// The compact status line's tooltip: a tap opens Control.
    StatusBarHint => "点按打开控制页", "Tap to open Control";
    /// Reopens the Preview's file list once a show is chosen.
    ChooseAnotherShow => "选择其他动作文件", "Choose another show";
    // ---- controls ----
    /// Why the playlist's icons are disabled while the matrix runs.
    PlaylistLocked => "演出运行或浮球移动时不能修改配置（勾选仍可用）。按急停或等待结束后再编辑。", "The playlist cannot change while a show plays or balls move (checking entries still works). Press E-stop or wait until it is over to edit it.";
    /// Why Start is disabled: no link to the bridge.
    StartNeedsConnection => "未连接控制器，不能开始", "Start needs the connection to the controller";
    /// Why Start is disabled: the matrix runs.
    StartWhileRunning => "演出正在运行或浮球正在移动：结束或急停后才能再次开始", "A show is playing or balls are moving: Start works again once it is over or after E-stop";
    /// Why Start is disabled: nothing to play, or a show cannot run.
    StartNeedsPlayableList => "配置为空，或有动作无法运行（见带宽检查）", "The playlist is empty or a show cannot run (see the bandwidth check)";
    /// The Home button: every ball home, then idle.
    Home => "回原点", "Home";
    /// Reset's confirmation: what will move.
    ConfirmReset => "确认：所有浮球回原点，然后从头播放配置", "Confirm: every ball moves home, then the playlist starts again";
    /// Home's confirmation: what will move.
    ConfirmHome => "确认：所有浮球回原点并停在那里", "Confirm: every ball moves home and stays there";
    /// Start's confirmation after an E-stop or an error: what will move.
    ConfirmStartAfterStop => "确认：所有浮球先回原点，再移到第一个动作的起点并开始播放", "Confirm: every ball moves home, then to the first show's start, and the playlist plays";
    /// The status while the balls home, before its percentage.
    Homing => "回原点中…", "Homing…";
    /// A gateway's line while a show streams: the fewest rows its units had buffered
    /// ahead (before the number).
    BufferAtLeast => "控制器缓冲至少", "buffered ahead: at least";
    /// … after the number.
    BufferRows => "行", "rows";
    // ---- app-install ----
    /// The preview once the installation is known: the show keeps its limits.
    WithinInstallationLimits => "在本装置的限制之内（行程、速度、加速度）", "Within the installation's limits (travel, speed, acceleration)";
    /// The preview once the installation is known: how many problems follow.
    BeyondInstallationLimits => "超出本装置的限制：", "Beyond the installation's limits:";
    /// The installation page's title and navigation name.
    InstallationTitle => "装置设置", "Installation";
    /// Settings: the button that opens the installation page.
    OpenInstallation => "装置设置（矩阵与网关）…", "Installation (matrix and gateways)…";
    /// The installation page: the matrix's part.
    MatrixTitle => "矩阵", "Matrix";
    /// Field: rows of balls.
    FieldRows => "行数", "Rows";
    /// Field: columns of balls.
    FieldCols => "列数", "Columns";
    /// Field: distance between balls.
    FieldPitch => "球距（毫米）", "Pitch (mm)";
    /// Field: lowest position.
    FieldTravel => "行程（毫米）", "Travel (mm)";
    /// Field: calibration.
    FieldCountsPerMm => "每毫米脉冲数", "Counts per mm";
    /// Field: top speed.
    FieldMaxSpeed => "最大速度（毫米/秒）", "Top speed (mm/s)";
    /// Field: top acceleration.
    FieldMaxAccel => "最大加速度（毫米/秒²）", "Top acceleration (mm/s²)";
    /// Field: home position.
    FieldHome => "原点位置（毫米）", "Home position (mm)";
    /// Field: speed of the move to a show's start.
    FieldApproachSpeed => "接近速度（毫米/秒）", "Approach speed (mm/s)";
    /// Field: a gateway's port.
    FieldPort => "端口", "Port";
    /// Field: a gateway's line speed.
    FieldBaud => "波特率", "Line speed (baud)";
    /// Field: a gateway's stations, as ranges.
    FieldStations => "站号（如 1-50, 52）", "Stations (e.g. 1-50, 52)";
    /// The installation page's save button.
    SaveInstallation => "保存并应用", "Save and apply";
    /// The installation was saved and applied.
    InstallationSaved => "装置设置已保存并生效", "Installation saved and applied";
    /// The installation page: fields the app cannot read; one line each follows.
    FieldsNotRead => "以下内容无法读取：", "These fields cannot be read:";
    /// A field that is not a number or a list of stations.
    FieldUnreadable => "无法读取", "cannot be read";
    /// The installation page while the controller has not said its installation.
    InstallationUnavailable => "控制器未提供装置设置", "The controller has not said its installation";
    /// What saving does: checked as `floatball check` does, applied only while idle.
    InstallationSaveNote => "保存时控制器会逐项检查（与 floatball check 相同）并列出所有问题；只有在矩阵空闲时才能应用。", "The controller checks every value as floatball check does and lists every problem; it applies the change only while the matrix is idle.";
    /// Control: the warning before Start when units are missing or in error.
    UnitsWarning => "注意：有单元缺失或报错，开始前请检查：", "Warning: units are missing or in error; check before Start:";
    /// Status: the first entry's show is loaded ahead of Start.
    Armed => "已预载", "Armed";
    /// Status: the first entry's show is being loaded ahead of Start.
    Arming => "预载中", "Loading ahead";
    /// Status: the label of the armed show.
    ArmedLabel => "预载", "Preloaded";
    /// The plan: the label of its advice.
    PlanAdvice => "建议：", "Advice:";
    // ---- app-commission ----
    /// Control's third tab and the page's title: Commissioning.
    NavCommission => "调试", "Commissioning";
    /// Column: serial number.
    Serial => "序列号", "Serial";
    /// Column: the unit's last error.
    UnitErrorColumn => "错误", "Error";
    // ---- appscale ----
    /// Status with many gateways: the label of how many links are up.
    GatewaysUp => "在线", "Up";
    /// Status with many gateways: the label of the lowest buffer and where.
    LowestBuffer => "最低缓冲", "Lowest buffer";
    /// Status with many gateways: the heading of those with a problem.
    GatewayProblems => "有问题的网关：", "Gateways with a problem:";
    /// Status with many gateways: none has a problem.
    NoGatewayProblems => "没有网关报告问题。", "No gateway reports a problem.";
    /// Status with many gateways: fold the full list away.
    HideGatewayList => "收起网关列表", "Hide the list";
    // ---- create ----
    /// The Create page's tab.
    NavCreate => "创作", "Create";
    /// Pick a picture for a picture pattern.
    ChoosePicture => "选择图片", "Choose a picture";
    // ---- the Schedule page and the Control page's schedule line ----
    /// Control's fourth tab and the page's title: Schedule.
    NavSchedule => "时间表", "Schedule";
    /// Control: the next start of the schedule.
    ScheduleNextStart => "时间表下次开始", "Schedule's next start";
    /// The Live card's heading and its opener on Control (the card is in a chunk).
    LiveMode => "实时模式", "Live mode";
    /// A live recording stored as a show (the show's name follows).
    RecordedAs => "录制已保存为演出", "Recording stored as the show";
    /// Control: no start ahead.
    ScheduleNone => "无", "none";
    /// Control: what the schedule did last.
    ScheduleLast => "时间表上次", "Schedule, last";
    // ---- the Patch page (live input) ----
    /// Control's subtab and the page's title.
    NavPatch => "配接", "Patch";
}

impl Lang {
    /// The language's code as stored in the browser.
    pub fn code(self) -> &'static str {
        match self {
            Lang::Zh => "zh",
            Lang::En => "en",
        }
    }

    /// The language for a stored code; unknown codes give the default.
    pub fn from_code(code: &str) -> Self {
        match code {
            "en" => Lang::En,
            _ => Lang::Zh,
        }
    }

    /// The language to start in: the stored choice (`zh` / `en`) if there is one,
    /// else the browser's preferred language (`navigator.languages`, first first):
    /// 中文 for any `zh…`, English for anything else.
    pub fn at_start(stored: Option<&str>, browser: &[String]) -> Self {
        match stored {
            Some("zh") => Lang::Zh,
            Some("en") => Lang::En,
            _ => match browser.first() {
                Some(tag) if tag.to_ascii_lowercase().starts_with("zh") => Lang::Zh,
                _ => Lang::En,
            },
        }
    }

    /// The template of `code` in this language, if this app knows the code: the
    /// shared English template ([`Code::english`]), or the 中文 one of [`codes`].
    pub fn template(self, code: Code) -> Option<&'static str> {
        match self {
            Lang::Zh => codes::ERROR_TEXTS
                .iter()
                .find(|(known, _)| *known == code)
                .map(|&(_, zh)| zh),
            Lang::En => Some(code.english()),
        }
    }

    /// An error given by code and parameters, in this language: where it happened
    /// (line and column, or ball and time) and then the code's template with its
    /// parameters; `english` (the bridge's own text) for a code this app does not know.
    pub fn coded(self, code: &str, params: &Params, english: &str) -> String {
        let Some(template) = Code::parse(code).and_then(|code| self.template(code)) else {
            return english.to_owned();
        };
        let mut text = self.place(params);
        text.push_str(&fill(template, params));
        text
    }

    /// Where an error happened, from its parameters, as a prefix: `line`/`column`, or
    /// `unit` (with `unit_row`, `unit_col`) and `time_s`; empty when neither.
    fn place(self, params: &Params) -> String {
        let get = |name: &str| params.get(name).map(String::as_str);
        match (get("line"), get("column"), get("unit")) {
            (Some(line), Some(column), _) => match self {
                Lang::Zh => format!("第 {line} 行第 {column} 列："),
                Lang::En => format!("line {line}, column {column}: "),
            },
            (_, _, Some(unit)) => {
                let cell = get("unit_row").zip(get("unit_col"));
                let mut place = match (self, cell) {
                    (Lang::Zh, Some((row, col))) => {
                        format!("球 {unit}（第 {row} 行，第 {col} 列）")
                    }
                    (Lang::Zh, None) => format!("球 {unit}"),
                    (Lang::En, Some((row, col))) => format!("ball {unit} (row {row}, col {col})"),
                    (Lang::En, None) => format!("ball {unit}"),
                };
                if let Some(time_s) = get("time_s") {
                    place.push_str(&match self {
                        Lang::Zh => format!("在 {time_s} 秒"),
                        Lang::En => format!(" at {time_s} s"),
                    });
                }
                place.push_str(match self {
                    Lang::Zh => "：",
                    Lang::En => ": ",
                });
                place
            }
            _ => String::new(),
        }
    }

    /// A typed error of the shared code (a parse error, a validation problem…).
    pub fn error_of(self, error: &(impl Coded + std::fmt::Display)) -> String {
        self.coded(error.code().as_str(), &error.params(), &error.to_string())
    }

    /// A show's given start, `ms` from now: `Starting in 0.1 s`.
    pub fn starting_in(self, ms: u64) -> String {
        let seconds = ms as f64 / 1_000.0;
        match self {
            Lang::Zh => format!("{seconds:.1} 秒后开始"),
            Lang::En => format!("Starting in {seconds:.1} s"),
        }
    }

    /// Why a show file cannot be read or is refused, as the preview says it: the
    /// parser's problem (with its line and column) when the file does not read.
    /// Called in the CSV reader's chunk ([`crate::lazy::read_csv`]), which carries the
    /// words of the CSV reader's problems; a native (JSON) file's reading in the main
    /// module uses [`Self::refused_json`].
    pub fn refused(self, refused: &floatball_shared::show::Refused) -> String {
        use floatball_shared::show::Refused;
        match refused {
            Refused::Csv(error) | Refused::KeyframeTooLate { error, .. } => self.error_of(error),
            other => self.refused_json(other),
        }
    }

    /// [`Self::refused`] for a native (JSON) show file, whose reading never gives a
    /// CSV reader's problem: the JSON parser's problem (with its line and column) when
    /// the file does not read, else the refusal.
    pub fn refused_json(self, refused: &floatball_shared::show::Refused) -> String {
        use floatball_shared::show::Refused;
        match refused {
            Refused::Unreadable(error) => self.error_of(error),
            other => self.error_of(other),
        }
    }

    /// The sentence of an HTTP error body. A `reason` parameter (English) is replaced
    /// by the error's one coded problem when the bridge sent it (a Q program's).
    pub fn api_error(self, error: &ApiError) -> String {
        let reason_is_coded = Code::parse(&error.code)
            .is_some_and(|code| code.params().contains(&"reason"))
            && error.problems.len() == 1
            && self.knows(&error.problems[0].code);
        if reason_is_coded {
            let mut params = error.params.clone();
            params.insert("reason".to_owned(), self.problems(error).remove(0));
            return self.coded(&error.code, &params, &error.error);
        }
        self.coded(&error.code, &error.params, &error.error)
    }

    /// This app has a text for `code`.
    fn knows(self, code: &str) -> bool {
        Code::parse(code)
            .and_then(|code| self.template(code))
            .is_some()
    }

    /// Why a show cannot run (a plan report's verdict), in this language: its coded
    /// reason, followed by "… and N more problems" when it has `more`; the English
    /// `reason` from a bridge without the code or with a code this app does not know.
    pub fn plan_reason(self, report: &PlanReport) -> Option<String> {
        let english = report.reason.as_deref().unwrap_or_default();
        let Some(problem) = &report.reason_problem else {
            return report.reason.clone();
        };
        if !self.knows(&problem.code) {
            return report.reason.clone();
        }
        Some(self.reason(problem, english))
    }

    /// A coded reason (a [`Problem`] this app knows), followed by "… and N more
    /// problems" when it has `more`.
    fn reason(self, Problem { code, params }: &Problem, english: &str) -> String {
        let mut text = self.coded(code, params, english);
        if let Some(more) = params.get("more") {
            let count: Params = [("count".to_owned(), more.clone())].into();
            text.push(' ');
            text.push_str(&self.coded(Code::MoreProblems.as_str(), &count, ""));
        }
        text
    }

    /// A refusal over the WebSocket in this language: its code's template, with the
    /// `reason` and `fixes` parameters (English) replaced by their coded problems when
    /// the bridge sent them and this app knows every code (a refused Start: why the
    /// entry cannot run, what would make it run); `english` for an unknown code.
    pub fn refusal(
        self,
        code: &str,
        params: &Params,
        english: &str,
        reason: Option<&Problem>,
        fixes: &[Problem],
    ) -> String {
        let mut params = params.clone();
        if let Some(reason) = reason.filter(|reason| self.knows(&reason.code)) {
            let english_reason = params.get("reason").cloned().unwrap_or_default();
            params.insert("reason".to_owned(), self.reason(reason, &english_reason));
        }
        if !fixes.is_empty() && fixes.iter().all(|fix| self.knows(&fix.code)) {
            let separator = match self {
                Lang::Zh => "；",
                Lang::En => "; ",
            };
            let fixes: Vec<String> = fixes
                .iter()
                .map(|fix| self.coded(&fix.code, &fix.params, ""))
                .collect();
            params.insert("fixes".to_owned(), fixes.join(separator));
        }
        self.coded(code, &params, english)
    }

    /// What would make a show run (a plan report's fixes), in this language; each
    /// fix the app has no text for in the bridge's English.
    pub fn plan_fixes(self, report: &PlanReport) -> Vec<String> {
        if report.fix_problems.len() != report.fixes.len() {
            return report.fixes.clone();
        }
        report
            .fix_problems
            .iter()
            .zip(&report.fixes)
            .map(|(Problem { code, params }, english)| self.coded(code, params, english))
            .collect()
    }

    /// Every problem of an HTTP error body: the coded problems when the bridge sent
    /// them (each falling back to its English detail), else the English details.
    pub fn problems(self, error: &ApiError) -> Vec<String> {
        if error.problems.is_empty() {
            return error.details.clone();
        }
        error
            .problems
            .iter()
            .enumerate()
            .map(|(index, Problem { code, params })| {
                let english = error
                    .details
                    .get(index)
                    .map_or(code.as_str(), String::as_str);
                self.coded(code, params, english)
            })
            .collect()
    }

    /// The other language (what the switch changes to).
    pub fn other(self) -> Self {
        match self {
            Lang::Zh => Lang::En,
            Lang::En => Lang::Zh,
        }
    }

    /// `text` in this language.
    pub fn t(self, text: impl Words) -> &'static str {
        let (zh, en) = text.pair();
        match self {
            Lang::Zh => zh,
            Lang::En => en,
        }
    }

    /// 429 on login, with the wait if the bridge gave one.
    pub fn too_many_attempts(self, retry_after_s: Option<u64>) -> String {
        match (self, retry_after_s) {
            (Lang::Zh, Some(s)) => format!("登录失败次数过多，请 {s} 秒后再试"),
            (Lang::Zh, None) => "登录失败次数过多，请稍后再试".into(),
            (Lang::En, Some(s)) => {
                format!("Too many failed logins; try again in {s} s")
            }
            (Lang::En, None) => "Too many failed logins; try again later".into(),
        }
    }

    /// A picked file that is not a show file, and what is.
    pub fn unsupported_file(self, name: &str) -> String {
        let supported = crate::files::supported_extensions();
        match self {
            Lang::Zh => format!("{name}：不支持这种文件，支持的格式：{supported}"),
            Lang::En => format!("{name}: not a supported show file; supported: {supported}"),
        }
    }

    /// A long problem list, cut: how many are not shown, of how many.
    pub fn more_problems(self, hidden: usize, total: usize) -> String {
        match self {
            Lang::Zh => format!("另有 {hidden} 条未显示（共 {total} 条）"),
            Lang::En => format!("{hidden} more not shown ({total} in all)"),
        }
    }

    /// The controller cannot be reached.
    pub fn unreachable(self, detail: &str) -> String {
        match self {
            Lang::Zh => format!("无法连接控制器（{detail}）"),
            Lang::En => format!("Cannot reach the controller ({detail})"),
        }
    }

    /// What a failed API call means, in one sentence (details, if any, are listed
    /// apart by the caller).
    pub fn failure(self, failure: &Failure) -> String {
        match failure {
            Failure::Network(detail) => self.unreachable(detail),
            Failure::Unauthorized => self.t(Text::SessionExpired).into(),
            Failure::MustChangePassword => self.t(Text::MustChangePasswordFirst).into(),
            Failure::TooManyAttempts { retry_after_s } => self.too_many_attempts(*retry_after_s),
            Failure::NotFound => self.t(Text::NotFound).into(),
            Failure::TooLarge => self.t(Text::TooLarge).into(),
            Failure::Rejected(error) => self.api_error(error),
            Failure::Unexpected { status, body } => match self {
                Lang::Zh => format!("控制器出错（HTTP {status}）：{body}"),
                Lang::En => format!("The controller failed (HTTP {status}): {body}"),
            },
        }
    }

    /// A form value that cannot be used.
    pub fn input_error(self, error: InputError) -> &'static str {
        self.t(match error {
            InputError::Delay => Text::BadDelay,
            InputError::Cycles => Text::BadCycles,
        })
    }

    /// A Q program's report: moves, segments and lines, and the largest deviation from
    /// the show with its show time.
    pub fn qprogram_summary(self, listing: &QProgramListing) -> String {
        let at = crate::files::format_duration_ms(listing.at_ms);
        let deviation = listing.max_deviation_mm;
        let (moves, segments, lines) = (listing.moves, listing.segments, listing.lines);
        match self {
            Lang::Zh => format!(
                "{moves} 段移动，{segments} 个程序段，共 {lines} 行；与动作的最大偏差 {deviation:.1} 毫米，在 {at}"
            ),
            Lang::En => format!(
                "{moves} moves in {segments} segments, {lines} lines; largest deviation from the show {deviation:.1} mm, at {at}"
            ),
        }
    }

    /// The player's state.
    pub fn player_state(self, state: PlayerState) -> &'static str {
        self.t(match state {
            PlayerState::Idle => Text::StateIdle,
            PlayerState::Waiting => Text::StateWaiting,
            PlayerState::Approaching => Text::StateApproaching,
            PlayerState::Loading => Text::StateLoading,
            PlayerState::Playing => Text::StatePlaying,
            PlayerState::Stopped => Text::StateStopped,
            PlayerState::Homing => Text::StateHoming,
            PlayerState::Error => Text::StateError,
        })
    }

    /// A gateway link's state.
    pub fn link_state(self, link: LinkState) -> &'static str {
        self.t(match link {
            LinkState::Up => Text::LinkUp,
            LinkState::Connecting => Text::LinkConnecting,
            LinkState::Down => Text::LinkDown,
            LinkState::NotAnswering => Text::LinkNotAnswering,
        })
    }

    /// Console: the text parses.
    pub fn ready_to_send(self, instructions: usize) -> String {
        match self {
            Lang::Zh => format!("✓ {instructions} 条指令，可以发送"),
            Lang::En => format!("✓ {instructions} instruction(s), ready to send"),
        }
    }

    /// Files: an upload's progress.
    pub fn uploading(self, percent: u32) -> String {
        match self {
            Lang::Zh => format!("正在上传… {percent}%"),
            Lang::En => format!("Uploading… {percent}%"),
        }
    }

    /// A ball of the matrix (`index` row-major, `row` and `col` from 0).
    pub fn ball_name(self, index: usize, row: u32, col: u32) -> String {
        let (row, col) = (u64::from(row) + 1, u64::from(col) + 1);
        match self {
            Lang::Zh => format!("球 u{index}（第 {row} 行，第 {col} 列）"),
            Lang::En => format!("Ball u{index} (row {row}, col {col})"),
        }
    }

    /// A ball's range and top speed over the show.
    pub fn ball_facts(self, highest_mm: f64, lowest_mm: f64, peak_mm_s: f64) -> String {
        match self {
            Lang::Zh => format!(
                "最高 {highest_mm:.0} 毫米，最低 {lowest_mm:.0} 毫米，最大速度 {peak_mm_s:.0} 毫米/秒"
            ),
            Lang::En => format!(
                "highest {highest_mm:.0} mm, lowest {lowest_mm:.0} mm, top speed {peak_mm_s:.0} mm/s"
            ),
        }
    }

    /// Performance panel: measuring a size.
    pub fn measuring(self, balls: usize) -> String {
        match self {
            Lang::Zh => format!("正在测量 {balls} 个球…"),
            Lang::En => format!("Measuring {balls} balls…"),
        }
    }

    /// Performance panel: what drew, at what size.
    pub fn drawn_by(self, webgl2: bool, width: u32, height: u32) -> String {
        match (self, webgl2) {
            (Lang::Zh, true) => format!("WebGL2 三维，{width}×{height} 像素"),
            (Lang::Zh, false) => format!("二维俯视图，{width}×{height} 像素"),
            (Lang::En, true) => format!("WebGL2 3D, {width}×{height} px"),
            (Lang::En, false) => format!("2D top view, {width}×{height} px"),
        }
    }

    // ---- app-install ----

    /// A matrix field's name on the installation page.
    pub fn field_name(self, field: crate::installation::Field) -> &'static str {
        use crate::installation::Field;
        self.t(match field {
            Field::Rows => Text::FieldRows,
            Field::Cols => Text::FieldCols,
            Field::Pitch => Text::FieldPitch,
            Field::Travel => Text::FieldTravel,
            Field::CountsPerMm => Text::FieldCountsPerMm,
            Field::MaxSpeed => Text::FieldMaxSpeed,
            Field::MaxAccel => Text::FieldMaxAccel,
            Field::Home => Text::FieldHome,
            Field::ApproachSpeed => Text::FieldApproachSpeed,
        })
    }

    /// A field of the installation page that cannot be read: `Gateway 2, Port: cannot be read`.
    pub fn form_error(self, error: crate::installation::FormError) -> String {
        use crate::installation::{FormError, GatewayField};
        let cannot = self.t(Text::FieldUnreadable);
        match error {
            FormError::Matrix(field) => format!("{}: {cannot}", self.field_name(field)),
            FormError::Gateway(index, field) => {
                let name = self.t(match field {
                    GatewayField::Port => Text::FieldPort,
                    GatewayField::Baud => Text::FieldBaud,
                    GatewayField::Stations => Text::FieldStations,
                });
                format!("{} {}, {name}: {cannot}", self.t(Text::Gateways), index + 1)
            }
        }
    }

    /// A gateway's stations in short: `100 units: 1-100`.
    pub fn stations_summary(self, stations: &[u8]) -> String {
        let ranges = crate::installation::format_stations(stations);
        let count = stations.len();
        match self {
            Lang::Zh => format!("{count} 个单元：{ranges}"),
            Lang::En => format!("{count} units: {ranges}"),
        }
    }

    /// A gateway whose units are not all there or not all well, in one line: how
    /// many answer, which stations are missing or shared, and each unit's last
    /// error in words.
    pub fn health_warning(self, warning: &crate::installation::HealthWarning) -> String {
        let list = |stations: &[u8]| {
            stations
                .iter()
                .map(u8::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        };
        let (answering, expected) = (warning.answering, warning.expected);
        let mut parts = vec![match self {
            Lang::Zh => format!("{}：{answering}/{expected} 个单元应答", warning.port),
            Lang::En => format!("{}: {answering} of {expected} units answer", warning.port),
        }];
        if !warning.missing.is_empty() {
            parts.push(match self {
                Lang::Zh => format!("缺失站号 {}", list(&warning.missing)),
                Lang::En => format!("missing stations {}", list(&warning.missing)),
            });
        }
        if !warning.duplicated.is_empty() {
            parts.push(match self {
                Lang::Zh => format!("多个单元共用站号 {}", list(&warning.duplicated)),
                Lang::En => format!(
                    "stations shared by several units {}",
                    list(&warning.duplicated)
                ),
            });
        }
        for fault in &warning.faults {
            let error = floatball_shared::uim2503::feedback::UnitError {
                error: fault.error,
                code: fault.code,
                index: fault.index,
            };
            parts.push(match self {
                Lang::Zh => format!("{} 号站：{}", fault.station, self.error_of(&error)),
                Lang::En => format!("station {}: {}", fault.station, self.error_of(&error)),
            });
        }
        parts.join(match self {
            Lang::Zh => "；",
            Lang::En => "; ",
        })
    }

    /// How long a show's preload takes before it can start: `preload 9.1 min`.
    pub fn preload(self, preload_ms: u64) -> String {
        let seconds = preload_ms as f64 / 1000.0;
        match (self, seconds >= 60.0) {
            (Lang::Zh, true) => format!("预载 {:.1} 分钟", seconds / 60.0),
            (Lang::Zh, false) => format!("预载 {seconds:.0} 秒"),
            (Lang::En, true) => format!("preload {:.1} min", seconds / 60.0),
            (Lang::En, false) => format!("preload {seconds:.0} s"),
        }
    }

    /// The show armed (or being armed) ahead of Start: `wave: armed` or
    /// `wave: loading ahead 45%`.
    pub fn armed(self, armed: &floatball_shared::api::ArmedShow) -> String {
        let separator = match self {
            Lang::Zh => "：",
            Lang::En => ": ",
        };
        if armed.progress >= 1.0 {
            format!("{}{separator}{}", armed.show, self.t(Text::Armed))
        } else {
            format!(
                "{}{separator}{} {:.0}%",
                armed.show,
                self.t(Text::Arming),
                (armed.progress * 100.0).clamp(0.0, 100.0)
            )
        }
    }

    /// A plan's advice (a long preload and the line speed that shortens it), in this
    /// language; the code itself for advice this app has no text for.
    pub fn plan_advice(self, report: &PlanReport) -> Vec<String> {
        report
            .advice
            .iter()
            .map(|Problem { code, params }| self.coded(code, params, code))
            .collect()
    }

    /// A show's size and length: `16 balls, 0:12.5`.
    pub fn show_facts(self, units: usize, duration: &str) -> String {
        match self {
            Lang::Zh => format!("{units} 个球，{duration}"),
            Lang::En => format!("{units} balls, {duration}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    #[wasm_bindgen_test(unsupported = test)]
    fn both_languages_name_the_connection_states() {
        assert_eq!(Lang::Zh.t(Text::Connected), "已连接");
        assert_eq!(Lang::Zh.t(Text::NotConnected), "未连接");
        assert_eq!(Lang::En.t(Text::Connected), "Connected");
        assert_eq!(Lang::En.t(Text::NotConnected), "Not connected");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn every_text_differs_between_the_languages() {
        fn check<T: Words + std::fmt::Debug>(texts: &[T]) {
            for text in texts {
                let (zh, en) = (Lang::Zh.t(*text), Lang::En.t(*text));
                assert!(!zh.is_empty() && !en.is_empty(), "{text:?}");
                assert_ne!(zh, en, "{text:?} is not translated");
            }
        }
        check(Text::ALL);
        // The tables of the pages in chunks of their own.
        check(ScheduleText::ALL);
        check(PatchText::ALL);
        check(LiveText::ALL);
        check(CommissionText::ALL);
        check(CreateText::ALL);
        check(PasswordText::ALL);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_q_program_report_names_its_deviation_and_when() {
        let listing = QProgramListing {
            unit: 3,
            show: "wave".into(),
            text: String::new(),
            segments: 4,
            lines: 180,
            moves: 55,
            max_deviation_mm: 12.34,
            at_ms: 61_500,
        };
        assert_eq!(
            Lang::En.qprogram_summary(&listing),
            "55 moves in 4 segments, 180 lines; largest deviation from the show 12.3 mm, at 1:01.5"
        );
        assert!(
            Lang::Zh
                .qprogram_summary(&listing)
                .contains("12.3 毫米，在 1:01.5")
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn balls_are_named_from_one_in_both_languages() {
        assert_eq!(Lang::En.ball_name(7, 1, 2), "Ball u7 (row 2, col 3)");
        assert_eq!(Lang::Zh.ball_name(7, 1, 2), "球 u7（第 2 行，第 3 列）");
        assert!(
            Lang::Zh
                .ball_facts(10.0, 7000.0, 1500.4)
                .contains("1500 毫米/秒")
        );
        assert_eq!(Lang::En.measuring(2500), "Measuring 2500 balls…");
        assert!(Lang::Zh.drawn_by(false, 640, 480).contains("640×480"));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn every_error_code_has_a_text_in_both_languages() {
        // 中文 from this app's table, English the shared template of the code.
        for &code in Code::ALL {
            let (Some(zh), Some(en)) = (Lang::Zh.template(code), Lang::En.template(code)) else {
                panic!("{code} has no text in one of the languages");
            };
            assert!(!zh.trim().is_empty() && !en.trim().is_empty(), "{code}");
            assert_ne!(zh, en, "{code} is not translated");
            // Every parameter the code always carries is said in English (where the
            // 中文 text may leave out English-only words), and no template asks for a
            // parameter the code does not carry.
            for name in code.params() {
                assert!(
                    en.contains(&format!("{{{name}}}")),
                    "{code}: English lacks {{{name}}}"
                );
            }
            for template in [zh, en] {
                let mut rest = template;
                while let Some(open) = rest.find('{') {
                    let after = &rest[open + 1..];
                    let close = after.find('}').unwrap_or(after.len());
                    let name = &after[..close];
                    assert!(
                        code.params().contains(&name),
                        "{code}: unknown parameter {{{name}}}"
                    );
                    rest = &after[close.min(after.len())..];
                }
            }
        }
        let listed: Vec<Code> = codes::ERROR_TEXTS.iter().map(|(code, _)| *code).collect();
        let mut unique = listed.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), listed.len(), "a code is listed twice");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn coded_errors_read_in_the_chosen_language() {
        let mut params = Params::new();
        params.insert("min".into(), "4".into());
        assert_eq!(
            Lang::Zh.coded("password_too_short", &params, "too short"),
            "新密码太短：至少 4 个字符"
        );
        assert_eq!(
            Lang::En.coded("password_too_short", &params, "too short"),
            "The new password is too short: at least 4 characters"
        );
        // A code this app does not know: the bridge's English words.
        assert_eq!(Lang::Zh.coded("from_the_future", &params, "later"), "later");
        assert_eq!(
            Lang::Zh.coded("", &Params::new(), "old bridge"),
            "old bridge"
        );
        let error =
            floatball_shared::uim2503::ascii::parse_script("*5;PV[1]=3;").expect_err("index");
        assert_eq!(Lang::Zh.error_of(&error), "第 1 行第 6 列：PV 不带下标");
        let body = ApiError {
            error: "the show does not fit".into(),
            code: "show_unfit".into(),
            params: [("count".to_owned(), "2".to_owned())].into(),
            details: vec!["x".into(), "english only".into()],
            problems: vec![
                Problem {
                    code: "too_fast".into(),
                    params: [
                        ("unit", "u3"),
                        ("unit_row", "1"),
                        ("unit_col", "4"),
                        ("time_s", "1.50"),
                        ("speed_mm_s", "900.0"),
                        ("limit_mm_s", "800.0"),
                    ]
                    .into_iter()
                    .map(|(k, v)| (k.to_owned(), v.to_owned()))
                    .collect(),
                },
                Problem {
                    code: "unknown_problem".into(),
                    params: Params::new(),
                },
            ],
        };
        assert_eq!(Lang::Zh.api_error(&body), "动作不适合本装置：2 个问题");
        assert_eq!(
            Lang::Zh.problems(&body),
            [
                "球 u3（第 1 行，第 4 列）在 1.50 秒：速度 900.0 毫米/秒超过上限 800.0 毫米/秒",
                "english only"
            ]
        );
        assert_eq!(
            Lang::En.problems(&body)[0],
            "ball u3 (row 1, col 4) at 1.50 s: speed 900.0 mm/s exceeds the limit of 800.0 mm/s"
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn plan_verdicts_read_in_the_chosen_language() {
        let params = |pairs: &[(&str, &str)]| -> Params {
            pairs
                .iter()
                .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
                .collect()
        };
        let mut report = PlanReport {
            preload_ms: 0,
            advice: Vec::new(),
            show: "wave".into(),
            feasible: false,
            reason: Some("english reason".into()),
            fixes: vec!["english fix".into(), "english other".into()],
            reason_problem: Some(Problem {
                code: "line_starved".into(),
                params: params(&[
                    ("gateway", "sim"),
                    ("baud", "9600"),
                    ("units", "100"),
                    ("show", "wave"),
                    ("needed_bytes_per_s", "2400"),
                    ("available_bytes_per_s", "960"),
                    ("dry_at_s", "1.5"),
                    ("preload_rows", "256"),
                ]),
            }),
            fix_problems: vec![
                Problem {
                    code: "fix_faster_line".into(),
                    params: params(&[("baud", "38400")]),
                },
                Problem {
                    code: "fix_from_the_future".into(),
                    params: Params::new(),
                },
            ],
            gateways: Vec::new(),
        };
        assert_eq!(
            Lang::Zh.plan_reason(&report).unwrap(),
            "网关 sim（9600 波特）供不上它的 100 个单元：“wave”每秒需要 2400 字节，线路只能传 960 \
             字节，即使预载满 256 行，单元的行缓冲也会在动作开始 1.5 秒后用尽"
        );
        assert!(
            Lang::En
                .plan_reason(&report)
                .unwrap()
                .starts_with("gateway sim (9600 baud) cannot keep its 100 units fed")
        );
        assert_eq!(
            Lang::Zh.plan_fixes(&report),
            [
                "把线路提高到 38400 波特（调试 → 线路速率）",
                "english other"
            ]
        );
        // A show's first problem and how many more.
        report.reason_problem = Some(Problem {
            code: "above_top".into(),
            params: params(&[("unit", "u1"), ("position_mm", "-50.0"), ("more", "3")]),
        });
        let zh = Lang::Zh.plan_reason(&report).unwrap();
        assert!(
            zh.starts_with("球 u1：") && zh.ends_with("3 个问题"),
            "{zh}"
        );
        // A code this app does not know, or no code (an older bridge): the English.
        report.reason_problem = Some(Problem {
            code: "from_the_future".into(),
            params: Params::new(),
        });
        assert_eq!(Lang::Zh.plan_reason(&report).unwrap(), "english reason");
        report.reason_problem = None;
        report.fix_problems.clear();
        assert_eq!(Lang::Zh.plan_reason(&report).unwrap(), "english reason");
        assert_eq!(
            Lang::Zh.plan_fixes(&report),
            ["english fix", "english other"]
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_refused_start_reads_its_coded_reason_and_fixes_in_the_chosen_language() {
        let params = |pairs: &[(&str, &str)]| -> Params {
            pairs
                .iter()
                .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
                .collect()
        };
        let english_reason = "gateway sim (9600 baud) cannot keep its 100 units fed: \"wave\" \
             streams 2400 B/s while the line carries 960 B/s, so the units' row buffers run dry \
             1.5 s into the show even with a full 256-row preload";
        let english_fixes = "raise the line to 38400 baud (Commissioning → Line speed); or \
             shorten the show to at most 500 rows per ball so it loads completely before it \
             starts";
        let english = format!(
            "entry 1 (\"wave\") cannot run: {english_reason}. To make it run: {english_fixes}"
        );
        let refusal_params = params(&[
            ("entry", "1"),
            ("show", "wave"),
            ("reason", english_reason),
            ("fixes", english_fixes),
        ]);
        let reason = Problem {
            code: "line_starved".into(),
            params: params(&[
                ("gateway", "sim"),
                ("baud", "9600"),
                ("units", "100"),
                ("show", "wave"),
                ("needed_bytes_per_s", "2400"),
                ("available_bytes_per_s", "960"),
                ("dry_at_s", "1.5"),
                ("preload_rows", "256"),
            ]),
        };
        let fixes = [
            Problem {
                code: "fix_faster_line".into(),
                params: params(&[("baud", "38400")]),
            },
            Problem {
                code: "fix_fewer_rows".into(),
                params: params(&[("rows", "500")]),
            },
        ];
        let zh = Lang::Zh.refusal(
            "entry_infeasible",
            &refusal_params,
            &english,
            Some(&reason),
            &fixes,
        );
        assert_eq!(
            zh,
            "第 1 项（“wave”）无法运行：网关 sim（9600 波特）供不上它的 100 个单元：“wave”每秒需要 \
             2400 字节，线路只能传 960 字节，即使预载满 256 行，单元的行缓冲也会在动作开始 1.5 \
             秒后用尽。建议：把线路提高到 38400 波特（调试 → 线路速率）；或把动作缩短到每个球最多 \
             500 行，使它在开始前完全载入"
        );
        assert!(
            !zh.contains("baud)") && !zh.contains("To make it run"),
            "{zh}"
        );
        // In English the coded sentence is the bridge's own.
        let en = Lang::En.refusal(
            "entry_infeasible",
            &refusal_params,
            &english,
            Some(&reason),
            &fixes,
        );
        assert_eq!(en.to_lowercase(), english.to_lowercase());
        // An older bridge (no problems) or a fix this app does not know: its English.
        let unknown = [Problem {
            code: "fix_from_the_future".into(),
            params: Params::new(),
        }];
        let older = Lang::Zh.refusal(
            "entry_infeasible",
            &refusal_params,
            &english,
            None,
            &unknown,
        );
        assert!(
            older.contains(english_reason) && older.contains(english_fixes),
            "{older}"
        );
        // An MBOX show that does not fit, coded.
        let invalid = Lang::Zh.refusal(
            "entry_invalid",
            &params(&[
                ("entry", "2"),
                ("show", "big"),
                ("reason", "the show has 9 balls…"),
            ]),
            "entry 2 (\"big\") cannot run: the show has 9 balls…",
            Some(&Problem {
                code: "ball_count".into(),
                params: params(&[("show_balls", "9"), ("units", "6")]),
            }),
            &[],
        );
        assert_eq!(
            invalid,
            "第 2 项（“big”）无法运行：动作有 9 个球，但本装置有 6 个"
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_refused_q_program_reads_its_coded_reason() {
        let body = ApiError {
            error: "the program would be 12.3 mm off…".into(),
            code: "qprogram_refused".into(),
            params: [(
                "reason".to_owned(),
                "the program would be 12.3 mm off…".to_owned(),
            )]
            .into(),
            details: vec!["ball u7: the program would be 12.3 mm off…".into()],
            problems: vec![Problem {
                code: "qprogram_too_far".into(),
                params: [
                    ("unit", "u7"),
                    ("time_s", "1.500"),
                    ("deviation_mm", "12.3"),
                    ("tolerance_mm", "10"),
                ]
                .into_iter()
                .map(|(k, v)| (k.to_owned(), v.to_owned()))
                .collect(),
            }],
        };
        let zh = Lang::Zh.api_error(&body);
        assert!(
            zh.starts_with(
                "无法编译 Q 程序：球 u7在 1.500 秒：程序会偏离动作 12.3 毫米，超过容差 10 毫米"
            ),
            "{zh}"
        );
        assert!(!zh.contains("the program"), "{zh}");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_app_starts_in_the_stored_or_the_browsers_language() {
        let tags = |list: &[&str]| list.iter().map(|tag| (*tag).to_owned()).collect::<Vec<_>>();
        assert_eq!(Lang::at_start(None, &tags(&["zh-CN", "en"])), Lang::Zh);
        assert_eq!(Lang::at_start(None, &tags(&["zh-Hant-TW"])), Lang::Zh);
        assert_eq!(Lang::at_start(None, &tags(&["en-US", "zh-CN"])), Lang::En);
        assert_eq!(Lang::at_start(None, &tags(&["de"])), Lang::En);
        assert_eq!(Lang::at_start(None, &[]), Lang::En);
        assert_eq!(Lang::at_start(Some("zh"), &tags(&["en-US"])), Lang::Zh);
        assert_eq!(Lang::at_start(Some("en"), &tags(&["zh-CN"])), Lang::En);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn codes_round_trip() {
        for lang in [Lang::Zh, Lang::En] {
            assert_eq!(Lang::from_code(lang.code()), lang);
        }
        assert_eq!(Lang::from_code("fr"), Lang::Zh);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn unsupported_files_are_named_with_what_is_supported() {
        assert_eq!(
            Lang::En.unsupported_file("a.bin"),
            "a.bin: not a supported show file; supported: .csv, .json"
        );
        assert!(Lang::Zh.unsupported_file("a.bin").contains(".csv, .json"));
        assert_eq!(
            Lang::En.more_problems(9_981, 10_001),
            "9981 more not shown (10001 in all)"
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn rate_limit_messages_carry_the_wait() {
        assert_eq!(
            Lang::En.too_many_attempts(Some(42)),
            "Too many failed logins; try again in 42 s"
        );
        assert!(Lang::Zh.too_many_attempts(Some(42)).contains("42 秒"));
        assert_eq!(
            Lang::En.too_many_attempts(None),
            "Too many failed logins; try again later"
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn failures_read_as_sentences() {
        assert_eq!(
            Lang::En.failure(&Failure::Unauthorized),
            "Your login has expired; please log in again"
        );
        assert!(
            Lang::En
                .failure(&Failure::Network("timeout".into()))
                .contains("timeout")
        );
        assert!(
            Lang::Zh
                .failure(&Failure::Unexpected {
                    status: 500,
                    body: "x".into()
                })
                .contains("500")
        );
        assert_eq!(
            Lang::En.player_state(PlayerState::Playing),
            "playing",
            "the end-to-end test reads this word"
        );
    }
}
