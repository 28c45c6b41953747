//! The live input's readers: each reads one UDP socket and hands every datagram, with
//! its sender and arrival, to the live task ([`super::Feed`]); they hold no state.
//! Art-Net's socket is the timecode chase's when both take Art-Net on the same
//! address (its reader, [`crate::timecode::receive::artnet`], then hands over what is
//! not timecode); otherwise [`read`] reads it. sACN's socket ([`bind_sacn`]) takes
//! unicast and, once the live task joins their groups, multicast.

use std::net::SocketAddr;
use std::sync::Arc;

use tokio::net::UdpSocket;
use tokio::sync::watch;
use tokio::time::Instant;

use super::{Feed, Protocol};

/// The largest datagram read: an sACN universe discovery packet is 1144 bytes.
const MAX_DATAGRAM: usize = 2048;

/// Binds the sACN socket on `listen`, shared with other sACN receivers on the host
/// (`SO_REUSEADDR`: multicast reaches every member socket).
///
/// # Errors
/// The address cannot be bound.
pub fn bind_sacn(listen: SocketAddr) -> std::io::Result<UdpSocket> {
    use socket2::{Domain, Protocol as IpProtocol, Socket, Type};
    let socket = Socket::new(
        Domain::for_address(listen),
        Type::DGRAM,
        Some(IpProtocol::UDP),
    )?;
    socket.set_reuse_address(true)?;
    socket.set_nonblocking(true)?;
    socket.bind(&listen.into())?;
    UdpSocket::from_std(socket.into())
}

/// Reads `socket` until the bridge stops or the live task is gone, handing every
/// datagram to `feed` as `protocol`.
pub async fn read(
    socket: Arc<UdpSocket>,
    protocol: Protocol,
    feed: Feed,
    mut stopping: watch::Receiver<bool>,
) {
    let mut buffer = vec![0u8; MAX_DATAGRAM];
    loop {
        let received = tokio::select! {
            _ = stopping.changed() => return,
            received = socket.recv_from(&mut buffer) => received,
        };
        let at = Instant::now();
        match received {
            Ok((length, from)) => {
                if !feed.offer(protocol, buffer.get(..length).unwrap_or_default(), from, at) {
                    return;
                }
            }
            Err(error) => tracing::debug!("{protocol:?}: receiving: {error}"),
        }
    }
}
