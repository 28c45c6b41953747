//! One ball's Q program for MOONS' drives, under the controller files: pick a ball,
//! see exactly the lines Start sends its drive for the selected show (the listing:
//! one segment loaded into the drive's queue, several stored in its segments, or a
//! show too long to store streamed into its command buffer; the segments and lines,
//! and the largest deviation from the show), and save it to the device as a `.q`
//! file — what an installer loads with MOONS' Q Programmer when Start is not to load
//! the drives (`programs = "stored"`).
//!
//! Shown on installations with MOONS' drives only; the ball number is the CSV's
//! `uN` (row-major, from 0).

use floatball_shared::api::{GatewayKind, QProgramListing};
use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::components::files::save_text;
use crate::components::widgets::{ActionButton, ErrorNote, TextField};
use crate::context::Ctx;
use crate::files::{parse_ball, qprogram_file_name};
use crate::i18n::Text;

/// Whether the installation has MOONS' drives (a gateway of kind SCL): the
/// installation's gateways when known (a status of many gateways details only those
/// with a problem), else those of the status.
pub fn has_scl_drives(ctx: Ctx) -> bool {
    let scl = |kind: GatewayKind| kind == GatewayKind::Scl;
    let configured = ctx.installation.with(|installation| {
        installation
            .as_ref()
            .filter(|installation| !installation.gateways.is_empty())
            .map(|installation| {
                installation
                    .gateways
                    .iter()
                    .any(|gateway| scl(gateway.kind))
            })
    });
    configured.unwrap_or_else(|| {
        ctx.status.with(|status| {
            status
                .iter()
                .flat_map(|status| &status.gateways)
                .any(|gateway| scl(gateway.kind))
        })
    })
}

/// The Q program panel for the show named by `selected`.
#[component]
pub fn QProgramPanel(
    /// The selected controller show, if any.
    #[prop(into)]
    selected: Signal<Option<String>>,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let ball = RwSignal::new(String::from("0"));
    let listing = RwSignal::new(None::<QProgramListing>);
    let error = RwSignal::new(None::<String>);
    let busy = RwSignal::new(false);
    // A new show or ball makes the old listing stale.
    Effect::new(move |_| {
        selected.track();
        ball.track();
        listing.set(None);
    });
    let show = Callback::new(move |()| {
        let (Some(name), Some(client)) = (selected.get_untracked(), ctx.client()) else {
            return;
        };
        let Some(unit) = parse_ball(&ball.get_untracked()) else {
            error.set(Some(ctx.t(Text::BallNumberWanted).into()));
            return;
        };
        busy.set(true);
        error.set(None);
        spawn_local(async move {
            match client.qprogram(&name, unit).await {
                Ok(found) => listing.set(Some(found)),
                Err(failure) => {
                    listing.set(None);
                    error.set(Some(ctx.failed(&failure)));
                }
            }
            busy.set(false);
        });
    });
    let save = Callback::new(move |()| {
        let Some(found) = listing.get_untracked() else {
            return;
        };
        let name = qprogram_file_name(&found.show, found.unit);
        if let Err(problem) = save_text(&name, &found.text, "text/plain") {
            error.set(Some(problem));
        }
    });
    let online = move || ctx.connected() && ctx.logged_in();
    view! {
        <section class="qprogram" data-testid="qprogram">
            <h3>{ctx.tr(Text::QProgram)}</h3>
            <div class="toolbar">
                <TextField
                    label=Text::Ball
                    value=ball
                    test_id="qprogram-ball"
                    inputmode="numeric"
                />
                <ActionButton
                    text=Text::ShowQProgram
                    test_id="qprogram-show"
                    disabled=Signal::derive(move || {
                        selected.get().is_none() || !online() || busy.get()
                    })
                    on_click=show
                />
                <ActionButton
                    text=Text::SaveToDevice
                    test_id="qprogram-save"
                    disabled=Signal::derive(move || listing.with(Option::is_none))
                    on_click=save
                />
            </div>
            <ErrorNote text=error test_id="qprogram-error" />
            {move || {
                listing
                    .get()
                    .map(|found| {
                        let summary = ctx.lang.get().qprogram_summary(&found);
                        view! {
                            <p class="note" data-testid="qprogram-summary">{summary}</p>
                            <pre class="listing" data-testid="qprogram-text">{found.text}</pre>
                        }
                    })
            }}
        </section>
    }
}
