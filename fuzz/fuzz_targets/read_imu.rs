//! Any bytes as a dataset's imu.txt: samples or an error naming the line, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = faithd::replay::imu_samples(data, "imu.txt");
});
