//! The password form: the forced change of the factory password right after the
//! first login (on the Login page), and the change from Settings at any time later
//! (`POST /api/password`, `docs/uim2503.md` §4). Both confirm a change with a toast.

use floatball_shared::codes::Code;
use leptos::prelude::*;
use leptos::task::spawn_local;

use crate::client::Failure;
use crate::components::widgets::{ErrorNote, TextField};
use crate::context::Ctx;
use crate::i18n::{PasswordText, Text};
use crate::page::Page;

/// Old, new and repeated password, and the change.
#[component]
pub fn PasswordForm(
    /// The forced change of the factory password (else the change from Settings).
    #[prop(optional)]
    forced: bool,
    /// The password typed at login while the app still has it: the forced change
    /// then does not ask for it again.
    #[prop(optional)]
    remembered: Option<RwSignal<Option<String>>>,
) -> impl IntoView {
    let ctx = expect_context::<Ctx>();
    let remembered = remembered.unwrap_or_else(|| RwSignal::new(None));
    let current = RwSignal::new(String::new());
    let new = RwSignal::new(String::new());
    let confirm = RwSignal::new(String::new());
    let busy = RwSignal::new(false);
    let note = RwSignal::new(None::<String>);
    let done = RwSignal::new(false);
    let edited = Callback::new(move |()| done.set(false));
    let submit = move |event: leptos::ev::SubmitEvent| {
        event.prevent_default();
        let lang = ctx.lang.get_untracked();
        done.set(false);
        if new.get_untracked() != confirm.get_untracked() {
            note.set(Some(lang.t(PasswordText::PasswordsDiffer).into()));
            return;
        }
        let Some(client) = ctx.client() else { return };
        let old = remembered
            .get_untracked()
            .unwrap_or_else(|| current.get_untracked());
        let typed = new.get_untracked();
        busy.set(true);
        note.set(None);
        spawn_local(async move {
            match client.change_password(&old, &typed).await {
                Ok(()) => {
                    remembered.set(None);
                    ctx.notify(lang.t(PasswordText::PasswordChanged));
                    if forced {
                        ctx.login_notice.set(None);
                        ctx.session.update(|session| {
                            if let Some(session) = session {
                                session.must_change_password = false;
                            }
                        });
                        ctx.page.set(Page::Files);
                    } else {
                        for field in [current, new, confirm] {
                            field.set(String::new());
                        }
                        done.set(true);
                    }
                }
                // The bridge answers a wrong current password with 403; the app may
                // have remembered a stale one, so the field shows from now on.
                // (An older bridge answers it without a code: MustChangePassword.)
                Err(Failure::MustChangePassword) => {
                    remembered.set(None);
                    note.set(Some(lang.t(PasswordText::WrongCurrentPassword).into()));
                }
                Err(Failure::Rejected(error))
                    if error.code == Code::WrongCurrentPassword.as_str() =>
                {
                    remembered.set(None);
                    note.set(Some(lang.t(PasswordText::WrongCurrentPassword).into()));
                }
                Err(failure) => {
                    let mut text = ctx.failed(&failure);
                    if let Failure::Rejected(error) = &failure {
                        for detail in lang.problems(error) {
                            text.push(' ');
                            text.push_str(&detail);
                        }
                    }
                    note.set(Some(text));
                }
            }
            busy.set(false);
        });
    };
    let (form_id, title) = if forced {
        ("password-form", PasswordText::ChangePasswordTitle)
    } else {
        ("settings-password-form", PasswordText::ChangePasswordButton)
    };
    view! {
        <form class="card form" on:submit=submit data-testid=form_id>
            <h2>{ctx.tr(title)}</h2>
            <p class="muted">
                {move || {
                    ctx.t(if forced { PasswordText::ChangePasswordNote } else { PasswordText::PasswordChangeNote })
                }}
            </p>
            <Show when=move || remembered.with(Option::is_none)>
                <TextField
                    label=PasswordText::CurrentPassword
                    value=current
                    test_id="password-current"
                    kind="password"
                    autocomplete="current-password"
                    on_edit=edited
                />
            </Show>
            <TextField
                label=PasswordText::NewPassword
                value=new
                test_id="password-new"
                kind="password"
                autocomplete="new-password"
                on_edit=edited
            />
            <TextField
                label=PasswordText::ConfirmPassword
                value=confirm
                test_id="password-confirm"
                kind="password"
                autocomplete="new-password"
                on_edit=edited
            />
            <button type="submit" class="primary" data-testid="password-submit" disabled=busy>
                {move || if busy.get() { ctx.t(Text::Working) } else { ctx.t(PasswordText::ChangePasswordButton) }}
            </button>
            <ErrorNote text=note test_id="password-error" alert=true />
            <Show when=move || done.get()>
                <p class="note done" data-testid="password-done">
                    {ctx.tr(PasswordText::PasswordChanged)}
                </p>
            </Show>
        </form>
    }
}
