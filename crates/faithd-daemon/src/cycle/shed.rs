//! Load shedding: a cycle that overran its budget makes the next ones cheaper.
//!
//! Each level halves the events per window that reach the flow, the plane fits per
//! window, the flow vectors per decision and FAITH's RANSAC iterations, down to
//! floors that still give a usable FOE. A calm
//! second (cycles under half the budget, so that the level above would still fit)
//! climbs back one level. Pure.

/// Cycles below half the budget in a row before one level is restored.
const CALM_CYCLES: u32 = 100;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Load {
    pub level: u32,
    pub max_vectors: usize,
    pub iterations: u32,
    pub max_fits: usize,
    pub max_events: usize,
}

#[derive(Clone, Debug)]
pub struct Shedder {
    full: Load,
    min_vectors: usize,
    min_iterations: u32,
    min_fits: usize,
    min_events: usize,
    level: u32,
    calm: u32,
    /// Cycles that overran their budget since start.
    pub overruns: u64,
}

impl Shedder {
    /// Sheds from the `full` load (level 0) down to the floors in `min`.
    pub fn new(full: Load, min: Load) -> Self {
        Self {
            full: Load { level: 0, ..full },
            min_vectors: min.max_vectors.min(full.max_vectors),
            min_iterations: min.iterations.min(full.iterations),
            min_fits: min.max_fits.min(full.max_fits),
            min_events: min.max_events.min(full.max_events),
            level: 0,
            calm: 0,
            overruns: 0,
        }
    }

    pub fn load(&self) -> Load {
        let k = self.level;
        Load {
            level: k,
            max_vectors: (self.full.max_vectors >> k).max(self.min_vectors),
            iterations: (self.full.iterations >> k).max(self.min_iterations),
            max_fits: (self.full.max_fits >> k).max(self.min_fits),
            max_events: (self.full.max_events >> k).max(self.min_events),
        }
    }

    fn at_floor(&self) -> bool {
        let l = self.load();
        l.max_vectors == self.min_vectors
            && l.iterations == self.min_iterations
            && l.max_fits == self.min_fits
            && l.max_events == self.min_events
    }

    /// Records one cycle; returns the new load when it changed.
    pub fn observe(&mut self, cycle_us: i64, budget_us: i64) -> Option<Load> {
        if cycle_us > budget_us {
            self.overruns += 1;
            self.calm = 0;
            if self.at_floor() {
                return None;
            }
            self.level += 1;
            return Some(self.load());
        }
        if cycle_us * 2 < budget_us && self.level > 0 {
            self.calm += 1;
            if self.calm >= CALM_CYCLES {
                self.calm = 0;
                self.level -= 1;
                return Some(self.load());
            }
        } else {
            self.calm = 0;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(level: u32, max_vectors: usize, iterations: u32, max_fits: usize) -> Load {
        Load {
            level,
            max_vectors,
            iterations,
            max_fits,
            max_events: (600_000 >> level).max(30_000),
        }
    }

    #[test]
    fn overruns_halve_down_to_the_floor_and_calm_restores() {
        let floor = Load {
            max_events: 30_000,
            ..load(0, 300, 13, 250)
        };
        let mut s = Shedder::new(load(0, 3000, 52, 2000), floor);
        assert_eq!(s.observe(12_000, 8_000).unwrap(), load(1, 1500, 26, 1000));
        assert_eq!(s.observe(12_000, 8_000).unwrap(), load(2, 750, 13, 500));
        assert_eq!(s.observe(12_000, 8_000).unwrap(), load(3, 375, 13, 250));
        assert_eq!(s.observe(12_000, 8_000).unwrap(), load(4, 300, 13, 250));
        assert_eq!(s.observe(12_000, 8_000).unwrap(), load(5, 300, 13, 250));
        assert_eq!(s.load().max_events, 30_000);
        assert_eq!(s.observe(12_000, 8_000), None, "at the floor");
        assert_eq!(s.overruns, 6);
        for _ in 0..CALM_CYCLES - 1 {
            assert_eq!(s.observe(3_900, 8_000), None);
        }
        assert_eq!(s.observe(3_900, 8_000).unwrap().level, 4);
        // A busy-but-within-budget cycle interrupts the calm streak.
        s.observe(5_000, 8_000);
        assert_eq!(s.load().level, 4);
        for _ in 0..CALM_CYCLES - 1 {
            assert_eq!(s.observe(1_000, 8_000), None);
        }
        assert_eq!(s.observe(1_000, 8_000).unwrap(), load(3, 375, 13, 250));
    }
}
