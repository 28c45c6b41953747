//! The Live card's strings (Control page, issue 38) and the Preview page's live
//! picture's: they come with their chunk.

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
    /// The Preview page's live picture: its heading.
    LivePictureTitle => "实时 — 来自矩阵的位置", "Live — positions from the matrix";
    /// What the live picture shows.
    LivePictureExplain => "矩阵处于实时模式：每个球画在控制器报告的位置（每秒最多更新 10 次）。实时模式结束后，预览回到之前显示的内容。", "The matrix is live: every ball is drawn where the controller reports it (up to 10 updates a second). When live mode ends, the preview goes back to what it showed before.";
    /// No positions yet.
    LivePictureWaiting => "正在等待矩阵的位置…", "Waiting for the positions from the matrix…";
    /// From the live picture back to the show chosen.
    LivePictureToShow => "显示所选演出", "Show the chosen show";
    /// A show shown while live: the matrix is live.
    LivePictureLiveNow => "矩阵处于实时模式。", "The matrix is live.";
    /// From the show back to the live picture.
    LivePictureToLive => "显示实时画面", "Show the live picture";
    /// The tapped ball's live position.
    LivePictureBallAt => "位置", "at";
}
