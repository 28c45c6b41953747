//! The Commissioning page (`#/commission`, reached from Control's tabs): per gateway
//! a roll call and its units (serial, station, position, last answer, error, flags),
//! "assign all in grid order" and a station per unit, Identify per unit, the grid
//! seen from below where a tap after Identify gives the moved ball its cell (and a
//! tap on a cell moves the ball configured there), "save mapping"
//! (`PUT /api/installation`), and the guided line-speed change.
//!
//! The decisions (flags, grid order, the mapping) are [`crate::commission`]'s; this
//! module wires them to the bridge and the page. A refusal is shown under its
//! gateway with every problem the bridge listed; a success is a toast.

use floatball_shared::api::{GatewayKind, InstallationInfo, RollCall};
use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::client::Failure;
use crate::commission::{
    BAUD_RATES, Mapping, Tap, age_text, grid_order, parse_distance, parse_station, position_text,
    roll_call_clean, unit_flags,
};
use crate::components::control::ControlTabs;
use crate::components::widgets::{ErrorNote, ProblemList, TextField};
use crate::context::Ctx;
use crate::i18n::{CommissionText, Text};

/// The page: the installation, then one panel per gateway.
#[component]
pub fn CommissionPage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let info = RwSignal::new(None::<InstallationInfo>);
    let load_error = RwSignal::new(None::<String>);
    // Fetched on opening and on every (re)connection.
    Effect::new(move |_| {
        if !ctx.connected() {
            return;
        }
        let Some(client) = ctx.client() else { return };
        spawn_local(async move {
            match client.installation().await {
                Ok(answer) => {
                    load_error.set(None);
                    info.set(Some(answer));
                }
                Err(failure) => load_error.set(Some(ctx.failed(&failure))),
            }
        });
    });
    // The panels stay (with their roll calls) when the installation is saved.
    let kinds = Memo::new(move |_| {
        info.with(|info| {
            info.as_ref().map_or_else(Vec::new, |info| {
                info.gateways
                    .iter()
                    .map(|gateway| gateway.kind)
                    .collect::<Vec<_>>()
            })
        })
    });
    let unreadable = Signal::derive(move || {
        load_error
            .get()
            .map(|why| format!("{} {why}", ctx.t(CommissionText::InstallationUnreadable)))
    });
    view! {
        <section class="commission" data-testid="commission">
            <ControlTabs />
            <p class="muted">{ctx.tr(CommissionText::CommissionIntro)}</p>
            <ErrorNote text=unreadable test_id="installation-error" />
            {move || {
                kinds
                    .get()
                    .into_iter()
                    .enumerate()
                    .map(|(gateway, kind)| view! { <GatewayPanel gateway kind info /> })
                    .collect_view()
            }}
        </section>
    }
}

/// What the bridge said about a gateway's latest request: its sentence and every
/// problem it listed.
#[derive(Debug, Clone, Default, PartialEq)]
struct Said {
    text: Option<String>,
    problems: Vec<String>,
}

fn said_of(ctx: Ctx, failure: &Failure) -> Said {
    let problems = match failure {
        Failure::Rejected(error) => ctx.lang.get_untracked().problems(error),
        _ => Vec::new(),
    };
    Said {
        text: Some(ctx.failed(failure)),
        problems,
    }
}

/// One gateway: roll call, units, grid, line speed.
#[component]
fn GatewayPanel(
    gateway: usize,
    kind: GatewayKind,
    info: RwSignal<Option<InstallationInfo>>,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let roll = RwSignal::new(None::<RollCall>);
    let busy = RwSignal::new(false);
    let said = RwSignal::new(Said::default());
    let identified = RwSignal::new(None::<u8>);
    let moving = RwSignal::new(None::<String>);
    let mapping = RwSignal::new(None::<Mapping>);
    // The mapping starts from the installation's stations, and again whenever they
    // change (a save); a new line speed leaves the taps made so far alone.
    let saved = Memo::new(move |_| {
        info.with(|info| info.as_ref().and_then(|info| Mapping::new(info, gateway)))
    });
    Effect::new(move |_| mapping.set(saved.get()));
    let title = move || {
        info.with(|info| {
            let port = info
                .as_ref()
                .and_then(|info| info.gateways.get(gateway))
                .map(|one| one.port.clone())
                .unwrap_or_default();
            ctx.lang.get().gateway_title(gateway, &port, kind)
        })
    };

    // Runs one request with the panel busy; `done` takes the answer.
    let run = move |work: std::pin::Pin<Box<dyn std::future::Future<Output = ()>>>| {
        busy.set(true);
        said.set(Said::default());
        spawn_local(async move {
            work.await;
            busy.set(false);
        });
    };
    let roll_call = move || {
        let Some(client) = ctx.client() else { return };
        run(Box::pin(async move {
            match client.roll_call(gateway).await {
                Ok(answer) => roll.set(Some(answer)),
                Err(failure) => said.set(said_of(ctx, &failure)),
            }
        }));
    };
    let assign = move |assignments: Vec<floatball_shared::api::Assignment>| {
        let Some(client) = ctx.client() else { return };
        let count = assignments.len();
        run(Box::pin(async move {
            match client.assign(gateway, assignments).await {
                Ok(answer) => {
                    roll.set(Some(answer));
                    ctx.notify(ctx.lang.get_untracked().assigned(count));
                }
                Err(failure) => said.set(said_of(ctx, &failure)),
            }
        }));
    };
    let distance = RwSignal::new(String::new());
    let identify = move |station: u8| {
        let Some(client) = ctx.client() else { return };
        let Ok(distance_mm) = parse_distance(&distance.get_untracked()) else {
            said.set(Said {
                text: Some(
                    ctx.lang
                        .get_untracked()
                        .t(CommissionText::BadDistance)
                        .to_owned(),
                ),
                problems: Vec::new(),
            });
            return;
        };
        run(Box::pin(async move {
            match client.identify(gateway, station, distance_mm).await {
                Ok(answer) => {
                    identified.set(Some(answer.station));
                    moving.set(Some(ctx.lang.get_untracked().identifying(&answer)));
                }
                Err(failure) => said.set(said_of(ctx, &failure)),
            }
        }));
    };
    let assign_all = move || {
        let assignments = roll.with_untracked(|roll| {
            let stations = mapping.with_untracked(|mapping| {
                mapping
                    .as_ref()
                    .map(|mapping| mapping.stations().to_vec())
                    .unwrap_or_default()
            });
            roll.as_ref()
                .map(|roll| grid_order(&roll.units, &stations))
                .unwrap_or_default()
        });
        if !assignments.is_empty() {
            assign(assignments);
        }
    };
    let tap = move |local: usize| {
        let Some(action) = mapping.with_untracked(|mapping| {
            mapping
                .as_ref()
                .map(|mapping| mapping.tap(local, identified.get_untracked()))
        }) else {
            return;
        };
        match action {
            Tap::Map { cell, station } => {
                mapping.update(|mapping| {
                    if let Some(mapping) = mapping {
                        mapping.place(cell, station);
                    }
                });
                identified.set(None);
                moving.set(None);
            }
            Tap::Identify(station) => identify(station),
            Tap::Nothing => {}
        }
    };
    let save = move || {
        let Some(client) = ctx.client() else { return };
        let Some(body) = info.with_untracked(|info| {
            let info = info.as_ref()?;
            mapping.with_untracked(|mapping| mapping.as_ref().map(|mapping| mapping.apply(info)))
        }) else {
            return;
        };
        run(Box::pin(async move {
            match client.put_installation(&body).await {
                Ok(answer) => {
                    info.set(Some(answer));
                    ctx.notify(ctx.lang.get_untracked().t(CommissionText::MappingSaved));
                }
                Err(failure) => said.set(said_of(ctx, &failure)),
            }
        }));
    };

    let uim = kind == GatewayKind::Uim2503;
    let not_uim = (!uim).then(|| {
        view! { <p class="note muted" data-testid="not-uim2503">{ctx.tr(CommissionText::NotUim2503)}</p> }
    });
    let body = uim.then(|| {
        view! {
            <div class="toolbar">
                <button
                    class="primary"
                    data-testid="rollcall"
                    disabled=move || busy.get() || !ctx.connected()
                    on:click=move |_| roll_call()
                >
                    {ctx.tr(CommissionText::RollCall)}
                </button>
                <button
                    data-testid="assign-all"
                    disabled=move || busy.get() || roll.with(Option::is_none)
                    on:click=move |_| assign_all()
                >
                    {ctx.tr(CommissionText::AssignAll)}
                </button>
                {move || busy.get().then(|| view! { <span class="muted">{ctx.t(Text::Working)}</span> })}
            </div>
            <p class="muted small">{ctx.tr(CommissionText::AssignAllNote)}</p>
            <div class="distance">
                <TextField
                    label=CommissionText::IdentifyDistance
                    value=distance
                    test_id="identify-distance"
                    inputmode="decimal"
                />
            </div>
            <RollCallView roll busy identify assign />
            <GridView mapping identified moving busy tap save />
            <BaudChange gateway info />
        }
    });
    view! {
        <article class="card gateway-panel" data-testid="gateway" data-gateway=gateway>
            <h3>{title}</h3>
            {not_uim}
            {move || {
                said.with(|said| {
                    said.text.clone().map(|text| {
                        view! {
                            <div class="note error" data-testid="commission-error" role="alert">
                                <p>{text}</p>
                                {(!said.problems.is_empty())
                                    .then(|| {
                                        view! {
                                            <ProblemList
                                                problems=said.problems.clone()
                                                test_id="commission-problems"
                                            />
                                        }
                                    })}
                            </div>
                        }
                    })
                })
            }}
            {body}
        </article>
    }
}

/// A roll call: its summary, what is wrong with the bus, and one row per unit.
#[component]
fn RollCallView(
    roll: RwSignal<Option<RollCall>>,
    busy: RwSignal<bool>,
    identify: impl Fn(u8) + Copy + Send + Sync + 'static,
    assign: impl Fn(Vec<floatball_shared::api::Assignment>) + Copy + Send + Sync + 'static,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    move || {
        let Some(found) = roll.get() else {
            return view! {
                <p class="muted" data-testid="no-rollcall">{ctx.tr(CommissionText::NoRollCallYet)}</p>
            }
            .into_any();
        };
        let lang = ctx.lang.get();
        let stations = |label: CommissionText, list: &[u8], test_id: &'static str| {
            (!list.is_empty()).then(|| {
                view! {
                    <p class="note warn" data-testid=test_id data-stations=lang.station_list(list)>
                        {lang.t(label)} " " {lang.station_list(list)}
                    </p>
                }
            })
        };
        let clean = roll_call_clean(&found).then(|| {
            view! { <p class="note done" data-testid="roll-clean">{lang.t(CommissionText::RollCallClean)}</p> }
        });
        let rows = found
            .units
            .iter()
            .map(|unit| {
                let flags = unit_flags(&found, unit);
                let keys = flags
                    .iter()
                    .map(|flag| flag.key())
                    .collect::<Vec<_>>()
                    .join(" ");
                let badges = flags
                    .iter()
                    .map(|flag| {
                        let text = match flag {
                            crate::commission::UnitFlag::Duplicated => CommissionText::FlagDuplicated,
                            crate::commission::UnitFlag::Unexpected => CommissionText::FlagUnexpected,
                            crate::commission::UnitFlag::Fault => CommissionText::FlagFault,
                        };
                        view! { <span class=format!("badge {}", flag.key())>{lang.t(text)}</span> }
                    })
                    .collect_view();
                let fault = unit.fault.map(|fault| {
                    view! { <span class="fault" data-testid="unit-fault">{lang.unit_fault(&fault)}</span> }
                });
                let station = unit.station;
                let typed = RwSignal::new(String::new());
                let bad = RwSignal::new(false);
                let serial = unit.serial;
                let give = move || match parse_station(&typed.get_untracked()) {
                    Some(station) => {
                        bad.set(false);
                        assign(vec![floatball_shared::api::Assignment { serial, station }]);
                    }
                    None => bad.set(true),
                };
                view! {
                    <li
                        class="unit"
                        data-testid="unit"
                        data-serial=serial
                        data-station=station
                        data-flags=keys
                    >
                        <div class="unit-facts">
                            <span class="mono">{format!("SN {serial}")}</span>
                            <span>
                                {lang.t(CommissionText::Station)} " " <strong>{station}</strong>
                            </span>
                            {badges}
                        </div>
                        <div class="unit-facts muted">
                            <span>{lang.t(CommissionText::Position)} " " {position_text(unit.position_mm)}</span>
                            <span>
                                {lang.t(CommissionText::LastAnswer)} " " {age_text(unit.last_answer_age_ms)}
                            </span>
                            {fault}
                        </div>
                        <div class="unit-actions">
                            <button
                                data-testid="unit-identify"
                                disabled=move || busy.get()
                                on:click=move |_| identify(station)
                            >
                                {lang.t(CommissionText::Identify)}
                            </button>
                            <input
                                type="text"
                                inputmode="numeric"
                                class="station-input"
                                data-testid="unit-station"
                                aria-label=lang.t(CommissionText::NewStation)
                                placeholder=lang.t(CommissionText::NewStation)
                                prop:value=typed
                                on:input=move |ev| typed.set(event_target_value(&ev))
                            />
                            <button
                                data-testid="unit-assign"
                                disabled=move || busy.get()
                                on:click=move |_| give()
                            >
                                {lang.t(CommissionText::Assign)}
                            </button>
                        </div>
                        {move || {
                            bad.get()
                                .then(|| {
                                    view! {
                                        <p class="note error" data-testid="bad-station">
                                            {ctx.t(CommissionText::BadStation)}
                                        </p>
                                    }
                                })
                        }}
                    </li>
                }
            })
            .collect_view();
        view! {
            <p data-testid="roll-summary">{lang.roll_call_summary(&found)}</p>
            {stations(CommissionText::DuplicatedStations, &found.duplicated, "duplicated-stations")}
            {stations(CommissionText::MissingStations, &found.missing, "missing-stations")}
            {stations(CommissionText::UnexpectedStations, &found.unexpected, "unexpected-stations")}
            {clean}
            <ul class="list units" data-testid="units" data-count=found.units.len()>
                {rows}
            </ul>
        }
        .into_any()
    }
}

/// The gateway's cells as the matrix is seen from below: each shows its station; a
/// tap after Identify places the moved ball there, a tap otherwise moves the ball
/// configured there. Save stores the mapping.
#[component]
fn GridView(
    mapping: RwSignal<Option<Mapping>>,
    identified: RwSignal<Option<u8>>,
    moving: RwSignal<Option<String>>,
    busy: RwSignal<bool>,
    tap: impl Fn(usize) + Copy + Send + Sync + 'static,
    save: impl Fn() + Copy + Send + Sync + 'static,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let grid = move || {
        mapping.with(|mapping| {
            let mapping = mapping.as_ref()?;
            let lang = ctx.lang.get();
            let (first_row, _) = mapping.rows();
            let pending = identified.get();
            let style = format!("grid-template-columns: repeat({}, 1fr)", mapping.cols());
            let cells = mapping
                .cells()
                .into_iter()
                .map(|cell| {
                    let place = format!(
                        "grid-row: {}; grid-column: {}",
                        cell.row - first_row + 1,
                        cell.col + 1
                    );
                    let local = cell.local;
                    view! {
                        <button
                            class="cell"
                            class:placed=cell.placed
                            class:changed=cell.changed
                            class:pending={pending == Some(cell.station)}
                            style=place
                            data-testid="cell"
                            data-cell=cell.cell
                            data-station=cell.station
                            data-placed={cell.placed.to_string()}
                            aria-label=lang.cell_label(cell.row, cell.col, cell.station)
                            on:click=move |_| tap(local)
                        >
                            {cell.station}
                        </button>
                    }
                })
                .collect_view();
            let placed = lang.placed_cells(mapping.placed_count(), mapping.stations().len());
            Some(view! {
                <div class="grid" data-testid="grid" style=style>
                    {cells}
                </div>
                <p class="muted" data-testid="placed">{placed}</p>
            })
        })
    };
    let unchanged = move || {
        mapping.with(|mapping| {
            mapping
                .as_ref()
                .is_none_or(|mapping| !mapping.changed() && mapping.placed_count() == 0)
        })
    };
    view! {
        <h4>{ctx.tr(CommissionText::GridSeenFromBelow)}</h4>
        <p class="muted small">{ctx.tr(CommissionText::GridHint)}</p>
        {move || {
            moving
                .get()
                .map(|text| {
                    view! {
                        <p class="note identified" data-testid="identified" role="status">
                            {text} " "
                            <button
                                class="link-button"
                                data-testid="cancel-identify"
                                on:click=move |_| {
                                    identified.set(None);
                                    moving.set(None);
                                }
                            >
                                {ctx.tr(Text::Cancel)}
                            </button>
                        </p>
                    }
                })
        }}
        {grid}
        <div class="toolbar">
            <button
                class="primary"
                data-testid="save-mapping"
                disabled=move || busy.get() || unchanged()
                on:click=move |_| save()
            >
                {ctx.tr(CommissionText::SaveMapping)}
            </button>
        </div>
    }
}

/// Where the guided line-speed change is.
#[derive(Debug, Clone, PartialEq)]
enum BaudStep {
    /// Nothing asked.
    Idle,
    /// The explanation is shown; the change starts on confirmation.
    Explain,
    /// Sent; waiting for the gateway to answer at the new speed.
    Waiting,
    /// It answered (the sentence), or it did not (the refusal).
    Done(Result<String, Said>),
}

/// The guided line-speed change of one gateway: pick a speed, read what happens (a
/// real gateway is switched off and on while the app waits), then the result.
#[component]
fn BaudChange(gateway: usize, info: RwSignal<Option<InstallationInfo>>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let current = move || {
        info.with(|info| {
            info.as_ref()
                .and_then(|info| info.gateways.get(gateway))
                .and_then(|one| one.baud)
        })
    };
    let chosen = RwSignal::new(BAUD_RATES[BAUD_RATES.len() - 1]);
    let step = RwSignal::new(BaudStep::Idle);
    let start = move || {
        let Some(client) = ctx.client() else { return };
        let baud = chosen.get_untracked();
        step.set(BaudStep::Waiting);
        spawn_local(async move {
            let outcome = match client.change_baud(gateway, baud).await {
                Ok(changed) => {
                    info.update(|info| {
                        if let Some(one) = info
                            .as_mut()
                            .and_then(|info| info.gateways.get_mut(gateway))
                        {
                            one.baud = Some(changed.baud);
                        }
                    });
                    Ok(ctx.lang.get_untracked().baud_changed(&changed))
                }
                Err(failure) => Err(said_of(ctx, &failure)),
            };
            step.set(BaudStep::Done(outcome));
        });
    };
    let options = move || {
        BAUD_RATES
            .iter()
            .map(|&baud| {
                view! {
                    <option value=baud.to_string() selected=move || chosen.get() == baud>
                        {baud.to_string()}
                    </option>
                }
            })
            .collect_view()
    };
    let stage = move || {
        match step.get() {
        BaudStep::Idle => ().into_any(),
        BaudStep::Explain => view! {
            <div class="note" data-testid="baud-explain">
                <p>{ctx.tr(CommissionText::BaudPowerCycle)}</p>
                <div class="confirm">
                    <button
                        class="confirm-yes primary"
                        data-testid="baud-confirm"
                        on:click=move |_| start()
                    >
                        {ctx.tr(CommissionText::StartBaudChange)}
                    </button>
                    <button
                        class="confirm-cancel"
                        data-testid="baud-cancel"
                        on:click=move |_| step.set(BaudStep::Idle)
                    >
                        {ctx.tr(Text::Cancel)}
                    </button>
                </div>
            </div>
        }
        .into_any(),
        BaudStep::Waiting => view! {
            <p class="note warn" data-testid="baud-waiting" role="status">
                {ctx.tr(CommissionText::BaudWaiting)}
            </p>
        }
        .into_any(),
        BaudStep::Done(Ok(text)) => view! {
            <p class="note done" data-testid="baud-result" data-outcome="ok">{text}</p>
        }
        .into_any(),
        BaudStep::Done(Err(said)) => view! {
            <div class="note error" data-testid="baud-result" data-outcome="error">
                <p>{said.text.clone()}</p>
                {(!said.problems.is_empty())
                    .then(|| view! { <ProblemList problems=said.problems test_id="baud-problems" /> })}
            </div>
        }
        .into_any(),
    }
    };
    view! {
        <h4>{ctx.tr(CommissionText::LineSpeed)}</h4>
        <div class="toolbar">
            <span class="muted" data-testid="baud-now">{move || ctx.lang.get().line_speed(current())}</span>
            <select
                data-testid="baud-select"
                aria-label=ctx.tr(CommissionText::LineSpeed)
                on:change=move |ev| {
                    if let Ok(baud) = event_target_value(&ev).parse() {
                        chosen.set(baud);
                    }
                }
            >
                {options}
            </select>
            <button
                data-testid="baud-change"
                disabled=move || {
                    step.get() == BaudStep::Waiting || current() == Some(chosen.get())
                }
                on:click=move |_| step.set(BaudStep::Explain)
            >
                {ctx.tr(CommissionText::ChangeLineSpeed)}
            </button>
        </div>
        {stage}
    }
}
