//! Links to gateways behind a serial device server on the network: `tcp://host:port`
//! (raw TCP: the bytes on the socket are the line's bytes — ser2net's `accepter:
//! tcp,PORT`, a Moxa-style "TCP server" mode) and `rfc2217://host:port` (Telnet with
//! COM-port control: the bridge sets the remote line's speed and 8N1 without flow
//! control, and moves the speed on [`super::Link::change_baud`]).
//!
//! The link behaves exactly like a serial one: the same [`supervisor`](super::supervisor)
//! (connect, greet, `Down` with a reason naming `host:port` when the connection is lost,
//! everything queued dropped, reconnect with backoff, the stop first after a reconnect
//! while the e-stop is latched) and the same writer ([`super::writer::Drive`]), paced to
//! the *remote* line's speed, so the device server holds no more than the write in
//! flight and the driver's short window ([`super::driver`]). `TCP_NODELAY` is set: a
//! write leaves at once instead of waiting for the previous one's acknowledgement.
//!
//! **One owner.** A connection is a [`NetIo`]: the socket (non-blocking), the Telnet
//! state and the feedback decoder, owned by whoever serves the line at the moment — the
//! supervisor thread while it sets the line up or changes its speed, the network driver
//! while the line streams. It reads, answers the server's Telnet requests and writes
//! itself, so nothing is locked and nothing waits on another thread: a socket that
//! takes nothing keeps its bytes in a backlog and holds up only its own link.
//!
//! The Telnet part (IAC escaping, negotiation, RFC 2217 commands) is [`super::telnet`].

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream, ToSocketAddrs};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use floatball_shared::plan::port::NetAddress;
use floatball_shared::uim2503::ascii::GreetingWatch;
use floatball_shared::uim2503::feedback::FrameDecoder;

use super::driver::{self, Back, Session};
use super::supervisor::Connector;
use super::telnet::{self, ComPortAgreement, ComPortReply, Decoder, Options};
use super::writer::{Drive, LineWrite};
use super::{Input, Shared};

/// How long a connection attempt to one address may take.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(3);

/// How long an RFC 2217 server has to agree to COM-port control and to answer a
/// COM-port command.
pub const NEGOTIATION_TIMEOUT: Duration = Duration::from_secs(3);

/// How often a wait for the server (set-up, a speed change) reads the socket and looks
/// at the e-stop latch.
const POLL: Duration = Duration::from_millis(5);

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

/// Opens a TCP connection to `address` (each resolved address in turn) with
/// `TCP_NODELAY`, non-blocking.
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
                    .and_then(|()| stream.set_nonblocking(true));
                return setup
                    .map(|()| stream)
                    .map_err(|err| format!("cannot set up the connection to {authority}: {err}"));
            }
            Err(err) => last = format!("cannot connect to {authority}: {err}"),
        }
    }
    Err(last)
}

/// The Telnet side of an RFC 2217 connection.
struct Telnet {
    decoder: Decoder,
    options: Options,
    agreement: Option<ComPortAgreement>,
    /// The latest answer to each command.
    replies: Vec<ComPortReply>,
    events: Vec<telnet::Event>,
}

/// One connection to a device server, owned by whoever serves the line.
pub(super) struct NetIo {
    stream: mio::net::TcpStream,
    authority: String,
    /// RFC 2217's state; `None` for raw TCP.
    telnet: Option<Telnet>,
    /// Bytes handed over that the socket has not taken yet.
    backlog: Vec<u8>,
    escaped: Vec<u8>,
    raw: Vec<u8>,
    data: Vec<u8>,
    feedback: FrameDecoder,
    greetings: GreetingWatch,
}

/// How much one read takes at most.
const READ_CHUNK: usize = 4096;

impl NetIo {
    fn new(stream: TcpStream, authority: String, mode: Mode) -> Self {
        let telnet = match mode {
            Mode::Raw => None,
            Mode::Rfc2217 => Some(Telnet {
                decoder: Decoder::new(),
                options: Options::new(),
                agreement: None,
                replies: Vec::new(),
                events: Vec::new(),
            }),
        };
        Self {
            stream: mio::net::TcpStream::from_std(stream),
            authority,
            telnet,
            backlog: Vec::new(),
            escaped: Vec::new(),
            raw: vec![0; READ_CHUNK],
            data: Vec::new(),
            feedback: FrameDecoder::new(),
            greetings: GreetingWatch::new(),
        }
    }

    /// The socket, for the driver to watch.
    pub(super) fn source(&mut self) -> &mut mio::net::TcpStream {
        &mut self.stream
    }

    /// Queues `bytes` as they go on the socket and hands on what the socket takes.
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.backlog.extend_from_slice(bytes);
        self.flush()
    }

    /// Hands the socket as much of the backlog as it takes now.
    fn flush(&mut self) -> std::io::Result<()> {
        while !self.backlog.is_empty() {
            match self.stream.write(&self.backlog) {
                Ok(0) => break,
                Ok(n) => {
                    self.backlog.drain(..n);
                }
                Err(err) if err.kind() == std::io::ErrorKind::WouldBlock => break,
                Err(err) if err.kind() == std::io::ErrorKind::Interrupted => {}
                Err(err) => {
                    return Err(std::io::Error::new(
                        err.kind(),
                        format!("{}: {err}", self.authority),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Reads everything that came in: Telnet requests answered, COM-port answers kept,
    /// the line's bytes to the greeting watch and the feedback decoder.
    fn read_all(&mut self, shared: &Shared) -> std::io::Result<()> {
        loop {
            let n = match self.stream.read(&mut self.raw) {
                Ok(0) => {
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::UnexpectedEof,
                        format!(
                            "the device server at {} closed the connection",
                            self.authority
                        ),
                    ));
                }
                Ok(n) => n,
                Err(err) if err.kind() == std::io::ErrorKind::WouldBlock => return Ok(()),
                Err(err) if err.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(err) => {
                    return Err(std::io::Error::new(
                        err.kind(),
                        format!("reading from {} failed: {err}", self.authority),
                    ));
                }
            };
            let Some(telnet) = self.telnet.as_mut() else {
                shared.heard(&mut self.greetings, &mut self.feedback, &self.raw[..n]);
                continue;
            };
            self.data.clear();
            telnet
                .decoder
                .push(&self.raw[..n], &mut self.data, &mut telnet.events);
            let mut replies = Vec::new();
            for event in telnet.events.drain(..) {
                tracing::debug!("{}: telnet {event:?}", self.authority);
                let handled = telnet.options.handle(event);
                replies.extend_from_slice(&handled.reply);
                if let Some(agreement) = handled.agreement {
                    telnet.agreement = Some(agreement);
                }
                if let Some(reply) = handled.com_port {
                    telnet.replies.retain(|old| old.command != reply.command);
                    telnet.replies.push(reply);
                }
            }
            if !self.data.is_empty() {
                shared.heard(&mut self.greetings, &mut self.feedback, &self.data);
            }
            if !replies.is_empty() {
                self.send(&replies)?;
            }
        }
    }

    /// Waits (reading) until `ready` finds its answer in the Telnet state, the line is
    /// lost or [`NEGOTIATION_TIMEOUT`] passes (`Ok(None)`). A pressed e-stop is written
    /// at once meanwhile (the writer writes it again when it next runs: the stop is
    /// inert).
    fn wait_for<T>(
        &mut self,
        shared: &Shared,
        lost: &AtomicBool,
        mut ready: impl FnMut(&Telnet) -> Option<T>,
    ) -> std::io::Result<Option<T>> {
        let deadline = Instant::now() + NEGOTIATION_TIMEOUT;
        let mut seen_generation = shared.config.latch.generation();
        loop {
            self.read_all(shared)?;
            self.flush()?;
            if let Some(answer) = self.telnet.as_ref().and_then(&mut ready) {
                return Ok(Some(answer));
            }
            let generation = shared.config.latch.generation();
            if generation != seen_generation {
                seen_generation = generation;
                let stop = shared.config.estop.as_bytes().to_vec();
                self.write_instruction(&stop)?;
            }
            if Instant::now() >= deadline || lost.load(Ordering::Acquire) || shared.is_closed() {
                return Ok(None);
            }
            std::thread::park_timeout(POLL);
        }
    }

    /// Sends an RFC 2217 `command` and waits for the server's answer, which must be
    /// `expected`; `Err` says what the server did instead.
    fn command(
        &mut self,
        shared: &Shared,
        lost: &AtomicBool,
        code: u8,
        command: &[u8],
        expected: &[u8],
    ) -> Result<(), String> {
        let authority = self.authority.clone();
        let Some(telnet) = self.telnet.as_mut() else {
            return Ok(());
        };
        telnet.replies.retain(|reply| reply.command != code);
        self.send(command)
            .map_err(|err| format!("write failed: {err}"))?;
        let what = match code {
            telnet::SET_BAUDRATE => "the line speed",
            telnet::SET_DATASIZE => "8 data bits",
            telnet::SET_PARITY => "no parity",
            telnet::SET_STOPSIZE => "one stop bit",
            _ => "no flow control",
        };
        let answer = self
            .wait_for(shared, lost, |telnet| {
                telnet
                    .replies
                    .iter()
                    .find(|reply| reply.command == code)
                    .cloned()
            })
            .map_err(|err| err.to_string())?;
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

    /// RFC 2217: offers COM-port control, waits for the server to take it up, then sets
    /// the line to `baud`, 8 data bits, no parity, one stop bit, no flow control, each
    /// answer checked. Raw TCP: nothing to do.
    fn prepare(&mut self, shared: &Shared, lost: &AtomicBool, baud: u32) -> Result<(), String> {
        let authority = self.authority.clone();
        let Some(telnet) = self.telnet.as_mut() else {
            return Ok(());
        };
        let start = telnet.options.start();
        self.send(&start)
            .map_err(|err| format!("write to {authority} failed: {err}"))?;
        let agreement = self
            .wait_for(shared, lost, |telnet| telnet.agreement)
            .map_err(|err| err.to_string())?;
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
        let settings: [(u8, Vec<u8>, Vec<u8>); 5] = [
            (
                telnet::SET_BAUDRATE,
                telnet::set_baud(baud),
                baud.to_be_bytes().to_vec(),
            ),
            (telnet::SET_DATASIZE, telnet::set_datasize(8), vec![8]),
            (
                telnet::SET_PARITY,
                telnet::set_parity(telnet::PARITY_NONE),
                vec![telnet::PARITY_NONE],
            ),
            (
                telnet::SET_STOPSIZE,
                telnet::set_stopsize(telnet::STOPSIZE_ONE),
                vec![telnet::STOPSIZE_ONE],
            ),
            (
                telnet::SET_CONTROL,
                telnet::set_control(telnet::CONTROL_NONE),
                vec![telnet::CONTROL_NONE],
            ),
        ];
        for (code, command, expected) in settings {
            self.command(shared, lost, code, &command, &expected)?;
        }
        tracing::info!("{authority}: RFC 2217 line set to {baud} baud, 8N1, no flow control");
        Ok(())
    }
}

/// A [`NetIo`] with what a line-speed change needs to wait for the server.
pub(super) struct NetLine<'a> {
    pub(super) io: &'a mut NetIo,
    pub(super) lost: &'a AtomicBool,
    pub(super) shared: &'a Shared,
}

impl LineWrite for NetIo {
    /// Hands the bytes to the socket (RFC 2217: with every 0xFF doubled); what it does
    /// not take now stays in the backlog.
    fn write_instruction(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        if self.telnet.is_none() {
            return self.send(bytes);
        }
        let mut escaped = std::mem::take(&mut self.escaped);
        escaped.clear();
        telnet::escape(bytes, &mut escaped);
        let sent = self.send(&escaped);
        self.escaped = escaped;
        sent
    }

    /// Only a line-speed change sets the speed, through [`NetLine`].
    fn set_baud(&mut self, _baud: u32) -> std::io::Result<()> {
        Err(std::io::Error::other(RAW_BAUD))
    }

    /// A real gateway is power-cycled by the installer.
    fn restart_gateway(&mut self) -> bool {
        false
    }

    fn backlog(&self) -> usize {
        self.backlog.len()
    }

    fn service(&mut self, shared: &Shared) -> std::io::Result<()> {
        self.flush()?;
        self.read_all(shared)
    }
}

impl LineWrite for NetLine<'_> {
    fn write_instruction(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.io.write_instruction(bytes)
    }

    /// RFC 2217: SET-BAUDRATE, the server's answer awaited. A raw TCP server's line
    /// speed is set on the server, so that is refused.
    fn set_baud(&mut self, baud: u32) -> std::io::Result<()> {
        if self.io.telnet.is_none() {
            return Err(std::io::Error::other(RAW_BAUD));
        }
        self.io
            .command(
                self.shared,
                self.lost,
                telnet::SET_BAUDRATE,
                &telnet::set_baud(baud),
                &baud.to_be_bytes(),
            )
            .map_err(std::io::Error::other)
    }

    fn restart_gateway(&mut self) -> bool {
        false
    }

    fn backlog(&self) -> usize {
        self.io.backlog()
    }

    fn service(&mut self, shared: &Shared) -> std::io::Result<()> {
        self.io.service(shared)
    }
}

impl Connector for NetConnector {
    type Connection = NetIo;

    fn connect(
        &mut self,
        _shared: &Arc<Shared>,
        _lost: &Arc<AtomicBool>,
        _baud: u32,
    ) -> Result<NetIo, String> {
        let stream = connect(&self.address)?;
        Ok(NetIo::new(stream, self.address.authority(), self.mode))
    }

    /// Sets the line up (RFC 2217), then hands it to the network driver until it is
    /// lost; a line-speed change comes back here and is carried out on this thread.
    fn serve(
        &mut self,
        shared: &Arc<Shared>,
        inbox: Receiver<Input>,
        mut io: NetIo,
        lost: &Arc<AtomicBool>,
    ) -> (Receiver<Input>, String) {
        if let Err(reason) = io.prepare(shared, lost, shared.baud()) {
            return (inbox, reason);
        }
        let mut session = Session {
            drive: Drive::new(shared, Instant::now()),
            shared: Arc::clone(shared),
            inbox,
            io,
            lost: Arc::clone(lost),
            lost_reason: None,
        };
        loop {
            let (returned, back) = match driver::drive(session) {
                Ok(returned) => returned,
                Err(inbox) => return (inbox, "the network driver stopped".to_owned()),
            };
            session = returned;
            let reason = match back {
                Back::Done(reason) => reason,
                Back::ChangeBaud => {
                    let mut line = NetLine {
                        io: &mut session.io,
                        lost: &session.lost,
                        shared,
                    };
                    match session.drive.change_baud(shared, &mut line, &session.lost) {
                        Ok(()) => continue,
                        Err(err) => format!("write failed: {err}"),
                    }
                }
            };
            session.drive.finish(shared, &session.inbox, &reason);
            return (session.inbox, reason);
        }
    }
}

/// Why a raw TCP link cannot change its line speed.
pub const RAW_BAUD: &str = "the line speed of a raw TCP (tcp://) device server is set on the \
                            server; use rfc2217:// to let the bridge set it";
