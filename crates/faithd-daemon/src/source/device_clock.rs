//! Maps a camera's clock onto the daemon's: pure arithmetic on (device time, host
//! arrival time) pairs, no I/O, so it is tested on synthetic hours of data.
//!
//! The host sees a packet only after USB latency (0.1 to 10 ms, varying packet by
//! packet), so `host - device` of any one packet overestimates the true offset by that
//! packet's latency. Latency only ever adds, so the *lowest* offsets seen are the
//! nearest to the truth: the estimator follows the lower envelope of the offsets. The
//! device's crystal also runs at its own rate (tens of ppm: 100 ppm is 0.36 s an hour),
//! so the envelope is a sloped line, not a constant: its slope is fitted to the lowest
//! offset of each quarter second of device time over the last 32 s.
//!
//! The mapping a packet's events get is that line, lowered under every window minimum
//! and under the newest packet, then clamped so that it
//! * never goes backwards across packets (the pipeline's windows and flow assume time
//!   only moves forward), and
//! * never lies after the host arrival of the packet being mapped (an event cannot have
//!   happened after the daemon received it).
//!
//! The device times fed in are libcaer's 64-bit ones (its 31-bit timestamps expanded
//! with the packet header's overflow count), so the 36-minute wrap is no jump. Device
//! times that go backwards (the camera's timestamp reset, or a wrap that was not
//! expanded) or leap ahead of the host's elapsed time (a device reset between packets)
//! start a new line at that packet: the old one describes a clock that no longer
//! exists. The drift estimate is kept across such a re-seed, since it is the same
//! crystal; the order clamp is kept too, so a re-seed never sends time backwards.

use std::collections::VecDeque;

/// Tuning of [`DeviceClock`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceClockConfig {
    /// Device time per window whose lowest offset is kept. Long enough to hold many
    /// packets (libcaer hands out a container every few milliseconds), so that some
    /// arrived with little latency; short enough that the drift fit starts soon (after
    /// two windows) and that a window's minimum sits where the drifting envelope is.
    pub window_us: i64,
    /// Windows kept for the drift fit: `windows * window_us` of history. The slope of
    /// the minima is only as good as their span: in simulation (latency uniform over
    /// 0.2 to 8 ms, a packet every 1 to 10 ms), 8 s of history leaves the drift
    /// uncertain by ~13 ppm rms, 32 s by ~2 ppm; the mapped times stay within 0.4 ms
    /// either way, since the line is lowered onto the newest minima.
    pub windows: usize,
    /// How far the device clock may run ahead of the host's elapsed time between two
    /// packets before it counts as a reset. Latency makes the device fall behind, never
    /// ahead, so only a changed device clock (or drift over a gap far longer than a
    /// flight's) exceeds it.
    pub reset_step_us: i64,
    /// Largest drift believed, in ppm. A crystal is within a few hundred ppm; the
    /// default (5 %) leaves room for deliberately skewed test clocks and only stops
    /// nonsense fits.
    pub max_drift_ppm: f64,
}

impl Default for DeviceClockConfig {
    fn default() -> Self {
        Self {
            window_us: 250_000,
            windows: 128,
            reset_step_us: 100_000,
            max_drift_ppm: 50_000.0,
        }
    }
}

/// What one observation did to the mapping.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Observed {
    /// The first packet: the mapping starts at it.
    Seeded,
    /// The mapping follows the envelope, now including this packet.
    Tracked,
    /// The device clock changed under us; the mapping starts again at this packet.
    Reseeded(Jump),
}

/// A device-clock discontinuity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Jump {
    /// Device time went back by this much: a timestamp reset.
    Backwards { by_us: i64 },
    /// Device time advanced this much more than host time did.
    Ahead { by_us: i64 },
}

impl std::fmt::Display for Jump {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Jump::Backwards { by_us } => write!(f, "device time went back {by_us} us"),
            Jump::Ahead { by_us } => {
                write!(f, "device time leapt {by_us} us ahead of the host's")
            }
        }
    }
}

/// A device time and its offset to the host clock (`host - device`), both in us.
#[derive(Clone, Copy, Debug)]
struct Point {
    device_us: i64,
    offset_us: i64,
}

/// `offset(d) = offset_us + drift * (d - device_us)`; `drift` is host us per device us,
/// minus one.
#[derive(Clone, Copy, Debug)]
struct Line {
    device_us: i64,
    offset_us: f64,
    drift: f64,
}

impl Line {
    fn offset_at(&self, device_us: i64) -> f64 {
        self.offset_us + self.drift * device_us.saturating_sub(self.device_us) as f64
    }

    /// How far `p` lies above the line (negative: below).
    fn residual(&self, p: Point) -> f64 {
        p.offset_us as f64 - self.offset_at(p.device_us)
    }

    /// The line of slope `drift` at `device_us`, as high as it can be while lying on or
    /// under every point: the lower envelope.
    fn under(points: impl Iterator<Item = Point>, device_us: i64, drift: f64) -> Self {
        let mut line = Line {
            device_us,
            offset_us: f64::INFINITY,
            drift,
        };
        for p in points {
            let at_anchor =
                p.offset_us as f64 - drift * p.device_us.saturating_sub(device_us) as f64;
            line.offset_us = line.offset_us.min(at_anchor);
        }
        line
    }

    /// Lowers the line onto `p` if `p` lies below it.
    fn lower_to(&mut self, p: Point) {
        self.offset_us += self.residual(p).min(0.0);
    }
}

/// One continuous device clock: the window minima so far and the current line.
#[derive(Debug)]
struct Track {
    /// Lowest point of each completed window, oldest first.
    minima: VecDeque<Point>,
    window_start_us: i64,
    /// Lowest point (relative to the line) of the current window.
    best: Point,
    last_device_us: i64,
    last_host_us: i64,
    line: Line,
}

impl Track {
    fn seed(p: Point, host_us: i64, drift: f64) -> Self {
        Self {
            minima: VecDeque::new(),
            window_start_us: p.device_us,
            best: p,
            last_device_us: p.device_us,
            last_host_us: host_us,
            line: Line {
                device_us: p.device_us,
                offset_us: p.offset_us as f64,
                drift,
            },
        }
    }

    /// A discontinuity between the last packet and this one, if any.
    fn jump(&self, device_us: i64, host_us: i64, reset_step_us: i64) -> Option<Jump> {
        if device_us < self.last_device_us {
            return Some(Jump::Backwards {
                by_us: self.last_device_us.saturating_sub(device_us),
            });
        }
        let device_step_us = device_us.saturating_sub(self.last_device_us);
        let host_step_us = host_us.saturating_sub(self.last_host_us);
        let ahead_us = device_step_us.saturating_sub(host_step_us);
        (ahead_us > reset_step_us).then_some(Jump::Ahead { by_us: ahead_us })
    }

    /// Closes the current window (keeping its minimum), starts the next at `p`, and
    /// refits the line to the minima (`slopes` is scratch space).
    fn close_window(&mut self, p: Point, config: &DeviceClockConfig, slopes: &mut Vec<f64>) {
        self.minima.push_back(self.best);
        while self.minima.len() > config.windows.max(2) {
            self.minima.pop_front();
        }
        self.window_start_us = p.device_us;
        self.best = p;
        let drift = fit_drift(&self.minima, config, slopes).unwrap_or(self.line.drift);
        let points = self.minima.iter().copied().chain(std::iter::once(p));
        self.line = Line::under(points, p.device_us, drift);
    }
}

/// Slope of the window minima: the median of the slopes between every pair of them
/// (Theil-Sen), so that a window in which every packet was late (the host busy for a
/// quarter second) does not tilt the line. `None` until the minima span a window.
fn fit_drift(
    minima: &VecDeque<Point>,
    config: &DeviceClockConfig,
    slopes: &mut Vec<f64>,
) -> Option<f64> {
    let (first, last) = (minima.front()?, minima.back()?);
    if last.device_us.saturating_sub(first.device_us) < config.window_us {
        return None;
    }
    slopes.clear();
    for (i, a) in minima.iter().enumerate() {
        for b in minima.iter().skip(i + 1) {
            let dx = b.device_us.saturating_sub(a.device_us) as f64;
            if dx > 0.0 {
                slopes.push(b.offset_us.saturating_sub(a.offset_us) as f64 / dx);
            }
        }
    }
    slopes.retain(|s| s.is_finite());
    if slopes.is_empty() {
        return None;
    }
    let middle = slopes.len() / 2;
    let (_, &mut median, _) = slopes.select_nth_unstable_by(middle, f64::total_cmp);
    let max = config.max_drift_ppm * 1e-6;
    Some(median.clamp(-max, max))
}

/// The device-to-daemon clock mapping of one camera session.
///
/// Call [`observe`](Self::observe) once per packet, with the device time of the
/// packet's newest event and the host time it arrived, then [`map`](Self::map) the
/// packet's events in order.
#[derive(Debug)]
pub struct DeviceClock {
    config: DeviceClockConfig,
    track: Option<Track>,
    /// Last fitted drift (host us per device us, minus one), kept across re-seeds.
    drift: f64,
    /// Last mapped time: no later event maps before it.
    floor_us: i64,
    /// Newest host arrival: no event maps after it.
    ceiling_us: i64,
    /// Scratch space of the drift fit, kept to spare an allocation per window.
    slopes: Vec<f64>,
}

impl DeviceClock {
    pub fn new(config: DeviceClockConfig) -> Self {
        Self {
            config,
            track: None,
            drift: 0.0,
            floor_us: i64::MIN,
            ceiling_us: i64::MIN,
            slopes: Vec::new(),
        }
    }

    /// Takes one packet: `device_us` of its newest event, `host_us` when it arrived.
    pub fn observe(&mut self, device_us: i64, host_us: i64) -> Observed {
        self.ceiling_us = self.ceiling_us.max(host_us);
        let p = Point {
            device_us,
            offset_us: host_us.saturating_sub(device_us),
        };
        let Some(track) = self.track.as_mut() else {
            self.track = Some(Track::seed(p, host_us, self.drift));
            return Observed::Seeded;
        };
        if let Some(jump) = track.jump(device_us, host_us, self.config.reset_step_us) {
            self.track = Some(Track::seed(p, host_us, self.drift));
            return Observed::Reseeded(jump);
        }
        track.last_device_us = device_us;
        track.last_host_us = host_us;
        if device_us.saturating_sub(track.window_start_us) >= self.config.window_us {
            track.close_window(p, &self.config, &mut self.slopes);
            self.drift = track.line.drift;
        } else {
            if track.line.residual(p) < track.line.residual(track.best) {
                track.best = p;
            }
            track.line.lower_to(p);
        }
        Observed::Tracked
    }

    /// Daemon time of a device time from the last observed packet: on the envelope,
    /// never before the previous result, never after the last arrival. Before any
    /// packet there is nothing to map onto and the device time is returned as it is.
    pub fn map(&mut self, device_us: i64) -> i64 {
        let Some(track) = &self.track else {
            return device_us;
        };
        let raw_us = device_us as f64 + track.line.offset_at(device_us);
        // `as` saturates: a nonsense device time cannot overflow.
        let t_us = (raw_us.floor() as i64)
            .min(self.ceiling_us)
            .max(self.floor_us);
        self.floor_us = t_us;
        t_us
    }

    /// The device crystal's rate error against the host clock, in ppm (positive: the
    /// device runs slow, its offset to the host grows).
    pub fn drift_ppm(&self) -> f64 {
        self.drift * 1e6
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64Mcg;

    /// A device clock running `device_ppm` fast against the host (negative: slow),
    /// started at device time `device0_us` when the host was at `host0_us`.
    #[derive(Clone, Copy)]
    struct Crystal {
        host0_us: i64,
        device0_us: i64,
        device_ppm: f64,
    }

    impl Crystal {
        fn device_at(&self, host_us: i64) -> i64 {
            let elapsed = (host_us - self.host0_us) as f64;
            self.device0_us + (elapsed * (1.0 + self.device_ppm * 1e-6)).round() as i64
        }

        /// Host time at which the device read `device_us`: the truth.
        fn host_at(&self, device_us: i64) -> f64 {
            self.host0_us as f64
                + (device_us - self.device0_us) as f64 / (1.0 + self.device_ppm * 1e-6)
        }
    }

    /// One simulated packet: three events spread over the device time since the last.
    struct Packet {
        events_us: [i64; 3],
        arrival_us: i64,
    }

    /// Packets every 1 to 10 ms of host time for `duration_us`, each arriving 0.2 to
    /// 8 ms late (USB latency), never before the one sent earlier (one FIFO).
    fn packets(crystal: Crystal, duration_us: i64, seed: u64) -> Vec<Packet> {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut out = Vec::new();
        let (mut host_us, mut last_device_us, mut last_arrival_us) =
            (crystal.host0_us, crystal.device0_us, i64::MIN);
        while host_us < crystal.host0_us + duration_us {
            host_us += rng.random_range(1_000..=10_000);
            let newest_us = crystal.device_at(host_us);
            let span_us = newest_us - last_device_us;
            let events_us = [
                last_device_us + span_us / 3,
                last_device_us + span_us / 2,
                newest_us,
            ];
            let arrival_us = (host_us + rng.random_range(200..=8_000)).max(last_arrival_us);
            out.push(Packet {
                events_us,
                arrival_us,
            });
            last_device_us = newest_us;
            last_arrival_us = arrival_us;
        }
        out
    }

    /// Feeds every packet; returns the largest |mapped - truth| after `warm_up_us` of
    /// host time, checking the order and arrival bounds on the way.
    fn worst_error_us(
        clock: &mut DeviceClock,
        crystal: Crystal,
        packets: &[Packet],
        warm_up_us: i64,
    ) -> f64 {
        let mut worst: f64 = 0.0;
        let mut previous_us = i64::MIN;
        for p in packets {
            clock.observe(p.events_us[2], p.arrival_us);
            for &e in &p.events_us {
                let mapped_us = clock.map(e);
                assert!(mapped_us >= previous_us, "time went backwards at {e}");
                assert!(mapped_us <= p.arrival_us, "mapped after its arrival at {e}");
                previous_us = mapped_us;
                if p.arrival_us - crystal.host0_us > warm_up_us {
                    worst = worst.max((mapped_us as f64 - crystal.host_at(e)).abs());
                }
            }
        }
        worst
    }

    const HOUR_US: i64 = 3_600_000_000;

    #[test]
    fn an_hour_of_50_ppm_drift_and_usb_latency_maps_within_a_millisecond() {
        for (device_ppm, seed) in [(50.0, 1), (-50.0, 2)] {
            let crystal = Crystal {
                host0_us: 5_000_000,
                device0_us: 123_456,
                device_ppm,
            };
            let packets = packets(crystal, HOUR_US, seed);
            let mut clock = DeviceClock::new(DeviceClockConfig::default());
            let worst_us = worst_error_us(&mut clock, crystal, &packets, 10_000_000);
            assert!(
                worst_us <= 1_000.0,
                "{device_ppm} ppm: off by {worst_us} us"
            );
            assert!(
                (clock.drift_ppm() + device_ppm).abs() < 10.0,
                "{device_ppm} ppm fast: fitted {} ppm",
                clock.drift_ppm()
            );
            // What this replaces: the offset fixed at the first packet is off by the
            // hour's drift (180 ms) plus that packet's latency by the end.
            let first = &packets[0];
            let fixed_offset_us = first.arrival_us - first.events_us[2];
            let last = packets.last().unwrap();
            let fixed_error_us =
                (last.events_us[2] + fixed_offset_us) as f64 - crystal.host_at(last.events_us[2]);
            assert!(fixed_error_us.abs() > 150_000.0, "{fixed_error_us}");
        }
    }

    #[test]
    fn the_first_packets_latency_is_not_kept() {
        let mut clock = DeviceClock::new(DeviceClockConfig::default());
        // The first packet arrives 8 ms late, the next ones 0.2 ms.
        clock.observe(1_000, 9_000);
        assert_eq!(clock.map(1_000), 9_000);
        for k in 10..40 {
            let device_us = k * 1_000;
            clock.observe(device_us, device_us + 200);
            assert!(clock.map(device_us - 500) <= device_us + 200);
        }
        clock.observe(40_000, 40_200);
        assert_eq!(clock.map(39_500), 39_700, "0.2 ms late, not 8");
    }

    #[test]
    fn late_bursts_and_stalls_never_map_backwards_or_past_arrival() {
        let mut rng = Pcg64Mcg::seed_from_u64(7);
        let mut clock = DeviceClock::new(DeviceClockConfig::default());
        let (mut previous_us, mut arrival_us) = (i64::MIN, 0);
        for k in 1..20_000i64 {
            let device_us = k * 1_000;
            // Mostly 0.3 ms; sometimes a 50 ms stall, released as a burst.
            let stall = k < 19_000 && rng.random_range(0..200) == 0;
            let latency_us = if stall { 50_000 } else { 300 };
            arrival_us = (device_us + latency_us).max(arrival_us);
            let expected = if k == 1 {
                Observed::Seeded
            } else {
                Observed::Tracked
            };
            assert_eq!(
                clock.observe(device_us, arrival_us),
                expected,
                "a stall is no jump"
            );
            for e in [device_us - 500, device_us] {
                let t = clock.map(e);
                assert!(t >= previous_us && t <= arrival_us, "{k}: {t}");
                previous_us = t;
            }
        }
        assert_eq!(previous_us, 19_999 * 1_000 + 300, "back on the envelope");
    }

    #[test]
    fn a_device_timestamp_reset_reseeds_and_keeps_the_drift() {
        let crystal = Crystal {
            host0_us: 0,
            device0_us: 1_000_000_000,
            device_ppm: 100.0,
        };
        let before = packets(crystal, 20_000_000, 3);
        let mut clock = DeviceClock::new(DeviceClockConfig::default());
        worst_error_us(&mut clock, crystal, &before, 0);
        let drift_ppm = clock.drift_ppm();
        assert!((drift_ppm + 100.0).abs() < 10.0, "{drift_ppm}");
        // The camera resets its timestamps to zero; the host carries on.
        let host_us = before.last().unwrap().arrival_us + 5_000;
        let after_crystal = Crystal {
            host0_us: host_us,
            device0_us: 0,
            device_ppm: 100.0,
        };
        let after = packets(after_crystal, 20_000_000, 4);
        let observed = clock.observe(after[0].events_us[2], after[0].arrival_us);
        assert!(
            matches!(observed, Observed::Reseeded(Jump::Backwards { .. })),
            "{observed:?}"
        );
        assert_eq!(clock.drift_ppm(), drift_ppm, "same crystal, same drift");
        let worst_us = worst_error_us(&mut clock, after_crystal, &after[1..], 2_000_000);
        assert!(worst_us <= 1_000.0, "off by {worst_us} us after the reset");
    }

    #[test]
    fn a_device_clock_leaping_ahead_reseeds() {
        let mut clock = DeviceClock::new(DeviceClockConfig::default());
        for k in 1..1_000i64 {
            clock.observe(k * 1_000, k * 1_000 + 300);
        }
        // 5 ms of host time, 10 s of device time.
        let observed = clock.observe(1_000_000 + 10_000_000, 1_000_000 + 5_300);
        assert_eq!(
            observed,
            Observed::Reseeded(Jump::Ahead {
                by_us: 10_001_000 - 6_000
            })
        );
        assert_eq!(clock.map(11_000_000), 1_005_300);
        // Ordinary gaps and stalls are no jump.
        assert_eq!(clock.observe(13_000_000, 3_005_300), Observed::Tracked);
        assert_eq!(clock.observe(13_001_000, 3_200_000), Observed::Tracked);
    }

    #[test]
    fn nonsense_times_do_not_panic() {
        let mut clock = DeviceClock::new(DeviceClockConfig::default());
        assert_eq!(clock.map(42), 42, "nothing to map onto yet");
        for (device_us, host_us) in [
            (i64::MAX, 0),
            (i64::MIN, i64::MAX),
            (0, i64::MIN),
            (i64::MAX, i64::MAX),
            (-1, 1),
        ] {
            clock.observe(device_us, host_us);
            clock.map(device_us);
            clock.map(i64::MIN);
            clock.map(i64::MAX);
        }
        for k in 0..100 {
            clock.observe(k * 300_000, k);
            clock.map(k * 300_000);
        }
    }
}
