//! Any bytes given to the aedat3 reader give events or an error, never a panic or an
//! unbounded allocation.
#![no_main]

use faithd_formats::events::{Format, open_reader, read_all};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(mut reader) = open_reader(std::io::Cursor::new(data.to_vec()), Format::Aedat3) {
        let _ = read_all(&mut *reader);
    }
});
