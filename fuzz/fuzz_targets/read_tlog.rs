//! Any bytes as a .tlog: records or an error, never a panic or a runaway allocation.
#![no_main]

use faithd_formats::tlog::TlogReader;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut reader = TlogReader::new(data);
    for _ in 0..100_000 {
        match reader.next_record() {
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => break,
        }
    }
});
