//! Any text as a window log's lines: the header and the windows parse or are refused,
//! a header that parses goes through the daemon's own configuration checks, and a
//! window's attitude samples through the replay's check of them, never a panic.
#![no_main]

use faithd_core::attitude::AttitudeUsed;
use faithd_formats::window_log::{RecordedWindow, WindowLogHeader};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let mut lines = text.lines();
    if let Some(Ok(header)) = lines.next().map(serde_json::from_str::<WindowLogHeader>) {
        if let Ok(pipeline) = header.pipeline_as_run() {
            let _ = pipeline.validate();
        }
    }
    for line in lines.take(1000) {
        if let Ok(window) = serde_json::from_str::<RecordedWindow>(line) {
            let _ = window.attitude.as_ref().map(AttitudeUsed::impossible);
        }
    }
});
