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


def open_msp(device, baud):
    """A serial device, or tcp:HOST:PORT (iNav SITL's UARTs are TCP listeners)."""
    if device.startswith("tcp:"):
        import socket
        host, port = device[4:].rsplit(":", 1)
        sock = socket.create_connection((host, int(port)))
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

        class Port:
            def write(self, data):
                sock.sendall(data)
        return Port()
    import serial  # pyserial, a pymavlink dependency
    return serial.Serial(device, baud)


def test_roll(conn, args, msp):
    """Streams MSP_SET_RAW_RC as faithd does: a frame every 40 ms (faithd's roll frame
    period; iNav's serial task serves one MSP command per port every 10 ms, and with its
    read-back requests faithd uses half of that), the centre for args.warmup_s (iNav
    applies MSP override only after 200 ms + failsafe_recovery_delay of fresh frames),
    one roll for args.roll_s, then the centre again; measures iNav's echo in
    RC_CHANNELS."""
    value = 1500 + args.deflection_us
    echo_at = None
    echo_end = None
    centred_at = None
    period = 0.04
    start = time.monotonic()
    roll_start = start + args.warmup_s
    roll_end = roll_start + args.roll_s
    next_send = start
    while time.monotonic() < roll_end + 1.5:
        now = time.monotonic()
        if now >= next_send:
            rolling = roll_start <= now < roll_end
            chans = [1500] * 4
            chans[args.roll_channel - 1] = value if rolling else 1500
            msp_set_raw_rc(msp, chans)
            next_send += period
        msg = conn.recv_match(type="RC_CHANNELS", blocking=True, timeout=0.005)
        if msg is None:
            continue
        v = channel(msg, args.roll_channel)
        t = time.monotonic()
        if echo_at is None and t >= roll_start and abs(v - value) <= 10:
            echo_at = t
        if echo_at is not None and echo_end is None and abs(v - value) > 10:
            echo_end = t
        if t >= roll_end and centred_at is None and abs(v - 1500) <= 10:
            centred_at = t
    return {
        "roll_value_us": value,
        "echo_seen": echo_at is not None,
        "echo_delay_ms": None if echo_at is None else 1e3 * (echo_at - roll_start),
        "echo_held_s": None if echo_at is None or echo_end is None else echo_end - echo_at,
        "centred_after_release_ms": None if centred_at is None else 1e3 * (centred_at - roll_end),
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
    p.add_argument("--roll-s", type=float, default=1.5)
    p.add_argument("--warmup-s", type=float, default=1.0,
                   help="centre frames before the roll (iNav's MSP override recovery delay)")
    p.add_argument("--msp-device", required=True,
                   help="the UART to iNav's MSP port (faithd's command.sink.endpoint)")
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
    # iNav's streams top out at 25 Hz (a setting of 50 gives 24.6 Hz on SITL).
    ok_rates = report["rates_hz"]["ATTITUDE"] >= 20 and report["rates_hz"]["RC_CHANNELS"] >= 20
    report["rates_ok"] = ok_rates
    if not ok_rates:
        print("WARN: set mavlink_extra1_rate = 50 and mavlink_rc_chan_rate = 50 in iNav (hil/inav/faithd.cli)")

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
    msp = open_msp(args.msp_device, args.baud)
    report["test_roll"] = test_roll(conn, args, msp)
    print("test roll:", report["test_roll"])
    with open(args.report, "w") as f:
        json.dump(report, f, indent=2)
    print("report written to", args.report)
    return 0 if report["switch_ok"] and report["test_roll"]["echo_seen"] else 1


if __name__ == "__main__":
    sys.exit(main())
