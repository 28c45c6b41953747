//! `floatball simulate`: a simulated gateway on the far end of a real serial device —
//! for tests with a pseudo-terminal pair, and for demonstrations with two serial
//! adapters and a null-modem cable.
//!
//! It answers exactly as the in-process simulated gateway does ([`SimEngine`]): bytes
//! are handed to the gateway as they arrive, and its answers are written no faster than
//! the line's baud rate carries them.

use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::{Duration, Instant};

use floatball_shared::sim::GatewayConfig;

use crate::link::serial::open_port;
use crate::link::sim::SimEngine;

/// What to simulate, and where.
#[derive(Debug, Clone)]
pub struct SimulateOptions {
    /// The serial device to answer on.
    pub port: String,
    /// Its baud rate.
    pub baud: u32,
    /// The units behind the gateway.
    pub gateway: GatewayConfig,
}

/// Answers on `options.port` until `stop` is set or the port fails; `ready` is called
/// once the port is open.
///
/// # Errors
/// The port cannot be opened, or reading or writing it fails.
pub fn run(
    options: &SimulateOptions,
    stop: &Arc<AtomicBool>,
    ready: impl FnOnce(),
) -> Result<(), String> {
    let mut port = open_port(&options.port, options.baud)?;
    let mut reader = port
        .try_clone()
        .map_err(|err| format!("cannot read from {}: {err}", options.port))?;
    let mut engine = SimEngine::new(options.gateway.clone(), options.baud)?;
    let (arrivals, arrived) = channel::<Result<(Instant, Vec<u8>), String>>();
    let reader_stop = Arc::clone(stop);
    std::thread::Builder::new()
        .name("simulate-read".to_owned())
        .spawn(move || {
            let mut buffer = [0u8; 1024];
            while !reader_stop.load(Ordering::Acquire) {
                let result = match reader.read(&mut buffer) {
                    Ok(0) => continue,
                    Ok(n) => Ok((Instant::now(), buffer[..n].to_vec())),
                    Err(err) if err.kind() == std::io::ErrorKind::TimedOut => continue,
                    Err(err) if err.kind() == std::io::ErrorKind::Interrupted => continue,
                    Err(err) => Err(format!("read failed: {err}")),
                };
                let failed = result.is_err();
                if arrivals.send(result).is_err() || failed {
                    return;
                }
            }
        })
        .map_err(|err| format!("cannot start the reader thread: {err}"))?;
    ready();
    let mut answers = Vec::new();
    while !stop.load(Ordering::Acquire) {
        let now = Instant::now();
        let wait = engine
            .next_wakeup(now)
            .saturating_duration_since(now)
            .min(Duration::from_millis(50));
        match arrived.recv_timeout(wait) {
            Ok(Ok((at, bytes))) => engine.receive(at, &bytes),
            Ok(Err(reason)) => return Err(reason),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return Err("the reader stopped".to_owned()),
        }
        answers.clear();
        engine.step(Instant::now(), &mut answers);
        if !answers.is_empty() {
            port.write_all(&answers)
                .map_err(|err| format!("write failed: {err}"))?;
        }
    }
    Ok(())
}
