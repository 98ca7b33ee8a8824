//! Any bytes on the MAVLink port: parsed as the link parses them, applied to the
//! vehicle state as the link applies them, and judged by the safety gate at a time
//! taken from the input. Never a panic, and the gate never opens on a state the bytes
//! could not have made complete (no HEARTBEAT, no RC_CHANNELS).
#![no_main]

use faithd::link::clock_sync::ClockSync;
use faithd::link::telemetry;
use faithd::command::stream::INAV_MSP_WORDS;
use faithd_core::safety::gate::{
    self, AutopilotStatus, CommandPathStatus, GateConfig, PipelineStatus,
};
use faithd_core::safety::vehicle::VehicleState;
use libfuzzer_sys::fuzz_target;
use mavlink::dialects::common::MavMessage;

fuzz_target!(|data: &[u8]| {
    let mut reader = mavlink::MavlinkReader::new(data);
    let mut vehicle = VehicleState {
        link_up: true,
        ..Default::default()
    };
    let mut sync = ClockSync::new(50);
    let mut rx_us = 0i64;
    loop {
        match reader.read_any_message::<MavMessage>() {
            Ok((_, msg)) => {
                rx_us += 20_000;
                let _ = telemetry::apply(&mut vehicle, &mut sync, &msg, rx_us);
            }
            Err(mavlink::error::MessageReadError::Io(_)) => break,
            Err(_) => {}
        }
    }
    let pipeline = PipelineStatus {
        last_cycle_us: Some(rx_us),
        problem: None,
    };
    let command = CommandPathStatus {
        setup_refused: false,
        setup_changed: false,
        ready_at_us: Some(0),
        roll_not_in_effect: false,
        autopilot: Some(AutopilotStatus {
            t_us: rx_us,
            armed: true,
            failsafe: false,
            override_active: true,
            stabilised: true,
        }),
        words: &INAV_MSP_WORDS,
    };
    let state = gate::evaluate(&GateConfig::default(), &vehicle, &pipeline, &command, rx_us);
    if state.is_open() {
        assert!(vehicle.heartbeat.is_some() && vehicle.rc.is_some());
    }
});
