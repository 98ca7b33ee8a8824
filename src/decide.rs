//! The avoidance decision of the paper's section IV, with its evidence.
//!
//! The cluster with the lowest mean TTC is the obstacle. If the FOE (where the vehicle
//! is heading) lies inside the obstacle's bounding box and its mean TTC is below the
//! threshold, roll for a fixed time toward the side of the cluster with the highest
//! mean TTC (the most open space). Every outcome, including "do nothing", carries the
//! reason and the numbers behind it so the log can explain it.

use serde::{Deserialize, Serialize};

use crate::cluster::ClusterStats;
use crate::foe::FoeEstimate;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DecisionConfig {
    /// Roll when the obstacle's mean TTC is below this, seconds.
    pub ttc_threshold_s: f64,
    /// Length of one avoidance roll, microseconds (the paper's 1.5 s).
    pub roll_duration_us: i64,
    /// The obstacle box is grown by this much on every side before the FOE test,
    /// pixels: the vehicle is wider than a point.
    pub box_margin_px: f64,
    /// Fewer flow vectors than this in the window and nothing is decided.
    pub min_vectors: usize,
    /// The FOE must be supported by at least this fraction of the vectors.
    pub min_foe_support: f64,
}

impl Default for DecisionConfig {
    fn default() -> Self {
        Self {
            ttc_threshold_s: 2.0,
            roll_duration_us: 1_500_000,
            box_margin_px: 4.0,
            min_vectors: 40,
            min_foe_support: 0.5,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RollDirection {
    Left,
    Right,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Action {
    Hold,
    Roll {
        direction: RollDirection,
        duration_us: i64,
    },
}

/// Why the decision came out as it did.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Reason {
    /// No attitude to derotate with: the flow cannot be trusted.
    NoAttitude,
    TooFewVectors {
        vectors: usize,
        needed: usize,
    },
    /// The FOE could not be estimated.
    NoFoe,
    /// The FOE is outside the view: the vehicle is not heading into what it sees.
    FoeOutsideView,
    /// The FOE is supported by too few vectors to act on.
    WeakFoe {
        support: usize,
        vectors: usize,
    },
    NoClusters,
    /// The nearest obstacle is not in the way.
    ObstacleNotAhead,
    /// The obstacle is ahead but not yet close enough.
    ObstacleFar {
        ttc_s: f64,
        threshold_s: f64,
    },
    /// Obstacle ahead and close: avoid.
    ObstacleAhead {
        ttc_s: f64,
        threshold_s: f64,
    },
}

/// One decision and the evidence behind it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Decision {
    pub t_us: i64,
    pub action: Action,
    pub reason: Reason,
    pub foe_px: Option<(f64, f64)>,
    pub vectors: usize,
    pub clusters: usize,
    pub obstacle: Option<ClusterStats>,
    /// The cluster the roll heads toward (highest mean TTC), when rolling.
    pub escape: Option<ClusterStats>,
}

impl std::fmt::Display for Decision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.action {
            Action::Hold => write!(f, "hold")?,
            Action::Roll {
                direction,
                duration_us,
            } => write!(f, "roll {direction:?} for {} ms", duration_us / 1000)?,
        }
        write!(f, " because {:?}", self.reason)?;
        if let Some((x, y)) = self.foe_px {
            write!(f, "; foe ({x:.1}, {y:.1}) px")?;
        }
        if let Some(o) = &self.obstacle {
            write!(
                f,
                "; obstacle {} vectors, ttc {:.2} s, box x {:.0}..{:.0} y {:.0}..{:.0}",
                o.count, o.mean_ttc_s, o.min_x_px, o.max_x_px, o.min_y_px, o.max_y_px
            )?;
        }
        write!(f, "; {} vectors, {} clusters", self.vectors, self.clusters)
    }
}

/// Applies the rule to one window's FOE and clusters.
pub fn decide(
    t_us: i64,
    config: &DecisionConfig,
    attitude_ok: bool,
    vectors: usize,
    foe: &FoeEstimate,
    clusters: &[ClusterStats],
) -> Decision {
    let mut d = Decision {
        t_us,
        action: Action::Hold,
        reason: Reason::NoFoe,
        foe_px: foe.point(),
        vectors,
        clusters: clusters.len(),
        obstacle: None,
        escape: None,
    };
    if !attitude_ok {
        d.reason = Reason::NoAttitude;
        return d;
    }
    if vectors < config.min_vectors {
        d.reason = Reason::TooFewVectors {
            vectors,
            needed: config.min_vectors,
        };
        return d;
    }
    let (fx, fy) = match *foe {
        FoeEstimate::Point { x_px, y_px, .. } => (x_px, y_px),
        FoeEstimate::Unbounded { .. } => {
            d.reason = Reason::FoeOutsideView;
            return d;
        }
        FoeEstimate::Insufficient { .. } => return d,
    };
    if (foe.support() as f64) < config.min_foe_support * vectors as f64 {
        d.reason = Reason::WeakFoe {
            support: foe.support(),
            vectors,
        };
        return d;
    }
    let by_ttc = |a: &&ClusterStats, b: &&ClusterStats| a.mean_ttc_s.total_cmp(&b.mean_ttc_s);
    let (Some(obstacle), Some(open)) = (
        clusters.iter().min_by(by_ttc),
        clusters.iter().max_by(by_ttc),
    ) else {
        d.reason = Reason::NoClusters;
        return d;
    };
    d.obstacle = Some(*obstacle);
    let m = config.box_margin_px;
    let ahead = fx >= obstacle.min_x_px - m
        && fx <= obstacle.max_x_px + m
        && fy >= obstacle.min_y_px - m
        && fy <= obstacle.max_y_px + m;
    if !ahead {
        d.reason = Reason::ObstacleNotAhead;
        return d;
    }
    if obstacle.mean_ttc_s >= config.ttc_threshold_s {
        d.reason = Reason::ObstacleFar {
            ttc_s: obstacle.mean_ttc_s,
            threshold_s: config.ttc_threshold_s,
        };
        return d;
    }
    let direction = roll_direction(obstacle, open, fx);
    d.escape = Some(*open);
    d.action = Action::Roll {
        direction,
        duration_us: config.roll_duration_us,
    };
    d.reason = Reason::ObstacleAhead {
        ttc_s: obstacle.mean_ttc_s,
        threshold_s: config.ttc_threshold_s,
    };
    d
}

/// Toward the most open cluster; if the obstacle is the only cluster, out of its box
/// by the shorter way from the FOE.
fn roll_direction(obstacle: &ClusterStats, open: &ClusterStats, foe_x_px: f64) -> RollDirection {
    if open.id != obstacle.id && open.centroid_x_px != obstacle.centroid_x_px {
        return if open.centroid_x_px < obstacle.centroid_x_px {
            RollDirection::Left
        } else {
            RollDirection::Right
        };
    }
    if foe_x_px - obstacle.min_x_px < obstacle.max_x_px - foe_x_px {
        RollDirection::Left
    } else {
        RollDirection::Right
    }
}
