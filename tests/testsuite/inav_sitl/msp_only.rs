//! The MSP-only link on iNav's own firmware: no MAVLink at all, faithd reading iNav
//! over a second MSP port (hil/inav/faithd-msp.cli, `[telemetry] kind = "msp"`), as
//! on the F411 and F722 boards whose iNav 10 has no MAVLink. The route tests of the
//! MAVLink link run unchanged on it; the traffic on each port is read off the wire.

use std::time::Duration;

use super::{
    Bench, Link, manoeuvres, route_beside_the_pilots_radio, stops_and_a_kill_give_roll_back,
};
use crate::common::sitl::*;
use crate::common::wiretap::Wiretap;
use crate::require_sitl;

fn bench(extra: &[&str]) -> Bench {
    Bench::with(Link::Msp, &[], extra)
}

#[test]
fn the_roll_route_works_beside_the_pilots_radio() {
    require_sitl!();
    route_beside_the_pilots_radio(&bench(&[]));
}

#[test]
fn every_stop_and_a_restart_after_a_kill_give_roll_back() {
    require_sitl!();
    stops_and_a_kill_give_roll_back(&bench(&[]));
}

/// iNav serves one command per port every 10 ms: faithd asks at most half of that on
/// each of its two ports, one request at a time, through a roll and its release.
#[test]
fn each_port_carries_at_most_half_of_what_inav_serves() {
    require_sitl!();
    let bench = bench(&[]);
    bench.radio.set(CH_SWITCH, AUTO_US);
    let telemetry = Wiretap::to(bench.sitl.port(UART_MAVLINK));
    let command = Wiretap::to(bench.sitl.port(UART_MSP_FAITHD));
    let mut daemon = bench.faithd_on(&telemetry.endpoint, &command.endpoint, 2_000_000, "");
    assert!(
        daemon.wait_for_log("manoeuvre completed", Duration::from_secs(10)),
        "{}",
        daemon.log()
    );
    std::thread::sleep(Duration::from_millis(500));
    let log = daemon.log();
    assert!(daemon.stop().success(), "{log}");
    assert_eq!(manoeuvres(&log).len(), 1, "{log}");
    for (port, tap) in [
        ("telemetry (UART3)", &telemetry),
        ("command (UART4)", &command),
    ] {
        let requests = tap.requests();
        let span_s = (requests.last().unwrap().t_us - requests[0].t_us) as f64 / 1e6;
        let (most_per_s, most_waiting) = tap.busiest();
        let mut by_command = std::collections::BTreeMap::<u16, usize>::new();
        for r in &requests {
            *by_command.entry(r.command).or_default() += 1;
        }
        let per_s: Vec<String> = by_command
            .iter()
            .map(|(c, n)| format!("{c:#06x}: {:.1}/s", *n as f64 / span_s))
            .collect();
        eprintln!(
            "measured ({port}): {} requests in {span_s:.1} s, {:.1} a second on average, at most {most_per_s} in any second, at most {most_waiting} waiting; {}",
            requests.len(),
            requests.len() as f64 / span_s,
            per_s.join(", ")
        );
        // A slot every 20 ms; a frame's time on the wire moves its arrival by a
        // fraction of a millisecond, so one second can hold 51.
        assert!(
            most_per_s <= 51,
            "{port}: {most_per_s} requests in a second"
        );
        assert_eq!(most_waiting, 1, "{port}: one request outstanding at a time");
        assert!(
            requests.len() as f64 / span_s > 40.0,
            "{port}: the port is used"
        );
    }
}

/// Over MSP iNav says nothing of its receiver before its failsafe: the gate closes
/// when iNav's FAILSAFE mode comes on, and nothing is commanded during it.
#[test]
fn inavs_failsafe_closes_the_gate() {
    require_sitl!();
    super::radio_lost_mid_flight(&bench(&[]));
}

/// `faithd check-fc` over MSP alone: the set-up passes without a MAVLink setting
/// judged, and a telemetry UART without MSP is named with the line that fixes it.
#[test]
fn check_fc_passes_over_msp_alone_and_names_a_silent_telemetry_port() {
    require_sitl!();
    // With faithd's two MSP ports, SITL's UART2 gives up MSP (iNav allows three).
    let sitl = Sitl::with_scripts(
        &[FAITHD_MSP_CLI],
        &["serial 1 0 115200 115200 115200 115200"],
    );
    let toml = format!(
        "[telemetry]\nkind = \"msp\"\nendpoint = \"{}\"\n",
        sitl.endpoint(UART_MAVLINK)
    );
    let (code, out) = super::check_fc_with(&sitl, &toml);
    assert_eq!(code, 0, "{out}");
    assert!(out.contains("ok    telemetry: read over MSP"), "{out}");
    assert!(
        out.contains("ok    telemetry port: iNav answers MSP"),
        "{out}"
    );
    assert!(!out.contains("MAVLink"), "{out}");
    // UART3 back to no function: nothing answers there.
    sitl.cli_save(&["serial 2 0 115200 115200 115200 115200".to_string()]);
    let (code, out) = super::check_fc_with(&sitl, &toml);
    assert_eq!(code, 2, "{out}");
    let fail = out
        .lines()
        .position(|l| l.starts_with("FAIL  telemetry port"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        out.lines()
            .nth(fail + 1)
            .unwrap_or("")
            .contains("serial N 1 115200"),
        "{out}"
    );
}
