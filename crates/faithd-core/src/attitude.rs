//! Autopilot attitude samples and their alignment to event time.

use std::collections::VecDeque;

use nalgebra::Vector3;

/// One ATTITUDE report of the autopilot, stamped in the event camera's time base.
///
/// Angles and rates follow MAVLink: FRD body axes, radians and radians per second.
/// Aligning the autopilot clock to the camera clock is the adapters' job; the core
/// only ever sees camera time.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct AttitudeSample {
    pub t_us: i64,
    pub roll_rad: f64,
    pub pitch_rad: f64,
    pub yaw_rad: f64,
    pub roll_rate_rad_s: f64,
    pub pitch_rate_rad_s: f64,
    pub yaw_rate_rad_s: f64,
}

impl AttitudeSample {
    pub fn body_rates_rad_s(&self) -> Vector3<f64> {
        Vector3::new(
            self.roll_rate_rad_s,
            self.pitch_rate_rad_s,
            self.yaw_rate_rad_s,
        )
    }
}

/// Body rates at `t_us`, linearly interpolated between the samples around it.
///
/// `samples` must be sorted by time. Outside the covered span the nearest sample is
/// held (the autopilot reports at 50 Hz or more, so a hold is at most one period).
/// Returns `None` when there are no samples at all: derotation then cannot run and the
/// caller must say so rather than assume the vehicle is not rotating.
pub fn body_rates_at(samples: &[AttitudeSample], t_us: i64) -> Option<Vector3<f64>> {
    let first = samples.first()?;
    let last = samples.last()?;
    if t_us <= first.t_us {
        return Some(first.body_rates_rad_s());
    }
    if t_us >= last.t_us {
        return Some(last.body_rates_rad_s());
    }
    let after = samples.partition_point(|s| s.t_us <= t_us);
    let (a, b) = (&samples[after - 1], &samples[after]);
    let span_us = (b.t_us - a.t_us) as f64;
    let w = if span_us > 0.0 {
        (t_us - a.t_us) as f64 / span_us
    } else {
        0.0
    };
    Some(a.body_rates_rad_s() * (1.0 - w) + b.body_rates_rad_s() * w)
}

/// Mean body rates over `from_us..to_us`, rad/s: the integral of the rates that
/// `body_rates_at` interpolates, over the span's length. An empty or reversed span
/// gives the rates at `to_us`.
pub fn mean_body_rates(
    samples: &[AttitudeSample],
    from_us: i64,
    to_us: i64,
) -> Option<Vector3<f64>> {
    let at_end = body_rates_at(samples, to_us)?;
    if to_us <= from_us {
        return Some(at_end);
    }
    let mut t = from_us;
    let mut rates = body_rates_at(samples, from_us)?;
    let mut integral = Vector3::zeros();
    // Piecewise linear between samples: the trapezoid is exact on each piece.
    let first_after = samples.partition_point(|s| s.t_us <= from_us);
    for s in samples[first_after..].iter().take_while(|s| s.t_us < to_us) {
        let next = s.body_rates_rad_s();
        integral += (rates + next) * (0.5 * (s.t_us - t) as f64);
        (t, rates) = (s.t_us, next);
    }
    integral += (rates + at_end) * (0.5 * (to_us - t) as f64);
    Some(integral / (to_us - from_us) as f64)
}

/// Recent attitude samples on the daemon clock: the live daemon shares one with its pipeline
/// thread, and the replay of its recordings fills one the same way.
///
/// It numbers every sample it is given, from 0 at the daemon's start, so that a window
/// can say which samples it was handed ([`AttitudeUsed`]): the link pushes a sample a
/// moment after it records its frame, and on a loaded board a window can run inside
/// that moment. The replay then feeds each window the samples it names, not the ones
/// whose frames were recorded before it.
#[derive(Debug, Default)]
pub struct AttitudeLog {
    samples: VecDeque<AttitudeSample>,
    /// Samples ever pushed: the number the next one gets.
    pushed: u64,
    /// The number of the first sample since the last [`Self::clear`] (a new link session,
    /// whose clock offset is estimated afresh).
    session: u64,
}

/// Which samples of an [`AttitudeLog`] a window was handed: numbers `from..to` in
/// the order they were pushed, of the link session that began at sample `session`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AttitudeUsed {
    pub from: u64,
    pub to: u64,
    pub session: u64,
    /// The time of the newest sample handed (`None` when none was): a replay checks
    /// that its sample `to - 1` is the same one.
    pub last_t_us: Option<i64>,
}

impl AttitudeUsed {
    /// Why these numbers cannot come from an [`AttitudeLog`] (`None`: they can).
    pub fn impossible(&self) -> Option<String> {
        let u = self;
        if u.from > u.to || u.session > u.from {
            return Some(format!(
                "attitude samples {}..{} of a session from {}: not a range an attitude log hands out",
                u.from, u.to, u.session
            ));
        }
        if (u.from == u.to) != u.last_t_us.is_none() {
            return Some(format!(
                "attitude samples {}..{} with last_t_us {:?}: a time goes with samples, and only then",
                u.from, u.to, u.last_t_us
            ));
        }
        None
    }
}

impl AttitudeLog {
    /// How far back samples are kept.
    const SPAN_US: i64 = 2_000_000;

    pub fn push(&mut self, sample: AttitudeSample) {
        if self
            .samples
            .back()
            .is_some_and(|last| sample.t_us < last.t_us)
        {
            // Out of order (or the autopilot rebooted): start over rather than
            // hand derotation an unsorted list.
            self.samples.clear();
        }
        self.samples.push_back(sample);
        self.pushed += 1;
        let oldest = sample.t_us - Self::SPAN_US;
        while self.samples.front().is_some_and(|s| s.t_us < oldest) {
            self.samples.pop_front();
        }
    }

    /// Copies the samples from `from_us` on (and the one before, for interpolation);
    /// returns which they were.
    pub fn copy_since(&self, from_us: i64, out: &mut Vec<AttitudeSample>) -> AttitudeUsed {
        out.clear();
        let start = self.samples.partition_point(|s| s.t_us < from_us);
        out.extend(self.samples.range(start.saturating_sub(1)..).copied());
        AttitudeUsed {
            from: self.pushed - out.len() as u64,
            to: self.pushed,
            session: self.session,
            last_t_us: out.last().map(|s| s.t_us),
        }
    }

    /// The samples a pipeline window ending at `window_end_us` needs: its history and
    /// a 100 ms margin before it (the live daemon and the replay of its recordings
    /// both ask this).
    pub fn copy_for_window(
        &self,
        window_end_us: i64,
        history_us: i64,
        out: &mut Vec<AttitudeSample>,
    ) -> AttitudeUsed {
        self.copy_since(window_end_us - history_us - 100_000, out)
    }

    /// Forgets every sample: the link was lost, and the next session's clock offset is
    /// estimated afresh.
    pub fn clear(&mut self) {
        self.samples.clear();
        self.session = self.pushed;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t_us: i64, yaw_rate: f64) -> AttitudeSample {
        AttitudeSample {
            t_us,
            yaw_rate_rad_s: yaw_rate,
            ..Default::default()
        }
    }

    #[test]
    fn interpolates_between_samples_and_holds_at_ends() {
        let s = [sample(0, 0.0), sample(1000, 1.0), sample(3000, -1.0)];
        assert_eq!(body_rates_at(&s, 500).unwrap().z, 0.5);
        assert_eq!(body_rates_at(&s, 2000).unwrap().z, 0.0);
        assert_eq!(body_rates_at(&s, -10).unwrap().z, 0.0);
        assert_eq!(body_rates_at(&s, 9000).unwrap().z, -1.0);
        assert!(body_rates_at(&[], 0).is_none());
    }

    #[test]
    fn mean_rates_integrate_the_interpolated_rates() {
        let s = [sample(0, 0.0), sample(1000, 1.0), sample(3000, -1.0)];
        let mean = |a, b| mean_body_rates(&s, a, b).unwrap().z;
        // 0..1000 ramps 0 to 1; 1000..3000 ramps 1 to -1: both average 0.5 and 0.
        assert!((mean(0, 1000) - 0.5).abs() < 1e-12);
        assert!((mean(1000, 3000) - 0.0).abs() < 1e-12);
        // 500..2000: 0.75 over 500 us, then 0.5 over 1000 us.
        assert!((mean(500, 2000) - (0.75 * 500.0 + 0.5 * 1000.0) / 1500.0).abs() < 1e-12);
        // Held before the first and after the last sample, as `body_rates_at` does.
        assert!((mean(-1000, 0) - 0.0).abs() < 1e-12);
        assert!((mean(3000, 5000) + 1.0).abs() < 1e-12);
        assert_eq!(mean(2000, 2000), body_rates_at(&s, 2000).unwrap().z);
        assert!(mean_body_rates(&[], 0, 10).is_none());
    }

    fn at(t_us: i64) -> AttitudeSample {
        AttitudeSample {
            t_us,
            ..Default::default()
        }
    }

    #[test]
    fn attitude_log_keeps_two_seconds_and_the_sample_before_a_window() {
        let mut log = AttitudeLog::default();
        for t in (0..=3_000_000).step_by(20_000) {
            log.push(at(t));
        }
        let mut out = Vec::new();
        log.copy_since(0, &mut out);
        assert_eq!(out[0].t_us, 1_000_000, "older than 2 s dropped");
        log.copy_since(2_010_000, &mut out);
        assert_eq!(out[0].t_us, 2_000_000, "one sample before the window");
        log.push(at(5));
        log.copy_since(0, &mut out);
        assert_eq!(out.len(), 1, "out of order starts over");
    }

    /// The numbers a window is handed count every sample pushed, across an
    /// out-of-order restart and a new session alike.
    #[test]
    fn a_window_is_told_which_samples_it_was_handed() {
        let mut log = AttitudeLog::default();
        let mut out = Vec::new();
        assert_eq!(log.copy_since(0, &mut out), AttitudeUsed::default());
        for t in [0, 20_000, 40_000] {
            log.push(at(t));
        }
        let used = log.copy_since(30_000, &mut out);
        assert_eq!((used.from, used.to, used.session), (1, 3, 0));
        assert_eq!(used.last_t_us, Some(40_000));
        log.clear();
        log.push(at(7));
        let used = log.copy_since(0, &mut out);
        assert_eq!((used.from, used.to, used.session), (3, 4, 3));
        assert_eq!(used.impossible(), None);
        let crossed = AttitudeUsed {
            from: 4,
            to: 3,
            ..used
        };
        assert!(crossed.impossible().is_some());
        let timeless = AttitudeUsed {
            last_t_us: None,
            ..used
        };
        assert!(timeless.impossible().is_some());
    }
}
