//! Clustering flow vectors into obstacles: DBSCAN on position and time to contact.
//!
//! The paper clusters on (x, y normalised to 0..1, TTC normalised by mean and
//! variance) with eps 0.2 and minPts 20. A pole ahead then stands out as a dense
//! group of low TTC against the background.

mod dbscan;
mod dense_grid;
mod expansion;
mod features;
mod geometry;
mod sorted_grid;
mod stats;

pub use dbscan::{Dbscan, DbscanConfig, dbscan_brute_force};
pub use expansion::{Expansion, expansion};
pub use features::cluster_features;
pub use stats::{ClusterStats, cluster_stats};
