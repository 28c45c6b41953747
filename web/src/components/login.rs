//! The Login page: controller address and password; the forced change of the factory
//! password ([`super::password`]); logout.
//!
//! After too many wrong passwords the bridge names a wait (429, `Retry-After`): the
//! page counts it down every second and logs in by itself when it is over, with the
//! password still in the field.

use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::client::Failure;
use crate::components::widgets::{ErrorNote, TextField};
use crate::context::Ctx;
use crate::i18n::{Lang, Text};
use crate::page::Page;
use crate::session::Session;

/// The Login page.
#[component]
pub fn LoginPage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    // The password typed at login, kept in memory only, so that the forced change does
    // not ask for it again.
    let remembered = RwSignal::new(None::<String>);
    view! {
        <section class="login">
            <ErrorNote
                text=Signal::derive(move || ctx.login_notice.get().map(|text| ctx.t(text).to_owned()))
                test_id="login-notice"
            />
            {move || match ctx.session.get() {
                None => view! { <LoginForm remembered=remembered /> }.into_any(),
                Some(session) if session.must_change_password => {
                    crate::lazy::chunk_view(
                        ctx.lang.into(),
                        Text::PartFailed,
                        crate::lazy::forced_password_form,
                        move |form: crate::lazy::PasswordView| form(remembered),
                    )
                    .into_any()
                }
                Some(session) => view! { <LoggedIn address=session.address /> }.into_any(),
            }}
        </section>
    }
}

#[component]
fn LoginForm(remembered: RwSignal<Option<String>>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let address = RwSignal::new(ctx.origin().host);
    let password = RwSignal::new(String::new());
    let busy = RwSignal::new(false);
    let note = RwSignal::new(None::<String>);
    // Seconds left of the bridge's wait after too many wrong passwords.
    let wait_s = RwSignal::new(None::<u64>);
    let submit = move |event: leptos::ev::SubmitEvent| {
        event.prevent_default();
        if busy.get_untracked() {
            return;
        }
        busy.set(true);
        note.set(None);
        spawn_local(async move {
            // One pass a try: a wait the bridge names is counted down, then the
            // login is tried again with what the fields hold then.
            loop {
                let (Some(typed), Some(typed_address)) =
                    (password.try_get_untracked(), address.try_get_untracked())
                else {
                    return; // The page is gone.
                };
                let address = typed_address.trim().to_owned();
                let client = ctx.client_for(&address);
                let lang = ctx.lang.get_untracked();
                match client.login(&typed).await {
                    Ok(answer) => {
                        ctx.login_notice.set(None);
                        let _ = remembered.try_set(answer.must_change_password.then_some(typed));
                        ctx.session.set(Some(Session {
                            address,
                            token: answer.token,
                            must_change_password: answer.must_change_password,
                        }));
                        if !answer.must_change_password {
                            ctx.page.set(Page::Files);
                        }
                    }
                    Err(Failure::Unauthorized) => {
                        let _ = note.try_set(Some(lang.t(Text::WrongPassword).into()));
                    }
                    Err(Failure::TooManyAttempts {
                        retry_after_s: Some(wait),
                    }) if wait > 0 => {
                        if !count_down(wait_s, wait).await {
                            return;
                        }
                        let still_typed = password
                            .try_with_untracked(|typed| !typed.is_empty())
                            .unwrap_or(false);
                        if still_typed {
                            continue;
                        }
                    }
                    Err(failure) => {
                        let _ = note.try_set(Some(lang.failure(&failure)));
                    }
                }
                break;
            }
            let _ = busy.try_set(false);
        });
    };
    let wait_note = Signal::derive(move || {
        wait_s
            .get()
            .map(|left| ctx.lang.get().too_many_attempts(Some(left)))
    });
    view! {
        <form class="card form" on:submit=submit data-testid="login-form">
            <h2>{ctx.tr(Text::LoginTitle)}</h2>
            <TextField
                label=Text::Address
                value=address
                test_id="login-address"
                inputmode="url"
                autocomplete="url"
            />
            <TextField
                label=Text::Password
                value=password
                test_id="login-password"
                kind="password"
                autocomplete="current-password"
            />
            <button type="submit" class="primary" data-testid="login-submit" disabled=busy>
                {move || {
                    ctx.t(
                        if busy.get() && wait_s.with(Option::is_none) {
                            Text::Working
                        } else {
                            Text::LoginButton
                        },
                    )
                }}
            </button>
            <ErrorNote text=note test_id="login-error" alert=true />
            <ErrorNote text=wait_note test_id="login-error" />
            <Show when=move || wait_s.with(Option::is_some)>
                <p class="muted" data-testid="login-wait-note">
                    {ctx.tr(Text::LoginWhenWaitEnds)}
                </p>
            </Show>
        </form>
    }
}

#[component]
fn LoggedIn(address: String) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let logout = move |_| {
        if let Some(client) = ctx.client() {
            spawn_local(async move {
                // The login ends here either way; a bridge that cannot be told keeps
                // the token until it expires.
                if let Err(failure) = client.logout().await {
                    leptos::logging::warn!("logout: {}", Lang::En.failure(&failure));
                }
            });
        }
        ctx.session.set(None);
        ctx.set_status(None);
    };
    let shown = if address.is_empty() {
        ctx.origin().host
    } else {
        address
    };
    view! {
        <div class="card form">
            <p data-testid="logged-in">
                {ctx.tr(Text::LoggedInTo)} " " <strong>{shown}</strong>
            </p>
            <button data-testid="logout" on:click=logout>
                {ctx.tr(Text::Logout)}
            </button>
        </div>
    }
}

/// Counts `wait_s` down from `seconds` to nothing, one step a second; `false` when
/// the page went away meanwhile.
async fn count_down(wait_s: RwSignal<Option<u64>>, seconds: u64) -> bool {
    for left in (1..=seconds).rev() {
        if wait_s.try_set(Some(left)).is_some() {
            return false;
        }
        sleep_ms(1_000).await;
    }
    wait_s.try_set(None).is_none()
}

/// Lets `ms` of the browser's time pass.
async fn sleep_ms(ms: i32) {
    let promise = js_sys::Promise::new(&mut |resolve, _| {
        // Without a window there is no page to wait for: resolve at once.
        if window()
            .set_timeout_with_callback_and_timeout_and_arguments_0(&resolve, ms)
            .is_err()
        {
            let _ = resolve.call0(&wasm_bindgen::JsValue::NULL);
        }
    });
    let _ = wasm_bindgen_futures::JsFuture::from(promise).await;
}
