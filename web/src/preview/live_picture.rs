//! The Preview page's live picture (issue 38, `docs/live.md`): while the matrix is
//! live, the matrix in 3D (or the 2D top view, where WebGL2 cannot draw or the
//! operator chooses it) with every ball where the bridge last said it is
//! (`live_positions`, at most ten messages a second), on the installation's grid,
//! travel and pitch. Its code and words are in the Live card's chunk
//! ([`crate::lazy::live_preview`]): the first load carries only the Preview page's
//! switch to it.
//!
//! A show chosen on the Preview page stays chosen: while live the live picture takes
//! over, with a button back to the show; with the show on screen, a bar says the
//! matrix is live, with a button to the live picture
//! ([`crate::context::Ctx::preview_show_while_live`]; choosing a show from the lists
//! shows it). When live mode ends, the page shows what it showed before (the show,
//! or the empty page).
//!
//! The stage draws shows ([`super::stage::Stage`]), so the positions are given it as
//! one ([`live_show`]): every ball at rest where it is, drawn at 0 ms.

use std::rc::Rc;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use floatball_shared::api::InstallationInfo;
use floatball_shared::show::{DEFAULT_PITCH_MM, Layout, Show, Track};
use leptos::prelude::*;

use super::gestures::Gestures;
use super::model::{Mode, ViewChoice};
use super::stage::{Matrix, RendererKind, Stage};
use super::{StageParts, animate, stage_canvas, with_stage};
use crate::components::live::{grid, phase_text, want_live_positions};
use crate::context::{Ctx, tr_in};
use crate::i18n::{Lang, LiveText, Text};

/// The layout of `balls` live positions: the installation's rows, columns and pitch
/// when it holds them (it is not known without a login), else one row at the
/// default pitch.
pub fn live_layout(balls: usize, installation: Option<&InstallationInfo>) -> Layout {
    let (rows, cols, pitch_mm) = installation.map_or((0, 0, DEFAULT_PITCH_MM), |info| {
        (info.rows, info.cols, info.pitch_mm)
    });
    let (rows, cols) = grid(balls, rows, cols);
    let count = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
    Layout {
        rows: count(rows),
        cols: count(cols),
        pitch_mm,
    }
}

/// The live positions as a show the stage draws: on `layout`, every ball at rest at
/// its position (mm below the top), row-major as the bridge sends them.
pub fn live_show(positions_mm: &[i32], layout: Layout) -> Show {
    Show {
        name: String::new(),
        layout,
        tracks: positions_mm
            .iter()
            .map(|&position_mm| Track {
                start_mm: f64::from(position_mm),
                rows: Vec::new(),
                colours: Vec::new(),
            })
            .collect(),
        outputs: Vec::new(),
    }
}

/// The shallowest and deepest of `positions_mm`, whole mm.
fn range_mm(positions_mm: &[f32]) -> Option<(i64, i64)> {
    let low = positions_mm.iter().copied().reduce(f32::min)?;
    let high = positions_mm.iter().copied().reduce(f32::max)?;
    #[allow(
        clippy::cast_possible_truncation,
        reason = "positions within the travel"
    )]
    let whole = |mm: f32| mm.round() as i64;
    Some((whole(low), whole(high)))
}

/// The live picture, or (the operator chose the show) the bar that leads to it.
#[component]
pub fn LivePicture() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let lang: Signal<Lang> = ctx.lang.into();
    move || {
        if ctx.preview_show_while_live.get() {
            view! {
                <p class="note" data-testid="preview-live-bar">
                    {tr_in(lang, LiveText::LivePictureLiveNow)} " "
                    <button
                        data-testid="preview-live-open"
                        on:click=move |_| ctx.preview_show_while_live.set(false)
                    >
                        {tr_in(lang, LiveText::LivePictureToLive)}
                    </button>
                </p>
            }
            .into_any()
        } else {
            view! { <LiveStage /> }.into_any()
        }
    }
}

/// The matrix at its live positions, asked for while shown.
#[component]
fn LiveStage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let lang: Signal<Lang> = ctx.lang.into();
    want_live_positions(ctx);
    let installation = Memo::new(move |_| ctx.installation_now());
    let show = Memo::new_with_compare(
        move |_| {
            ctx.live_positions.with(|positions_mm| {
                (!positions_mm.is_empty()).then(|| {
                    let layout =
                        installation.with(|info| live_layout(positions_mm.len(), info.as_ref()));
                    Arc::new(live_show(positions_mm, layout))
                })
            })
        },
        super::show_changed,
    );
    let matrix = Memo::new(move |_| {
        installation.with(|info| {
            info.as_ref().map(|info| Matrix {
                travel_mm: info.travel_mm,
                pitch_mm: info.pitch_mm,
            })
        })
    });
    let view_choice = RwSignal::new(ViewChoice::default());
    let renderer = Memo::new(move |_| view_choice.with(ViewChoice::renderer));
    let selected = Memo::new(move |_| view_choice.with(ViewChoice::selected));
    let stage = StoredValue::new_local(None::<Stage>);
    let parts = StageParts {
        show: show.into(),
        canvas: NodeRef::new(),
        stage,
        gestures: StoredValue::new(Gestures::default()),
        view_choice,
    };

    // The stage follows the positions, the canvas and the renderer; where WebGL2
    // cannot draw, the canvas is replaced by a 2D one.
    Effect::new(move |_| {
        let kind = renderer.get();
        let canvas = parts.canvas.get();
        let matrix = matrix.get();
        let unit = selected.get_untracked();
        show.with(|show| {
            let (Some(canvas), Some(show)) = (canvas, show) else {
                stage.set_value(None);
                return;
            };
            let reused = stage
                .try_update_value(|current| match current {
                    Some(current) if current.canvas() == &canvas && current.kind() == kind => {
                        Some(current.set_show(show, Vec::new()))
                    }
                    _ => None,
                })
                .flatten();
            let outcome = match reused {
                Some(outcome) => outcome,
                None => Stage::new(canvas, show, Vec::new(), kind).map(|new| {
                    stage.set_value(Some(new));
                }),
            }
            .and_then(|()| {
                stage
                    .try_update_value(|stage| {
                        stage.as_mut().map(|stage| {
                            stage.select(unit);
                            stage.set_matrix(matrix)
                        })
                    })
                    .flatten()
                    .unwrap_or(Ok(()))
            });
            if let Err(why) = outcome {
                stage.set_value(None);
                if kind == RendererKind::WebGl2 {
                    leptos::logging::warn!("3D preview unavailable: {why}");
                    view_choice.update(|view| view.webgl_failed(why));
                }
            }
        });
    });
    Effect::new(move |_| {
        let unit = selected.get();
        with_stage(stage, |stage| stage.select(unit));
    });

    // Every frame the stage draws if its picture changed (new positions, a gesture,
    // a resize); what it drew is told in `data-*` (the balls, the shallowest and the
    // deepest, mm) and under the picture.
    let drawn = RwSignal::new(None::<(usize, i64, i64)>);
    let tapped = RwSignal::new(None::<f32>);
    let alive = Arc::new(AtomicBool::new(true));
    {
        let alive = Arc::clone(&alive);
        on_cleanup(move || alive.store(false, Ordering::Relaxed));
    }
    let step = move || {
        let facts = stage
            .try_update_value(|stage| {
                let stage = stage.as_mut()?;
                stage.draw(0.0, false).then(|| {
                    let positions = stage.positions_mm();
                    let unit = selected.get_untracked();
                    (
                        range_mm(positions).map(|(low, high)| (positions.len(), low, high)),
                        unit.and_then(|unit| positions.get(unit).copied()),
                    )
                })
            })
            .flatten();
        if let Some((range, at)) = facts {
            drawn.set(range);
            tapped.set(at);
        }
    };
    animate(Rc::new(step), alive);

    let phase = Memo::new(move |_| {
        ctx.status.with(|status| {
            status
                .as_ref()
                .and_then(|status| status.live.as_deref().map(|live| live.phase))
        })
    });
    let ball = move || {
        let unit = selected.get()?;
        let at = tapped.get()?;
        let (row, col) = show.with(|show| show.as_ref().map(|show| show.layout.cell(unit)))?;
        let lang = lang.get();
        Some(format!(
            "{} {} {at:.0} mm",
            lang.ball_name(unit, row, col),
            lang.t(LiveText::LivePictureBallAt)
        ))
    };
    let attribute = move |pick: fn((usize, i64, i64)) -> String| {
        move || drawn.get().map(pick).unwrap_or_default()
    };
    view! {
        <section
            class="preview live-picture"
            data-testid="preview-live-picture"
            data-balls=attribute(|(balls, _, _)| balls.to_string())
            data-low-mm=attribute(|(_, low, _)| low.to_string())
            data-high-mm=attribute(|(_, _, high)| high.to_string())
        >
            <h2 data-testid="preview-live-title">{tr_in(lang, LiveText::LivePictureTitle)}</h2>
            <p class="muted small">{tr_in(lang, LiveText::LivePictureExplain)}</p>
            {move || {
                phase.get().map(|phase| {
                    view! {
                        <p class="note" data-testid="preview-live-phase" data-phase=phase.as_str()>
                            {tr_in(lang, LiveText::LivePhaseLabel)} ": "
                            {tr_in(lang, phase_text(phase))}
                            {move || {
                                drawn.get().map(|(balls, low, high)| {
                                    format!(
                                        " · {balls} {}: {low}–{high} mm",
                                        lang.get().t(LiveText::LiveBalls),
                                    )
                                })
                            }}
                        </p>
                    }
                })
            }}
            <Show when=move || show.with(Option::is_none)>
                <p class="muted" data-testid="preview-live-waiting">
                    {tr_in(lang, LiveText::LivePictureWaiting)}
                </p>
            </Show>
            <div class="stage-box">
                <Show
                    when=move || renderer.get() == RendererKind::WebGl2
                    fallback=move || stage_canvas(RendererKind::TopView, parts)
                >
                    {stage_canvas(RendererKind::WebGl2, parts)}
                </Show>
            </div>
            <Show when=move || view_choice.with(ViewChoice::explains_no_webgl)>
                <p class="note" data-testid="preview-no-webgl">{tr_in(lang, Text::NoWebGl)}</p>
            </Show>
            <p class="muted small" data-testid="preview-live-ball">{ball}</p>
            <div class="tools">
                <div class="segmented" role="group">
                    <button
                        data-testid="preview-mode-3d"
                        aria-pressed=move || (view_choice.with(ViewChoice::mode) == Mode::ThreeD).to_string()
                        disabled=move || !view_choice.with(ViewChoice::offers_3d)
                        on:click=move |_| view_choice.update(|view| view.choose(Mode::ThreeD))
                    >
                        {tr_in(lang, Text::View3d)}
                    </button>
                    <button
                        data-testid="preview-mode-top"
                        aria-pressed=move || (renderer.get() == RendererKind::TopView).to_string()
                        on:click=move |_| view_choice.update(|view| view.choose(Mode::Top))
                    >
                        {tr_in(lang, Text::TopView)}
                    </button>
                </div>
                <Show when=move || renderer.get() == RendererKind::WebGl2>
                    <button
                        data-testid="preview-reset-view"
                        on:click=move |_| with_stage(stage, Stage::reset_view)
                    >
                        {tr_in(lang, Text::ResetView)}
                    </button>
                </Show>
                <Show when=move || ctx.preview.with(Option::is_some)>
                    <button
                        data-testid="preview-live-to-show"
                        on:click=move |_| ctx.preview_show_while_live.set(true)
                    >
                        {tr_in(lang, LiveText::LivePictureToShow)}
                    </button>
                </Show>
            </div>
            <Show when=move || renderer.get() == RendererKind::WebGl2>
                <p class="muted small">{tr_in(lang, Text::GestureHint)}</p>
            </Show>
        </section>
    }
}

#[cfg(test)]
mod tests {
    use wasm_bindgen_test::wasm_bindgen_test;

    use floatball_shared::show::Sampler;

    use super::*;

    fn installation(rows: u32, cols: u32) -> InstallationInfo {
        InstallationInfo {
            rows,
            cols,
            pitch_mm: 400.0,
            travel_mm: 2000.0,
            max_speed_mm_s: 1000.0,
            max_accel_mm_s2: 2000.0,
            home_mm: 0.0,
            approach_speed_mm_s: 500.0,
            counts_per_mm: 100.0,
            gateways: Vec::new(),
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_live_positions_are_laid_out_on_the_installations_grid() {
        let info = installation(2, 3);
        assert_eq!(
            live_layout(6, Some(&info)),
            Layout {
                rows: 2,
                cols: 3,
                pitch_mm: 400.0
            }
        );
        // More balls than the installation holds (it changed meanwhile): one row.
        assert_eq!(live_layout(8, Some(&info)).rows, 1);
        assert_eq!(live_layout(8, Some(&info)).cols, 8);
        // Not known (no login): one row at the default pitch.
        assert_eq!(
            live_layout(4, None),
            Layout {
                rows: 1,
                cols: 4,
                pitch_mm: DEFAULT_PITCH_MM
            }
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn every_ball_is_drawn_at_its_live_position() {
        let positions_mm = [0, 500, 1000, 1999, 250, 750];
        let show = live_show(&positions_mm, live_layout(6, Some(&installation(2, 3))));
        assert_eq!(show.tracks.len(), 6);
        let mut sampled = vec![f32::NAN; 6];
        // Whatever the time drawn: they are at rest.
        for t_ms in [0.0, 1000.0] {
            Sampler::new(&show).sample(t_ms, &mut sampled, None);
            let expected: Vec<f32> = positions_mm.iter().map(|&mm| mm as f32).collect();
            assert_eq!(sampled, expected);
        }
        assert_eq!(range_mm(&sampled), Some((0, 1999)));
        assert_eq!(range_mm(&[]), None);
    }
}
