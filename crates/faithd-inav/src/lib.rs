//! faithd's model of iNav 9.1 as it runs on a flight controller, written from iNav's
//! source (`../shared/inav.md` has the facts and their file paths): its MSP ports and
//! MSP RC override ([`msp`]), and the MAVLink telemetry it sends ([`mavlink`]).
//!
//! A model encodes assumptions: this one is faithful where a roll's safety depends on
//! it (serial timing, buffers, scaling, modes) and says where it simplifies. CI holds
//! faithd to it; `tests/testsuite/inav_sitl.rs` holds faithd to iNav's own firmware when a SITL
//! build is at hand. It shares no code with faithd's own MSP codec: what it parses and
//! answers follows iNav, so a mistake in faithd's framing cannot hide in both.

pub mod frame;
pub mod mavlink;
pub mod msp;
