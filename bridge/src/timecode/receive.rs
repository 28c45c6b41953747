//! The timecode receivers: Art-Net on a UDP socket (a task), MTC from a raw MIDI
//! device read on a blocking thread. Each hands [`Sample`]s, stamped with their
//! arrival, to the chase task over a channel; neither holds any state but its
//! decoder.
//!
//! The Art-Net socket is bound with `SO_REUSEADDR`, so that other Art-Net software on
//! the same host (a lighting desk, `olad`) may listen on port 6454 too — broadcast
//! timecode reaches every socket. It reads every Art-Net packet and dispatches on the
//! OpCode ([`artnet::decode`]): OpTimeCode to the chase; everything else (OpDmx,
//! OpPoll…, and what is not Art-Net at all) to live input ([`crate::live`]) when it
//! takes Art-Net on the same address — one socket, one reader.

use std::io::Read;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use floatball_shared::timecode::Timecode;
use floatball_shared::timecode::artnet::{self, Packet};
use floatball_shared::timecode::mtc::{Direction, MtcDecoder, MtcEvent};
use tokio::net::UdpSocket;
use tokio::sync::{mpsc, watch};
use tokio::time::Instant;

/// One timecode as it arrived.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sample {
    /// The timecode runs and is here.
    Running(Timecode),
    /// The timecode is here and stands (MTC's full frame, or running backward).
    Parked(Timecode),
}

/// Binds the Art-Net socket on `listen`, shared with other Art-Net listeners on the
/// host (`SO_REUSEADDR`), broadcast allowed.
///
/// # Errors
/// The address cannot be bound.
pub fn bind_artnet(listen: SocketAddr) -> std::io::Result<UdpSocket> {
    use socket2::{Domain, Protocol, Socket, Type};
    let socket = Socket::new(
        Domain::for_address(listen),
        Type::DGRAM,
        Some(Protocol::UDP),
    )?;
    socket.set_reuse_address(true)?;
    socket.set_broadcast(true)?;
    socket.set_nonblocking(true)?;
    socket.bind(&listen.into())?;
    UdpSocket::from_std(socket.into())
}

/// Reads Art-Net from `socket` until the bridge stops: timecode to `samples`, every
/// other datagram to `live` (live input sharing the socket), if given.
pub async fn artnet(
    socket: Arc<UdpSocket>,
    samples: mpsc::Sender<(Sample, Instant)>,
    mut live: Option<crate::live::Feed>,
    mut stopping: watch::Receiver<bool>,
) {
    let mut buffer = vec![0u8; 2048];
    let mut logged_other = false;
    loop {
        let received = tokio::select! {
            _ = stopping.changed() => return,
            received = socket.recv_from(&mut buffer) => received,
        };
        let at = Instant::now();
        let (length, sender) = match received {
            Ok(received) => received,
            Err(error) => {
                tracing::debug!("Art-Net: receiving: {error}");
                continue;
            }
        };
        let datagram = buffer.get(..length).unwrap_or_default();
        let decoded = artnet::decode(datagram);
        if let Some(feed) = &live
            && !matches!(decoded, Ok(Packet::TimeCode { .. }))
        {
            if !feed.offer(crate::live::Protocol::Artnet, datagram, sender, at) {
                live = None;
            }
            continue;
        }
        match decoded {
            Ok(Packet::TimeCode { timecode, .. }) => {
                if samples.try_send((Sample::Running(timecode), at)).is_err() && samples.is_closed()
                {
                    return;
                }
            }
            Ok(Packet::Other { opcode }) => {
                // OpDmx, OpPoll…: not read yet (a later Art-Net input takes them here).
                if !logged_other {
                    logged_other = true;
                    tracing::debug!("Art-Net from {sender}: OpCode {opcode:#06x} not read");
                }
            }
            Err(error) => tracing::debug!("Art-Net from {sender}: {error}"),
        }
    }
}

/// How long the MTC reader waits before opening its device again (it cannot be
/// opened, or a FIFO's writer closed it).
const REOPEN: Duration = Duration::from_millis(200);

/// Reads MIDI timecode from `device` on a thread of its own until the chase task is
/// gone: the device is opened again whenever it ends or fails (a FIFO whose writer
/// closed, a MIDI interface unplugged), its failure logged once until it opens.
pub fn spawn_mtc(device: PathBuf, samples: mpsc::Sender<(Sample, Instant)>) {
    let spawned = std::thread::Builder::new()
        .name("mtc".to_owned())
        .spawn(move || {
            let mut failing = false;
            let mut buffer = [0u8; 256];
            while !samples.is_closed() {
                let mut file = match std::fs::File::open(&device) {
                    Ok(file) => {
                        if failing {
                            tracing::info!("MTC: reading {}", device.display());
                        }
                        failing = false;
                        file
                    }
                    Err(error) => {
                        if !failing {
                            tracing::warn!("MTC: cannot open {}: {error}", device.display());
                        }
                        failing = true;
                        std::thread::sleep(REOPEN);
                        continue;
                    }
                };
                let mut decoder = MtcDecoder::new();
                loop {
                    let length = match file.read(&mut buffer) {
                        Ok(0) => break,
                        Ok(length) => length,
                        Err(error) => {
                            tracing::warn!("MTC: reading {}: {error}", device.display());
                            break;
                        }
                    };
                    let at = Instant::now();
                    for event in decoder.push_all(buffer.get(..length).unwrap_or_default()) {
                        let sample = match event {
                            MtcEvent::QuarterFrames {
                                timecode,
                                direction: Direction::Forward,
                            } => Sample::Running(timecode),
                            MtcEvent::QuarterFrames { timecode, .. }
                            | MtcEvent::FullFrame(timecode) => Sample::Parked(timecode),
                        };
                        if samples.try_send((sample, at)).is_err() && samples.is_closed() {
                            return;
                        }
                    }
                }
                std::thread::sleep(REOPEN);
            }
        });
    if let Err(error) = spawned {
        tracing::error!("MTC: cannot start the reader: {error}");
    }
}
