//! The Schedule page's fixed strings ([`ScheduleText`]), in its own table so that
//! they come with the page's chunk, not in the first load.

texts! {
    /// The Schedule page's fixed strings: they come with its chunk.
    ScheduleText;
    /// Schedule: what the page is for and what the schedule never does.
    ScheduleIntro => "按星期设置开放时段和播放内容：时段开始时控制器播放播放列表，时段结束时小球回原点、电机关闭。它只在空闲、所有连接正常、没有缺少单元时开始，从不解除急停，也不清除错误。", "Opening windows per weekday and what plays in them: when a window opens the controller starts the playlist; at its end the balls go home and the motors go off. It starts only from idle, with every link up and no unit missing, and never releases an E-stop nor clears an error.";
    /// Schedule: the switch.
    ScheduleEnabled => "按时间表运行", "Follow the schedule";
    /// Schedule: the time zone field.
    ScheduleTimeZone => "时区（IANA 名称，例如 Asia/Shanghai）", "Time zone (IANA name, e.g. Europe/Zurich)";
    /// Monday.
    Monday => "星期一", "Monday";
    /// Tuesday.
    Tuesday => "星期二", "Tuesday";
    /// Wednesday.
    Wednesday => "星期三", "Wednesday";
    /// Thursday.
    Thursday => "星期四", "Thursday";
    /// Friday.
    Friday => "星期五", "Friday";
    /// Saturday.
    Saturday => "星期六", "Saturday";
    /// Sunday.
    Sunday => "星期日", "Sunday";
    /// Schedule: a window's start.
    ScheduleFrom => "从", "From";
    /// Schedule: a window's end.
    ScheduleTo => "到（24:00 为午夜）", "To (24:00: midnight)";
    /// Schedule: the loop program.
    ScheduleLoop => "循环播放播放列表", "The playlist over and over";
    /// Schedule: the every-N program.
    ScheduleEvery => "每 N 分钟播放一次", "The playlist every N minutes";
    /// Schedule: N.
    ScheduleMinutes => "N（分钟）", "N (minutes)";
    /// Schedule: add a window.
    ScheduleAddWindow => "添加时段", "Add a window";
    /// Schedule: remove a window or an exception.
    ScheduleRemove => "删除", "Remove";
    /// Schedule: the exceptions' heading.
    ScheduleExceptions => "例外日期（休息日、特别日）", "Exceptions (closed days, special days)";
    /// Schedule: an exception's date.
    ScheduleDate => "日期（YYYY-MM-DD）", "Date (YYYY-MM-DD)";
    /// Schedule: an exception's note.
    ScheduleNote => "备注", "Note";
    /// Schedule: an exception without windows.
    ScheduleClosed => "全天关闭", "Closed all day";
    /// Schedule: add an exception.
    ScheduleAddException => "添加例外日期", "Add an exception";
    /// Schedule: the save button.
    ScheduleSave => "保存时间表", "Save the schedule";
    /// Schedule: saved.
    ScheduleSaved => "时间表已保存", "Schedule saved";
    /// Schedule: a window's number.
    ScheduleWindow => "时段", "window";
    /// Schedule: an exception's number.
    ScheduleException => "例外", "exception";
    /// Schedule: a time that cannot be read.
    ScheduleBadTime => "时间必须是 HH:MM（00:00–24:00）", "A time must be HH:MM (00:00–24:00)";
    /// Schedule: N that cannot be read.
    ScheduleBadMinutes => "N 必须是 1 到 1440 的整数", "N must be a whole number from 1 to 1440";
    /// Schedule: a date that cannot be read.
    ScheduleBadDate => "日期必须是 YYYY-MM-DD", "A date must be YYYY-MM-DD";
}
