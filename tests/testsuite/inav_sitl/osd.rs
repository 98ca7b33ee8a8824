//! faithd's state in the pilot's goggles, on iNav's own firmware: the committed OSD
//! script (hil/inav/osd.cli) applied after faithd's, faithd writing its three global
//! variables, and the variables read back from iNav (MSP2_INAV_GVAR_STATUS on a port
//! of the test's own) through each state the pilot can see.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::{Bench, Link, manoeuvres};
use crate::common::sitl::*;
use crate::require_sitl;

/// MSP2_INAV_GVAR_STATUS: iNav's eight global variables, int32 each (fc/fc_msp.c).
const MSP2_INAV_GVAR_STATUS: u16 = 0x2027;
/// faithd's variables with `[osd] first_gvar = 5`.
const GATE: usize = 5;
const ROLL: usize = 6;
const TTC: usize = 7;

/// iNav's global variables read back every 50 ms: (Unix us, values).
struct GvarReader {
    seen: Arc<Mutex<Vec<(i64, [i32; 8])>>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl GvarReader {
    fn start(sitl: &Sitl) -> Self {
        let mut client = MspClient::connect(sitl.port(UART_CLI)).expect("UART1");
        let seen = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (seen, stop) = (seen.clone(), stop.clone());
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    if let Ok(reply) = client.request(MSP2_INAV_GVAR_STATUS, &[]) {
                        let mut values = [0i32; 8];
                        for (v, b) in values.iter_mut().zip(reply.chunks_exact(4)) {
                            *v = i32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                        }
                        seen.lock().unwrap().push((unix_us(), values));
                    }
                    std::thread::sleep(Duration::from_millis(50));
                }
            })
        };
        GvarReader {
            seen,
            stop,
            thread: Some(thread),
        }
    }

    /// Waits until iNav's variables satisfy `pred`; when they did.
    fn wait_for(&self, timeout: Duration, pred: impl Fn(&[i32; 8]) -> bool) -> Option<i64> {
        let from = unix_us();
        let deadline = std::time::Instant::now() + timeout;
        while std::time::Instant::now() < deadline {
            if let Some((t, _)) = self
                .seen
                .lock()
                .unwrap()
                .iter()
                .find(|(t, v)| *t >= from && pred(v))
            {
                return Some(*t);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        None
    }

    fn between(&self, from_us: i64, to_us: i64) -> Vec<[i32; 8]> {
        let seen = self.seen.lock().unwrap();
        seen.iter()
            .filter(|(t, _)| (from_us..=to_us).contains(t))
            .map(|(_, v)| *v)
            .collect()
    }
}

impl Drop for GvarReader {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Every state the pilot can see, read back from iNav's own variables: MANUAL (1),
/// open (0), a roll to one side with the obstacle's time to contact, MANUAL again,
/// and iNav's failsafe (3).
#[test]
fn the_goggles_show_each_state_of_faithd() {
    require_sitl!();
    let bench = Bench::with(Link::Msp, &[OSD_CLI], &[]);
    let gvars = GvarReader::start(&bench.sitl);
    bench.radio.set(CH_SWITCH, MANUAL_US);
    let mut daemon = bench.faithd(3_000_000, "[osd]\nenabled = true\n");
    let wait = |what: &str, pred: &dyn Fn(&[i32; 8]) -> bool| {
        gvars
            .wait_for(Duration::from_secs(6), pred)
            .unwrap_or_else(|| panic!("the goggles never showed {what}:\n{}", daemon.log()))
    };
    wait("MANUAL (gate 1)", &|v| v[GATE] == 1 && v[ROLL] == 0);
    let auto = bench.radio.set(CH_SWITCH, AUTO_US);
    let open = wait("the gate open (0)", &|v| v[GATE] == 0);
    let rolling = wait("a roll with its time to contact", &|v| {
        v[ROLL] != 0 && v[TTC] > 0
    });
    let manual = bench.radio.set(CH_SWITCH, MANUAL_US);
    let closed = wait("MANUAL again (gate 1, no roll)", &|v| {
        v[GATE] == 1 && v[ROLL] == 0
    });
    bench.radio.set(CH_SWITCH, AUTO_US);
    wait("the gate open again", &|v| v[GATE] == 0);
    let lost = unix_us();
    bench.radio.transmit(false);
    let failsafe = wait("iNav's failsafe (gate 3)", &|v| v[GATE] == 3);
    let log = daemon.log();
    assert!(daemon.stop().success(), "{log}");
    let m = manoeuvres(&log);
    assert!(!m.is_empty(), "{log}");
    let shown = gvars.between(m[0].start_us, m[0].start_us + 1_000_000);
    let side = if m[0].roll_us > 1500 { 1 } else { -1 };
    assert!(
        shown.iter().any(|v| v[ROLL] == side),
        "the roll shown is the side commanded ({side}): {shown:?}"
    );
    eprintln!(
        "measured (goggles): open {:.0} ms after AUTO, a roll shown {:.0} ms after the manoeuvre started, MANUAL shown {:.0} ms after the switch, failsafe shown {:.0} ms after the radio stopped",
        (open - auto) as f64 / 1000.0,
        (rolling - m[0].start_us) as f64 / 1000.0,
        (closed - manual) as f64 / 1000.0,
        (failsafe - lost) as f64 / 1000.0
    );
}
