//! Every feedback code and payload value Floatball relies on, in one place.
//!
//! The manual documents the codes of BG, MP, PV, QP, QV, QT and SN. Where it is silent
//! (the other instructions, the RTCN notification, errors) the values below are our
//! choice, taken from UIROBOT's SimpleCAN 3.0 control words used by their other
//! controllers (UIM342 family), which the UFQ750's documented codes match. The simulator
//! follows them; `docs/protocol-notes.md` gives the reasons.
//!
//! ```
//! use floatball_shared::uim2503::ascii::Mnemonic;
//! use floatball_shared::uim2503::feedback::code;
//!
//! assert_eq!(code::of(Mnemonic::QT), Some(code::QT));
//! assert_eq!(code::name(0x27), Some("QT"));
//! assert_eq!(code::name(code::RTCN), Some("RTCN"));
//! ```

use crate::uim2503::ascii::Mnemonic;

/// `IE[X]` information enable; ACK `X, N0 N1` (N = 0 or 1). *Not in the manual.*
pub const IE: u8 = 0x07;
/// `SN` serial number; ACK `N0 … N7` (manual §8.5).
pub const SN: u8 = 0x0C;
/// Error report from a unit or the gateway: `E, C, X` (error, instruction code,
/// index); see [`error`]. *Not in the manual.*
pub const ER: u8 = 0x0F;
/// `MO` motor driver on/off; ACK `N0` (0 or 1). *Not in the manual.*
pub const MO: u8 = 0x15;
/// `BG` begin motion; ACK `N0 … N3` (manual §8.1).
pub const BG: u8 = 0x16;
/// `SD` stop deceleration; ACK `N0 … N3` (unsigned). *Not in the manual.*
pub const SD: u8 = 0x1C;
/// `SP` point-to-point speed; ACK `N0 … N3` (signed). *Not in the manual.*
pub const SP: u8 = 0x1E;
/// `PA` point-to-point absolute position; ACK `N0 … N3` (signed). *Not in the manual.*
pub const PA: u8 = 0x20;
/// `MP[X]` PVT motion profile; ACK `X, N0 N1` (manual §8.2).
pub const MP: u8 = 0x22;
/// `PV` PVT mode; ACK `N0 N1` (manual §8.3).
pub const PV: u8 = 0x23;
/// `QP[X]` PVT position; ACK `X0 X1, N0 … N3` (manual §8.4).
pub const QP: u8 = 0x25;
/// `QV[X]` PVT velocity; ACK `X0 X1, N0 … N3` (manual §8.4).
pub const QV: u8 = 0x26;
/// `QT[X]` PVT time; ACK `X0 X1, N0` (manual §8.4).
pub const QT: u8 = 0x27;
/// RTCN, a real-time change notification the unit sends unasked: `K` (the kind, see
/// [`notification`]). *Not in the manual*, which names it ("RTCN", `RTN0=44`) without
/// its code.
pub const RTCN: u8 = 0x5A;

/// The kinds of RTCN notification (its first data byte).
pub mod notification {
    /// The PVT water level has fallen to the watermark `MP[5]` (the manual's
    /// `RTN0=44`: data byte 0 is 44). Sent three times, only while `IE[5]=1`.
    pub const PVT_WATERMARK: u8 = 44;
}

/// The error numbers of an [`ER`](super::ER) report (its first data byte).
pub mod error {
    /// The gateway could not read the text: unknown mnemonic, bad syntax, more than 20
    /// characters, odd hexadecimal digits. Reported with station 0, code 0, index 0.
    pub const SYNTAX: u8 = 0x32;
    /// An operand out of range (`QT[X]=0`, `MP[3]=2`) or inconsistent (`MP[1]` ≥ `MP[2]`).
    pub const DATA: u8 = 0x33;
    /// An index out of range (`MP[7]`).
    pub const INDEX: u8 = 0x34;
    /// Not allowed while the motor moves (`PV=N` with non-zero velocity, `MP[1]`/`MP[2]`
    /// during a PVT run).
    pub const WHILE_MOVING: u8 = 0x3D;
    /// `BG` while the motor driver is off (`MO=0`).
    pub const MOTOR_OFF: u8 = 0x3E;
    /// A PVT row asks for more speed or acceleration than the unit has (or starts too
    /// far from where the ball is): the unit stops at once and switches its driver off.
    /// Sent unasked when the row starts, with code `QT` and the row as index. *Our
    /// number*, not from a UIROBOT manual.
    pub const OVERLOAD: u8 = 0x40;
    /// PVT motion reached the upper limit switch (position 0) or the end of the travel:
    /// the unit stops there, its driver stays on. Sent unasked at that moment, with code
    /// `QT` and the row as index. *Our number*, not from a UIROBOT manual.
    pub const LIMIT: u8 = 0x41;

    /// A few words on an error number, for operators.
    pub fn describe(error: u8) -> &'static str {
        match error {
            SYNTAX => "the gateway could not read the instruction",
            DATA => "value out of range or inconsistent",
            INDEX => "index out of range",
            WHILE_MOVING => "not allowed while the motor moves",
            MOTOR_OFF => "the motor driver is off",
            OVERLOAD => "the unit cannot follow the PVT row (speed or acceleration)",
            LIMIT => "the ball reached the end of its travel",
            _ => "unknown error",
        }
    }
}

/// The feedback code of an instruction's ACK, for the mnemonics that have one.
pub fn of(mnemonic: Mnemonic) -> Option<u8> {
    Some(match mnemonic {
        Mnemonic::IE => IE,
        Mnemonic::SN => SN,
        Mnemonic::MO => MO,
        Mnemonic::BG => BG,
        Mnemonic::SD => SD,
        Mnemonic::SP => SP,
        Mnemonic::PA => PA,
        Mnemonic::MP => MP,
        Mnemonic::PV => PV,
        Mnemonic::QP => QP,
        Mnemonic::QV => QV,
        Mnemonic::QT => QT,
        _ => return None,
    })
}

/// The name of a feedback code (`"QT"`, `"RTCN"`, `"ER"`), if Floatball knows it.
pub fn name(code: u8) -> Option<&'static str> {
    Some(match code {
        IE => "IE",
        SN => "SN",
        ER => "ER",
        MO => "MO",
        BG => "BG",
        SD => "SD",
        SP => "SP",
        PA => "PA",
        MP => "MP",
        PV => "PV",
        QP => "QP",
        QV => "QV",
        QT => "QT",
        RTCN => "RTCN",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn the_documented_codes_are_the_manuals() {
        assert_eq!([BG, MP, PV, QP, QV, QT, SN], [22, 34, 35, 37, 38, 39, 12]);
    }

    #[test]
    fn every_typed_mnemonic_has_a_distinct_code_with_its_name() {
        let mut codes: Vec<u8> = Mnemonic::TYPED.iter().filter_map(|&m| of(m)).collect();
        assert_eq!(codes.len(), Mnemonic::TYPED.len());
        for &mnemonic in &Mnemonic::TYPED {
            let code = of(mnemonic).unwrap();
            assert_eq!(name(code), Some(mnemonic.to_string().as_str()));
            assert!(code < 0x80, "codes travel without bit 7");
        }
        codes.extend([ER, RTCN]);
        codes.sort_unstable();
        codes.dedup();
        assert_eq!(codes.len(), Mnemonic::TYPED.len() + 2);
        assert_eq!(of(Mnemonic::new(*b"IL").unwrap()), None);
        assert_eq!(name(0x7F), None);
    }

    #[test]
    fn error_numbers_are_described() {
        for (error, words) in [
            (error::SYNTAX, "the gateway could not read the instruction"),
            (error::DATA, "value out of range or inconsistent"),
            (error::INDEX, "index out of range"),
            (error::WHILE_MOVING, "not allowed while the motor moves"),
            (error::MOTOR_OFF, "the motor driver is off"),
            (
                error::OVERLOAD,
                "the unit cannot follow the PVT row (speed or acceleration)",
            ),
            (error::LIMIT, "the ball reached the end of its travel"),
            (0, "unknown error"),
        ] {
            assert_eq!(error::describe(error), words);
        }
    }
}
