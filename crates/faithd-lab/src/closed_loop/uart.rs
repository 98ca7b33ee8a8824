//! A UART between faithd and the simulated iNav, inside the process: two byte
//! streams joined by a pump that takes as long as the wire would. Each chunk leaves
//! once the line is free and its bytes (ten bits each: start, eight data, stop) have
//! been clocked out at the baud rate; the pump runs in the simulation's time, so a
//! MAVLink frame arrives 3.5 ms after it was written at 115200 baud, as on the drone
//! (4 ms: tokio's timers, the daemon's included, fire on whole milliseconds).

use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream, ReadHalf, WriteHalf};

/// Bytes either side may have in flight before a writer waits (a UART driver's
/// buffer).
const BUFFER_BYTES: usize = 16 * 1024;

/// A UART at `baud`: returns faithd's end and the device's end.
pub fn pair(baud: u32) -> (DuplexStream, DuplexStream) {
    let (faithd, faithd_inner) = tokio::io::duplex(BUFFER_BYTES);
    let (device, device_inner) = tokio::io::duplex(BUFFER_BYTES);
    let (from_faithd, to_faithd) = tokio::io::split(faithd_inner);
    let (from_device, to_device) = tokio::io::split(device_inner);
    tokio::spawn(pump(from_faithd, to_device, baud));
    tokio::spawn(pump(from_device, to_faithd, baud));
    (faithd, device)
}

/// Time to clock `bytes` out at `baud`.
pub fn wire_time(bytes: usize, baud: u32) -> Duration {
    Duration::from_nanos(bytes as u64 * 10 * 1_000_000_000 / u64::from(baud.max(1)))
}

/// Moves bytes one way, each chunk delayed by its time on the wire; when either
/// side hangs up, the other end reads the end of the stream.
async fn pump(mut from: ReadHalf<DuplexStream>, mut to: WriteHalf<DuplexStream>, baud: u32) {
    let mut buf = vec![0u8; 4096];
    let mut line_free = tokio::time::Instant::now();
    loop {
        let n = match from.read(&mut buf).await {
            Ok(0) | Err(_) => break,
            Ok(n) => n,
        };
        let start = line_free.max(tokio::time::Instant::now());
        line_free = start + wire_time(n, baud);
        tokio::time::sleep_until(line_free).await;
        if to.write_all(&buf[..n]).await.is_err() {
            break;
        }
    }
    let _ = to.shutdown().await;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn bytes_arrive_after_their_time_on_the_wire() {
        let (mut faithd, mut device) = pair(115_200);
        let t0 = tokio::time::Instant::now();
        faithd.write_all(&[0x55; 40]).await.unwrap();
        let mut got = [0u8; 40];
        device.read_exact(&mut got).await.unwrap();
        let took = t0.elapsed();
        // 40 bytes x 10 bits / 115200 baud = 3.47 ms, and tokio's timers (the
        // daemon's as much as this one's) fire on whole milliseconds.
        assert!((3.47..3.48).contains(&(wire_time(40, 115_200).as_secs_f64() * 1e3)));
        assert_eq!(took, Duration::from_millis(4));
        // And back the other way.
        device.write_all(b"reply").await.unwrap();
        let mut back = [0u8; 5];
        faithd.read_exact(&mut back).await.unwrap();
        assert_eq!(&back, b"reply");
    }

    #[tokio::test(start_paused = true)]
    async fn a_busy_line_queues_what_follows() {
        let (mut faithd, mut device) = pair(115_200);
        let t0 = tokio::time::Instant::now();
        faithd.write_all(&[1; 100]).await.unwrap();
        faithd.write_all(&[2; 100]).await.unwrap();
        let mut got = vec![0u8; 200];
        device.read_exact(&mut got).await.unwrap();
        assert!(t0.elapsed() >= wire_time(200, 115_200));
        assert_eq!(&got[..100], &[1; 100]);
        assert_eq!(&got[100..], &[2; 100]);
    }

    #[tokio::test(start_paused = true)]
    async fn hanging_up_one_end_ends_the_other() {
        let (faithd, mut device) = pair(115_200);
        drop(faithd);
        let mut buf = [0u8; 8];
        let n = tokio::time::timeout(Duration::from_secs(1), device.read(&mut buf))
            .await
            .expect("the device sees the end")
            .unwrap();
        assert_eq!(n, 0);
    }
}
