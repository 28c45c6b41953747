//! An SCL link on an RS-485 line through the `serialport` crate (8N1, no flow
//! control, as the drives ship): the owner writes addressed requests; a reader
//! thread cuts what the drives send into lines at each carriage return and hands them
//! to the owner.

use std::io::{Read, Write};
use std::sync::mpsc::Sender;
use std::time::Duration;

use floatball_shared::scl::{CR, Command, Request};
use serialport::SerialPort;

use super::{Event, LinkShared, Opener, Transport};

/// The longest answer line kept; a longer run of bytes without a CR is noise.
const MAX_LINE: usize = 256;

/// How long a read waits before it looks whether the link was closed.
const READ_TIMEOUT: Duration = Duration::from_millis(50);

struct SerialLine {
    port: Box<dyn SerialPort>,
}

impl Transport for SerialLine {
    fn send(&mut self, shared: &LinkShared, drive: usize, text: &str) -> std::io::Result<()> {
        let mut bytes = Vec::with_capacity(text.len() + 2);
        if let Some(address) = shared.drives.get(drive).and_then(|drive| drive.address) {
            bytes.push(address.character() as u8);
        }
        bytes.extend_from_slice(text.as_bytes());
        bytes.push(CR);
        self.port.write_all(&bytes)
    }

    fn stop_all(&mut self, shared: &LinkShared) -> std::io::Result<()> {
        // Every drive's SK in one write: the first drive's stop leaves first and the
        // others follow back to back.
        let mut bytes = Vec::with_capacity(shared.drives.len() * 4);
        for drive in &shared.drives {
            match drive.address {
                Some(address) => bytes.extend(Request::to(address, Command::StopKill).to_wire()),
                None => bytes.extend(Request::new(Command::StopKill).to_wire()),
            }
        }
        self.port.write_all(&bytes)?;
        self.port.flush()
    }

    fn per_drive(&self) -> bool {
        false
    }
}

/// Opens `port` at `baud` for the owner, with a reader thread.
pub(super) fn opener(port: String, baud: u32) -> Opener {
    Box::new(move |connection, events: Sender<Event>| {
        let opened = crate::ports::uim2503::serial::open_port(&port, baud)?;
        let reader = opened
            .try_clone()
            .map_err(|err| format!("cannot read from {port}: {err}"))?;
        let name = port.clone();
        std::thread::Builder::new()
            .name(format!("scl-read-{connection}"))
            .spawn(move || read_lines(reader, connection, &events, &name))
            .map_err(|err| format!("cannot start the reader of {port}: {err}"))?;
        Ok(Box::new(SerialLine { port: opened }) as Box<dyn Transport>)
    })
}

/// The reader: bytes to lines until the port fails or the owner is gone.
fn read_lines(mut port: Box<dyn SerialPort>, connection: u64, events: &Sender<Event>, name: &str) {
    let _ = port.set_timeout(READ_TIMEOUT);
    let mut buffer = [0u8; 256];
    let mut line = Vec::new();
    loop {
        match port.read(&mut buffer) {
            Ok(0) => {}
            Ok(count) => {
                for &byte in buffer.get(..count).unwrap_or_default() {
                    if byte == CR {
                        let text = String::from_utf8_lossy(&line).into_owned();
                        line.clear();
                        if text.is_empty() {
                            continue;
                        }
                        let event = Event::Line {
                            connection,
                            drive: None,
                            text,
                        };
                        if events.send(event).is_err() {
                            return;
                        }
                    } else if byte != b'\n' && line.len() < MAX_LINE {
                        line.push(byte);
                    }
                }
            }
            Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {
                // Nothing came; a send fails once the owner is gone.
                if events.send(Event::Wake).is_err() {
                    return;
                }
            }
            Err(err) => {
                let _ = events.send(Event::Lost {
                    connection,
                    reason: format!("reading {name} failed: {err}"),
                });
                return;
            }
        }
    }
}
