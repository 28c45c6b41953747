//! The `[osc]` table of `floatball.toml`: show control over OSC (`crate::osc`), off
//! unless `listen` is given — the UDP address and port, the senders obeyed (`allow`:
//! addresses or networks), the two switches (`estop`, `motion`) and where feedback
//! goes (`feedback`), checked with line and column like the rest
//! (docs/show-control.md).

use std::net::{IpAddr, SocketAddr};

use super::ConfigError;
use super::check::Checker;
use super::raw::RawOsc;

/// Show control over OSC, when `[osc] listen` is given.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OscConfig {
    /// The UDP address and port commands are received on (and feedback sent from).
    pub listen: SocketAddr,
    /// The senders obeyed; every other sender is refused (and logged).
    pub allow: Vec<Source>,
    /// Whether `/floatball/estop` is obeyed (default: yes).
    pub estop: bool,
    /// Whether the commands that move balls are obeyed: start, reset, home, goto
    /// (default: no).
    pub motion: bool,
    /// Where the state, the entry and the show time are sent, if anywhere.
    pub feedback: Option<SocketAddr>,
}

/// A sender the bridge obeys: one address (`192.168.1.20`) or a network
/// (`10.0.0.0/24`, `fd00::/64`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Source {
    /// The network's address (its bits past the prefix are ignored).
    pub address: IpAddr,
    /// How many leading bits must match: 32 (IPv4) or 128 (IPv6) for one address.
    pub prefix: u8,
}

impl Source {
    /// Reads `192.168.1.20`, `10.0.0.0/24`, `::1` or `fd00::/64`.
    pub fn parse(text: &str) -> Option<Self> {
        let (address, prefix) = match text.trim().split_once('/') {
            Some((address, prefix)) => (address, Some(prefix)),
            None => (text.trim(), None),
        };
        let address: IpAddr = address.parse().ok()?;
        let bits = if address.is_ipv4() { 32 } else { 128 };
        let prefix = match prefix {
            None => bits,
            Some(prefix) if prefix.bytes().all(|byte| byte.is_ascii_digit()) => {
                prefix.parse().ok().filter(|prefix| *prefix <= bits)?
            }
            Some(_) => return None,
        };
        Some(Self { address, prefix })
    }

    /// Whether `sender` is this address or inside this network (an IPv4 sender seen
    /// as IPv6 on a dual-stack socket, `::ffff:a.b.c.d`, counts as its IPv4 address).
    pub fn contains(&self, sender: IpAddr) -> bool {
        match (self.address, sender.to_canonical()) {
            (IpAddr::V4(net), IpAddr::V4(sender)) => {
                let mask = u32::MAX
                    .checked_shl(32 - u32::from(self.prefix))
                    .unwrap_or(0);
                u32::from(net) & mask == u32::from(sender) & mask
            }
            (IpAddr::V6(net), IpAddr::V6(sender)) => {
                let mask = u128::MAX
                    .checked_shl(128 - u32::from(self.prefix))
                    .unwrap_or(0);
                u128::from(net) & mask == u128::from(sender) & mask
            }
            _ => false,
        }
    }
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let bits = if self.address.is_ipv4() { 32 } else { 128 };
        if self.prefix == bits {
            write!(f, "{}", self.address)
        } else {
            write!(f, "{}/{}", self.address, self.prefix)
        }
    }
}

impl Checker<'_> {
    /// `[osc]`: `None` when OSC is off (no `listen`).
    pub(super) fn osc(&self, raw: &RawOsc) -> Result<Option<OscConfig>, ConfigError> {
        let Some(listen) = &raw.listen else {
            return Ok(None);
        };
        let address = |value: &toml::Spanned<String>, key: &str| {
            value.get_ref().trim().parse::<SocketAddr>().map_err(|_| {
                self.at(
                    &value.span(),
                    format!(
                        "[osc] {key} = {:?} is not an address and UDP port such as \
                         \"0.0.0.0:9000\"",
                        value.get_ref()
                    ),
                )
            })
        };
        let listen = address(listen, "listen")?;
        let feedback = raw
            .feedback
            .as_ref()
            .map(|feedback| address(feedback, "feedback"))
            .transpose()?;
        if let Some(feedback) = feedback
            && (feedback.ip().is_unspecified() || feedback.port() == 0)
        {
            return Err(self.wrong(
                raw.feedback.as_ref().map(toml::Spanned::span).as_ref(),
                format!(
                    "[osc] feedback = \"{feedback}\" must name the address and port of the \
                     client that receives the feedback, such as \"192.168.1.20:9001\""
                ),
            ));
        }
        if let Some(feedback) = feedback
            && feedback.port() == listen.port()
            && (feedback.ip() == listen.ip()
                || (listen.ip().is_unspecified() && feedback.ip().is_loopback()))
        {
            return Err(self.wrong(
                raw.feedback.as_ref().map(toml::Spanned::span).as_ref(),
                format!(
                    "[osc] feedback = \"{feedback}\" is the bridge's own OSC port: give the \
                     address and port of the client that receives the feedback"
                ),
            ));
        }
        let mut allow = Vec::with_capacity(raw.allow.len());
        for source in &raw.allow {
            allow.push(Source::parse(source.get_ref()).ok_or_else(|| {
                self.at(
                    &source.span(),
                    format!(
                        "[osc] allow: {:?} is not an address such as \"192.168.1.20\" nor a \
                         network such as \"192.168.1.0/24\"",
                        source.get_ref()
                    ),
                )
            })?);
        }
        if allow.is_empty() {
            return Err(self.wrong(
                raw.listen.as_ref().map(toml::Spanned::span).as_ref(),
                "[osc] allow lists no sender: OSC obeys only the addresses listed, such as \
                 allow = [\"192.168.1.20\"] (leave listen out to switch OSC off)"
                    .to_owned(),
            ));
        }
        Ok(Some(OscConfig {
            listen,
            allow,
            estop: raw.estop.as_ref().is_none_or(|estop| *estop.get_ref()),
            motion: raw.motion.as_ref().is_some_and(|motion| *motion.get_ref()),
            feedback,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_are_addresses_or_networks() {
        let one = Source::parse("192.168.1.20").unwrap();
        assert!(one.contains("192.168.1.20".parse().unwrap()));
        assert!(!one.contains("192.168.1.21".parse().unwrap()));
        assert!(one.contains("::ffff:192.168.1.20".parse().unwrap()));
        let net = Source::parse("10.0.0.0/24").unwrap();
        assert!(net.contains("10.0.0.255".parse().unwrap()));
        assert!(!net.contains("10.0.1.0".parse().unwrap()));
        assert_eq!(net.to_string(), "10.0.0.0/24");
        let all = Source::parse("0.0.0.0/0").unwrap();
        assert!(all.contains("203.0.113.9".parse().unwrap()));
        assert!(!all.contains("::1".parse().unwrap()));
        let v6 = Source::parse("fd00::/64").unwrap();
        assert!(v6.contains("fd00::1:2".parse().unwrap()));
        assert!(!v6.contains("fd01::1".parse().unwrap()));
        for wrong in [
            "",
            "host",
            "10.0.0.0/33",
            "10.0.0.0/",
            "10.0.0.0/+8",
            "::/129",
        ] {
            assert_eq!(Source::parse(wrong), None, "{wrong}");
        }
    }
}
