//! The Login page: controller address and password; the forced change of the factory
//! password; logout.

use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::client::Failure;
use crate::context::Ctx;
use crate::i18n::Text;
use crate::page::Page;
use crate::session::Session;

/// An error under a form.
fn error_view(error: RwSignal<Option<String>>, test_id: &'static str) -> impl IntoView {
    move || {
        error.get().map(|text| {
            view! {
                <p class="note error" data-testid=test_id role="alert">
                    {text}
                </p>
            }
        })
    }
}

/// The Login page.
#[component]
pub fn LoginPage() -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    // The password typed at login, kept in memory only, so that the forced change does
    // not ask for it again.
    let remembered = RwSignal::new(None::<String>);
    view! {
        <section class="login">
            {move || {
                ctx.login_notice
                    .get()
                    .map(|text| {
                        view! {
                            <p class="note error" data-testid="login-notice">
                                {move || ctx.t(text)}
                            </p>
                        }
                    })
            }}
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
            <label>
                <span>{move || ctx.t(Text::Address)}</span>
                <input
                    type="text"
                    inputmode="url"
                    autocomplete="url"
                    data-testid="login-address"
                    prop:value=address
                    on:input=move |ev| address.set(event_target_value(&ev))
                />
            </label>
            <label>
                <span>{move || ctx.t(Text::Password)}</span>
                <input
                    type="password"
                    autocomplete="current-password"
                    data-testid="login-password"
                    prop:value=password
                    on:input=move |ev| password.set(event_target_value(&ev))
                />
            </label>
            <button type="submit" class="primary" data-testid="login-submit" disabled=busy>
                {move || ctx.t(if busy.get() { Text::Working } else { Text::LoginButton })}
            </button>
            {error_view(note, "login-error")}
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
                    let details = error.details.join(" ");
                    note.set(Some(format!("{} {details}", error.error)));
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
                <label>
                    <span>{move || ctx.t(Text::CurrentPassword)}</span>
                    <input
                        type="password"
                        autocomplete="current-password"
                        data-testid="password-current"
                        prop:value=current
                        on:input=move |ev| current.set(event_target_value(&ev))
                    />
                </label>
            </Show>
            <label>
                <span>{move || ctx.t(Text::NewPassword)}</span>
                <input
                    type="password"
                    autocomplete="new-password"
                    data-testid="password-new"
                    prop:value=new
                    on:input=move |ev| new.set(event_target_value(&ev))
                />
            </label>
            <label>
                <span>{move || ctx.t(Text::ConfirmPassword)}</span>
                <input
                    type="password"
                    autocomplete="new-password"
                    data-testid="password-confirm"
                    prop:value=confirm
                    on:input=move |ev| confirm.set(event_target_value(&ev))
                />
            </label>
            <button type="submit" class="primary" data-testid="password-submit" disabled=busy>
                {move || ctx.t(Text::ChangePasswordButton)}
            </button>
            {error_view(note, "password-error")}
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
