//! Links to gateways behind a serial device server on the network: `tcp://host:port`
//! (raw TCP: the bytes on the socket are the line's bytes — ser2net's `accepter:
//! tcp,PORT`, a Moxa-style "TCP server" mode) and `rfc2217://host:port` (Telnet with
//! COM-port control: the bridge sets the remote line's speed and 8N1 without flow
//! control, and moves the speed on [`super::Link::change_baud`]).
//!
//! The link behaves exactly like a serial one: the same [`supervisor`](super::supervisor)
//! (connect, greet, `Down` with a reason naming `host:port` when the connection is lost,
//! everything queued dropped, reconnect with backoff, the stop first after a reconnect
//! while the e-stop is latched) and the same writer, which hands the socket one
//! instruction at a time paced to the *remote* line's speed — so the device server
//! never holds more than the instruction in flight and an e-stop waits for at most that
//! one. `TCP_NODELAY` is set: an instruction leaves at once instead of waiting for the
//! previous one's acknowledgement (Nagle).
//!
//! The Telnet part (IAC escaping, negotiation, RFC 2217 commands) is [`super::telnet`];
//! this module puts it on a socket: the writer escapes instructions, the reader thread
//! decodes, answers the server's option requests and hands COM-port answers to the
//! writer, which waits for them when it sets the line.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use floatball_shared::plan::port::NetAddress;

use super::supervisor::{Connector, LineRead, write_watching};
use super::telnet::{self, ComPortAgreement, ComPortReply, Decoder, Options};
use super::{LineWrite, Shared};

/// How long a connection attempt to one address may take.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(3);

/// How long an RFC 2217 server has to agree to COM-port control and to answer a
/// COM-port command.
pub const NEGOTIATION_TIMEOUT: Duration = Duration::from_secs(3);

/// How long a read or a write waits before checking whether to stop.
const IO_TIMEOUT: Duration = Duration::from_millis(50);

/// How the bytes travel on the socket.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Mode {
    /// Raw TCP.
    Raw,
    /// Telnet with COM-port control (RFC 2217).
    Rfc2217,
}

/// Connects to a serial device server.
pub(super) struct NetConnector {
    address: NetAddress,
    mode: Mode,
}

impl NetConnector {
    pub(super) fn new(address: NetAddress, mode: Mode) -> Self {
        Self { address, mode }
    }
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Opens a TCP connection to `address` (each resolved address in turn) with
/// `TCP_NODELAY` and short read/write timeouts.
///
/// # Errors
/// Why not, naming `host:port`.
pub fn connect(address: &NetAddress) -> Result<TcpStream, String> {
    let authority = address.authority();
    let resolved: Vec<SocketAddr> = (address.host.as_str(), address.port)
        .to_socket_addrs()
        .map_err(|err| format!("cannot resolve {authority}: {err}"))?
        .collect();
    let mut last = format!("cannot resolve {authority}: no address");
    for socket in resolved {
        match TcpStream::connect_timeout(&socket, CONNECT_TIMEOUT) {
            Ok(stream) => {
                let setup = stream
                    .set_nodelay(true)
                    .and_then(|()| stream.set_read_timeout(Some(IO_TIMEOUT)))
                    .and_then(|()| stream.set_write_timeout(Some(IO_TIMEOUT)));
                return setup
                    .map(|()| stream)
                    .map_err(|err| format!("cannot set up the connection to {authority}: {err}"));
            }
            Err(err) => last = format!("cannot connect to {authority}: {err}"),
        }
    }
    Err(last)
}

/// What the reader learnt of the RFC 2217 negotiation, for the writer.
#[derive(Debug, Default)]
struct ComPortState {
    agreement: Option<ComPortAgreement>,
    /// The latest answer to each command.
    replies: Vec<ComPortReply>,
}

/// The RFC 2217 state both ends of a connection share.
#[derive(Debug, Default)]
struct ComPort {
    state: Mutex<ComPortState>,
    changed: Condvar,
}

impl ComPort {
    /// Waits until `ready` says yes (its answer), the connection is lost, or
    /// `NEGOTIATION_TIMEOUT` passes (`None`).
    fn wait_for<T>(
        &self,
        lost: &AtomicBool,
        mut ready: impl FnMut(&ComPortState) -> Option<T>,
    ) -> Option<T> {
        let deadline = Instant::now() + NEGOTIATION_TIMEOUT;
        let mut state = lock(&self.state);
        loop {
            if let Some(answer) = ready(&state) {
                return Some(answer);
            }
            let now = Instant::now();
            if now >= deadline || lost.load(Ordering::Acquire) {
                return None;
            }
            state = self
                .changed
                .wait_timeout(state, (deadline - now).min(IO_TIMEOUT))
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .0;
        }
    }

    fn forget(&self, command: u8) {
        lock(&self.state)
            .replies
            .retain(|reply| reply.command != command);
    }
}

impl Connector for NetConnector {
    type Line = NetLine;
    type Reader = NetReader;

    fn connect(
        &mut self,
        shared: &Arc<Shared>,
        lost: &Arc<AtomicBool>,
        _baud: u32,
    ) -> Result<(NetLine, NetReader), String> {
        let authority = self.address.authority();
        let stream = connect(&self.address)?;
        let reading = stream
            .try_clone()
            .map_err(|err| format!("cannot read from {authority}: {err}"))?;
        let writer = Arc::new(Mutex::new(stream));
        let telnet = match self.mode {
            Mode::Raw => None,
            Mode::Rfc2217 => {
                let mut options = Options::new();
                let start = options.start();
                write_watching(&mut *lock(&writer), &start, shared, lost)
                    .map_err(|err| format!("write to {authority} failed: {err}"))?;
                Some(TelnetReader {
                    decoder: Decoder::new(),
                    options,
                    com_port: Arc::new(ComPort::default()),
                    writer: Arc::clone(&writer),
                    scratch: Vec::new(),
                    events: Vec::new(),
                })
            }
        };
        let com_port = telnet.as_ref().map(|telnet| Arc::clone(&telnet.com_port));
        Ok((
            NetLine {
                writer,
                authority: authority.clone(),
                com_port,
                escaped: Vec::new(),
                shared: Arc::clone(shared),
                lost: Arc::clone(lost),
            },
            NetReader {
                stream: reading,
                authority,
                telnet,
                raw: Vec::new(),
            },
        ))
    }

    /// RFC 2217: waits for the server to take up COM-port control, then sets the line
    /// to `baud`, 8 data bits, no parity, one stop bit, no flow control, each answer
    /// checked.
    fn prepare(&mut self, line: &mut NetLine, baud: u32) -> Result<(), String> {
        let Some(com_port) = line.com_port.clone() else {
            return Ok(());
        };
        let authority = line.authority.clone();
        let agreement = com_port.wait_for(&line.lost, |state| state.agreement);
        match agreement {
            Some(ComPortAgreement::Agreed) => {}
            Some(ComPortAgreement::Refused) => {
                return Err(format!(
                    "{authority} refuses COM-port control (RFC 2217); if it is a raw TCP \
                     port, write tcp://{authority}"
                ));
            }
            None => {
                return Err(format!(
                    "{authority} did not take up COM-port control (RFC 2217) within {} s; if \
                     it is a raw TCP port, write tcp://{authority}",
                    NEGOTIATION_TIMEOUT.as_secs()
                ));
            }
        }
        line.command(
            telnet::SET_BAUDRATE,
            &telnet::set_baud(baud),
            &baud.to_be_bytes(),
        )?;
        line.command(telnet::SET_DATASIZE, &telnet::set_datasize(8), &[8])?;
        line.command(
            telnet::SET_PARITY,
            &telnet::set_parity(telnet::PARITY_NONE),
            &[telnet::PARITY_NONE],
        )?;
        line.command(
            telnet::SET_STOPSIZE,
            &telnet::set_stopsize(telnet::STOPSIZE_ONE),
            &[telnet::STOPSIZE_ONE],
        )?;
        line.command(
            telnet::SET_CONTROL,
            &telnet::set_control(telnet::CONTROL_NONE),
            &[telnet::CONTROL_NONE],
        )?;
        tracing::info!("{authority}: RFC 2217 line set to {baud} baud, 8N1, no flow control");
        Ok(())
    }
}

/// The Telnet half of the reader.
struct TelnetReader {
    decoder: Decoder,
    options: Options,
    com_port: Arc<ComPort>,
    writer: Arc<Mutex<TcpStream>>,
    scratch: Vec<u8>,
    events: Vec<telnet::Event>,
}

/// The reader's end of a connection.
pub(super) struct NetReader {
    stream: TcpStream,
    authority: String,
    telnet: Option<TelnetReader>,
    raw: Vec<u8>,
}

impl LineRead for NetReader {
    fn read_some(&mut self, buffer: &mut [u8]) -> Result<usize, String> {
        let Some(telnet) = self.telnet.as_mut() else {
            return read_raw(&mut self.stream, &self.authority, buffer);
        };
        self.raw.resize(buffer.len(), 0);
        let n = read_raw(&mut self.stream, &self.authority, &mut self.raw)?;
        telnet.scratch.clear();
        telnet.events.clear();
        telnet
            .decoder
            .push(&self.raw[..n], &mut telnet.scratch, &mut telnet.events);
        for event in telnet.events.drain(..) {
            tracing::debug!("{}: telnet {event:?}", self.authority);
            let handled = telnet.options.handle(event);
            if !handled.reply.is_empty() {
                lock(&telnet.writer)
                    .write_all(&handled.reply)
                    .map_err(|err| format!("write to {} failed: {err}", self.authority))?;
            }
            if handled.agreement.is_some() || handled.com_port.is_some() {
                let mut state = lock(&telnet.com_port.state);
                if let Some(agreement) = handled.agreement {
                    state.agreement = Some(agreement);
                }
                if let Some(reply) = handled.com_port {
                    state.replies.retain(|old| old.command != reply.command);
                    state.replies.push(reply);
                }
                drop(state);
                telnet.com_port.changed.notify_all();
            }
        }
        // Decoding only shrinks the bytes: the data fits where they were read.
        let data = &telnet.scratch[..telnet.scratch.len().min(buffer.len())];
        buffer[..data.len()].copy_from_slice(data);
        Ok(data.len())
    }
}

/// Reads from a socket: `Ok(0)` when nothing came within the timeout; a closed
/// connection is an `Err`.
fn read_raw(stream: &mut TcpStream, authority: &str, buffer: &mut [u8]) -> Result<usize, String> {
    match stream.read(buffer) {
        Ok(0) => Err(format!(
            "the device server at {authority} closed the connection"
        )),
        Ok(n) => Ok(n),
        Err(err)
            if matches!(
                err.kind(),
                std::io::ErrorKind::TimedOut
                    | std::io::ErrorKind::WouldBlock
                    | std::io::ErrorKind::Interrupted
            ) =>
        {
            Ok(0)
        }
        Err(err) => Err(format!("reading from {authority} failed: {err}")),
    }
}

/// The writer's end of a connection.
pub(super) struct NetLine {
    /// Shared with the reader, which answers the server's Telnet requests on it.
    writer: Arc<Mutex<TcpStream>>,
    authority: String,
    /// RFC 2217's state; `None` for raw TCP.
    com_port: Option<Arc<ComPort>>,
    escaped: Vec<u8>,
    shared: Arc<Shared>,
    lost: Arc<AtomicBool>,
}

impl NetLine {
    fn write_bytes(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        write_watching(&mut *lock(&self.writer), bytes, &self.shared, &self.lost)
            .map_err(|err| std::io::Error::new(err.kind(), format!("{}: {err}", self.authority)))
    }

    /// Sends an RFC 2217 `command` and waits for the server's answer, which must be
    /// `expected`; `Err` says what the server did instead.
    fn command(&mut self, code: u8, command: &[u8], expected: &[u8]) -> Result<(), String> {
        let Some(com_port) = self.com_port.clone() else {
            return Ok(());
        };
        let authority = self.authority.clone();
        com_port.forget(code);
        self.write_bytes(command)
            .map_err(|err| format!("write failed: {err}"))?;
        let what = match code {
            telnet::SET_BAUDRATE => "the line speed",
            telnet::SET_DATASIZE => "8 data bits",
            telnet::SET_PARITY => "no parity",
            telnet::SET_STOPSIZE => "one stop bit",
            _ => "no flow control",
        };
        let answer = com_port.wait_for(&self.lost, |state| {
            state
                .replies
                .iter()
                .find(|reply| reply.command == code)
                .cloned()
        });
        match answer {
            Some(reply) if reply.value == expected => Ok(()),
            Some(reply) => Err(match (reply.baud(), code) {
                (Some(set), telnet::SET_BAUDRATE) => format!(
                    "{authority} refused {what} of {} baud (RFC 2217): the line runs at {set} baud",
                    u32::from_be_bytes(expected.try_into().unwrap_or_default())
                ),
                _ => format!(
                    "{authority} refused {what} (RFC 2217): it answered {:?}",
                    reply.value
                ),
            }),
            None => Err(format!(
                "{authority} did not answer the request for {what} (RFC 2217) within {} s",
                NEGOTIATION_TIMEOUT.as_secs()
            )),
        }
    }
}

impl LineWrite for NetLine {
    /// Writes the whole instruction (RFC 2217: with every 0xFF doubled).
    fn write_instruction(&mut self, instruction: &[u8]) -> std::io::Result<()> {
        if self.com_port.is_none() {
            return self.write_bytes(instruction);
        }
        let mut escaped = std::mem::take(&mut self.escaped);
        escaped.clear();
        telnet::escape(instruction, &mut escaped);
        let written = self.write_bytes(&escaped);
        self.escaped = escaped;
        written
    }

    /// RFC 2217: SET-BAUDRATE, the server's answer awaited. A raw TCP server's line
    /// speed is set on the server, so that is refused.
    fn set_baud(&mut self, baud: u32) -> std::io::Result<()> {
        if self.com_port.is_none() {
            return Err(std::io::Error::other(RAW_BAUD));
        }
        self.command(
            telnet::SET_BAUDRATE,
            &telnet::set_baud(baud),
            &baud.to_be_bytes(),
        )
        .map_err(std::io::Error::other)
    }

    /// A real gateway is power-cycled by the installer.
    fn restart_gateway(&mut self) -> bool {
        false
    }
}

/// Why a raw TCP link cannot change its line speed.
pub const RAW_BAUD: &str = "the line speed of a raw TCP (tcp://) device server is set on the \
                            server; use rfc2217:// to let the bridge set it";
