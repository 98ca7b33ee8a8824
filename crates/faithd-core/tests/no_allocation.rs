//! Once warmed up, a window allocates nothing: the pipeline owns every buffer it
//! needs, so a steady stream never waits on the allocator (whose time is not
//! bounded) and never fragments a board's memory over a long flight.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use faithd_core::attitude::AttitudeSample;
use faithd_core::camera::CameraIntrinsics;
use faithd_core::pipeline::{NoClock, Pipeline, PipelineConfig};
use faithd_core::synth::{LoomingEdges, looming_edge_events_seen_by};

/// Counts allocations (and reallocations) while `COUNTING` is set.
struct Counting;

static COUNTING: AtomicBool = AtomicBool::new(false);
/// The counter is the process's: one test counts at a time.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// A global allocator is an `unsafe` trait by Rust's design: the only way to count
// what the pipeline asks of the allocator. It forwards every call to System.
#[allow(unsafe_code)]
// SAFETY: every method forwards to System with the caller's arguments unchanged, so
// System's guarantees are this allocator's.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: the layout comes from the caller, as for System itself.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by System with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
        // SAFETY: as for `dealloc`; System handles the new size.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn a_warmed_up_pipeline_allocates_nothing_per_window() {
    let _alone = one_at_a_time();
    let per_window = run_counted(CameraIntrinsics::dvs240(), PipelineConfig::default());
    // The pole looms: counted windows hold more vectors than any of the warm-up (2,651
    // against 2,071), so buffers sized by the number of points must already be sized
    // for them (`Dbscan::with_capacity`), not merely grown to what came before.
    assert_looming_and_allocation_free(&per_window);
}

/// A DVXplorer's 640 x 480 surfaces, and windows over the event cap: the events they
/// keep go to a buffer sized for the cap up front.
#[test]
fn a_dvxplorer_pipeline_over_its_event_cap_allocates_nothing_per_window() {
    let _alone = one_at_a_time();
    let cam = CameraIntrinsics::dvxplorer();
    let mut config = PipelineConfig {
        camera: cam,
        ..PipelineConfig::default()
    };
    config.flow.max_events_per_window = 6_000;
    let (per_window, _) = run_counted(cam, config);
    assert!(
        per_window.iter().all(|w| w.3 > 0 && w.1 > 300),
        "every counted window over the cap, with vectors: {per_window:?}"
    );
    let allocating: Vec<_> = per_window.iter().filter(|w| w.2 > 0).collect();
    assert!(
        allocating.is_empty(),
        "windows that allocated (t_us, vectors, allocations, skipped): {allocating:?}"
    );
}

/// Allocations anywhere in the process count, a failing test's message too: each
/// test holds this from start to end.
fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

/// Windows 31 to 90 of the looming pole seen by `cam`: (t_us, vectors, allocations,
/// events skipped), after the first 30 windows warmed the buffers up; and the most
/// vectors a warm-up window held.
fn run_counted(
    cam: CameraIntrinsics,
    config: PipelineConfig,
) -> (Vec<(i64, usize, usize, u64)>, usize) {
    let mut scene = LoomingEdges::pole_ahead((130.0, 85.0));
    scene.noise_rate_hz = 0.5;
    scene.jitter_us = 50.0;
    scene.duration_s = 0.9;
    let events = looming_edge_events_seen_by(&cam, &scene, 3);
    let attitude: Vec<AttitudeSample> = (0..=60)
        .map(|k| AttitudeSample {
            t_us: k * 20_000,
            roll_rad: 0.0,
            pitch_rad: 0.0,
            yaw_rad: 0.0,
            roll_rate_rad_s: 0.0,
            pitch_rate_rad_s: 0.0,
            yaw_rate_rad_s: 0.0,
        })
        .collect();
    let mut pipeline = Pipeline::new(config);
    let mut start = 0;
    let mut per_window = Vec::new();
    let mut warm_up_vectors = 0;
    for k in 1..=90 {
        let end_us = k * 10_000;
        let stop = start + faithd_core::window::events_until(&events[start..], end_us);
        // The first 30 windows warm the buffers up (the history fills, FAITH's and
        // DBSCAN's scratch reach their sizes); the last 60 are counted.
        ALLOCATIONS.store(0, Ordering::Relaxed);
        COUNTING.store(k > 30, Ordering::Relaxed);
        let report = pipeline.process_window(&events[start..stop], &attitude, end_us, &mut NoClock);
        let vectors = report.vectors.len();
        let skipped = report.flow_stats.skipped;
        COUNTING.store(false, Ordering::Relaxed);
        if k > 30 {
            per_window.push((
                end_us,
                vectors,
                ALLOCATIONS.load(Ordering::Relaxed),
                skipped,
            ));
        } else {
            warm_up_vectors = warm_up_vectors.max(vectors);
        }
        start = stop;
    }
    (per_window, warm_up_vectors)
}

fn assert_looming_and_allocation_free(
    (per_window, warm_up_vectors): &(Vec<(i64, usize, usize, u64)>, usize),
) {
    assert!(
        per_window.iter().all(|&(_, v, _, _)| v > 500),
        "{per_window:?}"
    );
    assert!(
        per_window
            .iter()
            .any(|&(_, v, _, _)| v > warm_up_vectors + 100),
        "warm-up up to {warm_up_vectors} vectors: {per_window:?}"
    );
    let allocating: Vec<_> = per_window.iter().filter(|w| w.2 > 0).collect();
    assert!(
        allocating.is_empty(),
        "windows that allocated (t_us, vectors, allocations, skipped): {allocating:?}"
    );
}
