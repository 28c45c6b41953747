//! The Files page: local files (in the browser) and controller files, with Upload,
//! Download, Preview, Save to device and Delete (`docs/uim2503.md` §4); on installations of
//! MOONS' drives, each ball's Q program ([`super::qprogram`]).

use std::rc::Rc;

use floatball_shared::api::ShowSummary;
use floatball_shared::show::ShowFormat;
use leptos::prelude::*;
use leptos::task::spawn_local;
use wasm_bindgen::JsCast;
use wasm_bindgen_futures::JsFuture;

use crate::client::{Client, Failure, OnProgress, UploadProgress};
use crate::components::qprogram::has_scl_drives;
use crate::components::widgets::{
    ActionButton, ConfirmButton, EmptyItem, ProblemList, RowButton, TabButton,
};
use crate::context::Ctx;
use crate::files::{LocalFile, clip_message, format_bytes, format_duration_ms};
use crate::i18n::Text;
use crate::page::Page;

/// Which list the page shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Tab {
    Local,
    Controller,
}

/// A message under the lists (and under the Create page's actions): what happened,
/// and the problems the bridge listed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Message {
    pub(crate) error: bool,
    pub(crate) text: String,
    pub(crate) details: Vec<String>,
}

impl Message {
    pub(crate) fn done(text: impl Into<String>) -> Self {
        Self {
            error: false,
            text: text.into(),
            details: Vec::new(),
        }
    }

    pub(crate) fn error(text: impl Into<String>) -> Self {
        Self {
            error: true,
            text: text.into(),
            details: Vec::new(),
        }
    }
}

/// The Files page.
#[component]
pub fn FilesPage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let tab = RwSignal::new(Tab::Local);
    let message = RwSignal::new(None::<Message>);
    let tab_button = move |which: Tab, text: Text, test_id: &'static str| {
        view! {
            <TabButton
                text
                test_id
                active=Signal::derive(move || tab.get() == which)
                on_click=Callback::new(move |()| {
                    tab.set(which);
                    message.set(None);
                })
            />
        }
    };
    let online = move || ctx.connected() && ctx.logged_in();
    view! {
        <section class="files">
            <div class="subtabs">
                {tab_button(Tab::Local, Text::LocalFiles, "tab-local")}
                {tab_button(Tab::Controller, Text::ControllerFiles, "tab-controller")}
            </div>
            <Show when=move || !online()>
                <div class="note muted offline-hint" data-testid="offline-hint">
                    <p>{ctx.tr(Text::OfflineHint)}</p>
                    <Show when=move || !ctx.logged_in()>
                        <button
                            class="primary"
                            data-testid="files-login"
                            on:click=move |_| ctx.page.set(Page::Login)
                        >
                            {ctx.tr(Text::LoginButton)}
                        </button>
                    </Show>
                </div>
            </Show>
            {move || match tab.get() {
                Tab::Local => view! { <LocalTab message=message /> }.into_any(),
                Tab::Controller => view! { <ControllerTab message=message /> }.into_any(),
            }}
            {move || message.get().map(message_view)}
        </section>
    }
}

fn message_view(message: Message) -> impl IntoView {
    let class = if message.error {
        "note error"
    } else {
        "note done"
    };
    view! {
        <div class=class data-testid="files-message" role="status">
            <p>{clip_message(&message.text)}</p>
            {(!message.details.is_empty())
                .then(|| view! { <ProblemList problems=message.details test_id="upload-details" /> })}
        </div>
    }
}

#[component]
fn LocalTab(message: RwSignal<Option<Message>>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let progress = RwSignal::new(None::<f64>);
    let confirm_delete = RwSignal::new(false);
    let selected = move || ctx.local_files.with(|list| list.selected().cloned());
    let online = move || ctx.connected() && ctx.logged_in();

    let on_pick = move |event: leptos::ev::Event| {
        let Some(input) = event
            .target()
            .and_then(|target| target.dyn_into::<web_sys::HtmlInputElement>().ok())
        else {
            return;
        };
        let files: Vec<web_sys::File> = input
            .files()
            .map(|list| (0..list.length()).filter_map(|i| list.get(i)).collect())
            .unwrap_or_default();
        // So that picking the same file again is a change too.
        input.set_value("");
        spawn_local(add_files(ctx, files, message));
    };
    let upload = Callback::new(move |()| {
        let (Some(file), Some(client)) = (selected(), ctx.client()) else {
            return;
        };
        message.set(None);
        progress.set(Some(0.0));
        let on_progress: OnProgress =
            Rc::new(move |p: UploadProgress| progress.set(Some(p.fraction())));
        spawn_local(async move {
            let outcome = upload_show(
                ctx,
                &client,
                file.show_name(),
                file.kind,
                file.text.clone(),
                on_progress,
            )
            .await;
            progress.set(None);
            message.set(Some(outcome));
        });
    });
    let preview = Callback::new(move |()| {
        if let Some(file) = selected() {
            ctx.preview_local(&file);
        }
    });
    let save = Callback::new(move |()| {
        if let Some(file) = selected()
            && let Err(error) = save_to_device(&file)
        {
            message.set(Some(Message::error(error)));
        }
    });
    let delete = Callback::new(move |()| {
        let Some(file) = selected() else { return };
        let store = ctx.store();
        spawn_local(async move {
            match store.delete(&file.name).await {
                Ok(()) => {
                    ctx.local_files.update(|list| {
                        list.remove(&file.name);
                    });
                    let lang = ctx.lang.get_untracked();
                    ctx.notify(format!("{}: {}", lang.t(Text::Deleted), file.name));
                }
                Err(error) => message.set(Some(Message::error(format!(
                    "{}: {error}",
                    ctx.lang.get_untracked().t(Text::StorageFailed)
                )))),
            }
        });
    });
    let nothing = move || ctx.local_files.with(|list| list.selected_name().is_none());
    view! {
        <div class="toolbar">
            <label class="button" data-testid="add-files">
                {ctx.tr(Text::AddFiles)}
                <input
                    type="file"
                    class="hidden"
                    accept=".csv,.json,text/csv,application/json"
                    multiple
                    data-testid="file-picker"
                    on:change=on_pick
                />
            </label>
            <ActionButton
                text=Text::Upload
                test_id="upload"
                disabled=Signal::derive(move || nothing() || !online() || progress.get().is_some())
                on_click=upload
            />
            <ActionButton
                text=Text::Preview
                test_id="preview-local"
                disabled=Signal::derive(nothing)
                on_click=preview
            />
            <ActionButton
                text=Text::SaveToDevice
                test_id="save-local"
                disabled=Signal::derive(nothing)
                on_click=save
            />
            <ConfirmButton
                test_id="delete-local"
                armed=confirm_delete
                disabled=Signal::derive(nothing)
                on_confirm=delete
            />
        </div>
        {move || {
            progress
                .get()
                .map(|fraction| {
                    let percent = (fraction * 100.0).round() as u32;
                    view! {
                        <div class="progress-row">
                            <progress
                                data-testid="upload-progress"
                                max="1"
                                prop:value=fraction
                                attr:data-value=format!("{fraction:.2}")
                            ></progress>
                            <span data-testid="upload-percent">
                                {move || ctx.lang.get().uploading(percent)}
                            </span>
                        </div>
                    }
                })
        }}
        <ul class="list" data-testid="local-list">
            {move || {
                let list = ctx.local_files.get();
                if list.items().is_empty() {
                    return view! { <EmptyItem text=Text::NoLocalFiles /> }.into_any();
                }
                let selected = list.selected_name().map(str::to_owned);
                list.items()
                    .iter()
                    .map(|file| {
                        let name = file.name.clone();
                        let is_selected = selected.as_deref() == Some(name.as_str());
                        let facts = format!("{} · {}", file.kind.label(), format_bytes(file.bytes()));
                        let pick = Callback::new(move |()| {
                            confirm_delete.set(false);
                            ctx.local_files.update(|list| list.select(&name));
                        });
                        view! {
                            <RowButton
                                name=file.name.clone()
                                test_id="local-file"
                                selected=is_selected
                                facts
                                on_click=pick
                            />
                        }
                    })
                    .collect_view()
                    .into_any()
            }}
        </ul>
    }
}

/// Sends a show's file to the controller as `name`. Once stored it joins the
/// controller's list and a toast says so; the message to show either way (a refusal
/// with every problem the bridge listed).
pub(crate) async fn upload_show(
    ctx: Ctx,
    client: &Client,
    name: &str,
    kind: ShowFormat,
    text: String,
    on_progress: OnProgress,
) -> Message {
    let lang = ctx.lang.get_untracked();
    match client.upload(name, kind, text, on_progress).await {
        Ok(summary) => {
            let text = format!("{}: {}", lang.t(Text::Uploaded), summary.name);
            ctx.controller_files.update(|list| list.upsert(summary));
            ctx.notify(text.clone());
            Message::done(text)
        }
        Err(Failure::Rejected(error)) => Message {
            error: true,
            text: format!("{} {}", lang.t(Text::UploadRefused), lang.api_error(&error)),
            details: lang.problems(&error),
        },
        Err(failure) => Message::error(ctx.failed(&failure)),
    }
}

/// Reads picked files and keeps the show files (CSV and JSON). Others are refused
/// by name, with what is supported, before they are read; a pick that adds nothing
/// leaves nothing selected, so Upload cannot act on a file picked earlier.
async fn add_files(ctx: Ctx, files: Vec<web_sys::File>, message: RwSignal<Option<Message>>) {
    let lang = ctx.lang.get_untracked();
    let store = ctx.store();
    let mut refused = Vec::new();
    let mut storage_failed = false;
    let mut added = false;
    for picked in files {
        let name = picked.name();
        if ShowFormat::from_file_name(&name).is_none() {
            refused.push(lang.unsupported_file(&name));
            continue;
        }
        let text = match JsFuture::from(picked.text()).await {
            Ok(text) => text.as_string().unwrap_or_default(),
            Err(error) => {
                refused.push(format!("{name}: {}", crate::http::describe_js_error(error)));
                continue;
            }
        };
        let Some(file) = LocalFile::new(&name, text, js_sys::Date::now()) else {
            refused.push(lang.unsupported_file(&name));
            continue;
        };
        match store.put(&file).await {
            Ok(()) => {
                ctx.local_files.update(|list| list.upsert(file));
                added = true;
            }
            Err(error) => {
                storage_failed = true;
                refused.push(format!("{name}: {error}"));
            }
        }
    }
    if !added && !refused.is_empty() {
        ctx.local_files.update(|list| list.clear_selection());
    }
    let heading = if storage_failed {
        Text::StorageFailed
    } else {
        Text::FilesNotAdded
    };
    message.set((!refused.is_empty()).then(|| Message {
        error: true,
        text: lang.t(heading).into(),
        details: refused,
    }));
}

/// Offers `file` to the device as a download.
fn save_to_device(file: &LocalFile) -> Result<(), String> {
    save_text(&file.name, &file.text, file.kind.content_type())
}

/// Offers `text` to the device as a download named `name`.
///
/// # Errors
/// The browser's reason, when it cannot make the file.
pub fn save_text(name: &str, text: &str, content_type: &str) -> Result<(), String> {
    let parts = js_sys::Array::of1(&text.into());
    let options = web_sys::BlobPropertyBag::new();
    options.set_type(content_type);
    let blob = web_sys::Blob::new_with_str_sequence_and_options(&parts, &options)
        .map_err(crate::http::describe_js_error)?;
    let url =
        web_sys::Url::create_object_url_with_blob(&blob).map_err(crate::http::describe_js_error)?;
    let anchor: web_sys::HtmlAnchorElement = document()
        .create_element("a")
        .map_err(crate::http::describe_js_error)?
        .unchecked_into();
    anchor.set_href(&url);
    anchor.set_download(name);
    anchor.click();
    // Cannot fail for a URL made just above.
    let _ = web_sys::Url::revoke_object_url(&url);
    Ok(())
}

#[component]
fn ControllerTab(message: RwSignal<Option<Message>>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let confirm_delete = RwSignal::new(false);
    let busy = RwSignal::new(false);
    let selected = move || {
        ctx.controller_files
            .with(|list| list.selected_name().map(str::to_owned))
    };
    let online = move || ctx.connected() && ctx.logged_in();
    let download = Callback::new(move |()| {
        let (Some(name), Some(client)) = (selected(), ctx.client()) else {
            return;
        };
        busy.set(true);
        message.set(None);
        let store = ctx.store();
        spawn_local(async move {
            let lang = ctx.lang.get_untracked();
            let outcome = match client.download(&name).await {
                Ok(json) => {
                    let file = LocalFile::downloaded(&name, json, js_sys::Date::now());
                    match store.put(&file).await {
                        Ok(()) => {
                            let text = format!("{}: {}", lang.t(Text::Downloaded), file.name);
                            ctx.local_files.update(|list| list.upsert(file));
                            Message::done(text)
                        }
                        Err(error) => {
                            Message::error(format!("{}: {error}", lang.t(Text::StorageFailed)))
                        }
                    }
                }
                Err(failure) => Message::error(ctx.failed(&failure)),
            };
            message.set(Some(outcome));
            busy.set(false);
        });
    });
    let preview = Callback::new(move |()| {
        if let Some(name) = selected() {
            ctx.preview_controller(&name);
        }
    });
    let delete = Callback::new(move |()| {
        let (Some(name), Some(client)) = (selected(), ctx.client()) else {
            return;
        };
        spawn_local(async move {
            match client.delete_show(&name).await {
                Ok(()) => {
                    ctx.controller_files.update(|list| {
                        list.remove(&name);
                    });
                    let lang = ctx.lang.get_untracked();
                    ctx.notify(format!("{}: {name}", lang.t(Text::Deleted)));
                }
                Err(failure) => message.set(Some(Message::error(ctx.failed(&failure)))),
            }
        });
    });
    let unusable = move || selected().is_none() || !online() || busy.get();
    view! {
        <div class="toolbar">
            <ActionButton
                text=Text::Refresh
                test_id="refresh"
                disabled=Signal::derive(move || !online())
                on_click=Callback::new(move |()| ctx.refresh())
            />
            <ActionButton
                text=Text::Download
                test_id="download"
                disabled=Signal::derive(unusable)
                on_click=download
            />
            <ActionButton
                text=Text::Preview
                test_id="preview-controller"
                disabled=Signal::derive(unusable)
                on_click=preview
            />
            <ConfirmButton
                test_id="delete-controller"
                armed=confirm_delete
                disabled=Signal::derive(unusable)
                on_confirm=delete
            />
        </div>
        <Show when=move || ctx.library_indexing.get()>
            <p class="muted" data-testid="library-indexing">{ctx.tr(Text::LibraryIndexing)}</p>
        </Show>
        <table class="list table" data-testid="controller-list">
            <thead>
                <tr>
                    <th>{ctx.tr(Text::Name)}</th>
                    <th class="num">{ctx.tr(Text::Units)}</th>
                    <th class="num">{ctx.tr(Text::Duration)}</th>
                    <th class="num">{ctx.tr(Text::Size)}</th>
                </tr>
            </thead>
            <tbody>
                {move || {
                    let list = ctx.controller_files.get();
                    if list.items().is_empty() {
                        return view! {
                            <tr>
                                <td colspan="4" class="empty muted">
                                    {ctx.tr(Text::NoControllerFiles)}
                                </td>
                            </tr>
                        }
                            .into_any();
                    }
                    let selected = list.selected_name().map(str::to_owned);
                    list.items()
                        .iter()
                        .map(|show| controller_row(ctx, show, &selected, confirm_delete))
                        .collect_view()
                        .into_any()
                }}
            </tbody>
        </table>
        <Show when=move || has_scl_drives(ctx)>
            {crate::lazy::chunk_view(
                ctx.lang.into(),
                Text::PartFailed,
                crate::lazy::qprogram_panel,
                move |panel: crate::lazy::QProgramView| panel(Signal::derive(selected)),
            )}
        </Show>
    }
}

fn controller_row(
    ctx: Ctx,
    show: &ShowSummary,
    selected: &Option<String>,
    confirm_delete: RwSignal<bool>,
) -> impl IntoView {
    let name = show.name.clone();
    let is_selected = selected.as_deref() == Some(name.as_str());
    view! {
        <tr
            class="row"
            class:selected=is_selected
            data-testid="controller-file"
            data-name=name.clone()
            on:click=move |_| {
                confirm_delete.set(false);
                ctx.controller_files.update(|list| list.select(&name));
            }
        >
            <td class="name">{show.name.clone()}</td>
            <td class="num">{show.units}</td>
            <td class="num">{format_duration_ms(show.duration_ms)}</td>
            <td class="num">{format_bytes(show.bytes)}</td>
        </tr>
    }
}
