//! The Create page's benchmark in a real browser: what one change of a parameter
//! costs the page on a 10 × 10 and a 100 × 100 matrix until the new picture is drawn —
//! the show regenerated (offline, so no plan), handed to the stage (its sampler laid
//! out) and drawn until the GPU has finished — and the limit check that follows the
//! picture (as in the preview, two frames later); and, as online, the planner's
//! verdict on the show for a matrix on simulated gateways.
//!
//! `cargo xtask create-bench` runs it in the app as served (the `wasm-release`
//! profile, whose shared crate is optimised for speed); `wasm-pack test --headless
//! --chrome web --test browser -- create:: --nocapture` in a debug build.
//! Printed, not asserted (timings vary with the machine's load); `docs/create.md`
//! gives the figures. Only sanity is checked: every show within the limits.

use floatball_shared::create::Value;
use floatball_shared::plan::Installation;
use floatball_shared::plan::report::report;
use floatball_shared::show::validate;
use floatball_shared::uim2503::plan::PlanOptions;
use floatball_web::create::{Draft, Target};
use floatball_web::preview::stage::{RendererKind, Stage, now_ms};
use wasm_bindgen_futures::JsFuture;
use wasm_bindgen_test::*;

use crate::dom::*;

/// Waits for the next animation frame, so each change is its own frame.
async fn next_frame() {
    let promise = js_sys::Promise::new(&mut |resolve, _| {
        let _ = web_sys::window().unwrap().request_animation_frame(&resolve);
    });
    let _ = JsFuture::from(promise).await;
}

/// The size of the app's memory now, MB (it only grows).
fn memory_mb() -> f64 {
    use wasm_bindgen::JsCast;
    let memory: js_sys::WebAssembly::Memory = wasm_bindgen::memory().unchecked_into();
    let buffer: js_sys::ArrayBuffer = memory.buffer().unchecked_into();
    buffer.byte_length() as f64 / 1_048_576.0
}

/// The median and the largest of `times`, ms.
fn median_and_max(mut times: Vec<f64>) -> (f64, f64) {
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], times[times.len() - 1])
}

#[wasm_bindgen_test]
async fn a_change_regenerates_and_redraws_10x10_and_100x100() {
    let build = if cfg!(debug_assertions) {
        "debug"
    } else {
        "optimised"
    };
    console_log!("create: one change, regenerated and redrawn ({build} build, 640 × 480 px):");
    for (rows, cols, duration_s, changes, goal_ms) in [
        (10, 10, 20.0, 20, 16.0),
        (10, 10, 58.0, 20, 16.0),
        (100, 100, 20.0, 5, 100.0),
        (100, 100, 58.0, 5, 100.0),
    ] {
        let canvas = fresh_canvas(640, 480);

        let mut draft = Draft::new();
        draft.set_grid(rows, cols);
        draft.set_duration_s(duration_s);
        let target = Target::of(None, draft.grid());
        let made = draft.make(&target).expect("the default wave");
        let mut stage = Stage::new(canvas, &made.show, Vec::new(), RendererKind::WebGl2)
            .expect("WebGL2 in headless Chromium");
        stage.draw(6000.0, true);
        stage.finish();

        let mut times = Vec::new();
        let mut generate = Vec::new();
        let mut checks = Vec::new();
        let mut handing = Vec::new();
        for change in 0..changes {
            next_frame().await;
            let started = now_ms();
            draft.set_param(
                "amplitude_mm",
                Value::Number(300.0 + 50.0 * f64::from(change)),
            );
            let made = draft.make(&target).expect("a wave");
            let generated = now_ms();
            // As the preview does: the new show on the stage, drawn; then its check
            // against the limits (its balls beyond a limit turn red).
            stage
                .set_show(&made.show, Vec::new())
                .expect("the new show");
            let handed = now_ms();
            stage.draw(6000.0, true);
            stage.finish();
            let drawn = now_ms();
            let violations = validate(&made.show, &target.limits);
            assert!(violations.is_empty(), "{violations:?}");
            generate.push(generated - started);
            handing.push(handed - generated);
            times.push(drawn - started);
            checks.push(now_ms() - drawn);
        }
        // Online, the page also asks the planner whether the line can carry the show
        // (as the Create page does, once the slider rests): simulated gateways at
        // 115 200 baud, 100 balls each.
        let gateways = (rows * cols).div_ceil(100) as usize;
        let installation =
            Installation::demo(rows, cols, &vec![115_200; gateways]).expect("a demo installation");
        let memory_mb = memory_mb();
        let made = draft.make(&target).expect("a wave");
        let planning = now_ms();
        let verdict = report(&made.show, &installation, PlanOptions::default());
        let verdict_ms = now_ms() - planning;
        drop(made);
        let each: Vec<String> = times
            .iter()
            .zip(&generate)
            .zip(&handing)
            .map(|((ms, generate_ms), hand_ms)| {
                format!("{ms:.0} ({generate_ms:.0} + {hand_ms:.0})")
            })
            .collect();
        let (median_ms, max_ms) = median_and_max(times);
        let (generate_ms, _) = median_and_max(generate);
        let (check_ms, _) = median_and_max(checks);
        let (hand_ms, _) = median_and_max(handing);
        console_log!(
            "  {rows}×{cols} ({} s show): drawn {median_ms:.1} ms median, {max_ms:.1} ms max, of which generating {generate_ms:.1} ms, handing to the stage {hand_ms:.1} ms (goal ≤ {goal_ms} ms); the limit check after it {check_ms:.1} ms; each change in turn: {} ms; the app's memory {:.0} MB; online, the line's verdict after it {verdict_ms:.0} ms ({})",
            draft.total_s(),
            each.join(", "),
            memory_mb,
            if verdict.feasible {
                "it can run"
            } else {
                "it cannot run"
            }
        );
        assert!(median_ms > 0.0 && max_ms < 60_000.0);
    }
}
