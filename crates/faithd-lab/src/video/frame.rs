//! One window of a flight as a video frame shows it: what the pipeline saw and
//! decided, and what the flight around it knew when the source has it (the safety
//! gate and the roll on iNav in a simulated flight, the true heading of a simulated
//! vehicle). A replay fills the first part only; the renderer draws what is there
//! and says what is not, never a guess.

use faithd_core::cluster::ClusterStats;
use faithd_core::decide::{Decision, RollDirection};
use faithd_core::derotate::DerotationState;
use faithd_core::event::Event;
use faithd_core::foe::FoeEstimate;
use faithd_core::pipeline::WindowReport;
use faithd_core::safety::gate::GateState;

/// One window: the same record whether a replay or a simulated flight made it.
#[derive(Clone, Debug)]
pub struct Frame {
    /// The window's end, microseconds on the clock of the source (the daemon's in a
    /// simulated flight, the recording's in a replay).
    pub t_us: i64,
    /// The events the window took (only the new ones: the flow looks further back).
    pub events: Vec<Event>,
    /// The flow history the FOE and the clusters were computed on.
    pub vectors: Vec<FrameVector>,
    pub foe: FoeEstimate,
    pub clusters: Vec<ClusterStats>,
    pub decision: Decision,
    /// Whether the window's flow had the rotation taken out (attitude present).
    pub derotated: bool,
    /// What the simulator knows and no recording holds.
    pub truth: Option<Truth>,
    /// The commander's safety gate when the window ran; `None`: not recorded.
    pub gate: Option<GateState>,
    /// The roll iNav was using when the window ran; `None`: not recorded.
    pub inav_roll: Option<InavRoll>,
}

/// One flow vector as drawn. Single precision: a simulated flight keeps all its
/// frames until its end, thousands of vectors each, and a pixel needs no more.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameVector {
    pub x_px: f32,
    pub y_px: f32,
    pub u_px_s: f32,
    pub v_px_s: f32,
    /// Seconds; NaN where the vector contradicts the FOE (it was not clustered).
    pub ttc_s: f32,
    /// DBSCAN's cluster id; `None` for noise and vectors without a TTC.
    pub cluster: Option<u32>,
}

/// The simulated world's answer to what the pipeline estimates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truth {
    /// Where the vehicle is really heading, pixels; `None` when that is behind the
    /// camera.
    pub foe_px: Option<(f64, f64)>,
    /// True time to contact with the pole the course is laid against, seconds
    /// (negative once past it).
    pub ttc_s: f64,
}

/// The roll channel iNav uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InavRoll {
    pub value_us: u16,
    /// Which way that rolls the vehicle; `None` at the centre.
    pub direction: Option<RollDirection>,
}

impl Frame {
    /// The pipeline's part of a frame: `events` went into the window that `report`
    /// describes.
    pub fn of_window(events: &[Event], report: &WindowReport<'_>) -> Self {
        let vectors = report
            .vectors
            .iter()
            .zip(report.ttc_s)
            .zip(report.labels)
            .map(|((v, &ttc_s), &cluster)| FrameVector {
                x_px: v.x_px as f32,
                y_px: v.y_px as f32,
                u_px_s: v.u_px_s as f32,
                v_px_s: v.v_px_s as f32,
                ttc_s: ttc_s as f32,
                cluster,
            })
            .collect();
        Frame {
            t_us: report.t_us,
            events: events.to_vec(),
            vectors,
            foe: report.foe,
            clusters: report.clusters.to_vec(),
            decision: report.decision,
            derotated: report.derotation.state == DerotationState::Applied,
            truth: None,
            gate: None,
            inav_roll: None,
        }
    }
}
