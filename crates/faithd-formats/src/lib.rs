//! The files faithd reads and writes, each in the format other tools read: event
//! recordings (AEDAT 2.0, 3.1, 4.0 as jAER, libcaer and DV write them, and plain
//! text), MAVLink telemetry logs (.tlog, as pymavlink and QGroundControl read them)
//! and faithd's own window log (one JSON line per pipeline window).
//!
//! Readers never panic on what a file holds: every error names the byte offset or
//! the field.

pub mod events; // AEDAT 2.0 / 3.1 / 4.0 and text: streaming readers and writers
pub mod tlog; // MAVLink frames stamped in Unix microseconds
pub mod window_log; // what the pipeline decided, window by window, for replay
