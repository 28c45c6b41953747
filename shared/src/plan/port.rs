//! Where a gateway's line is: a gateway's `port` setting parsed ([`PortAddress`]) — the
//! built-in simulator, a local serial device, or a serial device server on the network
//! reached by raw TCP (`tcp://host:port`) or by Telnet with RFC 2217 COM-port control
//! (`rfc2217://host:port`, the bridge sets the remote line's speed and framing).
//!
//! Parsing is the one rule for the configuration check, the installation page and the
//! links, so that what one accepts the others open.

use std::fmt;

use thiserror::Error;

use super::installation::SIM_PORT;

/// The scheme of a raw TCP serial device server.
pub const TCP_SCHEME: &str = "tcp://";
/// The scheme of an RFC 2217 (Telnet COM-port control) serial device server.
pub const RFC2217_SCHEME: &str = "rfc2217://";

/// A gateway's `port`, parsed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PortAddress {
    /// The built-in simulated gateway (`sim`).
    Sim,
    /// A local serial device, e.g. `/dev/ttyUSB0` or `COM3`.
    Serial(String),
    /// A serial device server in raw TCP mode: the bytes are the line's bytes.
    Tcp(NetAddress),
    /// A serial device server speaking Telnet with COM-port control (RFC 2217).
    Rfc2217(NetAddress),
}

/// A host and a TCP port.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NetAddress {
    /// A host name or an IP address (IPv6 without its brackets).
    pub host: String,
    /// The TCP port, 1–65535.
    pub port: u16,
}

impl NetAddress {
    /// `host:port` as a socket library takes it (IPv6 hosts in brackets).
    #[must_use]
    pub fn authority(&self) -> String {
        if self.host.contains(':') {
            format!("[{}]:{}", self.host, self.port)
        } else {
            format!("{}:{}", self.host, self.port)
        }
    }
}

/// Why a `port` setting is not one.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum PortError {
    /// Nothing given.
    #[error(
        "the port is empty: give \"sim\", a serial device such as \"/dev/ttyUSB0\", \"tcp://host:port\" or \"rfc2217://host:port\""
    )]
    Empty,
    /// A network port without a host.
    #[error("\"{0}\" has no host: write it as \"tcp://host:port\" or \"rfc2217://host:port\"")]
    NoHost(String),
    /// A network port without a TCP port, or one that is not 1–65535.
    #[error("\"{0}\" needs a TCP port 1-65535 after the host, e.g. \"tcp://192.168.1.50:4001\"")]
    BadPort(String),
    /// A scheme other than tcp:// and rfc2217://.
    #[error(
        "\"{0}\": only tcp:// (raw TCP) and rfc2217:// (Telnet COM-port control) reach a gateway over the network"
    )]
    UnknownScheme(String),
}

impl PortAddress {
    /// Parses a `port` setting.
    ///
    /// # Errors
    /// [`PortError`] when it is empty, or a network address without a host or a valid
    /// TCP port, or with another scheme.
    pub fn parse(text: &str) -> Result<Self, PortError> {
        let text = text.trim();
        if text.is_empty() {
            return Err(PortError::Empty);
        }
        if text == SIM_PORT {
            return Ok(Self::Sim);
        }
        if let Some(rest) = text.strip_prefix(TCP_SCHEME) {
            return net_address(text, rest).map(Self::Tcp);
        }
        if let Some(rest) = text.strip_prefix(RFC2217_SCHEME) {
            return net_address(text, rest).map(Self::Rfc2217);
        }
        if text.contains("://") {
            return Err(PortError::UnknownScheme(text.to_owned()));
        }
        Ok(Self::Serial(text.to_owned()))
    }

    /// Whether the line is reached over the network.
    #[must_use]
    pub fn is_network(&self) -> bool {
        matches!(self, Self::Tcp(_) | Self::Rfc2217(_))
    }
}

/// `host:port`, `[v6]:port` (a trailing `/` allowed).
fn net_address(whole: &str, rest: &str) -> Result<NetAddress, PortError> {
    let rest = rest.trim_end_matches('/');
    let (host, port) = if let Some(bracketed) = rest.strip_prefix('[') {
        let (host, after) = bracketed
            .split_once(']')
            .ok_or_else(|| PortError::NoHost(whole.to_owned()))?;
        let port = after
            .strip_prefix(':')
            .ok_or_else(|| PortError::BadPort(whole.to_owned()))?;
        (host, port)
    } else {
        rest.rsplit_once(':')
            .ok_or_else(|| PortError::BadPort(whole.to_owned()))?
    };
    if host.is_empty() {
        return Err(PortError::NoHost(whole.to_owned()));
    }
    let port: u16 = port
        .parse()
        .ok()
        .filter(|&port| port != 0)
        .ok_or_else(|| PortError::BadPort(whole.to_owned()))?;
    Ok(NetAddress {
        host: host.to_owned(),
        port,
    })
}

impl fmt::Display for PortAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Sim => f.write_str(SIM_PORT),
            Self::Serial(device) => f.write_str(device),
            Self::Tcp(address) => write!(f, "{TCP_SCHEME}{}", address.authority()),
            Self::Rfc2217(address) => write!(f, "{RFC2217_SCHEME}{}", address.authority()),
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    fn net(host: &str, port: u16) -> NetAddress {
        NetAddress {
            host: host.to_owned(),
            port,
        }
    }

    #[test]
    fn every_kind_of_port_parses_and_prints_back() {
        let cases = [
            ("sim", PortAddress::Sim),
            ("/dev/ttyUSB0", PortAddress::Serial("/dev/ttyUSB0".into())),
            ("COM3", PortAddress::Serial("COM3".into())),
            (
                "tcp://10.0.0.5:4001",
                PortAddress::Tcp(net("10.0.0.5", 4001)),
            ),
            (
                "rfc2217://moxa-3.show.lan:950",
                PortAddress::Rfc2217(net("moxa-3.show.lan", 950)),
            ),
            (
                "tcp://[fe80::1]:4001",
                PortAddress::Tcp(net("fe80::1", 4001)),
            ),
        ];
        for (text, expected) in cases {
            let parsed = PortAddress::parse(text).expect(text);
            assert_eq!(parsed, expected, "{text}");
            assert_eq!(parsed.to_string(), text);
        }
        assert!(PortAddress::parse("tcp://h:1").expect("tcp").is_network());
        assert!(!PortAddress::parse("sim").expect("sim").is_network());
    }

    #[test]
    fn bad_network_ports_say_what_is_wrong() {
        assert_eq!(PortAddress::parse("  "), Err(PortError::Empty));
        assert!(matches!(
            PortAddress::parse("tcp://:4001"),
            Err(PortError::NoHost(_))
        ));
        assert!(matches!(
            PortAddress::parse("tcp://host"),
            Err(PortError::BadPort(_))
        ));
        assert!(matches!(
            PortAddress::parse("tcp://host:0"),
            Err(PortError::BadPort(_))
        ));
        assert!(matches!(
            PortAddress::parse("rfc2217://host:70000"),
            Err(PortError::BadPort(_))
        ));
        assert!(matches!(
            PortAddress::parse("udp://host:1"),
            Err(PortError::UnknownScheme(_))
        ));
    }
}
