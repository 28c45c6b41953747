//! Which controller the app talks to, and the login it holds there.
//!
//! The controller's address is what the operator types on the Login page (prefilled
//! with the host the page came from). From it come the API's base URL (empty for the
//! page's own origin, so calls stay same-origin) and the WebSocket URL with the token.
//!
//! The session (address, token, whether the password must still be changed) is kept in
//! `localStorage`, never the password: a kiosk relaunched in fullscreen, or a phone
//! whose browser dropped the tab while asleep, must be able to reach E-stop at once,
//! without someone typing the password again. `sessionStorage` would not survive
//! either. The token is the bridge's to revoke (Logout, expiry); a 401 sends the app
//! back to Login.

use serde::{Deserialize, Serialize};

/// A login held on one controller.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Session {
    /// The controller's address as typed (`192.168.1.17:8080`, or a URL).
    pub address: String,
    /// The bearer token.
    pub token: String,
    /// The bridge still has the factory password: it must be changed before uploads
    /// and control are allowed.
    pub must_change_password: bool,
}

/// Where the page was loaded from: `location.protocol` and `location.host`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Origin {
    /// `http:` or `https:`.
    pub protocol: String,
    /// Host and port (`192.168.1.17:8080`).
    pub host: String,
}

impl Origin {
    /// The API's base URL for a controller at `address`: `""` when it is the page's own
    /// host, else an absolute `http(s)://…` URL without a trailing slash.
    pub fn base_url(&self, address: &str) -> String {
        let address = address.trim().trim_end_matches('/');
        if address.starts_with("http://") || address.starts_with("https://") {
            address.to_owned()
        } else if address.is_empty() || address == self.host {
            String::new()
        } else {
            format!("{}//{address}", self.protocol)
        }
    }

    /// The WebSocket URL of a controller at `address`, carrying `token`.
    pub fn ws_url(&self, address: &str, token: &str) -> String {
        let base = self.base_url(address);
        let base = if base.is_empty() {
            format!("{}//{}", self.protocol, self.host)
        } else {
            base
        };
        let base = match base.strip_prefix("https://") {
            Some(rest) => format!("wss://{rest}"),
            None => format!("ws://{}", base.trim_start_matches("http://")),
        };
        format!(
            "{base}/ws?token={}",
            crate::client::encode_path_segment(token)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    fn origin(protocol: &str) -> Origin {
        Origin {
            protocol: protocol.into(),
            host: "192.168.1.17:8080".into(),
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_page_host_is_same_origin() {
        assert_eq!(origin("http:").base_url("192.168.1.17:8080"), "");
        assert_eq!(origin("http:").base_url(" 192.168.1.17:8080/ "), "");
        assert_eq!(origin("http:").base_url(""), "");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn another_address_is_absolute() {
        assert_eq!(
            origin("http:").base_url("10.0.0.5:8080"),
            "http://10.0.0.5:8080"
        );
        assert_eq!(
            origin("http:").base_url("https://show.example/"),
            "https://show.example"
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn websocket_urls_carry_the_token() {
        assert_eq!(
            origin("http:").ws_url("192.168.1.17:8080", "a b"),
            "ws://192.168.1.17:8080/ws?token=a%20b"
        );
        assert_eq!(
            origin("https:").ws_url("10.0.0.5", "t"),
            "wss://10.0.0.5/ws?token=t"
        );
        assert_eq!(
            origin("http:").ws_url("https://show.example", "t"),
            "wss://show.example/ws?token=t"
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn sessions_round_trip_without_a_password() {
        let session = Session {
            address: "10.0.0.5".into(),
            token: "t".into(),
            must_change_password: true,
        };
        let json = serde_json::to_string(&session).unwrap();
        assert!(!json.contains("password\":\""), "{json}");
        assert_eq!(serde_json::from_str::<Session>(&json).unwrap(), session);
    }
}
