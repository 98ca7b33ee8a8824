//! The sensor split into vertical tiles, one `Engine` each, run on as many threads.
//!
//! A tile processes the events in its columns (surface update and fit) and only marks
//! the surface with those in its halo, the columns within the fit radius of its own:
//! a fit reads the neighbourhood within that radius, so every fit a tile makes reads
//! exactly the times the one-surface flow would have read. Each tile keeps a full-size
//! surface whose owned and halo columns are current; the columns beyond are stale and
//! never read. Threads walk the whole window, each acting on its own tile's events in
//! order; their vectors carry the event's index and are merged back into event order,
//! and the counters are summed, so the output is the same to the bit as with one
//! surface. Below `parallel_min_events` events a window runs on the calling thread,
//! event by event, on the same tiles.
//!
//! The tile boundaries follow the events: before a window runs on threads they move
//! to where each tile gets an equal share of its events (when that lowers the largest
//! share by a tenth), and the columns a tile newly needs are copied in from the tile
//! that owned them.

use std::ops::Range;

use super::config::{FlowConfig, MAX_RADIUS_PX};
use super::engine::Engine;
use super::stats::FlowStats;
use super::vector::FlowVector;
use crate::event::Event;

/// The narrowest tile: wider than the largest halo, so that a column lies in the halo
/// of at most the tiles on either side of its owner.
const MIN_TILE_WIDTH_PX: usize = 2 * MAX_RADIUS_PX as usize + 1;

/// Events the split of a window's work looks at.
const BALANCE_SAMPLES: usize = 4_096;

/// Windows with at least this many events run on threads (when there is more than one
/// tile). Starting and joining a thread costs about 25 us on the development machine;
/// on the bench scenes cut into windows, two threads broke even at about 1000 events
/// per window and ran 1.2 times as fast at 1500, 1.35 at 2000 and 1.3 to 1.9 above
/// (both with and without the fit cap). A slower board pays more per event, so its
/// break-even is likely no higher.
pub(super) const DEFAULT_PARALLEL_MIN_EVENTS: usize = 2_048;

/// Who handles the events of one column.
#[derive(Clone, Copy, Debug, Default)]
struct Column {
    /// The tile that processes them.
    owner: u8,
    /// The tile left of the owner marks them too (the column is in its halo).
    left_marks: bool,
    /// The tile right of the owner marks them too.
    right_marks: bool,
}

impl Column {
    /// Whether tile `t` only marks this column's events.
    #[inline(always)]
    fn marked_by(self, t: usize) -> bool {
        let owner = usize::from(self.owner);
        (self.left_marks && t + 1 == owner) || (self.right_marks && t == owner + 1)
    }
}

struct Tile {
    engine: Engine,
    /// The columns whose events it processes.
    columns: Range<usize>,
    /// What it does with an event, by column (and one more for events beyond the
    /// sensor's right edge).
    roles: Vec<Role>,
    /// The events of the window being run that it handles, as `Entry` values (and
    /// more: it only grows).
    entries: Vec<u32>,
    /// Vectors of the last window run on threads, with their events' indices.
    found: Vec<(usize, FlowVector)>,
}

/// What a tile does with the events of a column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Skip,
    Process,
    Mark,
}

/// An entry of `Tile::entries`: the event's index in the window, with flags.
struct Entry;

impl Entry {
    const MARK: u32 = 1 << 31;
    const INDEX: u32 = Self::MARK - 1;
}

/// Windows run on threads have fewer events than this: their indices fit an `Entry`.
const MAX_THREADED_EVENTS: usize = Entry::INDEX as usize;

impl Tile {
    /// One window on this tile: its events processed (one in `fit_one_in` of those
    /// that mark their pixel fitted, see `chosen_for_fit`), its halo's marked, the
    /// others skipped.
    ///
    /// First the tile's events are listed, without a branch on whose they are (every
    /// event is written, only the tile's kept): the columns of consecutive events are
    /// random, and that branch was mispredicted about every other event.
    fn run(&mut self, events: &[Event], fit_one_in: u32, config: &FlowConfig) {
        debug_assert!(events.len() <= MAX_THREADED_EVENTS);
        if self.entries.len() < events.len() {
            self.entries.resize(events.len(), 0);
        }
        let (roles, entries) = (&self.roles[..], &mut self.entries[..]);
        let last = roles.len() - 1;
        let mut n = 0;
        for (i, e) in events.iter().enumerate() {
            let column = usize::from(e.x_px).min(last);
            let role = roles[column];
            entries[n] = i as u32 | (Entry::MARK * u32::from(role == Role::Mark));
            n += usize::from(role != Role::Skip);
        }
        self.found.clear();
        let engine = &mut self.engine;
        for &entry in &self.entries[..n] {
            let i = (entry & Entry::INDEX) as usize;
            let e = &events[i];
            if entry & Entry::MARK != 0 {
                engine.mark(e, config.refractory_us);
            } else if let Some(v) = engine.process_event(e, config, fit_one_in) {
                self.found.push((i, v));
            }
        }
    }
}

/// The tiles of a sensor and who handles each column.
pub(super) struct Tiles {
    width_px: usize,
    /// The fit radius: the halo's width.
    radius_px: usize,
    tiles: Vec<Tile>,
    /// Per column, and one more for events beyond the sensor's right edge (the last
    /// tile's, as a column past the sensor belongs to no halo).
    columns: Vec<Column>,
    pub parallel_min_events: usize,
    /// Work per column of the window being balanced.
    work: Vec<u64>,
}

impl Tiles {
    /// `threads` tiles of equal width (fewer on a sensor too narrow for them).
    pub fn new(width_px: u16, height_px: u16, radius_px: u16, threads: usize) -> Self {
        let width = usize::from(width_px);
        let count = threads.clamp(1, (width / MIN_TILE_WIDTH_PX).clamp(1, 255));
        let tiles = (0..count)
            .map(|t| Tile {
                engine: Engine::new(width_px, height_px),
                columns: t * width / count..(t + 1) * width / count,
                roles: vec![Role::Skip; width + 1],
                entries: Vec::new(),
                found: Vec::new(),
            })
            .collect();
        let mut tiles = Self {
            width_px: width,
            radius_px: usize::from(radius_px.min(MAX_RADIUS_PX)),
            tiles,
            columns: vec![Column::default(); width + 1],
            parallel_min_events: DEFAULT_PARALLEL_MIN_EVENTS,
            work: vec![0; width],
        };
        tiles.assign_columns();
        tiles
    }

    pub fn count(&self) -> usize {
        self.tiles.len()
    }

    /// The counters of every tile, summed and reset.
    pub fn take_stats(&mut self) -> FlowStats {
        let mut sum = FlowStats::default();
        for tile in &mut self.tiles {
            let s = std::mem::take(&mut tile.engine.stats);
            sum.events += s.events;
            sum.out_of_view += s.out_of_view;
            sum.refractory += s.refractory;
            sum.too_few_points += s.too_few_points;
            sum.bad_fit += s.bad_fit;
            sum.not_tight += s.not_tight;
            sum.speed_rejected += s.speed_rejected;
            sum.vectors += s.vectors;
            sum.not_fitted += s.not_fitted;
        }
        sum
    }

    pub fn clear(&mut self) {
        for tile in &mut self.tiles {
            tile.engine.surface.clear();
            tile.engine.stats = FlowStats::default();
        }
    }

    /// Fills `columns` and the tiles' roles from the tiles' column ranges.
    fn assign_columns(&mut self) {
        let r = self.radius_px;
        let count = self.tiles.len();
        for (t, tile) in self.tiles.iter().enumerate() {
            for c in tile.columns.clone() {
                self.columns[c] = Column {
                    owner: t as u8,
                    left_marks: t > 0 && c < tile.columns.start + r,
                    right_marks: t + 1 < count && c + r >= tile.columns.end,
                };
            }
        }
        self.columns[self.width_px] = Column {
            owner: (count - 1) as u8,
            left_marks: false,
            right_marks: false,
        };
        for (t, tile) in self.tiles.iter_mut().enumerate() {
            for (role, column) in tile.roles.iter_mut().zip(&self.columns) {
                *role = if usize::from(column.owner) == t {
                    Role::Process
                } else if column.marked_by(t) {
                    Role::Mark
                } else {
                    Role::Skip
                };
            }
        }
    }

    /// Processes one window, fitting one in `fit_one_in` of the events that mark their
    /// pixel (all with 1).
    pub fn run(
        &mut self,
        events: &[Event],
        fit_one_in: u32,
        config: &FlowConfig,
        out: &mut Vec<FlowVector>,
    ) {
        if self.tiles.len() == 1 {
            let engine = &mut self.tiles[0].engine;
            for e in events {
                if let Some(v) = engine.process_event(e, config, fit_one_in) {
                    out.push(v);
                }
            }
        } else if events.len() >= self.parallel_min_events && events.len() <= MAX_THREADED_EVENTS {
            self.balance(events);
            self.run_threads(events, fit_one_in, config, out);
        } else {
            for e in events {
                if let Some(v) = self.step(e, fit_one_in, config) {
                    out.push(v);
                }
            }
        }
    }

    /// Of every `stride`-th event of `events`, how many would mark their pixel on the
    /// surface as it stands (its owner tile's, so the same whatever the tiling), and
    /// how many were looked at.
    pub fn sample_would_mark(
        &self,
        events: &[Event],
        stride: usize,
        refractory_us: i64,
    ) -> (u64, u64) {
        let (mut passing, mut looked) = (0u64, 0u64);
        for e in events.iter().step_by(stride.max(1)) {
            let column = self.columns[usize::from(e.x_px).min(self.width_px)];
            let engine = &self.tiles[usize::from(column.owner)].engine;
            passing += u64::from(engine.would_mark(e, refractory_us));
            looked += 1;
        }
        (passing, looked)
    }

    /// Events that have marked their pixel (passed the refractory filter), summed over
    /// the tiles since their counters were last taken.
    pub fn marked(&self) -> u64 {
        self.tiles.iter().map(|t| t.engine.marked()).sum()
    }

    /// One event on the calling thread: its owner processes it, tiles whose halo holds
    /// it mark it.
    pub fn step(&mut self, e: &Event, fit_one_in: u32, config: &FlowConfig) -> Option<FlowVector> {
        let column = self.columns[usize::from(e.x_px).min(self.width_px)];
        let owner = usize::from(column.owner);
        if column.left_marks {
            self.tiles[owner - 1].engine.mark(e, config.refractory_us);
        }
        if column.right_marks {
            self.tiles[owner + 1].engine.mark(e, config.refractory_us);
        }
        self.tiles[owner]
            .engine
            .process_event(e, config, fit_one_in)
    }

    /// Each tile on its own thread (the first on the calling one), then the vectors
    /// merged back into event order.
    fn run_threads(
        &mut self,
        events: &[Event],
        fit_one_in: u32,
        config: &FlowConfig,
        out: &mut Vec<FlowVector>,
    ) {
        let (first, others) = self.tiles.split_first_mut().expect("at least one tile");
        // A thread the system refuses leaves its tile to the calling thread, after the
        // others: the tiles are independent, so the order does not matter.
        let mut refused = Vec::new();
        std::thread::scope(|scope| {
            for (t, tile) in others.iter_mut().enumerate() {
                let spawned = std::thread::Builder::new()
                    .name("faithd-flow".into())
                    .spawn_scoped(scope, move || tile.run(events, fit_one_in, config));
                if spawned.is_err() {
                    refused.push(t + 1);
                }
            }
            first.run(events, fit_one_in, config);
        });
        for t in refused {
            self.tiles[t].run(events, fit_one_in, config);
        }
        out.reserve(self.tiles.iter().map(|t| t.found.len()).sum());
        if let [a, b] = &self.tiles[..] {
            merge_two(&a.found, &b.found, out);
            return;
        }
        // A k-way merge on the event index; k is small.
        let mut heads = vec![0; self.tiles.len()];
        loop {
            let mut next: Option<(usize, usize)> = None;
            for (t, tile) in self.tiles.iter().enumerate() {
                if let Some(&(i, _)) = tile.found.get(heads[t])
                    && next.is_none_or(|(best, _)| i < best)
                {
                    next = Some((i, t));
                }
            }
            let Some((_, t)) = next else { break };
            out.push(self.tiles[t].found[heads[t]].1);
            heads[t] += 1;
        }
    }

    /// Moves the tile boundaries to where each tile gets an equal share of the work of
    /// `events`, if that lowers the largest share by at least a tenth.
    ///
    /// The work is estimated from at most `BALANCE_SAMPLES` events spread over the
    /// window, all weighing the same: the fitted events (chosen by a hash of each
    /// event) are spread evenly over the window too. Counting every event costs about
    /// as much as updating the surface with it; counting in the threads' own pass over
    /// the window made that pass twice as slow.
    fn balance(&mut self, events: &[Event]) {
        let step = events.len().div_ceil(BALANCE_SAMPLES).max(1);
        let mut work = std::mem::take(&mut self.work);
        work.fill(0);
        for e in events.iter().step_by(step) {
            if let Some(w) = work.get_mut(usize::from(e.x_px)) {
                *w += 1;
            }
        }
        self.split_work(&work);
        self.work = work;
    }

    /// Moves the boundaries to where each tile gets an equal share of `work` (per
    /// column), if that lowers the largest share by at least a tenth.
    fn split_work(&mut self, work: &[u64]) {
        let count = self.tiles.len();
        let total: u64 = work.iter().sum();
        if total == 0 {
            return;
        }
        // Boundary b (between tiles b - 1 and b) where the work to its left first
        // reaches b / count of the total, kept MIN_TILE_WIDTH_PX from its neighbours
        // and the sensor's edges.
        let mut starts = vec![0; count];
        let mut cumulative = 0;
        let mut b = 1;
        for (c, &w) in work.iter().enumerate() {
            if b == count {
                break;
            }
            cumulative += w;
            while b < count && cumulative * count as u64 >= total * b as u64 {
                starts[b] = c + 1;
                b += 1;
            }
        }
        starts[b..].fill(self.width_px);
        for b in 1..count {
            let lowest = starts[b - 1] + MIN_TILE_WIDTH_PX;
            let highest = self.width_px - (count - b) * MIN_TILE_WIDTH_PX;
            starts[b] = starts[b].clamp(lowest, highest);
        }
        let largest = |ranges: &mut dyn Iterator<Item = Range<usize>>| {
            ranges
                .map(|r| work[r].iter().sum::<u64>())
                .max()
                .unwrap_or(0)
        };
        let current = largest(&mut self.tiles.iter().map(|t| t.columns.clone()));
        let ranges: Vec<Range<usize>> = (0..count)
            .map(|t| starts[t]..starts.get(t + 1).copied().unwrap_or(self.width_px))
            .collect();
        let proposed = largest(&mut ranges.iter().cloned());
        if proposed * 10 <= current * 9 {
            self.move_boundaries(&ranges);
        }
    }

    /// Gives the tiles the column ranges `ranges`: each tile copies in the columns it
    /// now needs (owned or halo) from the tile that owned them until now, whose copy is
    /// current. A tile only writes columns it did not need, and only owned columns are
    /// read, so no copy reads what another wrote.
    fn move_boundaries(&mut self, ranges: &[Range<usize>]) {
        let r = self.radius_px;
        let width = self.width_px;
        let needed =
            |range: &Range<usize>| range.start.saturating_sub(r)..(range.end + r).min(width);
        let old_owner: Vec<usize> = self.columns[..width]
            .iter()
            .map(|c| usize::from(c.owner))
            .collect();
        for (t, range) in ranges.iter().enumerate() {
            let had = needed(&self.tiles[t].columns);
            for c in needed(range) {
                let source = old_owner[c];
                if had.contains(&c) || source == t {
                    continue;
                }
                let (target, from) = if t < source {
                    let (low, high) = self.tiles.split_at_mut(source);
                    (&mut low[t], &high[0])
                } else {
                    let (low, high) = self.tiles.split_at_mut(t);
                    (&mut high[0], &low[source])
                };
                target
                    .engine
                    .surface
                    .copy_column_from(&from.engine.surface, c);
            }
        }
        for (tile, range) in self.tiles.iter_mut().zip(ranges) {
            tile.columns = range.clone();
        }
        self.assign_columns();
    }
}

/// Appends two tiles' vectors in the order of their events' indices. Which tile the
/// next one comes from is random (the events' columns are), so it is chosen without a
/// branch: a mispredicted one per vector took most of the merge's time.
fn merge_two(a: &[(usize, FlowVector)], b: &[(usize, FlowVector)], out: &mut Vec<FlowVector>) {
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let ((ia, va), (ib, vb)) = (&a[i], &b[j]);
        let from_a = ia < ib;
        out.push(*if from_a { va } else { vb });
        i += usize::from(from_a);
        j += usize::from(!from_a);
    }
    out.extend(a[i..].iter().map(|p| p.1));
    out.extend(b[j..].iter().map(|p| p.1));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::CameraIntrinsics;
    use crate::flow::NormalFlow;
    use crate::synth::{LoomingEdges, looming_edge_events};

    /// The looming scene's events, in windows of 3000 seen only on the left quarter of
    /// the sensor, then only on its right quarter, then whole.
    fn shifting_windows() -> Vec<Vec<Event>> {
        let cam = CameraIntrinsics::dvs240();
        let mut scene = LoomingEdges::pole_ahead((120.0, 90.0));
        scene.noise_rate_hz = 1.0;
        let events = looming_edge_events(&cam, &scene, 4);
        let third = events.len() / 3;
        events
            .chunks(3_000)
            .enumerate()
            .map(|(k, w)| {
                w.iter()
                    .copied()
                    .filter(|e| match k * 3_000 / third {
                        0 => e.x_px < 60,
                        1 => e.x_px >= 180,
                        _ => true,
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn boundaries_follow_the_events_and_keep_the_vectors() {
        let cam = CameraIntrinsics::dvs240();
        let config = FlowConfig::default();
        let mut one = NormalFlow::new(&cam, config);
        let mut tiles = Tiles::new(cam.width_px, cam.height_px, config.radius_px, 2);
        tiles.parallel_min_events = 0;
        let (mut expected, mut got) = (Vec::new(), Vec::new());
        let mut boundaries = Vec::new();
        for window in shifting_windows() {
            one.process(&window, &mut expected);
            tiles.run(&window, 1, &config, &mut got);
            assert_eq!(one.take_stats(), tiles.take_stats());
            boundaries.push(tiles.tiles[1].columns.start);
        }
        assert_eq!(got, expected);
        // Left of the middle while the events are on the left, right of it after.
        let third = boundaries.len() / 3;
        assert!(
            boundaries[1..third].iter().all(|&b| b < 100),
            "{boundaries:?}"
        );
        assert!(
            boundaries[third + 1..2 * third].iter().all(|&b| b > 140),
            "{boundaries:?}"
        );
    }

    #[test]
    fn a_narrow_sensor_gets_fewer_tiles() {
        let tiles = Tiles::new(30, 20, 2, 4);
        assert_eq!(tiles.count(), 2);
        assert_eq!(Tiles::new(8, 8, 2, 2).count(), 1);
        assert_eq!(Tiles::new(240, 180, 2, 2).count(), 2);
    }
}
