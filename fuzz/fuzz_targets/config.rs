//! Any text as faithd.toml: a configuration the daemon accepts, or the key and the
//! reason, never a panic.
#![no_main]

use faithd::config::FaithdConfig;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = FaithdConfig::parse(text);
    }
});
