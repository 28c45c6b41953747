//! The stable error codes of every refusal, validation problem and parse error the
//! bridge and the shared parsers report, and the [`Coded`] trait that gives each typed
//! error its code and parameters.
//!
//! The bridge puts the code (`snake_case`, never renamed once published) and the
//! parameters into [`crate::api::ApiError`], [`crate::api::Problem`] and
//! [`crate::api::ServerMessage::Error`] beside an English sentence for API clients;
//! the app renders the code with its parameters in the operator's language. Every
//! code is in [`Code::ALL`], so a test can check that each has a text in every
//! language (`web/src/i18n.rs`), and the table in `docs/errors.md` lists them.

use std::collections::BTreeMap;

/// The parameters of a coded error: names (`unit`, `time_ms`, `limit`…) to values,
/// as text.
pub type Params = BTreeMap<String, String>;

/// A typed error that has a stable code and parameters.
pub trait Coded {
    /// Its stable code.
    fn code(&self) -> Code;
    /// Its parameters (the names [`Code::params`] lists, and optional others).
    fn params(&self) -> Params;
}

/// Builds [`Params`] from `name => value` pairs (values through `to_string`).
#[macro_export]
macro_rules! params {
    ($($name:literal => $value:expr),* $(,)?) => {{
        #[allow(unused_mut)]
        let mut params = $crate::codes::Params::new();
        $(params.insert($name.to_owned(), ($value).to_string());)*
        params
    }};
}

macro_rules! codes {
    ($($(#[doc = $doc:literal])* $name:ident = $code:literal [$($param:literal),*];)*) => {
        /// A stable error code. Its text is [`Code::as_str`]; [`Code::params`] names the
        /// parameters every error of that code carries.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Code {
            $($(#[doc = $doc])* $name,)*
        }

        impl Code {
            /// Every code, for the tests that check translations and docs.
            pub const ALL: &'static [Code] = &[$(Code::$name),*];

            /// The code as it appears in the JSON (`snake_case`).
            #[must_use]
            pub const fn as_str(self) -> &'static str {
                match self {
                    $(Code::$name => $code,)*
                }
            }

            /// The parameters every error with this code carries.
            #[must_use]
            pub const fn params(self) -> &'static [&'static str] {
                match self {
                    $(Code::$name => &[$($param),*],)*
                }
            }
        }
    };
}

impl Code {
    /// The code whose text is `code`, if it is one of [`Code::ALL`].
    #[must_use]
    pub fn parse(code: &str) -> Option<Self> {
        Self::ALL
            .iter()
            .copied()
            .find(|known| known.as_str() == code)
    }
}

impl std::fmt::Display for Code {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

codes! {
    // ---- HTTP in general ----
    /// No API call at that path.
    NotFound = "not_found" [];
    /// The API call does not take that method.
    MethodNotAllowed = "method_not_allowed" [];
    /// The request body is larger than the call accepts.
    BodyTooLarge = "body_too_large" ["limit_bytes"];
    /// The request's Content-Type is not one the call accepts.
    UnsupportedMediaType = "unsupported_media_type" [];
    /// The request body is not the JSON the call expects.
    BadJson = "bad_json" ["what"];
    /// The framework refused the request for another reason (`status`).
    RequestRefused = "request_refused" ["status"];
    /// Something failed inside the bridge (logged there).
    Internal = "internal" ["what"];
    // ---- sessions ----
    /// The call needs a login (no token sent).
    LoginRequired = "login_required" [];
    /// The token is unknown or expired.
    SessionExpired = "session_expired" [];
    /// The password is wrong.
    WrongPassword = "wrong_password" [];
    /// Too many wrong passwords from this address; wait `retry_after_s` seconds.
    TooManyAttempts = "too_many_attempts" ["retry_after_s"];
    /// The bridge is busy checking other passwords; wait `retry_after_s` seconds.
    LoginBusy = "login_busy" ["retry_after_s"];
    /// The factory password must be changed first.
    MustChangePassword = "must_change_password" [];
    /// The current password given for a change is wrong.
    WrongCurrentPassword = "wrong_current_password" [];
    /// The new password is shorter than `min` characters.
    PasswordTooShort = "password_too_short" ["min"];
    /// The new password may not be the factory password.
    PasswordIsDefault = "password_is_default" [];
    /// The page's origin may not open the WebSocket.
    OriginNotAllowed = "origin_not_allowed" [];
    // ---- the playlist ----
    /// The playlist's entries cannot change while a show plays or balls move.
    PlaylistLocked = "playlist_locked" [];
}
