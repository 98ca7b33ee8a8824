//! What keeps faithd from ever fighting the pilot: the safety gate, the vehicle state
//! it reads, and the manoeuvre state machine that obeys it. All pure; the daemon
//! feeds them messages and time.

pub mod commander;
pub mod confirm;
pub mod gate;
pub mod manoeuvre;
pub mod rc;
pub mod vehicle;
