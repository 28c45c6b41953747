//! The Installation page (`#/installation`, reached from Settings): the matrix's
//! grid, pitch, travel, calibration and limits, and the gateways (port, line speed,
//! stations), saved with `PUT /api/installation`.
//!
//! The fields start from the bridge's installation and follow it until the operator
//! edits one. What the app cannot read (a word where a number goes) is listed before
//! anything is sent; the values themselves are the bridge's to check, as `floatball
//! check` does: a 422 lists every problem at once, a 409 says the matrix is not idle.
//! A saved installation is the bridge's answer, shown in the fields and used by the
//! preview at once. The form's logic is [`crate::installation`]'s.

use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::client::Failure;
use crate::components::widgets::{ErrorNote, ProblemList};
use crate::context::Ctx;
use crate::i18n::Text;
use crate::installation::{Field, GatewayField, GatewayForm, InstallationForm};
use crate::page::Page;

/// The text of `which` on a gateway's form.
fn gateway_value(gateway: &GatewayForm, which: GatewayField) -> &str {
    match which {
        GatewayField::Port => &gateway.port,
        GatewayField::Baud => &gateway.baud,
        GatewayField::Stations => &gateway.stations,
    }
}

/// The Installation page.
#[component]
pub fn InstallationPage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let form = RwSignal::new(None::<InstallationForm>);
    // Whether the operator has changed a field since the bridge's installation was
    // shown (then a fresh one from the bridge does not overwrite the edit).
    let edited = RwSignal::new(false);
    Effect::new(move |_| {
        let shown = ctx
            .installation_now()
            .map(|info| InstallationForm::of(&info));
        if !edited.get_untracked() {
            form.set(shown);
        }
    });
    // The page shows what the bridge has now, not what it had at login.
    ctx.load_installation();

    let error = RwSignal::new(None::<String>);
    let problems = RwSignal::new(Vec::<String>::new());
    let busy = RwSignal::new(false);
    let saved = RwSignal::new(false);
    let save = move |event: leptos::ev::SubmitEvent| {
        event.prevent_default();
        let Some(current) = form.get_untracked() else {
            return;
        };
        let lang = ctx.lang.get_untracked();
        saved.set(false);
        match current.read() {
            Err(unread) => {
                error.set(Some(lang.t(Text::FieldsNotRead).into()));
                problems.set(unread.into_iter().map(|e| lang.form_error(e)).collect());
            }
            Ok(info) => {
                let Some(client) = ctx.client() else { return };
                error.set(None);
                problems.set(Vec::new());
                busy.set(true);
                spawn_local(async move {
                    let answer = client.put_installation(&info).await;
                    busy.set(false);
                    let lang = ctx.lang.get_untracked();
                    match answer {
                        Ok(now) => {
                            edited.set(false);
                            form.set(Some(InstallationForm::of(&now)));
                            ctx.set_installation(now);
                            saved.set(true);
                            ctx.notify(lang.t(Text::InstallationSaved));
                        }
                        Err(failure) => {
                            if let Failure::Rejected(refusal) = &failure {
                                problems.set(lang.problems(refusal));
                            }
                            error.set(Some(ctx.failed(&failure)));
                        }
                    }
                });
            }
        }
    };
    let edit = move |change: &dyn Fn(&mut InstallationForm)| {
        edited.set(true);
        saved.set(false);
        form.update(|form| {
            if let Some(form) = form {
                change(form);
            }
        });
    };
    let matrix_field = move |field: Field| {
        view! {
            <label>
                <span>{move || ctx.lang.get().field_name(field)}</span>
                <input
                    inputmode=if field.whole() { "numeric" } else { "decimal" }
                    data-testid=field.key()
                    prop:value=move || {
                        form.with(|form| form.as_ref().map(|f| f.value(field).to_owned()))
                            .unwrap_or_default()
                    }
                    on:input=move |ev| {
                        let value = event_target_value(&ev);
                        edit(&|form| form.set(field, value.clone()));
                    }
                />
            </label>
        }
    };
    let gateway_field = move |index: usize,
                              which: GatewayField,
                              label: Text,
                              test_id: &'static str| {
        view! {
            <label>
                <span>{ctx.tr(label)}</span>
                <input
                    data-testid=test_id
                    prop:value=move || {
                        form.with(|form| {
                            form.as_ref()
                                .and_then(|form| form.gateways.get(index))
                                .map(|gateway| gateway_value(gateway, which).to_owned())
                        })
                            .unwrap_or_default()
                    }
                    on:input=move |ev| {
                        let value = event_target_value(&ev);
                        edit(&|form| {
                            if let Some(gateway) = form.gateways.get_mut(index) {
                                match which {
                                    GatewayField::Port => gateway.port.clone_from(&value),
                                    GatewayField::Baud => gateway.baud.clone_from(&value),
                                    GatewayField::Stations => gateway.stations.clone_from(&value),
                                }
                            }
                        });
                    }
                />
            </label>
        }
    };
    // The gateways' rows, rebuilt only when their number changes.
    let gateway_count =
        Memo::new(move |_| form.with(|form| form.as_ref().map_or(0, |f| f.gateways.len())));
    let gateways = move || {
        (0..gateway_count.get())
            .map(|index| {
                let kind = form
                    .with_untracked(|form| form.as_ref().and_then(|f| f.gateways.get(index)).map(|g| g.kind))
                    .unwrap_or_default();
                let summary = move || {
                    form.with(|form| {
                        let stations = form.as_ref()?.gateways.get(index)?.stations.clone();
                        crate::installation::parse_stations(&stations)
                    })
                    .map(|stations| ctx.lang.get().stations_summary(&stations))
                };
                view! {
                    <li class="card gateway-form" data-testid="installation-gateway" data-gateway=index>
                        <h4>
                            {ctx.tr(Text::Gateways)} " " {index + 1} " · "
                            {crate::status::kind_key(kind)}
                        </h4>
                        {gateway_field(index, GatewayField::Port, Text::FieldPort, "gateway-port")}
                        {gateway_field(index, GatewayField::Baud, Text::FieldBaud, "gateway-baud")}
                        {gateway_field(index, GatewayField::Stations, Text::FieldStations, "gateway-stations")}
                        <p class="muted small" data-testid="gateway-summary">{summary}</p>
                    </li>
                }
            })
            .collect_view()
    };
    view! {
        <section class="installation">
            <div class="subtabs">
                <button data-testid="installation-back" on:click=move |_| ctx.page.set(Page::Settings)>
                    "← " {ctx.tr(Text::NavSettings)}
                </button>
            </div>
            <h2>{ctx.tr(Text::InstallationTitle)}</h2>
            <Show
                when=move || form.with(Option::is_some)
                fallback=move || view! { <p class="muted" data-testid="installation-unavailable">{ctx.tr(Text::InstallationUnavailable)}</p> }
            >
                <form class="form" data-testid="installation-form" on:submit=save>
                    <div class="card">
                        <h3>{ctx.tr(Text::MatrixTitle)}</h3>
                        <div class="installation-fields">{Field::ALL.into_iter().map(matrix_field).collect::<Vec<_>>()}</div>
                    </div>
                    <h3>{ctx.tr(Text::Gateways)}</h3>
                    <ol class="installation-gateways">{gateways}</ol>
                    <p class="muted small">{ctx.tr(Text::InstallationSaveNote)}</p>
                    <button type="submit" class="primary" data-testid="installation-save" disabled=move || busy.get()>
                        {ctx.tr(Text::SaveInstallation)}
                    </button>
                    <ErrorNote text=error test_id="installation-error" alert=true />
                    {move || {
                        let problems = problems.get();
                        (!problems.is_empty())
                            .then(|| view! { <ProblemList problems test_id="installation-problems" /> })
                    }}
                    {move || {
                        (saved.get() && error.with(Option::is_none))
                            .then(|| view! { <p class="note done" data-testid="installation-saved">{ctx.tr(Text::InstallationSaved)}</p> })
                    }}
                </form>
            </Show>
        </section>
    }
}
