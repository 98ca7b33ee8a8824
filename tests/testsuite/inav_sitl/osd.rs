//! faithd's state in the pilot's goggles, on iNav's own firmware: the committed OSD
//! script (hil/inav/osd.cli) applied after faithd's, faithd writing its three global
//! variables, and the variables read back from iNav (MSP2_INAV_GVAR_STATUS on a port
//! of the test's own) through each state the pilot can see.

use std::time::Duration;

use super::{Bench, Link, manoeuvres};
use crate::common::sitl::*;
use crate::require_sitl;

/// faithd's variables with `[osd] first_gvar = 5`.
const GATE: usize = 5;
const ROLL: usize = 6;
const TTC: usize = 7;

/// iNav's global variables as the monitor read them back: (Unix us, values).
fn gvars(bench: &Bench, from_us: i64, to_us: i64) -> Vec<(i64, [i32; 8])> {
    bench
        .monitor
        .between(from_us, to_us)
        .iter()
        .filter_map(|s| s.gvars.map(|g| (s.t_us, g)))
        .collect()
}

/// Every state the pilot can see, read back from iNav's own variables: MANUAL (2),
/// open (1), a roll to one side with the obstacle's time to contact, MANUAL again,
/// and iNav's failsafe (4). The committed OSD script is taken by iNav as it is
/// (`cli_save` fails on a line iNav refuses).
#[test]
fn the_goggles_show_each_state_of_faithd() {
    require_sitl!();
    let bench = Bench::with(Link::Msp, &[OSD_CLI], &[]);
    bench.radio.set(CH_SWITCH, MANUAL_US);
    let mut daemon = bench.faithd(3_000_000, "[osd]\nenabled = true\n");
    let wait = |what: &str, pred: &dyn Fn(&[i32; 8]) -> bool| {
        let from = unix_us();
        bench
            .monitor
            .wait_until(Duration::from_secs(6), |s| {
                s.t_us >= from && s.gvars.is_some_and(|g| pred(&g))
            })
            .map(|s| s.t_us)
            .unwrap_or_else(|| panic!("the goggles never showed {what}:\n{}", daemon.log()))
    };
    wait("MANUAL (gate 2)", &|v| v[GATE] == 2 && v[ROLL] == 0);
    let auto = bench.radio.set(CH_SWITCH, AUTO_US);
    let open = wait("the gate open (1)", &|v| v[GATE] == 1);
    let rolling = wait("a roll with its time to contact", &|v| {
        v[ROLL] != 0 && v[TTC] > 0
    });
    let manual = bench.radio.set(CH_SWITCH, MANUAL_US);
    let closed = wait("MANUAL again (gate 2, no roll)", &|v| {
        v[GATE] == 2 && v[ROLL] == 0
    });
    bench.radio.set(CH_SWITCH, AUTO_US);
    wait("the gate open again", &|v| v[GATE] == 1);
    let lost = unix_us();
    bench.radio.transmit(false);
    let failsafe = wait("iNav's failsafe (gate 4)", &|v| v[GATE] == 4);
    // A stopped faithd leaves nothing on the goggles: the gate's variable back to 0.
    let stopped = unix_us();
    assert!(daemon.stop().success(), "{}", daemon.log());
    let log = daemon.log();
    let cleared = bench
        .monitor
        .wait_until(Duration::from_secs(2), |s| {
            s.t_us >= stopped && s.gvars.is_some_and(|g| g[GATE] == 0)
        })
        .unwrap_or_else(|| panic!("the gate's variable not cleared on SIGTERM:\n{log}"))
        .t_us;
    let m = manoeuvres(&log);
    assert!(!m.is_empty(), "{log}");
    let shown = gvars(&bench, m[0].start_us, m[0].start_us + 1_000_000);
    let side = if m[0].roll_us > 1500 { 1 } else { -1 };
    assert!(
        shown.iter().any(|(_, v)| v[ROLL] == side),
        "the roll shown is the side commanded ({side}): {shown:?}"
    );
    eprintln!(
        "measured (goggles): open {:.0} ms after AUTO, a roll shown {:.0} ms after the manoeuvre started, MANUAL shown {:.0} ms after the switch, failsafe shown {:.0} ms after the radio stopped, cleared {:.0} ms after SIGTERM",
        (open - auto) as f64 / 1000.0,
        (rolling - m[0].start_us) as f64 / 1000.0,
        (closed - manual) as f64 / 1000.0,
        (failsafe - lost) as f64 / 1000.0,
        (cleared - stopped) as f64 / 1000.0
    );
}
