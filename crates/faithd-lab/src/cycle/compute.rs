//! What a window's compute costs in a simulated flight, and on which board.
//!
//! A simulated flight must give the same result on any machine and under any load,
//! so by default it does not charge the wall-clock time a window took here (that
//! follows whatever else the machine is doing) but a model of it: a sum of per-stage
//! costs linear in the window's counts ([`Work`]: events, plane fits, vectors,
//! FAITH's vectors times iterations, DBSCAN's points and their square), fitted to
//! stage timings measured on the development machine (`faithd bench compute`
//! refits it and prints the table below). `cpu_scale` then stands for the board:
//! 1 is the development machine, [`ATOM_X5_Z8350_SCALE`] the paper's Intel Atom.
//! `--compute measured` charges the measured time instead, to check the model.

use serde::Serialize;

use faithd_core::pipeline::StageTimings;
use faithd_daemon::cycle::Work;

/// How much slower one core of the paper's board (UP board, Intel Atom x5-Z8350,
/// Airmont at 1.44 GHz, 1.92 GHz burst) runs faithd's pipeline than one core of the
/// development machine (AMD EPYC, Zen 5, 3.6 GHz measured). Derived, not measured:
/// see docs/tuning.md, "The Atom's factor".
pub const ATOM_X5_Z8350_SCALE: f64 = 7.0;

/// The terms of the model, in the order of [`ComputeModel::ns`]: each stage's
/// constant and its per-count costs, nanoseconds.
pub const TERMS: [(&str, Stage); 13] = [
    ("flow: per window", Stage::Flow),
    ("flow: per event (that reached the flow)", Stage::Flow),
    ("flow: per plane fit", Stage::Flow),
    ("derotation: per window", Stage::Derotate),
    ("derotation: per new vector", Stage::Derotate),
    ("FOE: per window", Stage::Foe),
    ("FOE: per vector", Stage::Foe),
    ("FOE: per vector x iteration", Stage::Foe),
    ("TTC: per history vector", Stage::Ttc),
    ("DBSCAN: per window", Stage::Cluster),
    ("DBSCAN: per point", Stage::Cluster),
    ("DBSCAN: per point squared", Stage::Cluster),
    ("decision: per window", Stage::Decide),
];

/// The pipeline's stages, as [`StageTimings`] times them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Stage {
    Flow,
    Derotate,
    Foe,
    Ttc,
    Cluster,
    Decide,
}

impl Stage {
    pub const ALL: [Stage; 6] = [
        Stage::Flow,
        Stage::Derotate,
        Stage::Foe,
        Stage::Ttc,
        Stage::Cluster,
        Stage::Decide,
    ];

    pub fn measured_ns(self, t: &StageTimings) -> u64 {
        match self {
            Stage::Flow => t.flow_ns,
            Stage::Derotate => t.derotate_ns,
            Stage::Foe => t.foe_ns,
            Stage::Ttc => t.ttc_ns,
            Stage::Cluster => t.cluster_ns,
            Stage::Decide => t.decide_ns,
        }
    }
}

/// The counts each term multiplies, in the order of [`TERMS`].
pub fn features(w: &Work) -> [f64; 13] {
    let n = w.clustered as f64;
    [
        1.0,
        (w.events - w.skipped) as f64,
        w.fits as f64,
        1.0,
        w.new_vectors as f64,
        1.0,
        w.foe_vectors as f64,
        w.foe_vectors as f64 * f64::from(w.foe_iterations),
        w.history_vectors as f64,
        1.0,
        n,
        n * n,
        1.0,
    ]
}

/// Per-term costs, nanoseconds of the development machine.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ComputeModel {
    pub ns: [f64; 13],
}

impl ComputeModel {
    /// Fitted by `faithd bench compute --flights 24 --scene mixed` on the development
    /// machine (2 cores, AMD EPYC, 3.6 GHz; x86-64 baseline build; nothing else
    /// running) from the pipeline's stage timings over 7656 windows of simulated
    /// flights on the ray-traced camera in the four scenes: per-window error median
    /// 9 %, 90th percentile 24 %; mean window 335 us measured, 332 us modelled.
    pub const CALIBRATED: ComputeModel = ComputeModel {
        ns: [
            47763.363, 8.282, 179.749, 3073.683, 19.893, 25981.997, 37.022, 0.514, 11.535, 0.0,
            254.663, 0.0, 723.447,
        ],
    };

    /// Modelled compute time of a window here, nanoseconds.
    pub fn cost_ns(&self, work: &Work) -> f64 {
        features(work)
            .iter()
            .zip(&self.ns)
            .map(|(f, c)| f * c)
            .sum()
    }

    /// Modelled time of one stage, nanoseconds.
    pub fn stage_ns(&self, stage: Stage, work: &Work) -> f64 {
        features(work)
            .iter()
            .zip(&self.ns)
            .zip(TERMS)
            .filter(|(_, (_, s))| *s == stage)
            .map(|((f, c), _)| f * c)
            .sum()
    }
}

/// What a simulated cycle costs in simulated time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum ComputeCharge {
    /// The model's time times `cpu_scale`: the same on every machine and run.
    Model { model: ComputeModel, cpu_scale: f64 },
    /// The time measured here times `cpu_scale`: follows this machine's load, so
    /// two runs differ.
    Measured { cpu_scale: f64 },
}

impl ComputeCharge {
    /// The calibrated model at `cpu_scale`.
    pub fn modelled(cpu_scale: f64) -> Self {
        ComputeCharge::Model {
            model: ComputeModel::CALIBRATED,
            cpu_scale,
        }
    }

    /// Charged time of a window that did `work` in `measured_ns` here, whole
    /// microseconds (at least one: a cycle is never free).
    pub fn charge_us(&self, work: &Work, measured_ns: u64) -> i64 {
        let ns = match *self {
            ComputeCharge::Model { model, cpu_scale } => model.cost_ns(work) * cpu_scale,
            ComputeCharge::Measured { cpu_scale } => measured_ns as f64 * cpu_scale,
        };
        ((ns / 1000.0).round() as i64).max(1)
    }

    pub fn cpu_scale(&self) -> f64 {
        match *self {
            ComputeCharge::Model { cpu_scale, .. } | ComputeCharge::Measured { cpu_scale } => {
                cpu_scale
            }
        }
    }
}

/// Fits the model's terms to measured windows: for each stage, non-negative least
/// squares of its measured time on its own terms. Negative costs would make no
/// sense (and let one term cancel another outside the data's range).
pub fn fit(samples: &[(Work, StageTimings)]) -> ComputeModel {
    let mut ns = [0.0; 13];
    for stage in Stage::ALL {
        let cols: Vec<usize> = (0..TERMS.len()).filter(|&k| TERMS[k].1 == stage).collect();
        let rows: Vec<(Vec<f64>, f64)> = samples
            .iter()
            .map(|(w, t)| {
                let f = features(w);
                (
                    cols.iter().map(|&k| f[k]).collect(),
                    stage.measured_ns(t) as f64,
                )
            })
            .collect();
        for (k, c) in cols.iter().zip(nnls(&rows, cols.len())) {
            ns[*k] = c;
        }
    }
    ComputeModel { ns }
}

/// Non-negative least squares by active sets: solve on the free terms, and while a
/// coefficient comes out negative, fix the most negative at zero and solve again.
/// Enough for a handful of terms.
fn nnls(rows: &[(Vec<f64>, f64)], n: usize) -> Vec<f64> {
    let mut free: Vec<usize> = (0..n).collect();
    loop {
        let m = free.len();
        if m == 0 {
            return vec![0.0; n];
        }
        // Normal equations over the free columns, scaled for conditioning.
        let scale: Vec<f64> = free
            .iter()
            .map(|&j| {
                let s = rows.iter().map(|(x, _)| x[j] * x[j]).sum::<f64>().sqrt();
                if s > 0.0 { s } else { 1.0 }
            })
            .collect();
        let mut a = nalgebra::DMatrix::<f64>::zeros(m, m);
        let mut b = nalgebra::DVector::<f64>::zeros(m);
        for (x, y) in rows {
            for (p, &i) in free.iter().enumerate() {
                let xi = x[i] / scale[p];
                b[p] += xi * y;
                for (q, &j) in free.iter().enumerate() {
                    a[(p, q)] += xi * x[j] / scale[q];
                }
            }
        }
        let solved = a
            .clone()
            .svd(true, true)
            .solve(&b, 1e-12)
            .unwrap_or_else(|_| nalgebra::DVector::zeros(m));
        let coef: Vec<f64> = (0..m).map(|p| solved[p] / scale[p]).collect();
        match (0..m)
            .filter(|&p| coef[p] < 0.0)
            .min_by(|&p, &q| coef[p].total_cmp(&coef[q]))
        {
            Some(p) => {
                free.remove(p);
            }
            None => {
                let mut out = vec![0.0; n];
                for (p, &j) in free.iter().enumerate() {
                    out[j] = coef[p];
                }
                return out;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn work(events: usize, vectors: usize, clustered: usize) -> Work {
        Work {
            events,
            skipped: 0,
            fits: events * 9 / 10,
            new_vectors: vectors / 5,
            history_vectors: vectors,
            foe_vectors: vectors * 2 / 3,
            // Load shedding varies the iterations, which tells the per-vector cost
            // from the per-vector-iteration one.
            foe_iterations: [52, 26, 13][(events + vectors) % 3],
            clustered,
        }
    }

    #[test]
    fn the_fit_recovers_the_costs_that_made_the_timings() {
        let truth = ComputeModel {
            ns: [
                2000.0, 30.0, 250.0, 500.0, 20.0, 3000.0, 40.0, 1.5, 15.0, 1000.0, 60.0, 0.05,
                800.0,
            ],
        };
        let samples: Vec<(Work, StageTimings)> = (0..400)
            .map(|i| {
                let w = work(
                    200 + 37 * (i % 50),
                    300 + 23 * (i % 97),
                    100 + 19 * (i % 89),
                );
                let t = |s| truth.stage_ns(s, &w).round() as u64;
                let timings = StageTimings {
                    flow_ns: t(Stage::Flow),
                    derotate_ns: t(Stage::Derotate),
                    foe_ns: t(Stage::Foe),
                    ttc_ns: t(Stage::Ttc),
                    cluster_ns: t(Stage::Cluster),
                    decide_ns: t(Stage::Decide),
                };
                (w, timings)
            })
            .collect();
        let fitted = fit(&samples);
        for (k, (name, _)) in TERMS.iter().enumerate() {
            let (got, want) = (fitted.ns[k], truth.ns[k]);
            assert!(
                (got - want).abs() <= 0.02 * want + 1.0,
                "{name}: fitted {got}, made with {want}"
            );
        }
    }

    #[test]
    fn no_cost_comes_out_negative() {
        // Time falls with the events here: a free fit would give events a negative cost.
        let samples: Vec<(Work, StageTimings)> = (0..100)
            .map(|i| {
                let w = work(1000 - 5 * i, 500, 200);
                let t = StageTimings {
                    flow_ns: 10_000 + 3 * i as u64,
                    ..Default::default()
                };
                (w, t)
            })
            .collect();
        assert!(fit(&samples).ns.iter().all(|c| *c >= 0.0));
    }

    #[test]
    fn the_charge_scales_and_rounds_to_whole_microseconds() {
        let model = ComputeModel {
            ns: [
                1000.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
            ],
        };
        let w = work(100, 100, 100);
        let atom = ComputeCharge::Model {
            model,
            cpu_scale: 7.0,
        };
        assert_eq!(atom.charge_us(&w, 0), 7);
        let measured = ComputeCharge::Measured { cpu_scale: 2.0 };
        assert_eq!(measured.charge_us(&w, 1_600_000), 3200);
        assert_eq!(measured.charge_us(&w, 0), 1, "a cycle is never free");
    }
}
