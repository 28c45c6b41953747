//! Serial-port links through the `serialport` crate: 8 data bits, no parity, 1 stop bit,
//! no flow control (`docs/uim2503.md` §2).
//!
//! The port is opened, lost and opened again by the [`supervisor`](super::supervisor)
//! (the same loop as a network link's); this module owns how a port is opened, read
//! and written.

use std::io::Read;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::Receiver;
use std::time::Duration;

use serialport::SerialPort;

use super::supervisor::{Connector, LineRead, serve_with_reader, write_watching};
use super::writer::LineWrite;
use super::{Input, Shared};

/// How long a read waits for bytes before checking whether to stop.
const READ_TIMEOUT: Duration = Duration::from_millis(50);

/// Opens a serial port as the gateway expects it.
///
/// # Errors
/// The port's refusal, with the port's name in the message.
pub fn open_port(port: &str, baud: u32) -> Result<Box<dyn SerialPort>, String> {
    serialport::new(port, baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(READ_TIMEOUT)
        .open()
        .map_err(|err| format!("cannot open {port}: {err}"))
}

/// Opens a local serial device.
pub(super) struct SerialConnector {
    /// The device's path.
    pub(super) device: String,
}

impl Connector for SerialConnector {
    type Connection = (SerialLine, SerialReader);

    fn connect(
        &mut self,
        shared: &Arc<Shared>,
        lost: &Arc<AtomicBool>,
        baud: u32,
    ) -> Result<(SerialLine, SerialReader), String> {
        let port = open_port(&self.device, baud)?;
        let reader = port
            .try_clone()
            .map_err(|err| format!("cannot read from {}: {err}", self.device))?;
        Ok((
            SerialLine {
                port,
                shared: Arc::clone(shared),
                lost: Arc::clone(lost),
            },
            SerialReader { port: reader },
        ))
    }

    fn serve(
        &mut self,
        shared: &Arc<Shared>,
        inbox: Receiver<Input>,
        (line, reader): (SerialLine, SerialReader),
        lost: &Arc<AtomicBool>,
    ) -> (Receiver<Input>, String) {
        let reason = serve_with_reader(shared, &inbox, line, reader, lost);
        (inbox, reason)
    }
}

/// The reader's end of a serial port.
pub(super) struct SerialReader {
    port: Box<dyn SerialPort>,
}

impl LineRead for SerialReader {
    fn read_some(&mut self, buffer: &mut [u8]) -> Result<usize, String> {
        match self.port.read(buffer) {
            Ok(n) => Ok(n),
            Err(err)
                if matches!(
                    err.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted
                ) =>
            {
                Ok(0)
            }
            Err(err) => Err(format!("read failed: {err}")),
        }
    }
}

/// The writer's end of a serial port.
pub(super) struct SerialLine {
    port: Box<dyn SerialPort>,
    shared: Arc<Shared>,
    lost: Arc<AtomicBool>,
}

impl LineWrite for SerialLine {
    /// Writes the whole instruction ([`write_watching`]).
    fn write_instruction(&mut self, instruction: &[u8]) -> std::io::Result<()> {
        write_watching(&mut self.port, instruction, &self.shared, &self.lost)
    }

    /// Sets the port's speed (the reader's clone shares the device's settings).
    fn set_baud(&mut self, baud: u32) -> std::io::Result<()> {
        self.port.set_baud_rate(baud).map_err(std::io::Error::other)
    }

    /// A real gateway is power-cycled by the installer.
    fn restart_gateway(&mut self) -> bool {
        false
    }
}
