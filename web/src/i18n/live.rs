//! The Live card's strings (Control page, issue 38): they come with its chunk.

texts! {
    /// The Live card's fixed strings.
    LiveText;
    /// Go live.
    GoLive => "进入实时模式", "Go live";
    /// Leave live mode.
    LeaveLive => "退出实时模式", "Leave live";
    /// What going live does.
    LiveExplain => "球先回零（位置未知时），再以接近速度移到实时输入的位置，然后在限速和加速度内跟随 Art-Net / sACN 输入。急停会退出实时模式；之后须先按开始、复位或回零。", "The balls home first (when their positions are unknown), approach the live input at the approach speed, then follow Art-Net / sACN within the speed and acceleration limits. The E-stop leaves live mode; press Start, Reset or Home before going live again.";
    /// Not live now.
    LiveOffNow => "未处于实时模式", "Not live";
    /// The phase's label.
    LivePhaseLabel => "阶段", "Phase";
    /// Phase: homing.
    LivePhaseHoming => "回零", "Homing";
    /// Phase: preparing.
    LivePhasePreparing => "准备中", "Preparing";
    /// Phase: approaching.
    LivePhaseApproaching => "接近中", "Approaching";
    /// Phase: following.
    LivePhaseFollowing => "跟随输入", "Following";
    /// Phase: holding (input lost).
    LivePhaseHolding => "保持 — 输入丢失", "Holding — input lost";
    /// Phase: leaving.
    LivePhaseLeaving => "退出中", "Leaving";
    /// The latency's label.
    LiveLatency => "延迟", "Latency";
    /// The period's label.
    LivePeriod => "周期", "Period";
    /// Milliseconds.
    LiveMs => "毫秒", "ms";
    /// The recording's heading.
    LiveRecord => "录制", "Record";
    /// The name field.
    LiveRecordName => "演出名称", "Show name";
    /// Start recording.
    LiveRecordStart => "开始录制", "Record";
    /// Stop recording.
    LiveRecordStop => "停止录制", "Stop recording";
    /// Recorded so far, seconds.
    LiveRecorded => "已录制（秒）", "Recorded (s)";
    /// The live positions' label (the matrix from above, darker is lower).
    LivePositionsLabel => "实时位置（俯视，越深越低）", "Live positions (from above, darker is lower)";
    /// Balls.
    LiveBalls => "个球", "balls";
    /// Recording needs a name.
    LiveRecordNeedsName => "请输入演出名称", "Type a name for the show";
}
