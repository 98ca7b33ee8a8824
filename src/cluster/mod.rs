//! TEMPORARY compile stub; replaced by the real DBSCAN module.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DbscanConfig {
    pub eps: f64,
    pub min_points: usize,
}
impl Default for DbscanConfig {
    fn default() -> Self {
        Self {
            eps: 0.2,
            min_points: 20,
        }
    }
}
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ClusterStats {
    pub id: u32,
    pub count: usize,
    pub mean_ttc_s: f64,
    pub centroid_x_px: f64,
    pub centroid_y_px: f64,
    pub min_x_px: f64,
    pub max_x_px: f64,
    pub min_y_px: f64,
    pub max_y_px: f64,
}
pub struct Dbscan;
impl Dbscan {
    pub fn new(_c: DbscanConfig) -> Self {
        Dbscan
    }
    pub fn run(&mut self, p: &[[f64; 3]], l: &mut Vec<Option<u32>>) -> usize {
        l.clear();
        l.resize(p.len(), None);
        0
    }
}
pub fn cluster_features(_xy: &[(f64, f64)], _t: &[f64], _w: u16, _h: u16, out: &mut Vec<[f64; 3]>) {
    out.clear();
}
pub fn cluster_stats(
    _xy: &[(f64, f64)],
    _t: &[f64],
    _l: &[Option<u32>],
    out: &mut Vec<ClusterStats>,
) {
    out.clear();
}
