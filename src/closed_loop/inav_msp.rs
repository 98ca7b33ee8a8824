//! iNav's MSP port as a model: the set-up of the committed CLI script
//! (hil/inav/faithd.cli), the replies faithd's check reads, and MSP RC override
//! with iNav's own timing (rx/msp_override.c): applied only with the override mode
//! on (the switch in AUTO) and after 200 ms + failsafe_recovery_delay of fresh
//! frames; the last value kept for 200 ms + failsafe_delay after frames stop.
//!
//! The simulated flights and the daemon's integration tests use it. It is a model,
//! and a model encodes assumptions: `tests/inav_sitl.rs` holds faithd to iNav's
//! own firmware, and these timings are the ones measured there.

use crate::command::msp::{self, Decoder, Frame, MSP_SET_RAW_RC};
use crate::command::msp_port::{
    MSP_BOXIDS, MSP_FC_VARIANT, MSP_FC_VERSION, MSP_MODE_RANGES, MSP_RC, MSP_RX_MAP,
    MSP2_COMMON_SETTING, MSP2_INAV_STATUS,
};

/// MSP_BOXIDS as iNav 9.1's SITL build answers it.
pub const BOX_IDS: [u8; 29] = [
    0, 51, 61, 1, 2, 35, 5, 8, 6, 7, 32, 46, 3, 13, 60, 19, 27, 39, 40, 41, 42, 43, 44, 50, 62, 63,
    65, 66, 67,
];

/// What the vehicle side of the model is doing when faithd asks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FcView {
    /// The eight channels iNav uses (MSP_RC), in iNav's order; index 5 is the switch.
    pub rc_in_use: [u16; 8],
    pub armed: bool,
    pub failsafe: bool,
}

impl FcView {
    /// Armed, no failsafe, these channels.
    pub fn flying(rc_in_use: [u16; 8]) -> Self {
        Self {
            rc_in_use,
            armed: true,
            failsafe: false,
        }
    }
}

/// rx/msp.c: a frame older than this and iNav's MSP receiver has lost its signal.
const SIGNAL_TIMEOUT_US: i64 = 200_000;
const RXDATA_PERIOD_US: i64 = 200_000;

/// The settings faithd's check reads, as the committed script leaves them.
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    pub receiver_type: u8,
    pub msp_override_channels: u32,
    pub failsafe_delay_ds: u8,
    pub failsafe_recovery_delay_ds: u8,
    pub mavlink_extra1_rate: u8,
    pub mavlink_rc_chan_rate: u8,
    /// (slot, mode id, aux index, start step, end step)
    pub modes: Vec<(u8, u8, u8, u8, u8)>,
}

impl Default for Setup {
    fn default() -> Self {
        Self {
            receiver_type: 1,
            msp_override_channels: 1,
            failsafe_delay_ds: 5,
            failsafe_recovery_delay_ds: 5,
            mavlink_extra1_rate: 50,
            mavlink_rc_chan_rate: 50,
            // aux 0 0 0 1700 2100, aux 1 1 0 1700 2100, aux 2 50 1 1700 2100
            modes: vec![(0, 0, 0, 32, 48), (1, 1, 0, 32, 48), (2, 50, 1, 32, 48)],
        }
    }
}

impl Setup {
    /// Whether the MSP RC OVERRIDE mode is on at this switch value (channel 6).
    pub fn override_mode_on(&self, switch_us: u16) -> bool {
        self.modes.iter().any(|&(_, id, aux, start, end)| {
            id == 50
                && aux == 1
                && start < end
                && switch_us >= 900 + 25 * u16::from(start)
                && switch_us < 900 + 25 * u16::from(end)
        })
    }

    fn setting(&self, name: &[u8]) -> Option<Vec<u8>> {
        let byte = |v: u8| Some(vec![v]);
        match name {
            b"receiver_type" => byte(self.receiver_type),
            b"serialrx_provider" => byte(4), // IBUS
            b"msp_override_channels" => Some(self.msp_override_channels.to_le_bytes().to_vec()),
            b"failsafe_delay" => byte(self.failsafe_delay_ds),
            b"failsafe_recovery_delay" => byte(self.failsafe_recovery_delay_ds),
            b"mavlink_extra1_rate" => byte(self.mavlink_extra1_rate),
            b"mavlink_rc_chan_rate" => byte(self.mavlink_rc_chan_rate),
            b"mavlink_sysid" => byte(1),
            b"mavlink_version" => byte(2),
            b"mavlink_ext_status_rate" => byte(10),
            _ => None,
        }
    }
}

/// One MSP port of the simulated iNav and the override state behind it.
#[derive(Debug, Default)]
pub struct InavMsp {
    pub setup: Setup,
    decoder: Decoder,
    /// When the current run of fresh frames began, and the last frame's time.
    fresh_since_us: Option<i64>,
    last_frame_us: Option<i64>,
    /// Roll of the last MSP_SET_RAW_RC (radio channel 1, iNav's map is AETR here).
    msp_roll_us: u16,
    /// Every MSP_SET_RAW_RC received: (time, channels).
    pub frames: Vec<(i64, Vec<u16>)>,
}

impl InavMsp {
    pub fn new(setup: Setup) -> Self {
        Self {
            setup,
            ..Default::default()
        }
    }

    /// The roll value iNav uses at `now_us`: faithd's, while the override applies,
    /// the pilot's otherwise.
    pub fn roll_in_use(&self, now_us: i64, switch_us: u16, pilot_roll_us: u16) -> u16 {
        match self.override_roll(now_us) {
            Some(v) if self.setup.override_mode_on(switch_us) => v,
            _ => pilot_roll_us,
        }
    }

    /// faithd's roll while iNav's MSP override is out of its failsafe.
    fn override_roll(&self, now_us: i64) -> Option<u16> {
        let (since, last) = (self.fresh_since_us?, self.last_frame_us?);
        let recovery =
            RXDATA_PERIOD_US + i64::from(self.setup.failsafe_recovery_delay_ds) * 100_000;
        let failure = RXDATA_PERIOD_US + i64::from(self.setup.failsafe_delay_ds) * 100_000;
        let recovered = now_us.min(last) - since > recovery;
        (recovered && now_us - last <= failure).then_some(self.msp_roll_us)
    }

    /// Feeds bytes from faithd; returns the replies to write back.
    pub fn receive(&mut self, bytes: &[u8], now_us: i64, view: FcView) -> Vec<u8> {
        let mut frames = Vec::new();
        self.decoder.push(bytes, &mut frames);
        let mut out = Vec::new();
        for f in frames.into_iter().filter(|f| f.direction == b'<') {
            let reply = self.reply(&f, now_us, view);
            match reply {
                Some(payload) => out.extend(frame(b'>', f.command, &payload)),
                None => out.extend(frame(b'!', f.command, &[])),
            }
        }
        out
    }

    fn reply(&mut self, f: &Frame, now_us: i64, view: FcView) -> Option<Vec<u8>> {
        let u16s = |v: &[u16]| v.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>();
        match f.command {
            MSP_FC_VARIANT => Some(b"INAV".to_vec()),
            MSP_FC_VERSION => Some(vec![9, 1, 0]),
            MSP_RX_MAP => Some(vec![0, 1, 3, 2]),
            MSP_MODE_RANGES => {
                let mut out = vec![0u8; 40 * 4];
                for &(slot, id, aux, start, end) in &self.setup.modes {
                    let i = usize::from(slot) * 4;
                    out[i..i + 4].copy_from_slice(&[id, aux, start, end]);
                }
                Some(out)
            }
            MSP2_COMMON_SETTING => {
                let name = f.payload.split(|b| *b == 0).next().unwrap_or(&[]);
                self.setup.setting(name)
            }
            MSP_SET_RAW_RC => {
                let channels: Vec<u16> = crate::command::msp_port::rc_values(&f.payload).collect();
                let fresh = self
                    .last_frame_us
                    .is_some_and(|t| now_us - t <= SIGNAL_TIMEOUT_US);
                if !fresh {
                    self.fresh_since_us = Some(now_us);
                }
                self.last_frame_us = Some(now_us);
                self.msp_roll_us = channels.first().copied().unwrap_or(0);
                self.frames.push((now_us, channels));
                Some(Vec::new())
            }
            MSP_RC => Some(u16s(&view.rc_in_use)),
            MSP_BOXIDS => Some(BOX_IDS.to_vec()),
            MSP2_INAV_STATUS => Some(self.status(view)),
            _ => None,
        }
    }
}

impl InavMsp {
    /// MSP2_INAV_STATUS: cycle time .. profile, arming flags, the active modes' bits
    /// (positions in [`BOX_IDS`]), mixer profile.
    fn status(&self, view: FcView) -> Vec<u8> {
        let mut out = vec![0u8; 9];
        let flags: u32 = if view.armed { 0b1100 } else { 0 };
        out.extend_from_slice(&flags.to_le_bytes());
        let mut bits = [0u8; 8];
        let mut set = |id: u8| {
            if let Some(i) = BOX_IDS.iter().position(|b| *b == id) {
                bits[i / 8] |= 1 << (i % 8);
            }
        };
        set(1); // ANGLE
        if view.armed {
            set(0);
        }
        if view.failsafe {
            set(27);
        }
        if self.setup.override_mode_on(view.rc_in_use[5]) {
            set(50);
        }
        out.extend_from_slice(&bits);
        out.push(0);
        out
    }
}

fn frame(direction: u8, command: u16, payload: &[u8]) -> Vec<u8> {
    let mut f = msp::encode_request(command, payload);
    f[2] = direction;
    f
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::command::fc_check;

    #[test]
    fn the_check_passes_on_the_model_and_the_override_needs_its_warmup() {
        let mut fc = InavMsp::new(Setup::default());
        // A check, as faithd runs it, through the model's replies.
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let settings = rt.block_on(async {
            let (ours, theirs) = tokio::io::duplex(4096);
            let server = tokio::spawn(async move {
                use tokio::io::{AsyncReadExt, AsyncWriteExt};
                let mut theirs = theirs;
                let mut buf = [0u8; 256];
                while let Ok(n) = theirs.read(&mut buf).await {
                    if n == 0 {
                        break;
                    }
                    let out = fc.receive(&buf[..n], 0, FcView::flying([1500; 8]));
                    theirs.write_all(&out).await.unwrap();
                }
                fc
            });
            let mut port = crate::command::msp_port::MspPort::new(Box::pin(ours));
            let s = fc_check::read(&mut port, std::time::Duration::from_secs(1))
                .await
                .unwrap();
            drop(port);
            (s, server.await.unwrap())
        });
        let (settings, mut fc) = settings;
        let config = crate::config::FaithdConfig::default();
        let want = fc_check::Expectations::new(&config.gate, config.mavlink.autopilot_system_id);
        let report = fc_check::evaluate(&settings, &want);
        assert!(report.route.is_some(), "{}", report.summary());

        let roll = msp::set_raw_rc(&[1800, 1500, 1500, 1500]);
        for t in (0..=800_000).step_by(20_000) {
            fc.receive(&roll, t, FcView::flying([1500; 8]));
        }
        assert_eq!(
            fc.roll_in_use(600_000, 1900, 1400),
            1400,
            "not yet recovered"
        );
        assert_eq!(fc.roll_in_use(800_000, 1900, 1400), 1800, "applied in AUTO");
        assert_eq!(fc.roll_in_use(800_000, 1000, 1400), 1400, "never in MANUAL");
        assert_eq!(
            fc.roll_in_use(1_500_000, 1900, 1400),
            1800,
            "held after the stop"
        );
        assert_eq!(
            fc.roll_in_use(1_500_001, 1900, 1400),
            1400,
            "then the pilot's"
        );
    }
}
