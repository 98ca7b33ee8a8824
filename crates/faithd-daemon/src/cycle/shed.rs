//! Load shedding: a cycle that overran its budget makes the next ones cheaper.
//!
//! Each level halves the plane fits per window, the flow vectors per decision and
//! FAITH's RANSAC iterations, down to floors that still give a usable FOE. Only once
//! all three are at their floors do further levels halve the events per window that
//! reach the flow (down to their own floor): leaving events out costs the FOE most
//! (docs/tuning.md), and a stream that sheds within the first levels, a DVS240's at
//! the Atom's factor, keeps every event as it did before there was an event cap. A
//! calm second (cycles under half the budget, so that the level above would still
//! fit) climbs back one level. Pure.

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
    /// The first level at which the fits, vectors and iterations are all at their
    /// floors: the events are halved only beyond it.
    events_from_level: u32,
    level: u32,
    calm: u32,
    /// Cycles that overran their budget since start.
    pub overruns: u64,
}

impl Shedder {
    /// Sheds from the `full` load (level 0) down to the floors in `min`.
    pub fn new(full: Load, min: Load) -> Self {
        let mut shedder = Self {
            full: Load { level: 0, ..full },
            min_vectors: min.max_vectors.min(full.max_vectors),
            min_iterations: min.iterations.min(full.iterations),
            min_fits: min.max_fits.min(full.max_fits),
            min_events: min.max_events.min(full.max_events),
            events_from_level: 0,
            level: 0,
            calm: 0,
            overruns: 0,
        };
        while !shedder.others_at_floor(shedder.events_from_level) {
            shedder.events_from_level += 1;
        }
        shedder
    }

    pub fn load(&self) -> Load {
        let k = self.level;
        // A shift of 64 or more would overflow; every limit is at its floor by then.
        let halve = |full: usize, k: u32| full.checked_shr(k).unwrap_or(0);
        Load {
            level: k,
            max_vectors: halve(self.full.max_vectors, k).max(self.min_vectors),
            iterations: self
                .full
                .iterations
                .checked_shr(k)
                .unwrap_or(0)
                .max(self.min_iterations),
            max_fits: halve(self.full.max_fits, k).max(self.min_fits),
            max_events: halve(
                self.full.max_events,
                k.saturating_sub(self.events_from_level),
            )
            .max(self.min_events),
        }
    }

    /// Whether at `level` the fits, vectors and iterations are all at their floors.
    fn others_at_floor(&self, level: u32) -> bool {
        let (full, k) = (&self.full, level);
        full.max_vectors.checked_shr(k).unwrap_or(0) <= self.min_vectors
            && full.iterations.checked_shr(k).unwrap_or(0) <= self.min_iterations
            && full.max_fits.checked_shr(k).unwrap_or(0) <= self.min_fits
    }

    fn at_floor(&self) -> bool {
        self.others_at_floor(self.level) && self.load().max_events == self.min_events
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
            max_events: 200_000,
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
        // The fits, vectors and iterations at their floors: now the events.
        assert_eq!(s.observe(12_000, 8_000).unwrap(), load(4, 300, 13, 250));
        let events = |s: &mut Shedder| s.observe(12_000, 8_000).unwrap().max_events;
        assert_eq!(events(&mut s), 100_000);
        assert_eq!(events(&mut s), 50_000);
        assert_eq!(events(&mut s), 30_000);
        assert_eq!(s.load().level, 7);
        assert_eq!(s.observe(12_000, 8_000), None, "at the floor");
        assert_eq!(s.overruns, 8);
        for _ in 0..CALM_CYCLES - 1 {
            assert_eq!(s.observe(3_900, 8_000), None);
        }
        let back = s.observe(3_900, 8_000).unwrap();
        assert_eq!((back.level, back.max_events), (6, 50_000));
        // A busy-but-within-budget cycle interrupts the calm streak.
        s.observe(5_000, 8_000);
        assert_eq!(s.load().level, 6);
        for level in [5, 4, 3] {
            for _ in 0..CALM_CYCLES - 1 {
                assert_eq!(s.observe(1_000, 8_000), None);
            }
            assert_eq!(s.observe(1_000, 8_000).unwrap().level, level);
        }
        assert_eq!(s.load(), load(3, 375, 13, 250));
    }
}
