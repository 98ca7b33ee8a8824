//! Normal optic flow from events (Benosman 2014, made online by Hordijk 2018).
//!
//! Every event updates a surface of active events (the latest timestamp per pixel and
//! polarity). A plane `t = a*x + b*y + c` fitted to the recent timestamps around the
//! event gives the local time gradient; an edge moving at speed `s` across the pixel
//! grid leaves a gradient of `1/s` along its normal, so the normal flow is
//! `(a, b) / (a^2 + b^2)`.

mod config;
mod engine;
mod normal_flow;
mod plane_fit;
mod stats;
mod surface;
mod tiles;
mod vector;

pub use config::{FlowConfig, MAX_RADIUS_PX};
pub use normal_flow::NormalFlow;
pub use plane_fit::{PlaneFit, fit_plane};
pub use stats::FlowStats;
pub use surface::ActiveEventSurface;
pub use vector::FlowVector;
