//! The Control page's Live card (issue 38, `docs/live.md`): Go live / Leave live,
//! the phase (homing, preparing, approaching, following, holding — input lost,
//! leaving), the latency and the period, and Record (a name, Record / Stop
//! recording, the seconds recorded). Its code and strings ([`LiveText`]) are in a
//! chunk of their own ([`crate::lazy::live_card`]), fetched when the card is opened
//! or the matrix is live. The bridge refuses what it must (`live_estop_latched`,
//! `player_busy`, `live_off`, `record_name_taken`…): the refusal shows under the
//! Control page's buttons as any other.

use floatball_shared::api::{ClientMessage, LivePhase, LiveStatus};
use leptos::prelude::*;

use crate::context::Ctx;
use crate::i18n::LiveText;

/// The phase's words.
fn phase_text(phase: LivePhase) -> LiveText {
    match phase {
        LivePhase::Homing => LiveText::LivePhaseHoming,
        LivePhase::Preparing => LiveText::LivePhasePreparing,
        LivePhase::Approaching => LiveText::LivePhaseApproaching,
        LivePhase::Following => LiveText::LivePhaseFollowing,
        LivePhase::Holding => LiveText::LivePhaseHolding,
        LivePhase::Leaving => LiveText::LivePhaseLeaving,
    }
}

/// Whether a recording may begin in `live` (the balls follow the input).
fn can_record(live: Option<&LiveStatus>) -> bool {
    live.is_some_and(|live| live.phase == LivePhase::Following && !live.recording)
}

/// The Live card.
#[component]
pub fn LiveCard() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let live = Memo::new(move |_| {
        ctx.status.with(|status| {
            status
                .as_ref()
                .and_then(|status| status.live.as_deref().copied())
        })
    });
    let name = RwSignal::new(String::new());
    let needs_name = RwSignal::new(false);
    let connected = move || ctx.connected();
    let send = move |message: ClientMessage| {
        ctx.bridge_error.set(None);
        ctx.send(&message);
    };
    let record = move || {
        let typed = name.get_untracked().trim().to_owned();
        needs_name.set(typed.is_empty());
        if !typed.is_empty() {
            send(ClientMessage::Record { name: typed });
        }
    };
    view! {
        <div class="card live-card" data-testid="live-card">
            <h3>{ctx.tr(crate::i18n::Text::LiveMode)}</h3>
            <p class="muted small">{ctx.tr(LiveText::LiveExplain)}</p>
            <div class="actions">
                <button
                    class="primary"
                    data-testid="go-live"
                    disabled=move || !connected() || live.with(Option::is_some)
                    on:click=move |_| send(ClientMessage::Live { on: true })
                >
                    {ctx.tr(LiveText::GoLive)}
                </button>
                <button
                    data-testid="leave-live"
                    disabled=move || !connected() || live.with(Option::is_none)
                    on:click=move |_| send(ClientMessage::Live { on: false })
                >
                    {ctx.tr(LiveText::LeaveLive)}
                </button>
            </div>
            {move || {
                let lang = ctx.lang.get();
                match live.get() {
                    None => view! {
                        <p class="note" data-testid="live-phase" data-phase="off">
                            {lang.t(LiveText::LiveOffNow)}
                        </p>
                    }
                    .into_any(),
                    Some(live) => {
                        let class = if live.input_lost { "note warn" } else { "note" };
                        view! {
                            <p class=class data-testid="live-phase" data-phase=live.phase.as_str()>
                                {lang.t(LiveText::LivePhaseLabel)} ": "
                                {lang.t(phase_text(live.phase))}
                            </p>
                            <p class="note muted" data-testid="live-timing">
                                {lang.t(LiveText::LiveLatency)} ": " {live.latency_ms} " "
                                {lang.t(LiveText::LiveMs)} " · " {lang.t(LiveText::LivePeriod)}
                                ": " {live.period_ms} " " {lang.t(LiveText::LiveMs)}
                            </p>
                        }
                        .into_any()
                    }
                }
            }}
            <h4>{ctx.tr(LiveText::LiveRecord)}</h4>
            <label class="field">
                <span>{ctx.tr(LiveText::LiveRecordName)}</span>
                <input
                    type="text"
                    data-testid="record-name"
                    prop:value=move || name.get()
                    on:input=move |event| name.set(event_target_value(&event))
                />
            </label>
            {move || {
                needs_name
                    .get()
                    .then(|| {
                        view! {
                            <p class="note error" data-testid="record-needs-name">
                                {ctx.tr(LiveText::LiveRecordNeedsName)}
                            </p>
                        }
                    })
            }}
            <div class="actions">
                <button
                    data-testid="record-start"
                    disabled=move || !connected() || !live.with(|live| can_record(live.as_ref()))
                    on:click=move |_| record()
                >
                    {ctx.tr(LiveText::LiveRecordStart)}
                </button>
                <button
                    data-testid="record-stop"
                    disabled=move || {
                        !connected() || !live.with(|live| live.as_ref().is_some_and(|l| l.recording))
                    }
                    on:click=move |_| send(ClientMessage::RecordStop)
                >
                    {ctx.tr(LiveText::LiveRecordStop)}
                </button>
            </div>
            {move || {
                live.get()
                    .filter(|live| live.recording)
                    .map(|live| {
                        view! {
                            <p class="note" data-testid="live-recorded">
                                {ctx.tr(LiveText::LiveRecorded)} ": "
                                {format!("{:.1}", live.recorded_ms as f64 / 1000.0)}
                            </p>
                        }
                    })
            }}
        </div>
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    fn status(phase: LivePhase, recording: bool) -> LiveStatus {
        LiveStatus {
            phase,
            input_lost: phase == LivePhase::Holding,
            period_ms: 20,
            latency_ms: 40,
            recording,
            recorded_ms: 0,
        }
    }

    #[test]
    fn a_recording_begins_only_while_the_balls_follow_and_none_is_under_way() {
        assert!(!can_record(None));
        assert!(can_record(Some(&status(LivePhase::Following, false))));
        assert!(!can_record(Some(&status(LivePhase::Following, true))));
        for phase in [
            LivePhase::Homing,
            LivePhase::Preparing,
            LivePhase::Approaching,
            LivePhase::Holding,
            LivePhase::Leaving,
        ] {
            assert!(!can_record(Some(&status(phase, false))), "{phase:?}");
        }
    }

    #[test]
    fn every_phase_has_its_words() {
        let phases = [
            LivePhase::Homing,
            LivePhase::Preparing,
            LivePhase::Approaching,
            LivePhase::Following,
            LivePhase::Holding,
            LivePhase::Leaving,
        ];
        let texts: std::collections::BTreeSet<_> = phases
            .iter()
            .map(|&phase| format!("{:?}", phase_text(phase)))
            .collect();
        assert_eq!(texts.len(), phases.len());
    }
}
