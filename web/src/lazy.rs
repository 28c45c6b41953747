//! What the first load can do without, loaded when first needed. Pages an operator
//! on the show floor never opens: Create (its patterns, text and picture decoders,
//! the recipe model and the planner the worker runs), Commissioning, Installation,
//! Settings, Schedule and Patch. And parts of the first-load pages needed only now
//! and then, each fetched the first time it is asked for.
//!
//! Each is a split point of `wasm_split_helpers` (the runtime under Leptos'
//! `#[lazy]`, re-exported as [`leptos::wasm_split`]): built with `--cfg
//! floatball_split` (as `cargo xtask build` does, see `xtask/src/app.rs`), the linker
//! keeps its relocations and `wasm_split_cli_support` moves what only the split point
//! reaches (code and the data only that code uses, such as its words) into its own
//! wasm chunk, fetched the first time the point is called. Leptos' own `#[lazy]` is
//! not used: it panics when a chunk fails to load (a panic aborts the whole app, the
//! E-STOP with it); the `fallible` option used here gives [`ChunkError`] instead,
//! which [`LazyPage`] and [`chunk_view`] show with a Retry (a failed load is not
//! cached, so Retry fetches again) and a Reload. Without the cfg (the browser tests,
//! clippy) every point is a plain `async fn` in the one module.
//!
//! What the first load must carry — the top bar, the E-STOP, the WebSocket, Login,
//! Files, Preview, Control and Console — is never behind a split point. Parts of
//! those pages that can come a moment later are, and why each can wait:
//! - the console's parsers ([`console_parsers`]): the Console page opens at once,
//!   and its check of a typed line waits the few milliseconds its chunk takes,
//!   fetched as the page opens;
//! - the CSV reader ([`read_csv`]): a local CSV file's preview waits for it (native
//!   show files need no chunk), and it words a CSV file's refusal itself, so the
//!   CSV problems' parameters and words are in its chunk too;
//! - the Preview's check of a show against the limits ([`show_violations`]): the
//!   show is on screen first, its problems a moment after;
//! - the Preview's plot of a tapped ball ([`plot_panel`]) and its performance panel
//!   ([`perf_panel`]): drawn when asked for;
//! - the reading of the schedule's and the timecode chase's messages
//!   ([`read_show_control`]): fetched when the bridge first sends one;
//! - Control's Live card ([`live_card`]: fetched when it is opened or the matrix is
//!   live) and, in the same chunk, the reading of live positions
//!   ([`read_live_positions`]) and the Preview's live picture ([`live_preview`]:
//!   fetched when the Preview page is open while the matrix is live);
//! - the Files page's Q program panel ([`qprogram_panel`]): only on installations
//!   with MOONS' drives;
//! - the forced change of the factory password ([`forced_password_form`]): once per
//!   installation, at its first login.

use std::future::Future;
use std::pin::Pin;

use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::context::tr_in;
use crate::i18n::{Lang, Text};

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
    ($module:ident, $(#[$attr:meta])* pub fn $name:ident($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty $body:block) => {
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

/// The console's parsers, one per drive family (UIM2503 ASCII instructions, MBOX box
/// commands, SCL lines): with their command tables and error words they are some
/// 40 KB of the app, needed only once a line is typed on the Console page.
#[derive(Debug, Clone, Copy)]
pub struct ConsoleParsers {
    /// UIM2503 gateways ([`crate::console::check`]).
    pub uim2503: fn(&str) -> crate::console::Check,
    /// MBOX boxes, commands without a box going to the selected one
    /// ([`crate::console::check_mbox`]).
    pub mbox: fn(&str, floatball_shared::mbox::Route) -> crate::console::Check,
    /// MOONS' drives ([`crate::console::check_scl`]).
    pub scl: fn(&str) -> crate::console::Check,
}

split!(
    console,
    /// The console's parsers, in their own chunk: the Console page shows at once and
    /// checks the typed lines once they arrive (see [`ConsoleParsers`]).
    pub fn console_parsers() -> ConsoleParsers {
        ConsoleParsers {
            uim2503: crate::console::check,
            mbox: crate::console::check_mbox,
            scl: crate::console::check_scl,
        }
    }
);

split!(
    csv,
    /// A local CSV file read for the preview ([`crate::files::LocalFile::to_show`]):
    /// the CSV reader (keyframes, curves, their error words) is a chunk of its own,
    /// fetched when the first CSV file is previewed. A file that does not read gives
    /// why in `lang` ([`Lang::refused`]), worded in the chunk: the parameters of the
    /// CSV reader's problems are code of the chunk too.
    pub fn read_csv(
        file: crate::files::LocalFile,
        lang: Lang,
    ) -> Result<floatball_shared::show::Show, String> {
        file.to_show().map_err(|refused| lang.refused(&refused))
    }
);

/// The Preview's performance panel ([`crate::preview::perf::PerfPanel`]), given the
/// language of its labels.
pub type PerfView = fn(Signal<Lang>) -> AnyView;

split!(
    perf,
    /// The Preview's performance panel: a device check opened now and then, with the
    /// synthetic shows it draws.
    pub fn perf_panel() -> PerfView {
        |lang| view! { <crate::preview::perf::PerfPanel lang /> }.into_any()
    }
);

/// The Preview's plot of one ball ([`crate::preview::PlotPanel`]): the ball's plot,
/// the language, the show time on screen (ms) and what closes it.
pub type PlotView =
    fn(crate::preview::plot::BallPlot, Signal<Lang>, Signal<f64>, Callback<()>) -> AnyView;

split!(
    plot,
    /// The Preview's plot of a tapped ball (its curves, figures and problems), drawn
    /// when a ball is tapped.
    pub fn plot_panel() -> PlotView {
        |plot, lang, t_ms, on_close| {
            view! { <crate::preview::PlotPanel plot lang t_ms on_close=move || on_close.run(()) /> }
                .into_any()
        }
    }
);

split!(
    check,
    /// The Preview's check of a show against the limits
    /// ([`floatball_shared::show::validate`], every row of every ball): run a moment
    /// after a show is on screen, so its code can come a moment later too.
    pub fn show_violations(
        show: std::sync::Arc<floatball_shared::show::Show>,
        limits: floatball_shared::show::Limits,
        shown: usize,
    ) -> Violations {
        let all = floatball_shared::show::validate(&show, &limits);
        let words = |lang: Lang| {
            all.iter()
                .take(shown)
                .map(|violation| lang.error_of(violation))
                .collect()
        };
        Violations {
            words_zh: words(Lang::Zh),
            words_en: words(Lang::En),
            all,
        }
    }
);

/// A show's violations of the limits ([`show_violations`]) and the first few in
/// words, in each language (their words and parameters stay in the check's chunk).
#[derive(Debug, Clone, PartialEq)]
pub struct Violations {
    /// Every violation.
    pub all: Vec<floatball_shared::show::Violation>,
    /// The first ones in 中文.
    pub words_zh: Vec<String>,
    /// The first ones in English.
    pub words_en: Vec<String>,
}

split!(
    showcontrol,
    /// A `schedule` or `timecode` message read ([`crate::wire::read_show_control`]):
    /// their readers come with this chunk, fetched when the bridge first sends one
    /// (a schedule followed, a timecode chase on). `None` when it does not read (the
    /// browser's console says why).
    pub fn read_show_control(text: String) -> Option<floatball_shared::api::ServerMessage> {
        crate::wire::read_show_control(&text)
            .map_err(|err| {
                leptos::logging::warn!(
                    "ignoring a show-control message the app does not understand: {err}"
                );
            })
            .ok()
    }
);

/// The Files page's Q program panel ([`crate::components::qprogram::QProgramPanel`]),
/// given the selected controller show.
pub type QProgramView = fn(Signal<Option<String>>) -> AnyView;

split!(
    qprogram,
    /// The Q program panel of the Files page, shown only on an installation with
    /// MOONS' drives.
    pub fn qprogram_panel() -> QProgramView {
        |selected| view! { <crate::components::qprogram::QProgramPanel selected /> }.into_any()
    }
);

/// The forced change of the factory password at login
/// ([`crate::components::password::PasswordForm`]), given the password typed at login.
pub type PasswordView = fn(RwSignal<Option<String>>) -> AnyView;

split!(
    password,
    /// The forced password change: once per installation, at its first login.
    pub fn forced_password_form() -> PasswordView {
        |remembered| {
            view! { <crate::components::password::PasswordForm forced=true remembered=remembered /> }
                .into_any()
        }
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
    settings,
    /// The Settings page (defaults for new entries, the loop, the password): opened
    /// now and then from Control, never needed on the show floor.
    pub fn settings_page() -> PageView {
        || view! { <crate::components::control::SettingsPage /> }.into_any()
    }
);

split!(
    installation,
    /// The Installation page.
    pub fn installation_page() -> PageView {
        || view! { <crate::components::installation::InstallationPage /> }.into_any()
    }
);

split!(
    schedule,
    /// The Schedule page: edited now and then, never needed on the show floor.
    pub fn schedule_page() -> PageView {
        || view! { <crate::components::schedule::SchedulePage /> }.into_any()
    }
);

/// [`schedule_page`] as a [`Loader`].
pub fn load_schedule() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(schedule_page())
}

split!(
    patch,
    /// The Patch page (live input's patch).
    pub fn patch_page() -> PageView {
        || view! { <crate::components::patch::PatchPage /> }.into_any()
    }
);

split!(
    live,
    /// The Control page's Live card (live mode and recording): fetched when the card
    /// is opened or the matrix is live.
    pub fn live_card() -> PageView {
        || view! { <crate::components::live::LiveCard /> }.into_any()
    }
);

split!(
    live,
    /// A `live_positions` message read ([`crate::wire::read_live_positions`]): its
    /// reader comes with the Live card and the Preview's live picture, the ones
    /// asking for them. `None` when it does
    /// not read (the browser's console says why).
    pub fn read_live_positions(text: String) -> Option<floatball_shared::api::ServerMessage> {
        crate::wire::read_live_positions(&text)
            .map_err(|err| {
                leptos::logging::warn!("ignoring live positions that do not read: {err}")
            })
            .ok()
    }
);

split!(
    live,
    /// The Preview page's live picture ([`crate::preview::live_picture`]): the matrix
    /// at its live positions, in the Live card's chunk (it reads the same
    /// `live_positions`), fetched when the Preview page is open while live.
    pub fn live_preview() -> PageView {
        || view! { <crate::preview::live_picture::LivePicture /> }.into_any()
    }
);

/// [`live_preview`] as a [`Loader`].
pub fn load_live_preview() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(live_preview())
}

/// [`live_card`] as a [`Loader`].
pub fn load_live() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(live_card())
}

/// [`patch_page`] as a [`Loader`].
pub fn load_patch() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(patch_page())
}

/// [`create_page`] as a [`Loader`].
pub fn load_create() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(create_page())
}

/// [`commission_page`] as a [`Loader`].
pub fn load_commission() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(commission_page())
}

/// [`settings_page`] as a [`Loader`].
pub fn load_settings() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(settings_page())
}

/// [`installation_page`] as a [`Loader`].
pub fn load_installation() -> Pin<Box<dyn Future<Output = Result<PageView, ChunkError>>>> {
    Box::pin(installation_page())
}

/// What a chunk gave, as far as it came.
#[derive(Debug, Clone, Copy)]
enum Chunk<T> {
    Loading,
    Failed,
    Ready(T),
}

/// Loads the app again, page and all: after an update the chunks' old names are
/// gone from the bridge, and only the page served now names the new ones (the page
/// is never cached, see `bridge/src/server.rs`). The page opened stays open (its
/// `#/…`), and so does the login.
pub fn reload_app() {
    if let Err(error) = window().location().reload() {
        leptos::logging::warn!("cannot reload the app: {error:?}");
    }
}

/// A view whose code is in a chunk: `load` fetches the chunk and gives what makes the
/// view, `render` makes it. "Loading…" while it is fetched; when it cannot be
/// fetched, `failed` (in `lang`), a Retry (offline: try again) and a Reload (a stale
/// copy after an update: the page names the chunks of the version now served). The
/// rest of the app — the top bar, the E-STOP — is never held.
pub fn chunk_view<T, F>(
    lang: Signal<Lang>,
    failed: Text,
    load: impl Fn() -> F + Copy + Send + Sync + 'static,
    render: impl Fn(T) -> AnyView + Send + Sync + 'static,
) -> impl IntoView
where
    T: Clone + Send + Sync + 'static,
    F: Future<Output = Result<T, ChunkError>> + 'static,
{
    let chunk = RwSignal::new(Chunk::Loading);
    let start = move || {
        chunk.set(Chunk::Loading);
        spawn_local(async move {
            let loaded = load().await;
            // The view may be gone meanwhile (its signal then is gone too).
            let _ = chunk.try_set(match loaded {
                Ok(made) => Chunk::Ready(made),
                Err(ChunkError) => Chunk::Failed,
            });
        });
    };
    start();
    move || match chunk.get() {
        Chunk::Loading => view! {
            <p class="chunk-loading" data-testid="chunk-loading" aria-busy="true">
                {tr_in(lang, Text::Loading)}
            </p>
        }
        .into_any(),
        Chunk::Failed => view! {
            <div class="note error" data-testid="chunk-error" role="alert">
                <p>{tr_in(lang, failed)}</p>
                <button data-testid="chunk-retry" on:click=move |_| start()>
                    {tr_in(lang, Text::Retry)}
                </button>
                <button data-testid="chunk-reload" on:click=move |_| reload_app()>
                    {tr_in(lang, Text::ReloadApp)}
                </button>
            </div>
        }
        .into_any(),
        Chunk::Ready(made) => render(made),
    }
}

/// A page whose code is in a chunk ([`chunk_view`]).
#[component]
pub fn LazyPage(load: Loader) -> impl IntoView {
    let ctx = expect_context::<crate::context::Ctx>();
    chunk_view(
        ctx.lang.into(),
        Text::ChunkFailed,
        load,
        |page: PageView| page(),
    )
}
