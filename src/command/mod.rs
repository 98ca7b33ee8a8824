//! Command sinks: how a commander's [`Command`] reaches the flight controller.
//!
//! - `mavlink`: RC_CHANNELS_OVERRIDE on the MAVLink link, only the roll channel set,
//!   every other channel marked "ignore" (65535).
//! - `msp`: iNav's MSP RC override, MSP_SET_RAW_RC on a UART of its own; iNav takes
//!   only the channels in `msp_override_channels`, and only while its "MSP RC
//!   OVERRIDE" mode is on (bound to the pilot's switch).

pub mod msp;

use std::time::Duration;

use mavlink::dialects::common::{MavMessage, RC_CHANNELS_OVERRIDE_DATA};
use serde::{Deserialize, Serialize};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::sync::mpsc;

use crate::link::endpoint::Endpoint;
use crate::safety::manoeuvre::Command;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SinkKind {
    #[default]
    Mavlink,
    Msp,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CommandConfig {
    /// "mavlink" (RC_CHANNELS_OVERRIDE) or "msp" (iNav's MSP RC override).
    pub sink: SinkKind,
    /// Value sent to give the roll channel back. 0 means the protocol's own release:
    /// MAVLink's release value (0 on channels 1-8, 65534 on 9-18); for MSP, which
    /// has none, the stick centre (`manoeuvre.neutral_us`).
    pub release_us: u16,
    /// UART of the MSP sink and its baud rate.
    pub msp_endpoint: String,
    pub msp_baud: u32,
}

impl Default for CommandConfig {
    fn default() -> Self {
        Self {
            sink: SinkKind::Mavlink,
            release_us: 0,
            msp_endpoint: "serial:/dev/ttyAMA1".into(),
            msp_baud: 115_200,
        }
    }
}

/// RC_CHANNELS_OVERRIDE for one command: the roll channel set, all others ignored.
pub fn mavlink_override(
    cmd: Command,
    release_us: u16,
    target_system: u8,
    target_component: u8,
) -> MavMessage {
    let mut chans = [u16::MAX; 18];
    let (channel, value) = match cmd {
        Command::Roll { channel, value_us } => (channel, value_us),
        Command::Release { channel } => {
            let protocol_release = if channel <= 8 { 0 } else { u16::MAX - 1 };
            let v = if release_us == 0 {
                protocol_release
            } else {
                release_us
            };
            (channel, v)
        }
    };
    if let Some(slot) = chans.get_mut(usize::from(channel).wrapping_sub(1)) {
        *slot = value;
    }
    MavMessage::RC_CHANNELS_OVERRIDE(RC_CHANNELS_OVERRIDE_DATA {
        target_system,
        target_component,
        chan1_raw: chans[0],
        chan2_raw: chans[1],
        chan3_raw: chans[2],
        chan4_raw: chans[3],
        chan5_raw: chans[4],
        chan6_raw: chans[5],
        chan7_raw: chans[6],
        chan8_raw: chans[7],
        chan9_raw: chans[8],
        chan10_raw: chans[9],
        chan11_raw: chans[10],
        chan12_raw: chans[11],
        chan13_raw: chans[12],
        chan14_raw: chans[13],
        chan15_raw: chans[14],
        chan16_raw: chans[15],
        chan17_raw: chans[16],
        chan18_raw: chans[17],
    })
}

/// MSP_SET_RAW_RC for one command. Channels other than roll carry the centre value;
/// iNav ignores them unless `msp_override_channels` includes them.
pub fn msp_override(cmd: Command, release_us: u16, neutral_us: u16) -> Vec<u8> {
    let (channel, value) = match cmd {
        Command::Roll { channel, value_us } => (channel, value_us),
        Command::Release { channel } => (
            channel,
            if release_us == 0 {
                neutral_us
            } else {
                release_us
            },
        ),
    };
    let count = usize::from(channel).max(8);
    let mut chans = vec![neutral_us; count];
    chans[usize::from(channel).saturating_sub(1)] = value;
    msp::set_raw_rc(&chans)
}

/// The MSP sink: writes frames to its UART, reopening it when it vanishes, and logs
/// the flight controller's error replies (an MSP_SET_RAW_RC refused by iNav).
pub async fn run_msp(
    endpoint: Endpoint,
    mut frames: mpsc::Receiver<Vec<u8>>,
    reconnect_min: Duration,
    reconnect_max: Duration,
) {
    let mut backoff = reconnect_min;
    loop {
        match endpoint.open().await {
            Ok(port) => {
                tracing::info!(%endpoint, "MSP command port open");
                backoff = reconnect_min;
                let why = serve_msp(port, &mut frames).await;
                tracing::warn!(%endpoint, "MSP command port lost: {why}; reopening");
            }
            Err(e) => tracing::warn!(%endpoint, "cannot open MSP command port: {e}"),
        }
        while frames.try_recv().is_ok() {}
        tokio::time::sleep(backoff).await;
        backoff = (backoff * 2).min(reconnect_max);
    }
}

async fn serve_msp(
    port: crate::link::endpoint::BoxedTransport,
    frames: &mut mpsc::Receiver<Vec<u8>>,
) -> String {
    let (mut rx, mut tx) = tokio::io::split(port);
    let mut decoder = msp::Decoder::default();
    let mut replies = Vec::new();
    let mut buf = [0u8; 512];
    loop {
        tokio::select! {
            got = rx.read(&mut buf) => match got {
                Ok(0) => return "end of stream".into(),
                Ok(n) => {
                    decoder.push(&buf[..n], &mut replies);
                    for r in replies.drain(..) {
                        if r.direction == b'!' {
                            tracing::error!(command = r.command, "flight controller refused MSP command (is MSP RC override built in and the mode set up?)");
                        }
                    }
                }
                Err(e) => return format!("read failed: {e}"),
            },
            Some(frame) = frames.recv() => {
                if let Err(e) = tx.write_all(&frame).await {
                    return format!("write failed: {e}");
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mavlink_override_sets_only_the_roll_channel() {
        let MavMessage::RC_CHANNELS_OVERRIDE(m) = mavlink_override(
            Command::Roll {
                channel: 1,
                value_us: 1800,
            },
            0,
            1,
            1,
        ) else {
            panic!()
        };
        assert_eq!(m.chan1_raw, 1800);
        assert_eq!(m.chan2_raw, u16::MAX);
        assert_eq!(m.chan18_raw, u16::MAX);
        let MavMessage::RC_CHANNELS_OVERRIDE(r) =
            mavlink_override(Command::Release { channel: 1 }, 0, 1, 1)
        else {
            panic!()
        };
        assert_eq!(r.chan1_raw, 0, "MAVLink's release value");
        let MavMessage::RC_CHANNELS_OVERRIDE(r) =
            mavlink_override(Command::Release { channel: 10 }, 0, 1, 1)
        else {
            panic!()
        };
        assert_eq!(r.chan10_raw, u16::MAX - 1, "release on channels 9-18");
        let MavMessage::RC_CHANNELS_OVERRIDE(r) =
            mavlink_override(Command::Release { channel: 1 }, 1500, 1, 1)
        else {
            panic!()
        };
        assert_eq!(r.chan1_raw, 1500, "configured release value");
    }

    #[test]
    fn msp_release_is_the_centre() {
        let frame = msp_override(Command::Release { channel: 1 }, 0, 1500);
        let mut frames = Vec::new();
        msp::Decoder::default().push(&frame, &mut frames);
        assert_eq!(frames[0].payload[..2], 1500u16.to_le_bytes());
        assert_eq!(frames[0].payload.len(), 16);
    }
}
