//! Any bytes from the flight controller's MSP port, in any chunking, give frames or
//! nothing, never a panic; every reply faithd reads from them (MSP_RC, the status
//! bits, settings, the MSP-only link's gyro, channels, status and angles) decodes or
//! is refused.
#![no_main]

use faithd::command::fc_check::StatusBits;
use faithd::command::msp::Decoder;
use faithd::command::msp_port::{le_unsigned, rc_values};
use faithd::link::over_msp;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&split, bytes)) = data.split_first() else {
        return;
    };
    let mut decoder = Decoder::default();
    let mut frames = Vec::new();
    for chunk in bytes.chunks(usize::from(split).max(1)) {
        decoder.push(chunk, &mut frames);
    }
    let bits = StatusBits {
        failsafe: Some(split % 64),
        msp_override: split / 4,
        angle: Some(split / 2),
    };
    for f in &frames {
        assert!(f.payload.len() <= 1024);
        let _ = rc_values(&f.payload).count();
        let _ = le_unsigned(&f.payload);
        let _ = bits.decode(&f.payload);
        for command in [102, 105, 108, 0x2000] {
            for msg in over_msp::messages(bits, command, &f.payload, i64::from(split) * 1000) {
                // What the link hands on: finite angles, whatever came in.
                if let mavlink::dialects::common::MavMessage::ATTITUDE(a) = msg {
                    assert!(a.roll.is_finite() && a.rollspeed.is_finite());
                }
            }
        }
    }
});
