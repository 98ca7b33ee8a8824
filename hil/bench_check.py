#!/usr/bin/env python3
"""faithd bench check: link, rates, switch test and one timed test roll, props off.

Talks to the flight controller with pymavlink (an implementation independent of
faithd's), so a problem it finds is in the wiring or the iNav setup, not in faithd.
"""

import argparse
import json
import os
import sys
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402


def rates(conn, seconds):
    counts = {"HEARTBEAT": 0, "ATTITUDE": 0, "RC_CHANNELS": 0}
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        msg = conn.recv_match(type=list(counts), blocking=True, timeout=0.2)
        if msg is not None and msg.get_srcSystem() == conn.target_system:
            counts[msg.get_type()] += 1
    return {k: v / seconds for k, v in counts.items()}


def channel(msg, n):
    return getattr(msg, f"chan{n}_raw")


def wait_switch(conn, ch, want_auto, lo, hi, timeout):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        msg = conn.recv_match(type="RC_CHANNELS", blocking=True, timeout=0.5)
        if msg is None:
            continue
        v = channel(msg, ch)
        if (lo <= v <= hi) == want_auto:
            return v
    return None


def msp_set_raw_rc(port, channels):
    payload = b"".join(int(v).to_bytes(2, "little") for v in channels)
    body = bytes([0]) + (200).to_bytes(2, "little") + len(payload).to_bytes(2, "little") + payload
    crc = 0
    for b in body:
        crc ^= b
        for _ in range(8):
            crc = ((crc << 1) ^ 0xD5) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
    port.write(b"$X<" + body + bytes([crc]))


def test_roll(conn, args, msp):
    """Sends one roll for args.roll_s, then the release; measures the echo."""
    value = 1500 + args.deflection_us
    sent_at = None
    echo_at = None
    echo_end = None
    release_at = None
    centred_at = None
    period = 0.02
    start = time.monotonic()
    next_send = start
    while time.monotonic() - start < args.roll_s + 1.5:
        now = time.monotonic()
        rolling = now - start < args.roll_s
        if now >= next_send and (rolling or release_at is None or now - release_at < 0.1):
            out = value if rolling else 1500
            if msp is not None:
                chans = [1500] * max(8, args.roll_channel)
                chans[args.roll_channel - 1] = out
                msp_set_raw_rc(msp, chans)
            else:
                chans = [65535] * 18
                chans[args.roll_channel - 1] = out if rolling else args.release_us
                conn.mav.rc_channels_override_send(conn.target_system, 1, *chans)
            if rolling and sent_at is None:
                sent_at = now
            if not rolling and release_at is None:
                release_at = now
            next_send += period
        msg = conn.recv_match(type="RC_CHANNELS", blocking=True, timeout=0.005)
        if msg is None:
            continue
        v = channel(msg, args.roll_channel)
        t = time.monotonic()
        if echo_at is None and abs(v - value) <= 10:
            echo_at = t
        if echo_at is not None and echo_end is None and abs(v - value) > 10:
            echo_end = t
        if release_at is not None and centred_at is None and abs(v - 1500) <= 10:
            centred_at = t
    return {
        "roll_value_us": value,
        "echo_seen": echo_at is not None,
        "echo_delay_ms": None if echo_at is None else 1e3 * (echo_at - sent_at),
        "echo_held_s": None if echo_at is None or echo_end is None else echo_end - echo_at,
        "centred_after_release_ms": None if centred_at is None else 1e3 * (centred_at - release_at),
    }


def main():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--device", required=True)
    p.add_argument("--baud", type=int, default=115200)
    p.add_argument("--switch-channel", type=int, default=6)
    p.add_argument("--auto-min-us", type=int, default=1700)
    p.add_argument("--auto-max-us", type=int, default=2100)
    p.add_argument("--roll-channel", type=int, default=1)
    p.add_argument("--deflection-us", type=int, default=300)
    p.add_argument("--release-us", type=int, default=1500)
    p.add_argument("--roll-s", type=float, default=1.5)
    p.add_argument("--msp-device")
    p.add_argument("--non-interactive", action="store_true",
                   help="skip the prompts (switch test is then read, not guided)")
    p.add_argument("--report", default="hil-report.json")
    args = p.parse_args()

    conn = mavutil.mavlink_connection(args.device, baud=args.baud, source_system=1,
                                      source_component=191)
    report = {"device": args.device}
    print("waiting for the flight controller's HEARTBEAT ...")
    hb = conn.wait_heartbeat(timeout=10)
    if hb is None:
        print("FAIL: no HEARTBEAT in 10 s: check wiring, baud and the port's MAVLink function")
        report["heartbeat"] = False
        json.dump(report, open(args.report, "w"), indent=2)
        return 1
    report["heartbeat"] = True
    report["rates_hz"] = rates(conn, 5.0)
    print("rates (Hz):", report["rates_hz"])
    ok_rates = report["rates_hz"]["ATTITUDE"] >= 40 and report["rates_hz"]["RC_CHANNELS"] >= 5
    report["rates_ok"] = ok_rates
    if not ok_rates:
        print("WARN: set mavlink_extra1_rate = 50 and mavlink_rc_chan_rate = 10 in iNav")

    lo, hi = args.auto_min_us, args.auto_max_us
    if not args.non_interactive:
        input("Put the switch in MANUAL, then press Enter ")
    report["manual_value_us"] = wait_switch(conn, args.switch_channel, False, lo, hi, 10)
    if not args.non_interactive:
        input("Put the switch in AUTO, then press Enter ")
    report["auto_value_us"] = wait_switch(conn, args.switch_channel, True, lo, hi, 10)
    report["switch_ok"] = None not in (report["manual_value_us"], report["auto_value_us"])
    print("switch:", report["manual_value_us"], "(MANUAL) /", report["auto_value_us"], "(AUTO)")

    if not args.non_interactive:
        input("PROPS OFF? Press Enter to send one test roll ")
    msp = None
    if args.msp_device:
        import serial  # pyserial, a pymavlink dependency
        msp = serial.Serial(args.msp_device, args.baud)
    report["test_roll"] = test_roll(conn, args, msp)
    print("test roll:", report["test_roll"])
    with open(args.report, "w") as f:
        json.dump(report, f, indent=2)
    print("report written to", args.report)
    return 0 if report["switch_ok"] and report["test_roll"]["echo_seen"] else 1


if __name__ == "__main__":
    sys.exit(main())
