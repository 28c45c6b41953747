//! The Control page's Live card (issue 38, `docs/live.md`): Go live / Leave live,
//! the phase (homing, preparing, approaching, following, holding — input lost,
//! leaving), the latency and the period, and Record (a name, Record / Stop
//! recording, the seconds recorded). Its code and strings ([`LiveText`]) are in a
//! chunk of their own ([`crate::lazy::live_card`]), fetched when the card is opened
//! or the matrix is live. The bridge refuses what it must (`live_estop_latched`,
//! `player_busy`, `live_off`, `record_name_taken`…): the refusal shows under the
//! Control page's buttons as any other.
//!
//! While the card is shown it asks the bridge for the balls' live positions
//! (`live_positions`, read in this chunk: [`crate::lazy::read_live_positions`]) and,
//! while live, draws them ([`LiveMatrix`]): the matrix from above, each ball a square
//! shaded by its depth, with the shallowest and deepest positions in words. The
//! Preview page's live picture ([`crate::preview::live_picture`], in this chunk too)
//! asks for them as well: [`want_live_positions`] counts the views that want them,
//! so the one that goes does not stop them for the other.

use floatball_shared::api::{ClientMessage, LivePhase, LiveStatus};
use leptos::html::Canvas;
use leptos::prelude::*;
use wasm_bindgen::JsCast;

use crate::context::Ctx;
use crate::i18n::LiveText;

/// The phase's words.
pub(crate) fn phase_text(phase: LivePhase) -> LiveText {
    match phase {
        LivePhase::Homing => LiveText::LivePhaseHoming,
        LivePhase::Preparing => LiveText::LivePhasePreparing,
        LivePhase::Approaching => LiveText::LivePhaseApproaching,
        LivePhase::Following => LiveText::LivePhaseFollowing,
        LivePhase::Holding => LiveText::LivePhaseHolding,
        LivePhase::Leaving => LiveText::LivePhaseLeaving,
    }
}

/// The canvas' width, CSS pixels.
const MATRIX_WIDTH_PX: f64 = 320.0;

/// The grey of a ball `position_mm` deep in `travel_mm`: light at the top, dark at
/// the bottom.
fn shade(position_mm: i32, travel_mm: f64) -> String {
    let depth = (f64::from(position_mm) / travel_mm.max(1.0)).clamp(0.0, 1.0);
    #[allow(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "within 40–230"
    )]
    let level = (230.0 - depth * 190.0).round() as u8;
    format!("rgb({level},{level},{level})")
}

/// The matrix's rows and columns for `balls` balls: the installation's when it
/// holds them, else one row.
pub(crate) fn grid(balls: usize, rows: u32, cols: u32) -> (usize, usize) {
    let (rows, cols) = (rows as usize, cols as usize);
    if rows * cols >= balls && cols > 0 {
        (rows, cols)
    } else {
        (1, balls.max(1))
    }
}

/// One more view wants the live positions: whether it is the first.
fn wanted_by_one_more(wanted: &mut u32) -> bool {
    *wanted = wanted.saturating_add(1);
    *wanted == 1
}

/// A view that wanted the live positions is gone: whether it was the last.
fn wanted_by_one_less(wanted: &mut u32) -> bool {
    *wanted = wanted.saturating_sub(1);
    *wanted == 0
}

/// Asks the bridge for the balls' live positions while the calling view is shown
/// (again on every connect: a new session starts without them). The views that
/// want them are counted ([`Ctx::live_positions_wanted`]): only the last one to go
/// asks the bridge to stop and clears [`Ctx::live_positions`], so the Live card and
/// the Preview's live picture never switch them off for each other, whichever order
/// they come and go in.
pub(crate) fn want_live_positions(ctx: Ctx) {
    ctx.live_positions_wanted.update_value(|wanted| {
        wanted_by_one_more(wanted);
    });
    Effect::new(move |_| {
        if ctx.connected() {
            ctx.send(&ClientMessage::LivePositions { on: true });
        }
    });
    on_cleanup(move || {
        let last = ctx
            .live_positions_wanted
            .try_update_value(wanted_by_one_less)
            .unwrap_or(true);
        if last {
            ctx.send(&ClientMessage::LivePositions { on: false });
            ctx.live_positions.try_set(Vec::new());
        }
    });
}

/// The balls' live positions, drawn from above while live (see the module's doc).
#[component]
fn LiveMatrix() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    // Asked for while the card is shown, again on every connect.
    want_live_positions(ctx);
    let canvas = NodeRef::<Canvas>::new();
    Effect::new(move |_| {
        let Some(canvas) = canvas.get() else { return };
        let (rows, cols, travel_mm) = ctx.installation.with(|info| {
            info.as_ref()
                .map_or((0, 0, 1.0), |info| (info.rows, info.cols, info.travel_mm))
        });
        ctx.live_positions.with(|positions| {
            if positions.is_empty() {
                return;
            }
            let (rows, cols) = grid(positions.len(), rows, cols);
            #[allow(clippy::cast_precision_loss, reason = "a matrix's size")]
            let cell = (MATRIX_WIDTH_PX / cols as f64).clamp(1.0, 24.0);
            #[allow(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                clippy::cast_precision_loss,
                reason = "a canvas' size"
            )]
            {
                canvas.set_width((cell * cols as f64).ceil() as u32);
                canvas.set_height((cell * rows as f64).ceil() as u32);
            }
            let Some(context) =
                canvas.get_context("2d").ok().flatten().and_then(|context| {
                    context.dyn_into::<web_sys::CanvasRenderingContext2d>().ok()
                })
            else {
                return;
            };
            for (ball, &position_mm) in positions.iter().enumerate() {
                context.set_fill_style_str(&shade(position_mm, travel_mm));
                #[allow(clippy::cast_precision_loss, reason = "a matrix's size")]
                let (x, y) = ((ball % cols) as f64 * cell, (ball / cols) as f64 * cell);
                context.fill_rect(x, y, (cell - 1.0).max(1.0), (cell - 1.0).max(1.0));
            }
        });
    });
    let range = move || {
        ctx.live_positions.with(|positions| {
            let low = positions.iter().copied().min()?;
            let high = positions.iter().copied().max()?;
            Some((positions.len(), low, high))
        })
    };
    view! {
        <Show when=move || range().is_some()>
            <h4>{ctx.tr(LiveText::LivePositionsLabel)}</h4>
            <canvas class="live-matrix" node_ref=canvas data-testid="live-matrix"></canvas>
            {move || {
                range().map(|(balls, low, high)| {
                    view! {
                        <p
                            class="note muted"
                            data-testid="live-positions"
                            data-low-mm=low
                            data-high-mm=high
                        >
                            {balls} " " {ctx.tr(LiveText::LiveBalls)} ": " {low} "–" {high} " mm"
                        </p>
                    }
                })
            }}
        </Show>
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
            <LiveMatrix />
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
    use wasm_bindgen_test::wasm_bindgen_test;

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

    #[wasm_bindgen_test(unsupported = test)]
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

    #[wasm_bindgen_test(unsupported = test)]
    fn the_live_positions_stop_only_when_the_last_view_that_wants_them_goes() {
        let mut wanted = 0;
        assert!(wanted_by_one_more(&mut wanted), "the card: the first");
        assert!(!wanted_by_one_more(&mut wanted), "the preview: a second");
        assert!(
            !wanted_by_one_less(&mut wanted),
            "the card goes: still wanted"
        );
        assert!(
            wanted_by_one_less(&mut wanted),
            "the preview goes: the last"
        );
        // The other order: one goes before the next comes.
        assert!(wanted_by_one_more(&mut wanted));
        assert!(wanted_by_one_less(&mut wanted));
        assert!(wanted_by_one_more(&mut wanted));
        assert_eq!(wanted, 1);
        // Never below none.
        assert!(wanted_by_one_less(&mut wanted));
        assert!(wanted_by_one_less(&mut wanted));
        assert_eq!(wanted, 0);
    }

    #[wasm_bindgen_test(unsupported = test)]
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
