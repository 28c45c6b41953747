//! The connection to the bridge as a plain state machine: what the top bar shows and
//! when to try again. The browser side ([`crate::socket`]) feeds it events; it decides.

/// The first retry comes this soon after a connection is lost.
pub const FIRST_RETRY_MS: u32 = 250;
/// Retries never wait longer than this, so a restarted bridge is found within ~2 s.
pub const MAX_RETRY_MS: u32 = 2_000;
/// A connection that has been silent this long is treated as dead (a sleeping phone,
/// a WiFi that dropped without closing the socket).
pub const SILENCE_TIMEOUT_MS: u32 = 10_000;
/// How often the app pings the bridge while connected.
pub const PING_INTERVAL_MS: u32 = 4_000;

/// Whether the app can talk to the bridge right now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Link {
    /// Not connected; the next attempt is scheduled.
    Disconnected,
    /// A WebSocket is being opened.
    Connecting,
    /// The WebSocket is open and the bridge has spoken.
    Connected,
}

/// The connection state machine with exponential backoff.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Connection {
    link: Link,
    failures: u32,
}

impl Default for Connection {
    fn default() -> Self {
        Self::new()
    }
}

impl Connection {
    /// A fresh, not yet connected state.
    pub fn new() -> Self {
        Self {
            link: Link::Disconnected,
            failures: 0,
        }
    }

    /// What the top bar shows.
    pub fn link(&self) -> Link {
        self.link
    }

    /// A socket is being opened.
    pub fn on_connecting(&mut self) {
        self.link = Link::Connecting;
    }

    /// The bridge sent a message: the link is really up, and backoff starts over.
    pub fn on_message(&mut self) {
        self.link = Link::Connected;
        self.failures = 0;
    }

    /// The socket closed, failed, or went silent. Returns how long to wait before the
    /// next attempt.
    pub fn on_lost(&mut self) -> u32 {
        self.link = Link::Disconnected;
        let delay = retry_delay_ms(self.failures);
        self.failures = self.failures.saturating_add(1);
        delay
    }
}

/// The wait before retry number `failures` (0-based): 250 ms doubling up to 2 s.
pub fn retry_delay_ms(failures: u32) -> u32 {
    FIRST_RETRY_MS
        .saturating_mul(1u32 << failures.min(16))
        .min(MAX_RETRY_MS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    #[wasm_bindgen_test(unsupported = test)]
    fn starts_disconnected() {
        assert_eq!(Connection::new().link(), Link::Disconnected);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn connected_only_after_the_bridge_speaks() {
        let mut connection = Connection::new();
        connection.on_connecting();
        assert_eq!(connection.link(), Link::Connecting);
        connection.on_message();
        assert_eq!(connection.link(), Link::Connected);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn backoff_doubles_and_is_capped() {
        let mut connection = Connection::new();
        let delays: Vec<u32> = (0..6).map(|_| connection.on_lost()).collect();
        assert_eq!(delays, vec![250, 500, 1000, 2000, 2000, 2000]);
        assert_eq!(connection.link(), Link::Disconnected);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_message_resets_the_backoff() {
        let mut connection = Connection::new();
        connection.on_lost();
        connection.on_lost();
        connection.on_message();
        assert_eq!(connection.on_lost(), FIRST_RETRY_MS);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn huge_failure_counts_do_not_overflow() {
        assert_eq!(retry_delay_ms(u32::MAX), MAX_RETRY_MS);
    }
}
