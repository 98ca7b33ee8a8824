//! Clustering features shaped like the pipeline's (x, y in 0..1, TTC z-score), from a
//! fixed generator: the cluster benchmark times DBSCAN on them and the unit tests
//! check its labels against the brute-force reference on the same shapes.

/// `n` points: a pole (narrow, tall, low TTC), a closer box, a far wall band and a
/// sparse background with a long tail of TTC, mixed in index order as the pipeline's
/// history mixes them. The same `seed` gives the same points.
pub fn pipeline_shaped_features(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut s = seed;
    let mut rnd = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|k| match k % 10 {
            // Pole: 8 % of the width, the whole height, TTC z about -1.6.
            0..=2 => [0.48 + 0.08 * rnd(), rnd(), -1.6 + 0.25 * rnd()],
            // A closer box low in the view.
            3 => [0.15 + 0.2 * rnd(), 0.6 + 0.3 * rnd(), -2.4 + 0.3 * rnd()],
            // The far wall: everywhere, TTC spread about the mean.
            4..=7 => [rnd(), rnd(), 0.2 + 0.9 * rnd()],
            // Background: anything, long tail of TTC.
            _ => [rnd(), rnd(), -3.0 + 9.0 * rnd() * rnd()],
        })
        .collect()
}
