//! The Preview page: the show files on one side (local, and the controller's when
//! logged in), the chosen one playing on the other ([`crate::preview::PreviewPage`],
//! given the file's name and the bridge's status for its live mode).
//!
//! Once a show is chosen the file lists fold away on a phone, so the picture is
//! above the fold; "Choose another show" opens them again. Wide screens keep them
//! beside the picture.
//!
//! While the matrix is live the live picture takes over (the balls at their live
//! positions, [`crate::preview::live_picture`]: its code is in the Live card's chunk,
//! [`crate::lazy::live_preview`]); the chosen show stays chosen, hidden as it was, a
//! tap away, and is shown again when live mode ends.

use std::sync::Arc;

use leptos::prelude::*;

use crate::components::widgets::RowButton;
use crate::context::{Ctx, PreviewItem};
use crate::i18n::Text;
use crate::lazy::LazyPage;
use crate::preview::PreviewPage;

/// The Preview page.
#[component]
pub fn PreviewScreen() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    // Whether the operator asked for the lists again after choosing a show.
    let picking = RwSignal::new(false);
    let collapsed = move || !picking.get() && ctx.preview.with(Option::is_some);
    // The same show (its `Arc`) is no change: shows are compared by identity, never
    // row by row.
    let show = Memo::new_with_compare(
        move |_| {
            ctx.preview.with(|item| match item {
                Some(PreviewItem::Ready(_, show)) => Some(Arc::clone(show)),
                _ => None,
            })
        },
        crate::preview::show_changed,
    );
    let live = Memo::new(move |_| {
        ctx.status
            .with(|status| status.as_ref().is_some_and(|status| status.live.is_some()))
    });
    let current = move || {
        ctx.preview.with(|item| match item {
            Some(
                PreviewItem::Loading(name)
                | PreviewItem::Ready(name, _)
                | PreviewItem::Failed(name, _),
            ) => Some(name.clone()),
            None => None,
        })
    };
    let local = move || {
        ctx.local_files.with(|list| {
            list.items()
                .iter()
                .map(|file| {
                    let name = file.name.clone();
                    let active = current().as_deref() == Some(name.as_str());
                    let pick = Callback::new(move |()| {
                        let file = ctx.local_files.with_untracked(|list| list.get(&name).cloned());
                        if let Some(file) = file {
                            picking.set(false);
                            ctx.preview_local(&file);
                        }
                    });
                    view! {
                        <RowButton name=file.name.clone() test_id="preview-pick-local" selected=active on_click=pick />
                    }
                })
                .collect_view()
        })
    };
    let controller = move || {
        let online = ctx.logged_in() && ctx.connected();
        ctx.controller_files.with(|list| {
            list.items()
                .iter()
                .map(|summary| {
                    let name = summary.name.clone();
                    let active = current().as_deref() == Some(name.as_str());
                    let pick = Callback::new(move |()| {
                        picking.set(false);
                        ctx.preview_controller(&name);
                    });
                    view! {
                        <RowButton
                            name=summary.name.clone()
                            test_id="preview-pick-controller"
                            selected=active
                            disabled=!online
                            on_click=pick
                        />
                    }
                })
                .collect_view()
        })
    };
    view! {
        <section class="preview-screen">
            <aside class="chooser" class:collapsed=collapsed data-testid="preview-chooser">
                <button class="reopen" data-testid="preview-choose-another" on:click=move |_| picking.set(true)>
                    {ctx.tr(Text::ChooseAnotherShow)}
                </button>
                <div class="pick">
                    <h2>{ctx.tr(Text::ChooseShow)}</h2>
                    <h3>{ctx.tr(Text::LocalFiles)}</h3>
                    <ul class="list">{local}</ul>
                    <Show when=move || ctx.logged_in()>
                        <h3>{ctx.tr(Text::ControllerFiles)}</h3>
                        <ul class="list">{controller}</ul>
                    </Show>
                </div>
            </aside>
            <div class="viewer">
                {move || live.get().then(|| view! { <LazyPage load=crate::lazy::load_live_preview /> }.into_any())}
                // Hidden, not dropped, under the live picture: the show stays as it was
                // (and its view is never rebuilt, which keeps the first load small).
                <div style:display=move || {
                    if live.get() && !ctx.preview_show_while_live.get() { "none" } else { "block" }
                }>
                {move || match ctx.preview.get() {
                    Some(PreviewItem::Loading(name)) => Some(view! {
                        <h2>{name}</h2>
                        <p class="muted" data-testid="preview-loading">{ctx.tr(Text::Loading)}</p>
                    }.into_any()),
                    Some(PreviewItem::Failed(name, error)) => Some(view! {
                        <h2>{name}</h2>
                        <p class="note error" data-testid="preview-error">
                            {ctx.tr(Text::CannotRead)} " " {error}
                        </p>
                    }.into_any()),
                    Some(PreviewItem::Ready(name, _)) => Some(view! { <h2 data-testid="preview-name">{name}</h2> }.into_any()),
                    None => None,
                }}
                <PreviewPage
                    show=show
                    lang=ctx.lang
                    name=Signal::derive(current)
                    status=ctx.status
                    installation=Signal::derive(move || ctx.installation_now())
                    from_ms=Signal::derive(move || ctx.preview_from_ms.get())
                />
                </div>
            </div>
        </section>
    }
}
