//! The Files page: local files (in the browser) and controller files, with Upload,
//! Download, Preview, Save to device and Delete (PROTOCOL §1.7).

use std::rc::Rc;

use floatball_shared::api::ShowSummary;
use leptos::prelude::*;
use leptos::task::spawn_local;
use wasm_bindgen::JsCast;
use wasm_bindgen_futures::JsFuture;

use crate::client::{Failure, OnProgress, UploadProgress};
use crate::context::Ctx;
use crate::files::{LocalFile, format_bytes, format_duration_ms};
use crate::i18n::Text;

/// Which list the page shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Tab {
    Local,
    Controller,
}

/// A message under the lists: what happened, and the problems the bridge listed.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Message {
    error: bool,
    text: String,
    details: Vec<String>,
}

impl Message {
    fn done(text: impl Into<String>) -> Self {
        Self {
            error: false,
            text: text.into(),
            details: Vec::new(),
        }
    }

    fn error(text: impl Into<String>) -> Self {
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
            <button
                class="tab"
                class:active=move || tab.get() == which
                data-testid=test_id
                on:click=move |_| {
                    tab.set(which);
                    message.set(None);
                }
            >
                {move || ctx.t(text)}
            </button>
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
                <p class="note muted" data-testid="offline-hint">
                    {move || ctx.t(Text::OfflineHint)}
                </p>
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
            <p>{message.text}</p>
            {(!message.details.is_empty())
                .then(|| {
                    view! {
                        <ul data-testid="upload-details">
                            {message
                                .details
                                .into_iter()
                                .map(|detail| view! { <li>{detail}</li> })
                                .collect_view()}
                        </ul>
                    }
                })}
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
    let upload = move |_| {
        let (Some(file), Some(client)) = (selected(), ctx.client()) else {
            return;
        };
        message.set(None);
        progress.set(Some(0.0));
        let on_progress: OnProgress =
            Rc::new(move |p: UploadProgress| progress.set(Some(p.fraction())));
        spawn_local(async move {
            let lang = ctx.lang.get_untracked();
            let result = client
                .upload(file.show_name(), file.kind, file.text.clone(), on_progress)
                .await;
            progress.set(None);
            message.set(Some(match result {
                Ok(summary) => {
                    let text = format!("{}: {}", lang.t(Text::Uploaded), summary.name);
                    ctx.controller_files.update(|list| list.upsert(summary));
                    Message::done(text)
                }
                Err(Failure::Rejected(error)) => Message {
                    error: true,
                    text: format!("{} {}", lang.t(Text::UploadRefused), error.error),
                    details: error.details,
                },
                Err(failure) => Message::error(ctx.failed(&failure)),
            }));
        });
    };
    let preview = move |_| {
        if let Some(file) = selected() {
            ctx.preview_local(&file);
        }
    };
    let save = move |_| {
        if let Some(file) = selected()
            && let Err(error) = save_to_device(&file)
        {
            message.set(Some(Message::error(error)));
        }
    };
    let delete = move |_| {
        let Some(file) = selected() else { return };
        if !confirm_delete.get_untracked() {
            confirm_delete.set(true);
            return;
        }
        confirm_delete.set(false);
        let store = ctx.store();
        spawn_local(async move {
            match store.delete(&file.name).await {
                Ok(()) => ctx.local_files.update(|list| {
                    list.remove(&file.name);
                }),
                Err(error) => message.set(Some(Message::error(format!(
                    "{}: {error}",
                    ctx.lang.get_untracked().t(Text::StorageFailed)
                )))),
            }
        });
    };
    let nothing = move || ctx.local_files.with(|list| list.selected_name().is_none());
    view! {
        <div class="toolbar">
            <label class="button" data-testid="add-files">
                {move || ctx.t(Text::AddFiles)}
                <input
                    type="file"
                    class="hidden"
                    accept=".csv,.json,text/csv,application/json"
                    multiple
                    data-testid="file-picker"
                    on:change=on_pick
                />
            </label>
            <button
                data-testid="upload"
                disabled=move || nothing() || !online() || progress.get().is_some()
                on:click=upload
            >
                {move || ctx.t(Text::Upload)}
            </button>
            <button data-testid="preview-local" disabled=nothing on:click=preview>
                {move || ctx.t(Text::Preview)}
            </button>
            <button data-testid="save-local" disabled=nothing on:click=save>
                {move || ctx.t(Text::SaveToDevice)}
            </button>
            <button
                data-testid="delete-local"
                class:danger=confirm_delete
                disabled=nothing
                on:click=delete
            >
                {move || ctx.t(if confirm_delete.get() { Text::ConfirmDelete } else { Text::Delete })}
            </button>
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
                    return view! {
                        <li class="empty muted">{move || ctx.t(Text::NoLocalFiles)}</li>
                    }
                        .into_any();
                }
                let selected = list.selected_name().map(str::to_owned);
                list.items()
                    .iter()
                    .map(|file| {
                        let name = file.name.clone();
                        let is_selected = selected.as_deref() == Some(name.as_str());
                        let facts = format!("{} · {}", file.kind.label(), format_bytes(file.bytes()));
                        view! {
                            <li>
                                <button
                                    class="row"
                                    class:selected=is_selected
                                    data-testid="local-file"
                                    data-name=name.clone()
                                    on:click=move |_| {
                                        confirm_delete.set(false);
                                        ctx.local_files.update(|list| list.select(&name));
                                    }
                                >
                                    <span class="name">{file.name.clone()}</span>
                                    <span class="facts muted">{facts}</span>
                                </button>
                            </li>
                        }
                    })
                    .collect_view()
                    .into_any()
            }}
        </ul>
    }
}

/// Reads picked files and keeps the CSV and JSON ones.
async fn add_files(ctx: Ctx, files: Vec<web_sys::File>, message: RwSignal<Option<Message>>) {
    let lang = ctx.lang.get_untracked();
    let store = ctx.store();
    let mut problems = Vec::new();
    for picked in files {
        let name = picked.name();
        let text = match JsFuture::from(picked.text()).await {
            Ok(text) => text.as_string().unwrap_or_default(),
            Err(error) => {
                problems.push(format!("{name}: {error:?}"));
                continue;
            }
        };
        let Some(file) = LocalFile::new(&name, text, js_sys::Date::now()) else {
            problems.push(format!("{name} {}", lang.t(Text::NotAShowFile)));
            continue;
        };
        match store.put(&file).await {
            Ok(()) => ctx.local_files.update(|list| list.upsert(file)),
            Err(error) => problems.push(format!("{name}: {error}")),
        }
    }
    message.set((!problems.is_empty()).then(|| Message {
        error: true,
        text: lang.t(Text::StorageFailed).into(),
        details: problems,
    }));
}

/// Offers `file` to the device as a download.
fn save_to_device(file: &LocalFile) -> Result<(), String> {
    let parts = js_sys::Array::of1(&file.text.as_str().into());
    let options = web_sys::BlobPropertyBag::new();
    options.set_type(file.kind.content_type());
    let blob = web_sys::Blob::new_with_str_sequence_and_options(&parts, &options)
        .map_err(crate::http::describe_js_error)?;
    let url =
        web_sys::Url::create_object_url_with_blob(&blob).map_err(crate::http::describe_js_error)?;
    let anchor: web_sys::HtmlAnchorElement = document()
        .create_element("a")
        .map_err(crate::http::describe_js_error)?
        .unchecked_into();
    anchor.set_href(&url);
    anchor.set_download(&file.name);
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
    let download = move |_| {
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
    };
    let preview = move |_| {
        if let Some(name) = selected() {
            ctx.preview_controller(&name);
        }
    };
    let delete = move |_| {
        let (Some(name), Some(client)) = (selected(), ctx.client()) else {
            return;
        };
        if !confirm_delete.get_untracked() {
            confirm_delete.set(true);
            return;
        }
        confirm_delete.set(false);
        spawn_local(async move {
            match client.delete_show(&name).await {
                Ok(()) => ctx.controller_files.update(|list| {
                    list.remove(&name);
                }),
                Err(failure) => message.set(Some(Message::error(ctx.failed(&failure)))),
            }
        });
    };
    let unusable = move || selected().is_none() || !online() || busy.get();
    view! {
        <div class="toolbar">
            <button data-testid="refresh" disabled=move || !online() on:click=move |_| ctx.refresh()>
                {move || ctx.t(Text::Refresh)}
            </button>
            <button data-testid="download" disabled=unusable on:click=download>
                {move || ctx.t(Text::Download)}
            </button>
            <button data-testid="preview-controller" disabled=unusable on:click=preview>
                {move || ctx.t(Text::Preview)}
            </button>
            <button
                data-testid="delete-controller"
                class:danger=confirm_delete
                disabled=unusable
                on:click=delete
            >
                {move || ctx.t(if confirm_delete.get() { Text::ConfirmDelete } else { Text::Delete })}
            </button>
        </div>
        <table class="list table" data-testid="controller-list">
            <thead>
                <tr>
                    <th>{move || ctx.t(Text::Name)}</th>
                    <th class="num">{move || ctx.t(Text::Units)}</th>
                    <th class="num">{move || ctx.t(Text::Duration)}</th>
                    <th class="num">{move || ctx.t(Text::Size)}</th>
                </tr>
            </thead>
            <tbody>
                {move || {
                    let list = ctx.controller_files.get();
                    if list.items().is_empty() {
                        return view! {
                            <tr>
                                <td colspan="4" class="empty muted">
                                    {move || ctx.t(Text::NoControllerFiles)}
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
