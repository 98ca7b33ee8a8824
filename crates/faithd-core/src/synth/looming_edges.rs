//! Events of a camera flying straight at layered, fronto-parallel scenery.
//!
//! Each layer is a plane at its own time to contact, covered with straight edges.
//! Under pure translation a point's image moves away from the FOE with scale
//! `s(t) = tau0 / (tau0 - t)`, so an edge line `n . (p - foe) = d0` sits at
//! `n . (p - foe) = d0 * s(t)` and crosses the pixel centre with `n . (p - foe) = r` at
//! `t = tau0 * (1 - d0 / r)`. That closed form gives exact event times, exact normal
//! flow (`r / (tau0 - t)` along `n`) and exact TTC (`tau0 - t`) for every event.
//! Layers occlude farther ones where their (expanding) rectangle covers the pixel.

use crate::math;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64Mcg;

use crate::camera::CameraIntrinsics;
use crate::event::{Event, Polarity};

/// One plane of scenery.
#[derive(Clone, Debug)]
pub struct Layer {
    /// Time to contact at t = 0, seconds.
    pub tau0_s: f64,
    /// Image rectangle (x0, y0, x1, y1) covered at t = 0; `None` = the whole view.
    pub rect_px: Option<(f64, f64, f64, f64)>,
    /// Number of random straight edges on it.
    pub edges: usize,
}

/// A looming scene: FOE, layers and sensor imperfections.
#[derive(Clone, Debug)]
pub struct LoomingEdges {
    pub foe_px: (f64, f64),
    pub layers: Vec<Layer>,
    pub duration_s: f64,
    /// Standard deviation of timestamp jitter, microseconds.
    pub jitter_us: f64,
    /// Uniform background-activity noise, events per pixel per second.
    pub noise_rate_hz: f64,
}

impl LoomingEdges {
    /// A vehicle heading at a pole (TTC 1.2 s) in front of a wall (TTC 4 s).
    pub fn pole_ahead(foe_px: (f64, f64)) -> Self {
        Self {
            foe_px,
            layers: vec![
                Layer {
                    tau0_s: 1.2,
                    rect_px: Some((foe_px.0 - 12.0, -1e4, foe_px.0 + 12.0, 1e4)),
                    edges: 30,
                },
                Layer {
                    tau0_s: 4.0,
                    rect_px: None,
                    edges: 60,
                },
            ],
            duration_s: 0.5,
            jitter_us: 0.0,
            noise_rate_hz: 0.0,
        }
    }
}

struct Edge {
    nx: f64,
    ny: f64,
    d0_px: f64,
    polarity: Polarity,
}

/// All events of the scene over `[0, duration_s)`, sorted by time.
pub fn looming_edge_events(
    camera: &CameraIntrinsics,
    scene: &LoomingEdges,
    seed: u64,
) -> Vec<Event> {
    render(camera, scene, 1.0, seed)
}

/// All events of a scene laid out in the DVS240 preset's pixels, as `camera` (with
/// the same field of view, say a DVXplorer) sees it: the FOE, the rectangles and the
/// edges' offsets scaled about the principal point by the ratio of focal lengths,
/// with the same draws. Every edge then crosses the same directions at the same
/// times, over `px_per_dvs240_px()` squared as many pixels. The DVS240 preset gets
/// `looming_edge_events` itself.
pub fn looming_edge_events_seen_by(
    camera: &CameraIntrinsics,
    scene: &LoomingEdges,
    seed: u64,
) -> Vec<Event> {
    let reference = CameraIntrinsics::dvs240();
    if *camera == reference {
        return looming_edge_events(camera, scene, seed);
    }
    let scale = camera.px_per_dvs240_px();
    let x = |x_px: f64| (x_px - reference.cx_px) * scale + camera.cx_px;
    let y = |y_px: f64| (y_px - reference.cy_px) * scale + camera.cy_px;
    let mut seen = scene.clone();
    seen.foe_px = (x(scene.foe_px.0), y(scene.foe_px.1));
    for layer in &mut seen.layers {
        layer.rect_px = layer
            .rect_px
            .map(|(x0, y0, x1, y1)| (x(x0), y(y0), x(x1), y(y1)));
    }
    render(camera, &seen, scale, seed)
}

/// The scene's events with the edges' offsets (drawn in 1..150 px) times `px_scale`.
fn render(camera: &CameraIntrinsics, scene: &LoomingEdges, px_scale: f64, seed: u64) -> Vec<Event> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let duration_us = scene.duration_s * 1e6;
    let (fx, fy) = scene.foe_px;
    let layers: Vec<(&Layer, Vec<Edge>)> = scene
        .layers
        .iter()
        .map(|layer| {
            let edges = (0..layer.edges)
                .map(|_| {
                    let angle = rng.random_range(0.0..std::f64::consts::TAU);
                    Edge {
                        nx: math::cos(angle),
                        ny: math::sin(angle),
                        // Offsets such that edges keep entering the view during the run.
                        d0_px: rng.random_range(1.0..150.0) * px_scale,
                        polarity: Polarity::from_bool(rng.random_bool(0.5)),
                    }
                })
                .collect();
            (layer, edges)
        })
        .collect();
    let visible = |layer_idx: usize, x: f64, y: f64, t_s: f64| -> bool {
        // The nearest layer whose expanding rectangle covers the pixel wins.
        let covers = |l: &Layer| match l.rect_px {
            None => true,
            Some((x0, y0, x1, y1)) => {
                let s = l.tau0_s / (l.tau0_s - t_s);
                let (ux, uy) = (fx + (x - fx) / s, fy + (y - fy) / s);
                ux >= x0 && ux <= x1 && uy >= y0 && uy <= y1
            }
        };
        if !covers(layers[layer_idx].0) {
            return false;
        }
        let tau = layers[layer_idx].0.tau0_s;
        !layers.iter().any(|(l, _)| l.tau0_s < tau && covers(l))
    };

    let jitter = Normal::new(0.0, scene.jitter_us.max(0.0)).expect("finite jitter");
    let mut events = Vec::new();
    for y in 0..camera.height_px {
        for x in 0..camera.width_px {
            let (px, py) = (f64::from(x), f64::from(y));
            for (li, (layer, edges)) in layers.iter().enumerate() {
                for e in edges {
                    let r = e.nx * (px - fx) + e.ny * (py - fy);
                    if r <= e.d0_px {
                        continue;
                    }
                    let t_s = layer.tau0_s * (1.0 - e.d0_px / r);
                    if t_s * 1e6 >= duration_us || !visible(li, px, py, t_s) {
                        continue;
                    }
                    let t_us = (t_s * 1e6 + jitter.sample(&mut rng)).round() as i64;
                    events.push(Event::new(t_us.max(0), x, y, e.polarity));
                }
            }
        }
    }
    let noise_events =
        (scene.noise_rate_hz * scene.duration_s * camera.pixel_count() as f64) as usize;
    for _ in 0..noise_events {
        events.push(Event::new(
            rng.random_range(0..duration_us as i64),
            rng.random_range(0..camera.width_px),
            rng.random_range(0..camera.height_px),
            Polarity::from_bool(rng.random_bool(0.5)),
        ));
    }
    events.sort_by_key(|e| (e.t_us, e.y_px, e.x_px));
    events
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_expand_away_from_the_foe() {
        let cam = CameraIntrinsics::dvs240();
        let scene = LoomingEdges {
            foe_px: (120.0, 90.0),
            layers: vec![Layer {
                tau0_s: 2.0,
                rect_px: None,
                edges: 10,
            }],
            duration_s: 0.3,
            jitter_us: 0.0,
            noise_rate_hz: 0.0,
        };
        let events = looming_edge_events(&cam, &scene, 1);
        assert!(events.len() > 1000);
        assert!(events.windows(2).all(|w| w[0].t_us <= w[1].t_us));
        assert!(events.iter().all(|e| e.t_us < 300_000));
        // Every edge moves outward: within one run, the events' distance from the FOE
        // grows with time on average (the lines scale up by 1/(1 - t/tau0)).
        let dist = |e: &Event| math::hypot(f64::from(e.x_px) - 120.0, f64::from(e.y_px) - 90.0);
        let single = LoomingEdges {
            layers: vec![Layer {
                edges: 1,
                ..scene.layers[0].clone()
            }],
            ..scene.clone()
        };
        let events = looming_edge_events(&cam, &single, 5);
        let half = events.len() / 2;
        let early: f64 = events[..half].iter().map(dist).sum::<f64>() / half as f64;
        let late: f64 = events[half..].iter().map(dist).sum::<f64>() / (events.len() - half) as f64;
        assert!(late > early, "early {early} late {late}");
    }

    #[test]
    fn a_finer_camera_sees_the_same_edges_at_the_same_times() {
        let mut scene = LoomingEdges::pole_ahead((130.0, 85.0));
        scene.duration_s = 0.2;
        let dvs = CameraIntrinsics::dvs240();
        let coarse = looming_edge_events_seen_by(&dvs, &scene, 4);
        assert_eq!(coarse, looming_edge_events(&dvs, &scene, 4));
        let dvx = CameraIntrinsics::dvxplorer();
        let fine = looming_edge_events_seen_by(&dvx, &scene, 4);
        // (640 x 480) / (240 x 180) = 7.1 times the pixels: the edges sweep that many.
        let ratio = fine.len() as f64 / coarse.len() as f64;
        assert!((5.5..8.5).contains(&ratio), "{ratio}");
        // The same directions from the centre at the same times: mean time and mean
        // normalised position agree.
        let mean = |cam: &CameraIntrinsics, events: &[Event]| {
            let n = events.len() as f64;
            let (mut t, mut x, mut y) = (0.0, 0.0, 0.0);
            for e in events {
                let (xn, yn) = cam.normalise(f64::from(e.x_px), f64::from(e.y_px));
                (t, x, y) = (t + e.t_us as f64 / n, x + xn / n, y + yn / n);
            }
            (t, x, y)
        };
        let (a, b) = (mean(&dvs, &coarse), mean(&dvx, &fine));
        assert!((a.0 - b.0).abs() < 0.05 * a.0, "{a:?} {b:?}");
        assert!(
            (a.1 - b.1).abs() < 0.02 && (a.2 - b.2).abs() < 0.02,
            "{a:?} {b:?}"
        );
    }

    #[test]
    fn pole_occludes_the_background() {
        let cam = CameraIntrinsics::dvs240();
        let scene = LoomingEdges::pole_ahead((120.0, 90.0));
        let events = looming_edge_events(&cam, &scene, 2);
        assert!(!events.is_empty());
        assert_eq!(events, looming_edge_events(&cam, &scene, 2));
    }
}
