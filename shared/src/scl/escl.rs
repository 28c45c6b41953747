//! eSCL, SCL over Ethernet: each UDP datagram carries the two-byte header `00 07`, one
//! line of SCL text and its carriage return — a command to the drive's port
//! [`UDP_PORT`], an answer back.

use std::borrow::Cow;

use super::CR;
use super::command::Request;
use super::error::EsclError;
use super::response::Reply;

/// The two bytes before the SCL text in every eSCL datagram.
pub const HEADER: [u8; 2] = [0x00, 0x07];
/// The drive's UDP port for eSCL.
pub const UDP_PORT: u16 = 7775;
/// The drive's TCP port for eSCL (the same framing over a stream).
pub const TCP_PORT: u16 = 7776;

/// The datagram carrying `text`: header, text, carriage return.
fn frame(text: &str) -> Vec<u8> {
    let mut datagram = Vec::with_capacity(HEADER.len() + text.len() + 1);
    datagram.extend_from_slice(&HEADER);
    datagram.extend_from_slice(text.as_bytes());
    datagram.push(CR);
    datagram
}

/// The SCL text of a datagram, checked for the header and the one carriage return.
fn text(datagram: &[u8]) -> Result<Cow<'_, str>, EsclError> {
    let Some((header, rest)) = datagram.split_first_chunk::<2>() else {
        return Err(EsclError::Truncated {
            len: datagram.len(),
        });
    };
    if *header != HEADER {
        return Err(EsclError::BadHeader { found: *header });
    }
    let Some((&CR, body)) = rest.split_last() else {
        return Err(if rest.is_empty() {
            EsclError::Truncated {
                len: datagram.len(),
            }
        } else {
            EsclError::NotOneLine
        });
    };
    if body.contains(&CR) {
        return Err(EsclError::NotOneLine);
    }
    // Not UTF-8 is not ASCII either: the parsers refuse it, with its column.
    Ok(String::from_utf8_lossy(body))
}

impl Request {
    /// The eSCL datagram carrying this command.
    #[must_use]
    pub fn to_escl(&self) -> Vec<u8> {
        frame(&self.to_string())
    }

    /// The command in an eSCL datagram.
    ///
    /// # Errors
    /// A missing or wrong header, not exactly one line, or a refused command.
    pub fn from_escl(datagram: &[u8]) -> Result<Self, EsclError> {
        let text = text(datagram)?;
        if text.trim_matches([' ', '\t']).len() != text.len() {
            // The parser forgives spaces around a console line; a datagram has none.
            return Err(EsclError::NotOneLine);
        }
        Ok(Self::parse(&text)?)
    }
}

impl Reply {
    /// The eSCL datagram carrying this answer.
    #[must_use]
    pub fn to_escl(&self) -> Vec<u8> {
        frame(&self.to_string())
    }

    /// The answer in an eSCL datagram.
    ///
    /// # Errors
    /// A missing or wrong header, not exactly one line, or a refused answer.
    pub fn from_escl(datagram: &[u8]) -> Result<Self, EsclError> {
        Ok(Self::parse(&text(datagram)?)?)
    }
}
