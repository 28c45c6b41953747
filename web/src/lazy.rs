//! The pages an operator on the show floor never opens, loaded when opened: Create
//! (its patterns, text and picture decoders, the recipe model and the planner the
//! worker runs), Commissioning and Installation.
//!
//! Each is a split point of `wasm_split_helpers` (the runtime under Leptos'
//! `#[lazy]`, re-exported as [`leptos::wasm_split`]): built with `--cfg
//! floatball_split` (as `cargo xtask build` does, see `xtask/src/app.rs`), the linker
//! keeps its relocations and `wasm_split_cli_support` moves what only the split point
//! reaches into its own wasm chunk, fetched the first time the point is called.
//! Leptos' own `#[lazy]` is not used: it panics when a chunk fails to load (a panic
//! aborts the whole app, the E-STOP with it); the `fallible` option used here gives
//! [`ChunkError`] instead, which [`LazyPage`] shows with a Retry (a failed load is
//! not cached, so Retry fetches again). Without the cfg (the browser tests, clippy)
//! every point is a plain `async fn` in the one module.
//!
//! What the first load must carry — the top bar, the E-STOP, the WebSocket, Login,
//! Files, Preview, Control, Settings and Console — is never behind a split point.

use std::future::Future;
use std::pin::Pin;

use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::i18n::Text;

/// A chunk could not be loaded (offline, or a stale cache after an update): the
/// browser's console says why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChunkError;

impl From<leptos::wasm_split::SplitLoaderError> for ChunkError {
    fn from(_: leptos::wasm_split::SplitLoaderError) -> Self {
        ChunkError
    }
}

/// A page's view, made by code in its chunk.
pub type PageView = fn() -> AnyView;

/// Loads a page's chunk (at once when it is loaded already) and gives the function
/// that makes its view.
pub type Loader = fn() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>>;

/// A split point: `$module` names the chunk. The body runs in the chunk once it is
/// loaded; the function is `async` and fails with [`ChunkError`] when the chunk
/// cannot be loaded.
macro_rules! split {
    ($module:ident, $(#[$attr:meta])* pub fn $name:ident($($arg:ident: $ty:ty),*) -> $ret:ty $body:block) => {
        #[cfg(floatball_split)]
        #[leptos::wasm_split::wasm_split(
            $module,
            fallible,
            wasm_split_path = ::leptos::wasm_split
        )]
        $(#[$attr])*
        pub fn $name($($arg: $ty),*) -> Result<$ret, ChunkError> {
            Ok($body)
        }

        #[cfg(not(floatball_split))]
        $(#[$attr])*
        #[allow(clippy::unused_async)]
        pub async fn $name($($arg: $ty),*) -> Result<$ret, ChunkError> {
            Ok($body)
        }
    };
}

split!(
    create,
    /// The Create page.
    pub fn create_page() -> PageView {
        || view! { <crate::components::create::CreatePage /> }.into_any()
    }
);

split!(
    create,
    /// The planner's verdict on a recipe for an installation, in the Create chunk
    /// (the plan worker's entry, [`crate::plan_recipe`]).
    pub fn plan_recipe(recipe_json: String, installation_json: String) -> Result<String, String> {
        crate::create::plan_recipe(&recipe_json, &installation_json)
    }
);

split!(
    commission,
    /// The Commissioning page.
    pub fn commission_page() -> PageView {
        || view! { <crate::components::commission::CommissionPage /> }.into_any()
    }
);

split!(
    installation,
    /// The Installation page.
    pub fn installation_page() -> PageView {
        || view! { <crate::components::installation::InstallationPage /> }.into_any()
    }
);

/// [`create_page`] as a [`Loader`].
pub fn load_create() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(create_page())
}

/// [`commission_page`] as a [`Loader`].
pub fn load_commission() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(commission_page())
}

/// [`installation_page`] as a [`Loader`].
pub fn load_installation() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(installation_page())
}

/// Where a page's chunk is.
#[derive(Debug, Clone, Copy)]
enum Chunk {
    Loading,
    Failed,
    Ready(PageView),
}

/// A page whose code is in a chunk: "Loading…" while it is fetched, then the page;
/// when the chunk cannot be loaded, an error and a Retry. The rest of the app — the
/// top bar, the E-STOP — is never held.
#[component]
pub fn LazyPage(load: Loader) -> impl IntoView {
    let ctx = expect_context::<crate::context::Ctx>();
    let chunk = RwSignal::new(Chunk::Loading);
    let start = move || {
        chunk.set(Chunk::Loading);
        spawn_local(async move {
            let loaded = load().await;
            // The page may have been left meanwhile (its signal then is gone).
            let _ = chunk.try_set(match loaded {
                Ok(page) => Chunk::Ready(page),
                Err(ChunkError) => Chunk::Failed,
            });
        });
    };
    start();
    move || match chunk.get() {
        Chunk::Loading => view! {
            <p class="chunk-loading" data-testid="chunk-loading" aria-busy="true">
                {ctx.tr(Text::Loading)}
            </p>
        }
        .into_any(),
        Chunk::Failed => view! {
            <div class="note error" data-testid="chunk-error" role="alert">
                <p>{ctx.tr(Text::ChunkFailed)}</p>
                <button data-testid="chunk-retry" on:click=move |_| start()>
                    {ctx.tr(Text::Retry)}
                </button>
            </div>
        }
        .into_any(),
        Chunk::Ready(page) => page(),
    }
}
