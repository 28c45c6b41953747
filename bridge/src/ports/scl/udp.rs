//! An SCL link to eSCL drives over UDP: one socket for the gateway entry's drives,
//! each request a datagram (the header `00 07`, the text, CR) to one drive's address;
//! a receiver thread matches answers to drives by their source address and hands
//! their text to the owner.

use std::net::{SocketAddr, UdpSocket};
use std::sync::mpsc::Sender;
use std::time::Duration;

use floatball_shared::scl::{CR, Command, Request, escl};

use super::{Event, LinkShared, Opener, Transport};

/// How long a receive waits before it looks whether the link was closed.
const READ_TIMEOUT: Duration = Duration::from_millis(100);

struct EsclSocket {
    socket: UdpSocket,
    drives: Vec<SocketAddr>,
}

impl Transport for EsclSocket {
    fn send(&mut self, _shared: &LinkShared, drive: usize, text: &str) -> std::io::Result<()> {
        let Some(address) = self.drives.get(drive) else {
            return Ok(());
        };
        let mut datagram = Vec::with_capacity(text.len() + 3);
        datagram.extend_from_slice(&escl::HEADER);
        datagram.extend_from_slice(text.as_bytes());
        datagram.push(CR);
        self.socket.send_to(&datagram, address).map(|_| ())
    }

    fn stop_all(&mut self, _shared: &LinkShared) -> std::io::Result<()> {
        let datagram = Request::new(Command::StopKill).to_escl();
        let mut failed = None;
        for address in &self.drives {
            // A drive that cannot be reached must not keep the stop from the others.
            if let Err(err) = self.socket.send_to(&datagram, address) {
                failed = Some(err);
            }
        }
        match failed {
            // A drive not there (ICMP unreachable) is not a lost socket.
            Some(err) if err.kind() != std::io::ErrorKind::ConnectionRefused => Err(err),
            _ => Ok(()),
        }
    }

    fn per_drive(&self) -> bool {
        true
    }
}

/// Binds a socket on `host_port` (0: any free port) for the drives at `drives`, with
/// a receiver. An eSCL drive answers only the first host address and port that spoke
/// to it until it is powered down: a fixed port keeps it answering after a restart.
pub(super) fn opener(drives: Vec<SocketAddr>, host_port: u16) -> Opener {
    Box::new(move |connection, events: Sender<Event>| {
        let any: SocketAddr = if drives.first().is_some_and(SocketAddr::is_ipv6) {
            (std::net::Ipv6Addr::UNSPECIFIED, host_port).into()
        } else {
            (std::net::Ipv4Addr::UNSPECIFIED, host_port).into()
        };
        let socket = UdpSocket::bind(any)
            .map_err(|err| format!("cannot bind the eSCL host port UDP {host_port}: {err}"))?;
        let receiving = socket
            .try_clone()
            .map_err(|err| format!("cannot share the eSCL socket: {err}"))?;
        receiving
            .set_read_timeout(Some(READ_TIMEOUT))
            .map_err(|err| format!("cannot set the eSCL socket's timeout: {err}"))?;
        let known = drives.clone();
        std::thread::Builder::new()
            .name(format!("escl-read-{connection}"))
            .spawn(move || receive(&receiving, &known, connection, &events))
            .map_err(|err| format!("cannot start the eSCL receiver: {err}"))?;
        Ok(Box::new(EsclSocket {
            socket,
            drives: drives.clone(),
        }) as Box<dyn Transport>)
    })
}

/// The receiver: datagrams from known drives to answer lines.
fn receive(socket: &UdpSocket, drives: &[SocketAddr], connection: u64, events: &Sender<Event>) {
    let mut buffer = vec![0u8; 2048];
    loop {
        let (len, from) = match socket.recv_from(&mut buffer) {
            Ok(received) => received,
            // Timeouts, and ICMP "port unreachable" from a drive that is not there;
            // a send fails once the owner is gone.
            Err(_) => {
                if events.send(Event::Wake).is_err() {
                    return;
                }
                continue;
            }
        };
        let Some(drive) = drives.iter().position(|address| *address == from) else {
            continue;
        };
        let datagram = buffer.get(..len).unwrap_or_default();
        // The header, then one or more lines (an upload's answer), each ended by CR.
        let Some(body) = datagram.strip_prefix(&escl::HEADER) else {
            continue;
        };
        for line in body.split(|&byte| byte == CR) {
            if line.is_empty() {
                continue;
            }
            let event = Event::Line {
                connection,
                drive: Some(drive),
                text: String::from_utf8_lossy(line).into_owned(),
            };
            if events.send(event).is_err() {
                return;
            }
        }
    }
}
