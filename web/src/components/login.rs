//! The Login page: controller address and password; the forced change of the factory
//! password; logout.

use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::client::Failure;
use crate::components::widgets::{ErrorNote, TextField};
use crate::context::Ctx;
use crate::i18n::Text;
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
                    view! { <PasswordForm remembered=remembered /> }.into_any()
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
    let submit = move |event: leptos::ev::SubmitEvent| {
        event.prevent_default();
        if busy.get_untracked() {
            return;
        }
        busy.set(true);
        note.set(None);
        let address = address.get_untracked().trim().to_owned();
        let typed = password.get_untracked();
        let client = ctx.client_for(&address);
        spawn_local(async move {
            let lang = ctx.lang.get_untracked();
            match client.login(&typed).await {
                Ok(answer) => {
                    ctx.login_notice.set(None);
                    remembered.set(answer.must_change_password.then_some(typed));
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
                    note.set(Some(lang.t(Text::WrongPassword).into()));
                }
                Err(failure) => note.set(Some(lang.failure(&failure))),
            }
            busy.set(false);
        });
    };
    view! {
        <form class="card form" on:submit=submit data-testid="login-form">
            <h2>{move || ctx.t(Text::LoginTitle)}</h2>
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
                {move || ctx.t(if busy.get() { Text::Working } else { Text::LoginButton })}
            </button>
            <ErrorNote text=note test_id="login-error" alert=true />
        </form>
    }
}

#[component]
fn PasswordForm(remembered: RwSignal<Option<String>>) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let current = RwSignal::new(String::new());
    let new = RwSignal::new(String::new());
    let confirm = RwSignal::new(String::new());
    let busy = RwSignal::new(false);
    let note = RwSignal::new(None::<String>);
    let submit = move |event: leptos::ev::SubmitEvent| {
        event.prevent_default();
        let lang = ctx.lang.get_untracked();
        if new.get_untracked() != confirm.get_untracked() {
            note.set(Some(lang.t(Text::PasswordsDiffer).into()));
            return;
        }
        let Some(client) = ctx.client() else { return };
        let old = remembered
            .get_untracked()
            .unwrap_or_else(|| current.get_untracked());
        let new = new.get_untracked();
        busy.set(true);
        note.set(None);
        spawn_local(async move {
            match client.change_password(&old, &new).await {
                Ok(()) => {
                    remembered.set(None);
                    ctx.login_notice.set(None);
                    ctx.session.update(|session| {
                        if let Some(session) = session {
                            session.must_change_password = false;
                        }
                    });
                    ctx.page.set(Page::Files);
                }
                Err(Failure::Unauthorized) => {
                    // A wrong current password; the app may have remembered a stale one.
                    remembered.set(None);
                    note.set(Some(lang.t(Text::WrongCurrentPassword).into()));
                }
                Err(Failure::Rejected(error)) => {
                    let details = lang.problems(&error).join(" ");
                    note.set(Some(
                        format!("{} {details}", lang.api_error(&error))
                            .trim_end()
                            .to_owned(),
                    ));
                }
                Err(failure) => note.set(Some(ctx.failed(&failure))),
            }
            busy.set(false);
        });
    };
    view! {
        <form class="card form" on:submit=submit data-testid="password-form">
            <h2>{move || ctx.t(Text::ChangePasswordTitle)}</h2>
            <p class="muted">{move || ctx.t(Text::ChangePasswordNote)}</p>
            <Show when=move || remembered.with(Option::is_none)>
                <TextField
                    label=Text::CurrentPassword
                    value=current
                    test_id="password-current"
                    kind="password"
                    autocomplete="current-password"
                />
            </Show>
            <TextField
                label=Text::NewPassword
                value=new
                test_id="password-new"
                kind="password"
                autocomplete="new-password"
            />
            <TextField
                label=Text::ConfirmPassword
                value=confirm
                test_id="password-confirm"
                kind="password"
                autocomplete="new-password"
            />
            <button type="submit" class="primary" data-testid="password-submit" disabled=busy>
                {move || ctx.t(Text::ChangePasswordButton)}
            </button>
            <ErrorNote text=note test_id="password-error" alert=true />
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
                    leptos::logging::warn!("logout: {failure:?}");
                }
            });
        }
        ctx.session.set(None);
        ctx.status.set(None);
    };
    let shown = if address.is_empty() {
        ctx.origin().host
    } else {
        address
    };
    view! {
        <div class="card form">
            <p data-testid="logged-in">
                {move || ctx.t(Text::LoggedInTo)} " " <strong>{shown}</strong>
            </p>
            <button data-testid="logout" on:click=logout>
                {move || ctx.t(Text::Logout)}
            </button>
        </div>
    }
}
