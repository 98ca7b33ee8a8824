//! iNav's MSP port as it behaves on a flight controller, and the MSP RC override
//! behind it: faithd's own model of iNav, for the simulated flights and for the tests
//! that CI runs (it meets no iNav firmware).
//!
//! Written from iNav 9.1's source (src/main/ of iNavFlight/inav; facts in
//! `../shared/inav.md`), faithful where a roll's safety depends on it:
//!
//! - **Serial timing.** The serial task runs every 10 ms (fc/fc_tasks.c, TASK_SERIAL,
//!   `TASK_PERIOD_HZ(100)`) and handles at most one MSP command per port per run
//!   (msp/msp_serial.c, `mspSerialProcessOnePort`: "process one command at a time").
//! - **The receive ring.** 256 bytes (drivers/serial_uart.h, `UARTn_RX_BUFFER_SIZE`);
//!   the interrupt advances its head with no overflow check
//!   (drivers/serial_uart_stm32f4xx.c, `rxBufferHead = (rxBufferHead + 1) % size`), so
//!   a sender that outruns the port loses a whole ring of bytes at a time.
//! - **The MSP v2 parser** (msp/msp_serial.c, `mspSerialProcessReceivedData`): a bad
//!   checksum or a payload over 192 bytes (`MSP_PORT_INBUF_SIZE`) drops the frame; a
//!   `#` between frames, followed by a run with nothing waiting, enters the CLI.
//! - **MSP_SET_RAW_RC** (fc/fc_msp.c) hands the channels to rx/msp.c; channels not in
//!   the frame read 0.
//! - **The override** (rx/msp_override.c): the signal counts as received for 200 ms
//!   after a frame (`rxSignalTimeout = DELAY_5_HZ`); channels are recomputed on every
//!   frame and at 50 Hz; flight channels are scaled by `rxrange` (`scaleRange`) and
//!   clamped, and an invalid pulse (outside rx_min_usec..rx_max_usec) holds the old
//!   value; the override leaves its failsafe after 200 ms + failsafe_recovery_delay of
//!   valid data and falls back into it 200 ms + failsafe_delay after data stops
//!   (both periods fixed at boot, `mspOverrideInit`). It is applied while the MSP RC
//!   OVERRIDE mode is on and it is out of its failsafe (rx/rx.c), to the channels in
//!   `msp_override_channels`, read on every frame, except the channels that carry the
//!   override mode's own switch.
//! - **Modes** (fc/rc_modes.c, OR logic; fc/fc_core.c): ANGLE is on while its range
//!   is; MSP2_INAV_STATUS reports the flight mode (fc/fc_msp_box.c). Outside ANGLE the
//!   roll stick commands a rate (flight/pid.c, `pidRcCommandToRate`), inside a bank
//!   angle (`pidRcCommandToAngle`), both after the deadband and expo of fc/fc_core.c
//!   and fc/rc_curves.c: [`InavMsp::roll_target`].
//! - **The CLI** (fc/cli.c): enough of it to read `rxrange`, which no MSP command
//!   reports; `exit` reboots the flight controller (`cliExit` -> `cliReboot`).
//! - **Several MSP ports** on one board ([`InavMsp::add_port`]): each has its own ring,
//!   parser and one command per serial task run (msp/msp_serial.c, `mspSerialProcess`
//!   serves every port in each run, at most `MAX_MSP_PORT_COUNT` = 3, msp_serial.h:25);
//!   they share everything behind them (the override, the modes, the global
//!   variables). The CLI is on one port at a time (fc/cli.c, `cliEnter` returns when
//!   `cliMode` is already set) and MSP goes on on the others (fc/fc_tasks.c,
//!   `taskHandleSerial`: "Allow MSP processing even if in CLI mode").
//! - **Telemetry over MSP** (fc/fc_msp.c): MSP_ATTITUDE and MSP_RAW_IMU from the
//!   vehicle's motion as iNav estimates it ([`Motion`]), with iNav's own rounding.
//! - **Global variables** (programming/global_variables.c): eight int32, zero at boot
//!   (`gvInit` sets each to its configured default), each write clamped to the
//!   variable's configured min..max (INT16_MIN..INT16_MAX by default); set with
//!   MSP2_INAV_SET_GVAR, read with MSP2_INAV_GVAR_STATUS.
//!
//! Simplified, and said so: the override values are applied the moment they change
//! (iNav applies them at the pilot's next receiver frame, a few ms later); MSP v1
//! frames are not modelled (faithd speaks v2 only); a `#` enters the CLI armed too
//! (iNav evaluates non-MSP bytes only while disarmed, fc/fc_tasks.c); the
//! accelerometer reads 1 g straight down the board's z axis whatever the motion; no
//! logic condition writes the global variables.

use crate::frame::{self, Decoder, crc8_dvb_s2};

/// The MSP commands the model answers (msp/msp_protocol.h, msp_protocol_v2_common.h,
/// msp_protocol_v2_inav.h).
pub const MSP_FC_VARIANT: u16 = 2;
pub const MSP_FC_VERSION: u16 = 3;
pub const MSP_MODE_RANGES: u16 = 34;
pub const MSP_RX_MAP: u16 = 64;
pub const MSP_RC: u16 = 105;
pub const MSP_BOXIDS: u16 = 119;
pub const MSP_SET_RAW_RC: u16 = 200;
pub const MSP2_COMMON_SETTING: u16 = 0x1003;
pub const MSP2_INAV_STATUS: u16 = 0x2000;
pub const MSP_RAW_IMU: u16 = 102;
pub const MSP_ATTITUDE: u16 = 108;
pub const MSP2_INAV_GVAR_STATUS: u16 = 0x2027;
pub const MSP2_INAV_SET_GVAR: u16 = 0x2214;

/// programming/global_variables.h:29 (9.x and 10.x alike).
pub const MAX_GLOBAL_VARIABLES: usize = 8;

/// MSP_BOXIDS as iNav 9.1's SITL build answers it: the order of MSP2_INAV_STATUS's
/// mode bits.
pub const BOX_IDS: [u8; 29] = [
    0, 51, 61, 1, 2, 35, 5, 8, 6, 7, 32, 46, 3, 13, 60, 19, 27, 39, 40, 41, 42, 43, 44, 50, 62, 63,
    65, 66, 67,
];

/// Permanent mode ids (fc/fc_msp_box.c).
pub const MODE_ARM: u8 = 0;
pub const MODE_ANGLE: u8 = 1;
pub const MODE_FAILSAFE: u8 = 27;
pub const MODE_MSP_RC_OVERRIDE: u8 = 50;

/// The serial task's period on a board (SITL's is 500 us: target/SITL/target.h).
pub const SERIAL_TASK_US: i64 = 10_000;
/// A UART's receive ring.
pub const RX_RING_BYTES: usize = 256;
/// msp/msp_serial.h: larger payloads are dropped.
const MSP_PORT_INBUF_SIZE: usize = 192;
/// rx/rx.h: MAX_SUPPORTED_RC_CHANNEL_COUNT, NON_AUX_CHANNEL_COUNT.
const MAX_CHANNELS: usize = 34;
const FLIGHT_CHANNELS: usize = 4;
/// rx/ibus.c: IBUS_MAX_CHANNEL, the channels MSP_RC reports with an IBUS receiver.
pub const RECEIVER_CHANNELS: usize = 18;
/// rx/msp_override.c: the override is recomputed at least this often (DELAY_50_HZ).
const OVERRIDE_UPDATE_US: i64 = 20_000;
/// rx/msp.c: the override's signal is lost this long after the last frame.
const SIGNAL_TIMEOUT_US: i64 = 200_000;
/// flight/failsafe.h: PERIOD_RXDATA_RECOVERY, PERIOD_RXDATA_FAILURE.
const RXDATA_PERIOD_MS: i64 = 200;
/// rx/rx.h: an invalid pulse is held this long before the channel counts as lost.
const MAX_INVALID_RX_PULSE_MS: i64 = 300;
/// rx/rx.h: PWM_PULSE_MIN, PWM_PULSE_MAX; PWM_RANGE_MIDDLE.
const PWM_PULSE_MIN: i64 = 750;
const PWM_PULSE_MAX: i64 = 2250;
const PWM_RANGE_MIDDLE: u16 = 1500;
/// fc/rc_modes.h: CHANNEL_RANGE_MIN, CHANNEL_RANGE_STEP_WIDTH.
const CHANNEL_RANGE_MIN: u16 = 900;
const CHANNEL_RANGE_STEP_WIDTH: u16 = 25;
/// How long the board is gone after the CLI's `exit` (a reboot).
pub const REBOOT_US: i64 = 2_000_000;

/// One `aux` line: (slot, mode id, aux index, start step, end step).
pub type ModeSlot = (u8, u8, u8, u8, u8);

/// The settings the model answers with and acts on: the committed set-up by default
/// (tests/inav/pilot.cli, then hil/inav/faithd.cli), iNav's defaults elsewhere.
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    pub receiver_type: u8,
    pub msp_override_channels: u32,
    pub failsafe_delay_ds: u8,
    pub failsafe_recovery_delay_ds: u8,
    pub mavlink_extra1_rate: u8,
    pub mavlink_rc_chan_rate: u8,
    pub modes: Vec<ModeSlot>,
    /// MSP_RX_MAP: the radio channel (0-based) feeding roll, pitch, yaw, throttle.
    pub rcmap: [u8; 4],
    /// `rxrange` of roll, pitch, yaw and throttle.
    pub rxrange: [(u16, u16); 4],
    pub rx_min_usec: u16,
    pub rx_max_usec: u16,
    /// Default rates (fc/settings.yaml): rc_expo, deadband, roll_rate (tens of
    /// degrees per second), max_angle_inclination_rll (tenths of a degree).
    pub rc_expo: u8,
    pub deadband_us: u16,
    pub roll_rate: u8,
    pub max_angle_inclination_rll_ddeg: u16,
    /// What MSP_FC_VERSION answers: major, minor, patch (build/version.h, from
    /// CMakeLists.txt's `project(INAV VERSION ..)`). Nothing else in the model depends
    /// on it: the other answers are iNav 9.1's, and those faithd asks are the same in
    /// the 10.x branch (fc/fc_msp.c), but MSP_BOXIDS ([`BOX_IDS`]) is a build's own.
    /// The 10.x branch's SITL build itself still says 9.1.0 (its CMakeLists.txt:56).
    pub fc_version: [u8; 3],
    /// The build has MAVLink. iNav compiles MAVLink out on boards with 512 KB of flash
    /// or less (F411, F722), its `mavlink_*` settings with it: MSP2_COMMON_SETTING
    /// then refuses their names as it refuses any unknown one (fc/fc_msp.c,
    /// `mspSettingCommand`: `mspReadSetting` finds none, the reply is an error).
    pub has_mavlink: bool,
    /// `gvar <i> <default> <min> <max>` (fc/cli.c, `cliGvar`): each global variable's
    /// value at boot and the range its writes are clamped to.
    pub gvar_config: [GvarConfig; MAX_GLOBAL_VARIABLES],
}

/// One global variable's configuration (programming/global_variables.h,
/// `globalVariableConfig_t`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GvarConfig {
    pub default_value: i32,
    pub min: i32,
    pub max: i32,
}

impl Default for GvarConfig {
    /// programming/global_variables.c:41-48, `pgResetFn_globalVariableConfigs`:
    /// min INT16_MIN, max INT16_MAX, default 0.
    fn default() -> Self {
        Self {
            default_value: 0,
            min: i32::from(i16::MIN),
            max: i32::from(i16::MAX),
        }
    }
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
            rcmap: [0, 1, 3, 2],
            rxrange: [(1000, 2000); 4],
            rx_min_usec: 885,
            rx_max_usec: 2115,
            rc_expo: 70,
            deadband_us: 2,
            roll_rate: 20,
            max_angle_inclination_rll_ddeg: 450,
            fc_version: [9, 1, 0],
            has_mavlink: true,
            gvar_config: [GvarConfig::default(); MAX_GLOBAL_VARIABLES],
        }
    }
}

impl Setup {
    /// Whether mode `id` is on with these channels in use (OR over its ranges).
    pub fn mode_on(&self, id: u8, channels_us: &[u16]) -> bool {
        self.modes.iter().any(|&(_, mode, aux, start, end)| {
            let value = channels_us
                .get(FLIGHT_CHANNELS + usize::from(aux))
                .copied()
                .unwrap_or(0);
            mode == id
                && start < end
                && value >= CHANNEL_RANGE_MIN + CHANNEL_RANGE_STEP_WIDTH * u16::from(start)
                && value < CHANNEL_RANGE_MIN + CHANNEL_RANGE_STEP_WIDTH * u16::from(end)
        })
    }

    fn setting(&self, name: &[u8]) -> Option<Vec<u8>> {
        let byte = |v: u8| Some(vec![v]);
        if name.starts_with(b"mavlink_") && !self.has_mavlink {
            return None;
        }
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
            b"rx_min_usec" => Some(self.rx_min_usec.to_le_bytes().to_vec()),
            b"rx_max_usec" => Some(self.rx_max_usec.to_le_bytes().to_vec()),
            _ => None,
        }
    }
}

/// What the pilot's side of the vehicle gives iNav: the channels its receiver
/// delivers (iNav's order, calibrated), armed, and iNav's own failsafe.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pilot {
    pub channels_us: [u16; RECEIVER_CHANNELS],
    pub armed: bool,
    pub failsafe: bool,
}

impl Pilot {
    /// Armed, no failsafe, these first eight channels (the rest at 1500).
    pub fn flying(first_eight_us: [u16; 8]) -> Self {
        let mut channels_us = [PWM_RANGE_MIDDLE; RECEIVER_CHANNELS];
        channels_us[..8].copy_from_slice(&first_eight_us);
        Self {
            channels_us,
            armed: true,
            failsafe: false,
        }
    }
}

/// The vehicle's motion as iNav estimates it, in iNav's own variables and signs: what
/// MSP_ATTITUDE and MSP_RAW_IMU report.
///
/// - `roll_ddeg`, `pitch_ddeg`, `yaw_ddeg`: `attitude.values` (flight/imu.h:31-39),
///   decidegrees, from the rotation matrix in `imuUpdateEulerAngles` (flight/imu.c
///   9:624-629, 10:620-625). Roll positive = right wing down. Pitch positive = nose
///   DOWN: iNav's MAVLink negates it for ATTITUDE (telemetry/mavlink.c:726,
///   `-attitude.values.pitch`), as the RealFlight bridge does going in
///   (target/SITL/sim/realFlight.c:346). Yaw is the heading, clockwise from north,
///   0..3599 (imu.c adds 3600 to a negative one).
/// - `gyro_dps`: `gyro.gyroADCf` (sensors/gyro.c), degrees per second, float, in the
///   body frame of iNav's rate loop: roll positive = rolling right; pitch positive =
///   nose going DOWN (realFlight.c:371 and SITL's xplane.c:609 negate the simulator's
///   pitch rate); yaw positive = nose going LEFT, counter-clockwise seen from above
///   (xplane.c:610 negates X-Plane's yaw rate; fc/fc_core.c:404 negates the yaw stick),
///   the opposite sense to the heading's. Read from the code, not measured. iNav's
///   MAVLink ATTITUDE sends these same numbers unconverted as its "rad/s" rates
///   (telemetry/mavlink.c:730-734), while it flips the pitch angle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Motion {
    pub roll_ddeg: i16,
    pub pitch_ddeg: i16,
    pub yaw_ddeg: i16,
    pub gyro_dps: [f32; 3],
}

/// `lrintf` then a cast to int16_t, as iNav turns a float into an MSP int16
/// (sensors/gyro.c `gyroRateDps`, fc/fc_msp.c MSP_RAW_IMU): rounded to nearest in the
/// default rounding mode, ties to EVEN (12.5 -> 12, 13.5 -> 14, -12.5 -> -12; C's
/// `lrintf` is not `lroundf`), and the long narrowed to 16 bits modulo 2^16 (GCC's
/// conversion: 40000 -> -25536, no saturation).
pub fn lrintf_i16(v: f32) -> i16 {
    v.round_ties_even() as i32 as i16
}

/// common/maths.c:168-176, `constrain`: below `low` is `low`, else above `high` is
/// `high` (no panic when a CLI set min above max, unlike `i32::clamp`).
fn constrain(amt: i32, low: i32, high: i32) -> i32 {
    if amt < low {
        low
    } else if amt > high {
        high
    } else {
        amt
    }
}

/// What iNav's controller makes of the roll channel it uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RollTarget {
    /// ANGLE mode: a bank angle, degrees (positive right).
    BankDeg(f64),
    /// Outside ANGLE: a roll rate, degrees per second.
    RateDegS(f64),
}

/// What the port did, for tests that hold faithd to the board's budget.
#[derive(Clone, Debug, Default)]
pub struct PortLog {
    /// Every complete request that reached the port: (arrival time, command). Decoded
    /// as the bytes arrive, before the ring can lose them.
    pub arrived: Vec<(i64, u16)>,
    /// Every command iNav served: (time of the serial task's run, command).
    pub served: Vec<(i64, u16)>,
    /// Bytes lost to ring overflow, and when the last were.
    pub bytes_lost: u64,
    pub last_loss_us: Option<i64>,
    /// Every MSP_SET_RAW_RC served: (time, channels).
    pub frames: Vec<(i64, Vec<u16>)>,
    /// Every MSP2_INAV_SET_GVAR iNav accepted: (time served, index, the value sent,
    /// before iNav clamped it; [`InavMsp::gvars`] has what it holds).
    pub gvar_writes: Vec<(i64, u8, i32)>,
}

/// iNav's MSP ports (one to begin with, more with [`InavMsp::add_port`]) and what is
/// behind them: the override, the modes, the global variables. The methods without a
/// port number are the first port's.
#[derive(Debug)]
pub struct InavMsp {
    pub setup: Setup,
    pilot: Pilot,
    motion: Motion,
    /// programming/global_variables.c:37, `globalVariableState` (RAM).
    gvars: [i32; MAX_GLOBAL_VARIABLES],
    ports: Vec<Port>,
    /// The CLI: the port it took and its input so far.
    cli: Option<Cli>,
    rebooting_until_us: Option<i64>,
    /// The next serial task run and the next RX check (every millisecond).
    next_serial_us: i64,
    next_rx_us: i64,
    ovr: Override,
    /// The first port's log.
    pub log: PortLog,
    /// The other ports' logs, from the second port on.
    more_logs: Vec<PortLog>,
    /// A fault for tests: iNav acknowledges MSP_SET_RAW_RC but its override never
    /// sees the frames (what a set-up that reads right but misbehaves amounts to).
    pub ignore_frames: bool,
}

/// One MSP port: its UART's receive ring, its parser, what iNav writes to it.
#[derive(Debug, Default)]
struct Port {
    ring: Ring,
    parser: Parser,
    /// Decodes the arriving bytes for [`PortLog::arrived`] (not iNav's: a witness).
    witness: Decoder,
    pending_cli: bool,
    out: Vec<u8>,
}

#[derive(Debug)]
struct Cli {
    port: usize,
    line: Vec<u8>,
}

impl InavMsp {
    /// A board that booted at `boot_us`, with one MSP port.
    pub fn new(setup: Setup, boot_us: i64) -> Self {
        let ovr = Override::init(&setup, boot_us);
        // gvInit (global_variables.c:64-68, at boot: fc/fc_init.c:308): each variable
        // its configured default, not clamped.
        let gvars = setup.gvar_config.map(|g| g.default_value);
        Self {
            setup,
            pilot: Pilot::flying([1500, 1500, 1500, 1000, 1000, 1000, 1000, 1000]),
            motion: Motion::default(),
            gvars,
            ports: vec![Port::default()],
            cli: None,
            rebooting_until_us: None,
            next_serial_us: boot_us + SERIAL_TASK_US,
            next_rx_us: boot_us + 1000,
            ovr,
            log: PortLog::default(),
            more_logs: Vec::new(),
            ignore_frames: false,
        }
    }

    /// Another MSP port on the board (iNav has at most 3); its number for
    /// [`Self::receive_on`], [`Self::take_output_on`] and [`Self::port_log`].
    pub fn add_port(&mut self) -> usize {
        self.ports.push(Port::default());
        self.more_logs.push(PortLog::default());
        self.ports.len() - 1
    }

    /// What port `port` did (0 is the first, [`Self::log`]).
    pub fn port_log(&self, port: usize) -> &PortLog {
        match port {
            0 => &self.log,
            n => &self.more_logs[n - 1],
        }
    }

    fn port_log_mut(&mut self, port: usize) -> &mut PortLog {
        match port {
            0 => &mut self.log,
            n => &mut self.more_logs[n - 1],
        }
    }

    /// The vehicle's motion as iNav estimates it from now on.
    pub fn set_motion(&mut self, motion: Motion) {
        self.motion = motion;
    }

    /// iNav's global variables now (MSP2_INAV_GVAR_STATUS).
    pub fn gvars(&self) -> [i32; MAX_GLOBAL_VARIABLES] {
        self.gvars
    }

    /// The pilot's side as of now.
    pub fn set_pilot(&mut self, pilot: Pilot) {
        self.pilot = pilot;
    }

    /// Bytes from faithd reaching the first port's UART at `now_us` (after iNav has
    /// run up to then).
    pub fn receive(&mut self, bytes: &[u8], now_us: i64) {
        self.receive_on(0, bytes, now_us);
    }

    /// Bytes reaching port `port`'s UART at `now_us`.
    pub fn receive_on(&mut self, port: usize, bytes: &[u8], now_us: i64) {
        self.advance(now_us);
        let mut frames = Vec::new();
        self.ports[port].witness.push(bytes, &mut frames);
        let rebooting = self.rebooting_until_us.is_some();
        let Self {
            ports,
            log,
            more_logs,
            ..
        } = self;
        let log = match port {
            0 => log,
            n => &mut more_logs[n - 1],
        };
        log.arrived.extend(
            frames
                .iter()
                .filter(|f| f.direction == b'<')
                .map(|f| (now_us, f.command)),
        );
        if rebooting {
            log.bytes_lost += bytes.len() as u64;
            return;
        }
        for &b in bytes {
            if ports[port].ring.push(b) {
                log.bytes_lost += RX_RING_BYTES as u64;
                log.last_loss_us = Some(now_us);
            }
        }
    }

    /// Runs iNav's tasks up to `now_us`: the serial task every 10 ms, the RX check
    /// every millisecond.
    pub fn advance(&mut self, now_us: i64) {
        loop {
            let next = self.next_serial_us.min(self.next_rx_us);
            if next > now_us {
                return;
            }
            if let Some(until) = self.rebooting_until_us {
                if next < until {
                    self.next_serial_us = self.next_serial_us.max(until);
                    self.next_rx_us = self.next_rx_us.max(until);
                    continue;
                }
                self.boot(until);
                continue;
            }
            if self.next_serial_us <= self.next_rx_us {
                let t = self.next_serial_us;
                self.serial_task(t);
                self.next_serial_us += SERIAL_TASK_US;
            } else {
                let t = self.next_rx_us;
                self.ovr.rx_check(t, &self.setup);
                self.next_rx_us += 1000;
            }
        }
    }

    /// Replies iNav has written to the first port since the last call.
    pub fn take_output(&mut self) -> Vec<u8> {
        self.take_output_on(0)
    }

    /// What iNav has written to port `port` since the last call.
    pub fn take_output_on(&mut self, port: usize) -> Vec<u8> {
        std::mem::take(&mut self.ports[port].out)
    }

    /// The channels iNav uses now (MSP_RC, RC_CHANNELS), in its order.
    pub fn channels_in_use(&self) -> [u16; RECEIVER_CHANNELS] {
        let mut channels = self.pilot.channels_us;
        if self
            .setup
            .mode_on(MODE_MSP_RC_OVERRIDE, &self.pilot.channels_us)
            && !self.ovr.failsafe
        {
            // rx/msp_override.c, mspOverrideChannels: the mask is read on every call,
            // the override's own switch channels are never taken.
            let mask = self.setup.msp_override_channels & !self.ovr.ctrl_channels;
            for (i, c) in channels.iter_mut().enumerate() {
                if mask & (1 << i) != 0 {
                    *c = self.ovr.data[i];
                }
            }
        }
        channels
    }

    /// The roll value iNav uses now.
    pub fn roll_in_use(&self) -> u16 {
        self.channels_in_use()[0]
    }

    /// iNav flies in ANGLE mode now.
    pub fn angle_mode(&self) -> bool {
        self.setup.mode_on(MODE_ANGLE, &self.channels_in_use())
    }

    /// What iNav's controller makes of the roll it uses (fc/fc_core.c
    /// `getAxisRcCommand`, fc/rc_curves.c `rcLookup`, flight/pid.c).
    pub fn roll_target(&self) -> RollTarget {
        let s = &self.setup;
        let command = rc_command(s, self.roll_in_use());
        if self.angle_mode() {
            RollTarget::BankDeg(
                command / 500.0 * f64::from(s.max_angle_inclination_rll_ddeg) / 10.0,
            )
        } else {
            RollTarget::RateDegS(command / 500.0 * f64::from(s.roll_rate) * 10.0)
        }
    }

    /// Whether the port is in iNav's CLI (entered with `#`, left only by a reboot).
    pub fn in_cli(&self) -> bool {
        self.cli.is_some()
    }

    /// fc/fc_tasks.c, `taskHandleSerial`: the CLI first (`cliProcess`), then every
    /// MSP port (`mspSerialProcess`), the CLI's own port excepted (the CLI has read
    /// its bytes).
    fn serial_task(&mut self, now_us: i64) {
        if let Some(cli) = self.cli.as_mut() {
            let ring = &mut self.ports[cli.port].ring;
            while let Some(b) = ring.pop() {
                cli.line.push(b);
            }
            self.run_cli(now_us);
            if self.rebooting_until_us.is_some() {
                return;
            }
        }
        for port in 0..self.ports.len() {
            if self.cli.as_ref().is_some_and(|c| c.port == port) {
                continue;
            }
            self.msp_one_port(port, now_us);
        }
    }

    /// msp/msp_serial.c, `mspSerialProcessOnePort`: with bytes waiting, parse until
    /// one command is complete and answer it; with none, act on a pending `#` (the
    /// CLI is on one port at a time: fc/cli.c, `cliEnter`).
    fn msp_one_port(&mut self, port: usize, now_us: i64) {
        let p = &mut self.ports[port];
        if p.ring.is_empty() {
            if std::mem::take(&mut p.pending_cli) && self.cli.is_none() {
                self.cli = Some(Cli {
                    port,
                    line: Vec::new(),
                });
                p.out.extend_from_slice(
                    b"\r\nEntering CLI Mode, type 'exit' to return, or 'help'\r\n\r\n# ",
                );
            }
            return;
        }
        p.pending_cli = false;
        while let Some(b) = self.ports[port].ring.pop() {
            match self.ports[port].parser.push(b) {
                Parsed::NotMsp if b == b'#' => self.ports[port].pending_cli = true,
                Parsed::Command(command, payload) => {
                    self.port_log_mut(port).served.push((now_us, command));
                    let reply = self.answer(port, command, &payload, now_us);
                    self.ports[port].out.extend(match reply {
                        Some(p) => encode(b'>', command, &p),
                        None => encode(b'!', command, &[]),
                    });
                    return;
                }
                _ => {}
            }
        }
    }

    /// fc/fc_msp.c, `mspFcProcessCommand`: the reply's payload, `None` for an error
    /// reply (`MSP_RESULT_ERROR`, or a command the model does not know).
    fn answer(
        &mut self,
        port: usize,
        command: u16,
        payload: &[u8],
        now_us: i64,
    ) -> Option<Vec<u8>> {
        let u16s = |v: &[u16]| v.iter().flat_map(|c| c.to_le_bytes()).collect::<Vec<u8>>();
        match command {
            MSP_FC_VARIANT => Some(b"INAV".to_vec()),
            // fc_msp.c 9:403-407, 10:473-477.
            MSP_FC_VERSION => Some(self.setup.fc_version.to_vec()),
            MSP_RX_MAP => Some(self.setup.rcmap.to_vec()),
            MSP_MODE_RANGES => {
                let mut out = vec![0u8; 40 * 4];
                for &(slot, id, aux, start, end) in &self.setup.modes {
                    let i = usize::from(slot) * 4;
                    out[i..i + 4].copy_from_slice(&[id, aux, start, end]);
                }
                Some(out)
            }
            MSP2_COMMON_SETTING => {
                let name = payload.split(|b| *b == 0).next().unwrap_or(&[]);
                self.setup.setting(name)
            }
            MSP_SET_RAW_RC => {
                let count = payload.len() / 2;
                if count > MAX_CHANNELS || !payload.len().is_multiple_of(2) {
                    return None;
                }
                let channels: Vec<u16> = payload
                    .chunks_exact(2)
                    .map(|c| u16::from_le_bytes([c[0], c[1]]))
                    .collect();
                if !self.ignore_frames {
                    self.ovr.frame(&channels);
                }
                self.port_log_mut(port).frames.push((now_us, channels));
                Some(Vec::new())
            }
            MSP_RC => Some(u16s(&self.channels_in_use())),
            MSP_BOXIDS => Some(BOX_IDS.to_vec()),
            MSP2_INAV_STATUS => Some(self.status()),
            MSP_RAW_IMU => Some(self.raw_imu()),
            MSP_ATTITUDE => Some(self.attitude()),
            // fc_msp.c 9:624-628, 10:672-676: `gvGet(i)` as u32 each.
            MSP2_INAV_GVAR_STATUS => {
                Some(self.gvars.iter().flat_map(|v| v.to_le_bytes()).collect())
            }
            // fc_msp.c 9:2409-2424, 10:2526-2541 (the same): exactly 5 bytes, an index
            // below MAX_GLOBAL_VARIABLES, else an error reply; then `gvSet` and an
            // empty reply.
            MSP2_INAV_SET_GVAR => {
                let [index, a, b, c, d] = *payload else {
                    return None;
                };
                let value = i32::from_le_bytes([a, b, c, d]);
                let config = self.setup.gvar_config.get(usize::from(index))?;
                self.gvars[usize::from(index)] = constrain(value, config.min, config.max);
                self.port_log_mut(port)
                    .gvar_writes
                    .push((now_us, index, value));
                Some(Vec::new())
            }
            _ => None,
        }
    }

    /// MSP_RAW_IMU (fc_msp.c 9:516-532, 10:586-602): the accelerometer
    /// `(int16_t)lrintf(acc.accADCf[i] * 512)` (1 g = 512; the model's board is level:
    /// 0, 0, 512), the gyro `gyroRateDps(i)` = `lrintf(gyro.gyroADCf[i])` returned as
    /// int16_t (sensors/gyro.c 9:604-611, 10:614-621; [`lrintf_i16`]), the
    /// magnetometer 0 (the model has none: `USE_MAG` boards send `mag.magADC`).
    fn raw_imu(&self) -> Vec<u8> {
        let acc = [0i16, 0, 512];
        let gyro = self.motion.gyro_dps.map(lrintf_i16);
        acc.iter()
            .chain(&gyro)
            .chain(&[0i16; 3])
            .flat_map(|v| v.to_le_bytes())
            .collect()
    }

    /// MSP_ATTITUDE (fc_msp.c 9:676-680, 10:718-722): roll and pitch as int16
    /// decidegrees, then `DECIDEGREES_TO_DEGREES(attitude.values.yaw)`, which is
    /// `yaw / 10.0f` (common/maths.h:45), a float that sbufWriteU16's uint16_t
    /// parameter truncates: 3599 -> 359, never rounded up to 360.
    fn attitude(&self) -> Vec<u8> {
        let m = &self.motion;
        let yaw_deg = (f32::from(m.yaw_ddeg) / 10.0) as u16;
        let mut out = Vec::with_capacity(6);
        out.extend_from_slice(&m.roll_ddeg.to_le_bytes());
        out.extend_from_slice(&m.pitch_ddeg.to_le_bytes());
        out.extend_from_slice(&yaw_deg.to_le_bytes());
        out
    }

    /// MSP2_INAV_STATUS: cycle time .. profile, arming flags, the active modes' bits
    /// (positions in [`BOX_IDS`]), mixer profile.
    fn status(&self) -> Vec<u8> {
        let mut out = vec![0u8; 9];
        let flags: u32 = if self.pilot.armed { 0b1100 } else { 0 };
        out.extend_from_slice(&flags.to_le_bytes());
        let mut bits = [0u8; 8];
        let mut set = |id: u8| {
            if let Some(i) = BOX_IDS.iter().position(|b| *b == id) {
                bits[i / 8] |= 1 << (i % 8);
            }
        };
        if self.angle_mode() {
            set(MODE_ANGLE);
        }
        if self.pilot.armed {
            set(MODE_ARM);
        }
        if self.pilot.failsafe {
            set(MODE_FAILSAFE);
        }
        if self
            .setup
            .mode_on(MODE_MSP_RC_OVERRIDE, &self.pilot.channels_us)
        {
            set(MODE_MSP_RC_OVERRIDE);
        }
        out.extend_from_slice(&bits);
        out.push(0);
        out
    }

    /// fc/cli.c: each complete line is a command; `rxrange` prints the four flight
    /// channels' ranges, `exit` reboots.
    fn run_cli(&mut self, now_us: i64) {
        loop {
            let Some(cli) = self.cli.as_mut() else {
                return;
            };
            let Some(end) = cli.line.iter().position(|b| *b == b'\r' || *b == b'\n') else {
                return;
            };
            let line: Vec<u8> = cli.line.drain(..=end).collect();
            let line = String::from_utf8_lossy(&line[..end]).trim().to_string();
            if line.is_empty() {
                continue;
            }
            let out = &mut self.ports[cli.port].out;
            out.extend_from_slice(line.as_bytes());
            out.extend_from_slice(b"\r\n");
            match line.as_str() {
                "rxrange" => {
                    for (i, (min, max)) in self.setup.rxrange.iter().enumerate() {
                        out.extend_from_slice(format!("rxrange {i} {min} {max}\r\n").as_bytes());
                    }
                }
                "exit" => {
                    out.extend_from_slice(b"\r\nLeaving CLI mode, unsaved changes lost.\r\n");
                    self.rebooting_until_us = Some(now_us + REBOOT_US);
                    self.cli = None;
                    for port in &mut self.ports {
                        port.ring = Ring::default();
                    }
                    return;
                }
                _ => out.extend_from_slice(b"Unknown command, try 'help'\r\n"),
            }
            out.extend_from_slice(b"\r\n# ");
        }
    }

    /// The board comes back from a reboot: everything of the ports, the override and
    /// the global variables (RAM) starts afresh; the pilot and the vehicle's motion
    /// are as they were.
    fn boot(&mut self, now_us: i64) {
        let mut fresh = Self::new(self.setup.clone(), now_us);
        for _ in 1..self.ports.len() {
            fresh.add_port();
        }
        fresh.pilot = self.pilot;
        fresh.motion = self.motion;
        fresh.log = std::mem::take(&mut self.log);
        fresh.more_logs = std::mem::take(&mut self.more_logs);
        *self = fresh;
    }
}

/// rx/msp_override.c's state.
#[derive(Clone, Debug)]
struct Override {
    /// rx/msp.c's frame: the last MSP_SET_RAW_RC, missing channels 0.
    msp_frame: [u16; MAX_CHANNELS],
    frame_done: bool,
    signal_received: bool,
    need_signal_before_us: i64,
    processing_required: bool,
    next_update_us: i64,
    /// mspRcChannels: `.data` and the time each expires when its pulse is invalid.
    data: [u16; MAX_CHANNELS],
    expires_at_ms: [i64; MAX_CHANNELS],
    flight_channels_valid: bool,
    failsafe: bool,
    received_at_ms: i64,
    failed_at_ms: i64,
    /// Fixed at boot (mspOverrideInit).
    ctrl_channels: u32,
    failure_period_ms: i64,
    recovery_period_ms: i64,
    boot_us: i64,
}

impl Override {
    /// `mspOverrideInit`, at boot.
    fn init(setup: &Setup, boot_us: i64) -> Self {
        let mut data = [PWM_RANGE_MIDDLE; MAX_CHANNELS];
        data[3] = setup.rx_min_usec; // throttle
        let ctrl_channels = setup
            .modes
            .iter()
            .filter(|m| m.1 == MODE_MSP_RC_OVERRIDE && m.3 < m.4)
            .fold(0u32, |mask, m| {
                mask | 1 << (usize::from(m.2) + FLIGHT_CHANNELS)
            });
        Self {
            msp_frame: [0; MAX_CHANNELS],
            frame_done: false,
            signal_received: false,
            need_signal_before_us: 0,
            processing_required: false,
            next_update_us: 0,
            data,
            expires_at_ms: [MAX_INVALID_RX_PULSE_MS; MAX_CHANNELS],
            flight_channels_valid: false,
            failsafe: true,
            received_at_ms: 0,
            failed_at_ms: 0,
            ctrl_channels,
            failure_period_ms: RXDATA_PERIOD_MS + i64::from(setup.failsafe_delay_ds) * 100,
            recovery_period_ms: RXDATA_PERIOD_MS
                + i64::from(setup.failsafe_recovery_delay_ds) * 100,
            boot_us,
        }
    }

    /// rx/msp.c, `rxMspFrameReceive`.
    fn frame(&mut self, channels: &[u16]) {
        self.msp_frame = [0; MAX_CHANNELS];
        for (slot, v) in self.msp_frame.iter_mut().zip(channels) {
            *slot = *v;
        }
        self.frame_done = true;
    }

    /// `mspOverrideUpdateCheck`, then `mspOverrideCalculateChannels` when needed.
    fn rx_check(&mut self, now_us: i64, setup: &Setup) {
        if self.signal_received && now_us >= self.need_signal_before_us {
            self.signal_received = false;
        }
        if std::mem::take(&mut self.frame_done) {
            self.processing_required = true;
            self.signal_received = true;
            self.need_signal_before_us = now_us + SIGNAL_TIMEOUT_US;
        }
        if now_us > self.next_update_us {
            self.processing_required = true;
        }
        if !std::mem::take(&mut self.processing_required) {
            return;
        }
        self.next_update_us = now_us + OVERRIDE_UPDATE_US;
        let now_ms = (now_us - self.boot_us) / 1000;
        self.flight_channels_valid = true;
        let mut staging = [0u16; MAX_CHANNELS];
        for (channel, staged) in staging.iter_mut().enumerate() {
            let raw = if channel < FLIGHT_CHANNELS {
                usize::from(setup.rcmap[channel])
            } else {
                channel
            };
            let mut sample = i64::from(self.msp_frame.get(raw).copied().unwrap_or(0));
            if channel < FLIGHT_CHANNELS && sample != 0 {
                let (min, max) = setup.rxrange[channel];
                let (min, max) = (i64::from(min), i64::from(max));
                sample = if max != min {
                    1000 * (sample - min) / (max - min) + 1000
                } else {
                    sample
                };
                sample = sample.clamp(PWM_PULSE_MIN, PWM_PULSE_MAX);
            }
            let valid =
                sample >= i64::from(setup.rx_min_usec) && sample <= i64::from(setup.rx_max_usec);
            *staged = if valid {
                self.expires_at_ms[channel] = now_ms + MAX_INVALID_RX_PULSE_MS;
                sample as u16
            } else {
                if now_ms > self.expires_at_ms[channel] && channel < FLIGHT_CHANNELS {
                    self.flight_channels_valid = false;
                }
                self.data[channel]
            };
        }
        let good = self.flight_channels_valid && self.signal_received;
        if good {
            self.data = staging;
            self.received_at_ms = now_ms;
            if self.received_at_ms - self.failed_at_ms > self.recovery_period_ms {
                self.failsafe = false;
            }
        } else {
            self.failed_at_ms = now_ms;
            if self.failed_at_ms - self.received_at_ms > self.failure_period_ms {
                self.failsafe = true;
            }
        }
    }
}

/// A UART's receive ring as iNav's interrupt fills it.
#[derive(Debug)]
struct Ring {
    buf: [u8; RX_RING_BYTES],
    head: usize,
    tail: usize,
}

impl Default for Ring {
    fn default() -> Self {
        Self {
            buf: [0; RX_RING_BYTES],
            head: 0,
            tail: 0,
        }
    }
}

impl Ring {
    /// Stores a byte; `true` when the head ran into the tail and the ring's content
    /// is lost (iNav sees it empty again).
    fn push(&mut self, b: u8) -> bool {
        self.buf[self.head] = b;
        self.head = (self.head + 1) % RX_RING_BYTES;
        self.head == self.tail
    }

    fn pop(&mut self) -> Option<u8> {
        if self.is_empty() {
            return None;
        }
        let b = self.buf[self.tail];
        self.tail = (self.tail + 1) % RX_RING_BYTES;
        Some(b)
    }

    fn is_empty(&self) -> bool {
        self.head == self.tail
    }
}

/// What one byte did to the parser.
enum Parsed {
    /// Not part of a frame (`mspSerialProcessReceivedData` returned false).
    NotMsp,
    InFrame,
    Command(u16, Vec<u8>),
}

/// iNav's MSP v2 request parser (`$X<`, flag, command, size, payload, CRC-8/DVB-S2).
#[derive(Debug, Default)]
struct Parser {
    state: ParserState,
    header: Vec<u8>,
    payload: Vec<u8>,
    size: usize,
    crc: u8,
}

#[derive(Debug, Default, PartialEq, Eq)]
enum ParserState {
    #[default]
    Idle,
    Start,
    X,
    Header,
    Payload,
    Checksum,
}

impl Parser {
    fn push(&mut self, c: u8) -> Parsed {
        use ParserState::*;
        match self.state {
            Idle => {
                if c != b'$' {
                    return Parsed::NotMsp;
                }
                self.state = Start;
            }
            Start => self.state = if c == b'X' { X } else { Idle },
            X => {
                if c == b'<' {
                    self.header.clear();
                    self.crc = 0;
                    self.state = Header;
                } else {
                    self.state = Idle;
                }
            }
            Header => {
                self.header.push(c);
                self.crc = crc8_dvb_s2(self.crc, c);
                if self.header.len() == 5 {
                    self.size = usize::from(u16::from_le_bytes([self.header[3], self.header[4]]));
                    self.payload.clear();
                    self.state = if self.size > MSP_PORT_INBUF_SIZE {
                        Idle
                    } else if self.size == 0 {
                        Checksum
                    } else {
                        Payload
                    };
                }
            }
            Payload => {
                self.payload.push(c);
                self.crc = crc8_dvb_s2(self.crc, c);
                if self.payload.len() == self.size {
                    self.state = Checksum;
                }
            }
            Checksum => {
                self.state = Idle;
                if c == self.crc {
                    let command = u16::from_le_bytes([self.header[1], self.header[2]]);
                    return Parsed::Command(command, std::mem::take(&mut self.payload));
                }
            }
        }
        Parsed::InFrame
    }
}

/// An MSP v2 frame from the flight controller.
fn encode(direction: u8, command: u16, payload: &[u8]) -> Vec<u8> {
    frame::encode(direction, command, payload)
}

/// iNav's rcCommand (-500..500) for a roll or pitch channel at `stick_us`: the
/// deflection from 1500 within +-500 (fc/fc_core.c:180-198), the rescaled deadband
/// (common/maths.c:156-166) and the stabilised modes' expo (fc/rc_curves.c:56-60).
/// ANGLE turns it into an angle of rcCommand / 500 of the maximum inclination
/// (flight/pid.c:417-421): faithd's +300 us gives 165, 14.85 degrees of 45.
pub fn rc_command(setup: &Setup, stick_us: u16) -> f64 {
    let deflection = (i32::from(stick_us) - 1500).clamp(-500, 500);
    let deadband = i32::from(setup.deadband_us);
    let rescaled = if deflection.abs() < deadband {
        0
    } else if deflection > 0 {
        (deflection - deadband) * 500 / (500 - deadband)
    } else {
        (deflection + deadband) * 500 / (500 - deadband)
    };
    let x = rescaled as f32 / 100.0;
    ((2500.0 + f32::from(setup.rc_expo) * (x * x - 25.0)) * x / 25.0).round() as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Decoder, Frame};

    /// faithd's frame shapes, built here from iNav's framing (not faithd's code).
    mod msp {
        pub fn encode_request(command: u16, payload: &[u8]) -> Vec<u8> {
            crate::frame::request(command, payload)
        }
        pub fn set_raw_rc(channels_us: &[u16]) -> Vec<u8> {
            let payload: Vec<u8> = channels_us.iter().flat_map(|v| v.to_le_bytes()).collect();
            encode_request(super::MSP_SET_RAW_RC, &payload)
        }
    }

    /// Sends `bytes` at `t_us`, runs iNav to `until_us`, returns the replies.
    fn exchange(fc: &mut InavMsp, bytes: &[u8], t_us: i64, until_us: i64) -> Vec<Frame> {
        fc.receive(bytes, t_us);
        fc.advance(until_us);
        let mut frames = Vec::new();
        Decoder::default().push(&fc.take_output(), &mut frames);
        frames
    }

    fn roll(roll_us: u16) -> Vec<u8> {
        msp::set_raw_rc(&[roll_us, 1500, 1500, 1500])
    }

    /// The pilot's radio: roll 1440, the switch (channel 6) at `switch_us`, ARM and
    /// ANGLE on (channel 5 high).
    fn pilot(switch_us: u16) -> Pilot {
        Pilot::flying([1440, 1500, 1500, 1400, 1900, switch_us, 1000, 1000])
    }

    #[test]
    fn one_command_per_serial_task_run() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        let mut burst = Vec::new();
        for _ in 0..5 {
            burst.extend(msp::encode_request(MSP_RC, &[]));
        }
        let replies = exchange(&mut fc, &burst, 1_000, 9_999);
        assert!(replies.is_empty(), "nothing before the first run at 10 ms");
        fc.advance(10_000);
        assert!(!fc.take_output().is_empty());
        fc.advance(49_999);
        assert_eq!(fc.log.served.len(), 4, "one per 10 ms: {:?}", fc.log.served);
        fc.advance(50_000);
        assert_eq!(
            fc.log.served.iter().map(|s| s.0).collect::<Vec<_>>(),
            vec![10_000, 20_000, 30_000, 40_000, 50_000]
        );
        assert_eq!(fc.log.arrived.len(), 5);
    }

    #[test]
    fn a_sender_that_outruns_the_port_loses_a_ring_of_bytes() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        // 150 commands a second (faithd's old stream): 3 frames every 20 ms.
        let mut t = 0;
        while t < 1_000_000 {
            let mut burst = roll(1500);
            burst.extend(msp::encode_request(MSP_RC, &[]));
            burst.extend(msp::encode_request(MSP2_INAV_STATUS, &[]));
            fc.receive(&burst, t);
            t += 20_000;
        }
        fc.advance(1_000_000);
        assert!(fc.log.bytes_lost >= 256, "{:?}", fc.log.bytes_lost);
        assert!(fc.log.served.len() <= 100);
        // 50 a second, each waiting for its reply: nothing lost, all served.
        let mut fc = InavMsp::new(Setup::default(), 0);
        let mut t = 0;
        while t < 1_000_000 {
            fc.receive(&msp::encode_request(MSP_RC, &[]), t);
            t += 20_000;
        }
        fc.advance(1_000_000);
        assert_eq!(fc.log.bytes_lost, 0);
        assert_eq!(fc.log.served.len(), 50);
    }

    #[test]
    fn the_override_applies_after_its_recovery_and_holds_after_the_frames_stop() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        fc.set_pilot(pilot(1900));
        let mut applied_at = None;
        let mut t = 100_000;
        while t <= 1_500_000 {
            fc.receive(&roll(1800), t);
            for dt in (0..40_000).step_by(1000) {
                fc.advance(t + dt);
                if applied_at.is_none() && fc.roll_in_use() == 1800 {
                    applied_at = Some(t + dt);
                }
            }
            t += 40_000;
        }
        let applied_at = applied_at.expect("applied");
        // 200 ms + failsafe_recovery_delay 0.5 s after the first frame was served
        // (110 ms): measured on SITL 0.70-0.74 s.
        assert!((810_000..=830_000).contains(&applied_at), "{applied_at}");
        let last_served = fc.log.frames.last().unwrap().0;
        let mut released_at = None;
        let mut t = last_served;
        while released_at.is_none() && t < last_served + 2_000_000 {
            t += 1000;
            fc.advance(t);
            if fc.roll_in_use() != 1800 {
                released_at = Some(t);
            }
        }
        let hold = released_at.unwrap() - last_served;
        // 200 ms (signal lost) + 200 ms + failsafe_delay 0.5 s: measured 0.89-0.94 s.
        assert!((895_000..=925_000).contains(&hold), "{hold}");
        assert_eq!(fc.roll_in_use(), 1440, "the pilot's again");
    }

    #[test]
    fn never_in_manual_and_never_on_the_switch_channel() {
        let mut fc = InavMsp::new(
            Setup {
                msp_override_channels: 0b10_0001, // roll and channel 6, the switch
                ..Setup::default()
            },
            0,
        );
        fc.set_pilot(pilot(1000));
        let mut frame = vec![1800u16, 1500, 1500, 1500, 1900, 1000];
        for t in (0..2_000_000).step_by(40_000) {
            fc.receive(&msp::set_raw_rc(&frame), t);
            fc.advance(t + 39_000);
            assert_eq!(fc.roll_in_use(), 1440, "MANUAL: the pilot's roll");
        }
        fc.set_pilot(pilot(1900));
        frame[5] = 1000;
        fc.receive(&msp::set_raw_rc(&frame), 2_000_000);
        fc.advance(2_030_000);
        assert_eq!(fc.roll_in_use(), 1800);
        assert_eq!(fc.channels_in_use()[5], 1900, "the switch is the pilot's");
    }

    #[test]
    fn the_mask_is_read_on_every_frame() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        fc.set_pilot(pilot(1900));
        for t in (0..1_200_000).step_by(40_000) {
            fc.receive(&roll(1800), t);
            fc.advance(t + 39_000);
        }
        assert_eq!(fc.channels_in_use()[3], 1400, "throttle is the pilot's");
        // A configurator on another port sets roll and throttle.
        fc.setup.msp_override_channels = 0b1001;
        assert_eq!(fc.channels_in_use()[3], 1500, "faithd's centre on throttle");
    }

    #[test]
    fn rxrange_scales_what_faithd_sends() {
        let mut fc = InavMsp::new(
            Setup {
                rxrange: [(988, 2012); 4],
                ..Setup::default()
            },
            0,
        );
        fc.set_pilot(pilot(1900));
        for t in (0..1_200_000).step_by(40_000) {
            fc.receive(&roll(1800), t);
            fc.advance(t + 39_000);
        }
        assert_eq!(fc.roll_in_use(), 1792, "as measured on iNav");
    }

    #[test]
    fn outside_angle_the_stick_is_a_rate() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        fc.set_pilot(pilot(1900));
        for t in (0..1_200_000).step_by(40_000) {
            fc.receive(&roll(1800), t);
            fc.advance(t + 39_000);
        }
        assert!(fc.angle_mode());
        let RollTarget::BankDeg(bank) = fc.roll_target() else {
            panic!("ANGLE")
        };
        // 300 us through deadband 2 and expo 70: rcCommand 165 of 500, of 45 degrees.
        assert!((bank - 14.85).abs() < 1e-9, "{bank}");
        // ANGLE off (channel 5 low, still armed by another means in this model).
        let mut p = pilot(1900);
        p.channels_us[4] = 1000;
        fc.set_pilot(p);
        assert!(!fc.angle_mode());
        let RollTarget::RateDegS(rate) = fc.roll_target() else {
            panic!("rate")
        };
        // 66 degrees a second: 1.5 s of it is about 100 degrees of bank.
        assert!((rate * 1.5 - 99.0).abs() < 1e-9, "{rate}");
        let mut frames = Vec::new();
        fc.receive(&msp::encode_request(MSP2_INAV_STATUS, &[]), 1_300_000);
        fc.advance(1_320_000);
        Decoder::default().push(&fc.take_output(), &mut frames);
        let angle_bit = BOX_IDS.iter().position(|b| *b == MODE_ANGLE).unwrap();
        let modes = &frames.last().unwrap().payload[13..];
        assert_eq!(modes[angle_bit / 8] & (1 << (angle_bit % 8)), 0);
    }

    #[test]
    fn the_cli_reads_rxrange_and_exit_reboots() {
        let mut fc = InavMsp::new(
            Setup {
                rxrange: [(988, 2012), (1000, 2000), (1000, 2000), (1000, 2000)],
                ..Setup::default()
            },
            0,
        );
        fc.receive(b"#", 0);
        fc.advance(30_000);
        assert!(fc.in_cli());
        fc.receive(b"rxrange\r\n", 30_000);
        fc.advance(50_000);
        let text = String::from_utf8_lossy(&fc.take_output()).into_owned();
        assert!(text.contains("rxrange 0 988 2012"), "{text}");
        fc.receive(b"exit\r\n", 50_000);
        fc.advance(70_000);
        assert!(!fc.in_cli());
        fc.take_output();
        // Rebooting: nothing answers for 2 s, then MSP again.
        let replies = exchange(
            &mut fc,
            &msp::encode_request(MSP_RC, &[]),
            100_000,
            1_000_000,
        );
        assert!(replies.is_empty());
        let replies = exchange(
            &mut fc,
            &msp::encode_request(MSP_RC, &[]),
            2_100_000,
            2_200_000,
        );
        assert_eq!(replies.len(), 1);
    }

    /// Asks `command` on `port` at `t_us` and runs iNav one serial task further: its
    /// one reply.
    fn ask(fc: &mut InavMsp, port: usize, command: u16, payload: &[u8], t_us: i64) -> Frame {
        fc.receive_on(port, &msp::encode_request(command, payload), t_us);
        fc.advance(t_us + SERIAL_TASK_US);
        let mut frames = Vec::new();
        Decoder::default().push(&fc.take_output_on(port), &mut frames);
        assert_eq!(frames.len(), 1, "{frames:?}");
        assert_eq!(frames[0].command, command);
        frames.remove(0)
    }

    fn i16s(payload: &[u8]) -> Vec<i16> {
        payload
            .chunks_exact(2)
            .map(|c| i16::from_le_bytes([c[0], c[1]]))
            .collect()
    }

    #[test]
    fn lrintf_rounds_ties_to_even_and_wraps_into_int16() {
        let cases = [
            (12.5, 12),
            (13.5, 14),
            (-12.5, -12),
            (-13.5, -14),
            (12.49, 12),
            (12.51, 13),
            (-0.4, 0),
            (32767.0, 32767),
            (32768.0, -32768),
            (40000.0, -25536),
            (-40000.0, 25536),
        ];
        for (v, want) in cases {
            assert_eq!(lrintf_i16(v), want, "{v}");
        }
    }

    #[test]
    fn raw_imu_is_a_level_board_and_the_gyro_as_inav_rounds_it() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        fc.set_motion(Motion {
            gyro_dps: [12.5, -12.5, 40000.0],
            ..Motion::default()
        });
        let reply = ask(&mut fc, 0, MSP_RAW_IMU, &[], 0);
        assert_eq!(reply.direction, b'>');
        assert_eq!(reply.payload.len(), 18);
        assert_eq!(
            i16s(&reply.payload),
            vec![0, 0, 512, 12, -12, -25536, 0, 0, 0]
        );
        fc.set_motion(Motion {
            gyro_dps: [13.5, -13.5, -0.4],
            ..Motion::default()
        });
        let reply = ask(&mut fc, 0, MSP_RAW_IMU, &[], 20_000);
        assert_eq!(i16s(&reply.payload)[3..6], [14, -14, 0]);
    }

    #[test]
    fn attitude_is_decidegrees_and_the_heading_whole_degrees_truncated() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        fc.set_motion(Motion {
            roll_ddeg: -123,
            pitch_ddeg: 45,
            yaw_ddeg: 3599,
            gyro_dps: [0.0; 3],
        });
        let reply = ask(&mut fc, 0, MSP_ATTITUDE, &[], 0);
        assert_eq!(reply.direction, b'>');
        assert_eq!(reply.payload, vec![0x85, 0xFF, 45, 0, 0x67, 0x01]);
        assert_eq!(i16s(&reply.payload), vec![-123, 45, 359]);
        fc.set_motion(Motion {
            yaw_ddeg: 9,
            ..Motion::default()
        });
        let reply = ask(&mut fc, 0, MSP_ATTITUDE, &[], 20_000);
        assert_eq!(i16s(&reply.payload), vec![0, 0, 0]);
    }

    fn set_gvar(index: u8, value: i32) -> Vec<u8> {
        let mut payload = vec![index];
        payload.extend_from_slice(&value.to_le_bytes());
        payload
    }

    fn gvar_status(fc: &mut InavMsp, port: usize, t_us: i64) -> Vec<i32> {
        let reply = ask(fc, port, MSP2_INAV_GVAR_STATUS, &[], t_us);
        assert_eq!(reply.direction, b'>');
        assert_eq!(reply.payload.len(), 4 * MAX_GLOBAL_VARIABLES);
        reply
            .payload
            .chunks_exact(4)
            .map(|c| i32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect()
    }

    #[test]
    fn a_global_variable_is_set_clamped_and_read_back() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        assert_eq!(fc.gvars(), [0; MAX_GLOBAL_VARIABLES], "zero at boot");
        let reply = ask(&mut fc, 0, MSP2_INAV_SET_GVAR, &set_gvar(5, -42), 0);
        assert_eq!((reply.direction, reply.payload.len()), (b'>', 0));
        // INT16_MIN..INT16_MAX by default: 40000 is held as 32767.
        let reply = ask(&mut fc, 0, MSP2_INAV_SET_GVAR, &set_gvar(7, 40000), 20_000);
        assert_eq!(reply.direction, b'>');
        ask(&mut fc, 0, MSP2_INAV_SET_GVAR, &set_gvar(0, -40000), 40_000);
        assert_eq!(fc.gvars(), [-32768, 0, 0, 0, 0, -42, 0, 32767]);
        assert_eq!(
            gvar_status(&mut fc, 0, 60_000),
            vec![-32768, 0, 0, 0, 0, -42, 0, 32767]
        );
        // The value as sent, when served.
        assert_eq!(
            fc.log.gvar_writes,
            vec![(10_000, 5, -42), (30_000, 7, 40000), (50_000, 0, -40000)]
        );
    }

    #[test]
    fn a_global_variable_out_of_range_or_of_the_wrong_size_is_refused() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        let mut t = 0;
        let mut refused = |payload: &[u8]| {
            let reply = ask(&mut fc, 0, MSP2_INAV_SET_GVAR, payload, t);
            t += 20_000;
            reply.direction == b'!' && reply.payload.is_empty()
        };
        assert!(refused(&set_gvar(8, 1)), "index 8");
        assert!(refused(&set_gvar(255, 1)), "index 255");
        assert!(refused(&set_gvar(1, 1)[..4]), "4 bytes");
        let mut six = set_gvar(1, 1);
        six.push(0);
        assert!(refused(&six), "6 bytes");
        assert!(refused(&[]), "empty");
        assert!(!refused(&set_gvar(1, 1)), "a good one");
        assert_eq!(fc.gvars(), [0, 1, 0, 0, 0, 0, 0, 0]);
        assert_eq!(fc.log.gvar_writes.len(), 1);
    }

    #[test]
    fn the_gvar_configuration_bounds_writes_and_sets_the_boot_value() {
        let mut setup = Setup::default();
        setup.gvar_config[2] = GvarConfig {
            default_value: 7,
            min: -1_000_000,
            max: 1_000_000,
        };
        // A min above the max (the CLI takes it): iNav's constrain gives the min.
        setup.gvar_config[3] = GvarConfig {
            default_value: 0,
            min: 10,
            max: 5,
        };
        let mut fc = InavMsp::new(setup, 0);
        assert_eq!(fc.gvars()[2], 7);
        ask(&mut fc, 0, MSP2_INAV_SET_GVAR, &set_gvar(2, 40000), 0);
        ask(&mut fc, 0, MSP2_INAV_SET_GVAR, &set_gvar(3, 7), 20_000);
        assert_eq!(fc.gvars()[2..4], [40000, 10]);
    }

    #[test]
    fn a_reboot_clears_the_global_variables() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        ask(&mut fc, 0, MSP2_INAV_SET_GVAR, &set_gvar(5, 3), 0);
        assert_eq!(fc.gvars()[5], 3);
        fc.receive(b"#", 20_000);
        fc.advance(50_000);
        fc.receive(b"exit\r\n", 50_000);
        fc.advance(70_000);
        assert_eq!(fc.gvars()[5], 3, "RAM until the reboot");
        fc.advance(REBOOT_US + 100_000);
        assert_eq!(fc.gvars(), [0; MAX_GLOBAL_VARIABLES]);
        assert_eq!(fc.log.gvar_writes.len(), 1, "the log survives");
    }

    #[test]
    fn fc_version_is_the_setups() {
        let mut fc = InavMsp::new(
            Setup {
                fc_version: [10, 0, 0],
                ..Setup::default()
            },
            0,
        );
        assert_eq!(
            ask(&mut fc, 0, MSP_FC_VERSION, &[], 0).payload,
            vec![10, 0, 0]
        );
        let mut fc = InavMsp::new(Setup::default(), 0);
        assert_eq!(
            ask(&mut fc, 0, MSP_FC_VERSION, &[], 0).payload,
            vec![9, 1, 0]
        );
    }

    #[test]
    fn two_ports_share_the_board_and_each_serves_one_command_per_run() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        let telemetry = fc.add_port();
        assert_eq!(telemetry, 1);
        fc.set_pilot(pilot(1900));
        // The roll stream on the first port; MSP_RC on the second shows the override.
        for t in (0..1_200_000).step_by(40_000) {
            fc.receive(&roll(1800), t);
            fc.advance(t + 39_000);
        }
        fc.take_output();
        let rc = ask(&mut fc, telemetry, MSP_RC, &[], 1_200_000);
        assert_eq!(i16s(&rc.payload)[0], 1800);
        // A variable written on one port reads back on the other.
        ask(
            &mut fc,
            telemetry,
            MSP2_INAV_SET_GVAR,
            &set_gvar(6, 99),
            1_220_000,
        );
        assert_eq!(gvar_status(&mut fc, 0, 1_240_000)[6], 99);
        assert_eq!(fc.port_log(telemetry).gvar_writes, vec![(1_230_000, 6, 99)]);
        assert!(fc.log.gvar_writes.is_empty());
        // Two commands on each port at once: one on each per run.
        let mut two = msp::encode_request(MSP_ATTITUDE, &[]);
        two.extend(msp::encode_request(MSP_RAW_IMU, &[]));
        fc.receive_on(0, &two, 1_261_000);
        fc.receive_on(telemetry, &two, 1_261_000);
        fc.advance(1_270_000);
        let served = |fc: &InavMsp, port: usize| {
            fc.port_log(port)
                .served
                .iter()
                .filter(|s| s.0 >= 1_270_000)
                .count()
        };
        assert_eq!((served(&fc, 0), served(&fc, telemetry)), (1, 1));
        fc.advance(1_280_000);
        assert_eq!((served(&fc, 0), served(&fc, telemetry)), (2, 2));
    }

    #[test]
    fn the_cli_on_one_port_leaves_msp_on_the_other() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        let telemetry = fc.add_port();
        fc.receive(b"#", 0);
        fc.advance(30_000);
        assert!(fc.in_cli());
        fc.take_output();
        let reply = ask(&mut fc, telemetry, MSP_ATTITUDE, &[], 30_000);
        assert_eq!(reply.direction, b'>');
        // A second `#` elsewhere finds the CLI taken.
        fc.receive_on(telemetry, b"#", 50_000);
        fc.advance(80_000);
        assert!(fc.take_output_on(telemetry).is_empty());
        // `exit` reboots the whole board: neither port answers for a while.
        fc.receive(b"exit\r\n", 80_000);
        fc.advance(100_000);
        fc.receive_on(telemetry, &msp::encode_request(MSP_RC, &[]), 200_000);
        fc.advance(300_000);
        assert!(fc.take_output_on(telemetry).is_empty());
        assert_eq!(
            ask(&mut fc, telemetry, MSP_RC, &[], 2_200_000).direction,
            b'>'
        );
    }

    #[test]
    fn a_hash_inside_a_frame_is_data() {
        let mut fc = InavMsp::new(Setup::default(), 0);
        // 0x23 ('#') as a payload byte.
        let frame = msp::set_raw_rc(&[0x0523, 1500, 1500, 1500]);
        fc.receive(&frame, 0);
        fc.advance(100_000);
        assert!(!fc.in_cli());
        assert_eq!(fc.log.frames.len(), 1);
    }
}
