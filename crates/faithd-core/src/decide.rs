//! The avoidance decision of the paper's section IV, with its evidence.
//!
//! The paper takes the cluster with the lowest mean TTC as the obstacle and rolls when
//! the FOE (where the vehicle is heading) lies inside its bounding box and its mean
//! TTC is below a threshold, toward the side of the cluster with the highest mean TTC
//! (the most open space). faithd pools the clusters of each side for that choice
//! (see `roll_direction`).
//!
//! faithd checks every cluster below the threshold, most urgent first, and avoids the
//! first one whose box holds the FOE. The paper's rule looks only at the single lowest
//! cluster, so a close obstacle dead ahead is ignored whenever some other cluster (a
//! fragment of the same pole, a wall passing by) has a slightly lower TTC; DBSCAN
//! splits a tall, sparsely textured pole into several clusters often enough that this
//! matters. Every outcome, including "do nothing", carries the reason and the numbers
//! behind it so the log can explain it.

use serde::{Deserialize, Serialize};

use crate::invalid::{Invalid, check, non_negative, positive};

use crate::cluster::ClusterStats;
use crate::foe::FoeEstimate;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DecisionConfig {
    /// Roll when the obstacle's mean TTC is below this, seconds. 1.85 s since the TTC
    /// is taken at the end of the window (`ttc.rs`): before, it read about 7 % long, and
    /// 2.0 s was tuned on that. Measured in the closed loop (`faithd sim --runs 200`,
    /// seeds 1 and 2): 2.0 s avoided 120 and 118 of 120 with 4 and 6 false avoidances
    /// of 80, 1.9 s 119 and 118 with 4 and 4, 1.85 s 117 and 118 with 2 and 3 (the
    /// biased TTC and the 20 ms flow at 2.0 s: 118 and 116, 2 and 2; docs/tuning.md).
    pub ttc_threshold_s: f64,
    /// Length of one avoidance roll, microseconds (the paper's 1.5 s).
    pub roll_duration_us: i64,
    /// The obstacle box is grown by this much left and right before the FOE test,
    /// pixels: the vehicle is wider than a point, and a course that only clips the
    /// pole puts the FOE a pixel or two beside it. 12 px is the 0.15 m half-span at
    /// about 2.5 m. On the line camera (`faithd sim --straight`, seeds 1-8) 4 px
    /// missed 9 of 480 collision courses, 6 px 16, 8 px 1; on the ray-traced camera
    /// (seeds 1-5, with the other changes of docs/tuning.md) 10 px missed 6 of 120,
    /// 11 px 3, 12 px 1, with no near pass rolled on.
    pub box_margin_x_px: f64,
    /// The obstacle box's bottom is extended down by this much, pixels. Larger than
    /// the horizontal margin on purpose: flow on a tall obstacle often covers only
    /// its upper part (its lower part merges with the floor), and the manoeuvre is
    /// lateral, so what decides whether it is in the way is mostly its horizontal
    /// extent.
    pub box_margin_y_px: f64,
    /// The obstacle box's top is extended up by this much, pixels: a cluster whose
    /// top lies farther below the FOE's row than this is a patch of the floor ahead,
    /// under the vehicle's flight level, not something a roll avoids. On the
    /// ray-traced camera (`faithd sim --straight`, seeds 1-3), every false avoidance
    /// with the 45 px margin of `box_margin_y_px` on both sides was such a patch;
    /// 5 to 20 px rolled on none of 48 near passes and missed no more collision
    /// courses, 30 px rolled on one.
    pub box_margin_top_px: f64,
    /// Fewer flow vectors than this in the window and nothing is decided.
    pub min_vectors: usize,
    /// The FOE must be supported by at least this fraction of the vectors.
    pub min_foe_support: f64,
    /// A roll is commanded only when this many windows of the last
    /// `confirm_span_windows` call for it: one window's evidence (a poorly supported
    /// FOE while the flow history fills up, a passing pole pulling the FOE for a few
    /// windows) is not enough to take the stick from the pilot. Over 800 straight
    /// flights (`faithd sim --straight`, seeds 1-8) 3 in a row rolled on 14 of 320
    /// near passes and 4 in a row on 8, 5 of 6 on 1, while rolling in time on 478,
    /// 478 and 472 of 480 collision courses: 5 of 6 is 50 ms at 100 Hz against the
    /// 1.5 to 2 s of warning a roll needs.
    pub confirm_windows: u32,
    /// The span of recent windows `confirm_windows` are counted in (at most 64; equal
    /// to it, they must come in a row). One spare window lets a single window that
    /// lost the obstacle (a cluster split) not restart the count: 5 in a row rolled in
    /// time on 470 of the 480 collision courses, 5 of 6 on 472.
    pub confirm_span_windows: u32,
    /// A cluster wider than this fraction of the image is the scene around the
    /// vehicle (walls merged with the floor), not an obstacle a roll can clear. A 0.5 m
    /// pole at the closest range a roll still helps from (about 1.2 s at 2.5 m/s) is
    /// under a quarter of the DVS240's width. In `faithd sim` (100 flights, seed 1)
    /// 0.4 instead of 0.6 took false avoidances from 16 to 10 of 40 near passes, with
    /// every collision course still avoided: the rolls it removed were on 97 to 135 px
    /// wide clusters of background, most after the pole had been passed.
    pub max_obstacle_width: f64,
    /// A cluster less tall than this, pixels, is a stripe of horizontal edges (a
    /// wall's texture line), not a body standing in the way.
    pub min_obstacle_height_px: f64,
    /// Below this TTC the obstacle is already passing: no roll could act in time
    /// (the attitude alone takes longer to respond), and a near miss at the edge of
    /// the view is the usual cause.
    pub min_ttc_s: f64,
    /// An obstacle whose own flow expands about a column more than this many of its
    /// widths beside its box is passing by, whatever the FOE estimate says (see
    /// `cluster::expansion`): FAITH's FOE is pulled onto a pole passing close by,
    /// while the pole's two edges still move apart about the true heading. A 0.5 m
    /// pole the vehicle clips expands about a column within 0.3 of its widths of its
    /// edge; one passed 0.25 m clear, 0.8 or more. 0.2 leaves room for the noise of a
    /// distant pole's slow edges. When the expansion cannot be measured (one edge in
    /// view, too few vertical edges) the FOE test alone decides. Negative: off.
    pub expansion_margin: f64,
    /// Clusters stacked one above another, overlapping horizontally by at least half
    /// the narrower one's width and with mean TTCs within this fraction of each
    /// other, are pieces of one tall obstacle: the FOE's row is tested against their
    /// common vertical extent. DBSCAN (at eps 0.15) splits a pole whose flow is
    /// sparse along its height into such pieces: on the generated pole of
    /// `tests/pipeline.rs` 23 of 50 windows called for the roll without this, 40 with
    /// it. Wider tolerances roll on floor patches stacked under a passing pole
    /// (`faithd sim --straight` on the ray-traced camera, seeds 1-7: 3 of 112 near
    /// passes at 0.1, 8 at 0.2, 13 at 0.3). Negative: off.
    pub stack_ttc_tolerance: f64,
}

impl Default for DecisionConfig {
    fn default() -> Self {
        Self {
            ttc_threshold_s: 1.85,
            roll_duration_us: 1_500_000,
            box_margin_x_px: 12.0,
            box_margin_y_px: 45.0,
            box_margin_top_px: 15.0,
            min_vectors: 40,
            min_foe_support: 0.5,
            confirm_windows: 5,
            confirm_span_windows: 6,
            max_obstacle_width: 0.4,
            min_obstacle_height_px: 12.0,
            min_ttc_s: 0.25,
            expansion_margin: 0.2,
            stack_ttc_tolerance: 0.1,
        }
    }
}

impl DecisionConfig {
    /// `[pipeline.decision]`: thresholds, the confirmation span and the obstacle's size.
    pub fn validate(&self) -> Result<(), Invalid> {
        let de = self;
        positive(de.ttc_threshold_s, "pipeline.decision.ttc_threshold_s")?;
        check(
            (1..=10_000_000).contains(&de.roll_duration_us),
            "pipeline.decision.roll_duration_us",
            || format!("must be 1 us to 10 s, got {}", de.roll_duration_us),
        )?;
        non_negative(de.box_margin_x_px, "pipeline.decision.box_margin_x_px")?;
        non_negative(de.box_margin_y_px, "pipeline.decision.box_margin_y_px")?;
        non_negative(de.box_margin_top_px, "pipeline.decision.box_margin_top_px")?;
        check(
            de.stack_ttc_tolerance < 1.0,
            "pipeline.decision.stack_ttc_tolerance",
            || {
                format!(
                    "must be below 1 (negative: off), got {}",
                    de.stack_ttc_tolerance
                )
            },
        )?;
        check(
            (0.0..=1.0).contains(&de.min_foe_support),
            "pipeline.decision.min_foe_support",
            || format!("must be a fraction 0..1, got {}", de.min_foe_support),
        )?;
        check(
            (1..=64).contains(&de.confirm_windows),
            "pipeline.decision.confirm_windows",
            || format!("must be 1 to 64, got {}", de.confirm_windows),
        )?;
        check(
            (de.confirm_windows..=64).contains(&de.confirm_span_windows),
            "pipeline.decision.confirm_span_windows",
            || {
                format!(
                    "must be confirm_windows ({}) to 64, got {}",
                    de.confirm_windows, de.confirm_span_windows
                )
            },
        )?;
        check(
            de.max_obstacle_width > 0.0 && de.max_obstacle_width <= 1.0,
            "pipeline.decision.max_obstacle_width",
            || {
                format!(
                    "must be a fraction in (0, 1], got {}",
                    de.max_obstacle_width
                )
            },
        )?;
        non_negative(
            de.min_obstacle_height_px,
            "pipeline.decision.min_obstacle_height_px",
        )?;
        check(
            de.min_ttc_s >= 0.0 && de.min_ttc_s < de.ttc_threshold_s,
            "pipeline.decision.min_ttc_s",
            || {
                format!(
                    "must be 0 or more and below ttc_threshold_s, got {}",
                    de.min_ttc_s
                )
            },
        )?;
        Ok(())
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
    /// Obstacle ahead and close, but not yet in `confirm_windows` of the last
    /// `confirm_span_windows` windows.
    Unconfirmed {
        ttc_s: f64,
        windows: u32,
        needed: u32,
    },
}

/// One decision and the evidence behind it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Decision {
    pub t_us: i64,
    pub action: Action,
    pub reason: Reason,
    pub foe_px: Option<(f64, f64)>,
    /// The flow vectors the FOE was estimated from (the tight ones of the history).
    pub vectors: usize,
    pub clusters: usize,
    pub obstacle: Option<ClusterStats>,
    /// The cluster with the highest mean TTC (the most open space), when rolling.
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
            if let Some(e) = o.expansion {
                write!(
                    f,
                    ", expands about x {:.0} (ttc {:.2} s)",
                    e.centre_x_px, e.ttc_s
                )?;
            }
        }
        write!(f, "; {} vectors, {} clusters", self.vectors, self.clusters)
    }
}

/// Whether the cluster's own expansion centre (when measured) lies within `margin`
/// of its widths from its box.
fn expands_within_reach(c: &ClusterStats, margin: f64) -> bool {
    let reach_px = margin * (c.max_x_px - c.min_x_px);
    match c.expansion {
        Some(e) if margin >= 0.0 => {
            e.centre_x_px >= c.min_x_px - reach_px && e.centre_x_px <= c.max_x_px + reach_px
        }
        _ => true,
    }
}

/// The vertical extent of `c` and the clusters stacked with it (see
/// `DecisionConfig::stack_ttc_tolerance`).
fn stacked_extent(c: &ClusterStats, clusters: &[ClusterStats], tolerance: f64) -> (f64, f64) {
    let (mut top, mut bottom) = (c.min_y_px, c.max_y_px);
    if tolerance < 0.0 {
        return (top, bottom);
    }
    for o in clusters {
        let overlap = c.max_x_px.min(o.max_x_px) - c.min_x_px.max(o.min_x_px);
        let narrower = (c.max_x_px - c.min_x_px).min(o.max_x_px - o.min_x_px);
        let same_ttc = (o.mean_ttc_s - c.mean_ttc_s).abs() <= tolerance * c.mean_ttc_s;
        if overlap >= 0.5 * narrower && same_ttc {
            top = top.min(o.min_y_px);
            bottom = bottom.max(o.max_y_px);
        }
    }
    (top, bottom)
}

/// Where the FOE must lie for cluster `c` to be in the way, pixels: its box grown by
/// the margins, over the height of the clusters stacked with it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FoeRegion {
    pub min_x_px: f64,
    pub max_x_px: f64,
    pub min_y_px: f64,
    pub max_y_px: f64,
}

impl FoeRegion {
    pub fn contains(&self, x_px: f64, y_px: f64) -> bool {
        (self.min_x_px..=self.max_x_px).contains(&x_px)
            && (self.min_y_px..=self.max_y_px).contains(&y_px)
    }
}

/// The [`FoeRegion`] of cluster `c` among `clusters` (the decision's test; a
/// flight's video draws it).
pub fn foe_region(
    c: &ClusterStats,
    clusters: &[ClusterStats],
    config: &DecisionConfig,
) -> FoeRegion {
    let (top, bottom) = stacked_extent(c, clusters, config.stack_ttc_tolerance);
    FoeRegion {
        min_x_px: c.min_x_px - config.box_margin_x_px,
        max_x_px: c.max_x_px + config.box_margin_x_px,
        min_y_px: top - config.box_margin_top_px,
        max_y_px: bottom + config.box_margin_y_px,
    }
}

/// Why a cluster is not an obstacle in the way of a vehicle heading for `foe_px`:
/// the decision's checks, in the order it makes them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NotInTheWay {
    /// Wider than `max_obstacle_width` of the image: the scene around the vehicle.
    TooWide,
    /// Less tall than `min_obstacle_height_px`: a stripe of horizontal edges.
    TooFlat,
    /// Below `min_ttc_s`: already passing, too late for any roll.
    Passing,
    /// The FOE lies outside its [`FoeRegion`].
    FoeOutside,
    /// Its own flow expands about a column beside it (see `expansion_margin`).
    ExpandsBeside,
}

/// Whether cluster `c` (among `clusters`) is an obstacle in the way, and if not,
/// the first check it fails.
pub fn not_in_the_way(
    c: &ClusterStats,
    clusters: &[ClusterStats],
    config: &DecisionConfig,
    image_width_px: f64,
    (fx, fy): (f64, f64),
) -> Option<NotInTheWay> {
    if c.max_x_px - c.min_x_px > config.max_obstacle_width * image_width_px {
        Some(NotInTheWay::TooWide)
    } else if c.max_y_px - c.min_y_px < config.min_obstacle_height_px {
        Some(NotInTheWay::TooFlat)
    } else if c.mean_ttc_s < config.min_ttc_s {
        Some(NotInTheWay::Passing)
    } else if !foe_region(c, clusters, config).contains(fx, fy) {
        Some(NotInTheWay::FoeOutside)
    } else if !expands_within_reach(c, config.expansion_margin) {
        Some(NotInTheWay::ExpandsBeside)
    } else {
        None
    }
}

/// Applies the rule to one window's FOE and clusters.
pub fn decide(
    t_us: i64,
    config: &DecisionConfig,
    image_width_px: f64,
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
    let (Some(nearest), Some(open)) = (
        clusters.iter().min_by(by_ttc),
        clusters.iter().max_by(by_ttc),
    ) else {
        d.reason = Reason::NoClusters;
        return d;
    };
    let holds_foe =
        |c: &ClusterStats| not_in_the_way(c, clusters, config, image_width_px, (fx, fy)).is_none();
    // The most urgent cluster in the way, if any.
    let Some(ahead) = clusters.iter().filter(|c| holds_foe(c)).min_by(by_ttc) else {
        d.obstacle = Some(*nearest);
        d.reason = Reason::ObstacleNotAhead;
        return d;
    };
    let urgent = clusters
        .iter()
        .filter(|c| c.mean_ttc_s < config.ttc_threshold_s && holds_foe(c))
        .min_by(by_ttc);
    let Some(obstacle) = urgent else {
        d.obstacle = Some(*ahead);
        d.reason = Reason::ObstacleFar {
            ttc_s: ahead.mean_ttc_s,
            threshold_s: config.ttc_threshold_s,
        };
        return d;
    };
    d.obstacle = Some(*obstacle);
    let direction = roll_direction(obstacle, clusters, fx);
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

/// Toward the more open side: the side of the obstacle whose other clusters have the
/// higher mean TTC (weighted by their vector counts). The paper heads toward the
/// single cluster with the highest mean TTC, which a small far fragment on the wrong
/// side can win; pooling each side's clusters is steadier. With clusters on one side
/// only, that side; with none, out of the obstacle's box by the shorter way.
fn roll_direction(
    obstacle: &ClusterStats,
    clusters: &[ClusterStats],
    foe_x_px: f64,
) -> RollDirection {
    let (mut left, mut right) = ((0.0, 0usize), (0.0, 0usize));
    for c in clusters.iter().filter(|c| c.id != obstacle.id) {
        let side = if c.centroid_x_px < obstacle.centroid_x_px {
            &mut left
        } else {
            &mut right
        };
        side.0 += c.mean_ttc_s * c.count as f64;
        side.1 += c.count;
    }
    let mean = |(sum, n): (f64, usize)| (n > 0).then(|| sum / n as f64);
    match (mean(left), mean(right)) {
        (Some(l), Some(r)) if l > r => RollDirection::Left,
        (Some(_), Some(_)) => RollDirection::Right,
        (Some(_), None) => RollDirection::Left,
        (None, Some(_)) => RollDirection::Right,
        (None, None) => {
            if foe_x_px - obstacle.min_x_px < obstacle.max_x_px - foe_x_px {
                RollDirection::Left
            } else {
                RollDirection::Right
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cluster(id: u32, ttc_s: f64, x0: f64, x1: f64) -> ClusterStats {
        ClusterStats {
            id,
            count: 50,
            mean_ttc_s: ttc_s,
            centroid_x_px: (x0 + x1) / 2.0,
            centroid_y_px: 90.0,
            min_x_px: x0,
            max_x_px: x1,
            min_y_px: 20.0,
            max_y_px: 160.0,
            expansion: None,
        }
    }

    fn foe(x: f64) -> FoeEstimate {
        FoeEstimate::Point {
            x_px: x,
            y_px: 90.0,
            support: 900,
        }
    }

    fn run(foe_est: FoeEstimate, clusters: &[ClusterStats]) -> Decision {
        decide(
            7,
            &DecisionConfig::default(),
            240.0,
            true,
            1000,
            &foe_est,
            clusters,
        )
    }

    #[test]
    fn close_obstacle_ahead_rolls_toward_open_space() {
        let clusters = [
            cluster(0, 4.0, 0.0, 100.0),
            cluster(1, 1.0, 110.0, 130.0),
            cluster(2, 8.0, 150.0, 239.0),
        ];
        let d = run(foe(120.0), &clusters);
        assert_eq!(
            d.action,
            Action::Roll {
                direction: RollDirection::Right,
                duration_us: 1_500_000
            }
        );
        assert_eq!(d.obstacle.unwrap().id, 1);
        assert_eq!(d.escape.unwrap().id, 2);
        assert!(
            d.to_string()
                .starts_with("roll Right for 1500 ms because ObstacleAhead")
        );
    }

    #[test]
    fn obstacle_ahead_is_avoided_even_when_another_cluster_is_nearer() {
        // The paper's rule would look only at cluster 0 (lowest TTC, off course).
        let clusters = [
            cluster(0, 0.8, 10.0, 40.0),
            cluster(1, 1.2, 110.0, 130.0),
            cluster(2, 6.0, 150.0, 239.0),
        ];
        let d = run(foe(120.0), &clusters);
        assert!(matches!(d.action, Action::Roll { .. }));
        assert_eq!(d.obstacle.unwrap().id, 1);
    }

    #[test]
    fn holds_with_a_reason_otherwise() {
        let far = [cluster(0, 3.0, 100.0, 140.0)];
        assert!(matches!(
            run(foe(120.0), &far).reason,
            Reason::ObstacleFar { .. }
        ));
        let aside = [cluster(0, 1.0, 10.0, 40.0)];
        assert_eq!(run(foe(120.0), &aside).reason, Reason::ObstacleNotAhead);
        assert_eq!(run(foe(120.0), &[]).reason, Reason::NoClusters);
        let unbounded = FoeEstimate::Unbounded {
            side: crate::foe::Side::Left,
            dx: -1.0,
            dy: 0.0,
            support: 900,
        };
        assert_eq!(run(unbounded, &aside).reason, Reason::FoeOutsideView);
        let weak = FoeEstimate::Point {
            x_px: 120.0,
            y_px: 90.0,
            support: 100,
        };
        assert!(matches!(run(weak, &aside).reason, Reason::WeakFoe { .. }));
        let d = decide(
            7,
            &DecisionConfig::default(),
            240.0,
            false,
            1000,
            &foe(120.0),
            &aside,
        );
        assert_eq!((d.action, d.reason), (Action::Hold, Reason::NoAttitude));
        let d = decide(
            7,
            &DecisionConfig::default(),
            240.0,
            true,
            10,
            &foe(120.0),
            &aside,
        );
        assert!(matches!(
            d.reason,
            Reason::TooFewVectors { vectors: 10, .. }
        ));
    }

    #[test]
    fn an_obstacle_expanding_about_a_column_beside_it_is_passing_by() {
        use crate::cluster::Expansion;
        let with_centre = |x: f64| ClusterStats {
            expansion: Some(Expansion {
                centre_x_px: x,
                ttc_s: 1.0,
            }),
            ..cluster(0, 1.0, 110.0, 130.0)
        };
        // The FOE is on the pole, but the pole expands about column 170: passing.
        let d = run(foe(120.0), &[with_centre(170.0)]);
        assert_eq!(d.reason, Reason::ObstacleNotAhead);
        // Within 0.2 of its 20 px width of its box: in the way.
        for x in [107.0, 120.0, 133.0] {
            let d = run(foe(120.0), &[with_centre(x)]);
            assert!(matches!(d.action, Action::Roll { .. }), "{x}: {d}");
        }
        assert!(
            run(foe(120.0), &[with_centre(120.0)])
                .to_string()
                .contains("expands about x 120")
        );
    }

    #[test]
    fn lone_obstacle_is_left_by_the_shorter_way() {
        let only = [cluster(0, 1.0, 100.0, 140.0)];
        let left = run(foe(110.0), &only);
        let right = run(foe(135.0), &only);
        assert!(matches!(
            left.action,
            Action::Roll {
                direction: RollDirection::Left,
                ..
            }
        ));
        assert!(matches!(
            right.action,
            Action::Roll {
                direction: RollDirection::Right,
                ..
            }
        ));
    }
}
