"""An independent MAVLink peer playing iNav's telemetry for faithd's tests: pymavlink
on UDP.

Listens on 127.0.0.1:PORT and answers whoever talks to it (faithd) as iNav 9.1 does
on its MAVLink port at the rates of the committed set-up (every 40 ms ATTITUDE and
RC_CHANNELS with the pilot's switch at SWITCH_US; HEARTBEAT armed once a second;
SYS_STATUS with the RC receiver healthy every 120 ms, mavlink_ext_status_rate = 10). With --impostor, a second component of
the same system (154, a gimbal) also sends RC_CHANNELS with the switch in AUTO and
an armed HEARTBEAT on the same link, as a misbehaving peripheral would. With
--manual-after=S the pilot's switch goes to MANUAL (1000 us) S seconds in. Records
faithd's HEARTBEATs, any RC_CHANNELS_OVERRIDE, and every message it received by type
and sender ("TYPE SYS/COMP": count), then prints one JSON object.

    pymavlink_autopilot.py PORT SECONDS [SWITCH_US] [--impostor] [--manual-after=S]
"""

import json
import os
import sys
import time

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402

M = mavutil.mavlink


def heartbeat(mav):
    mav.heartbeat_send(
        M.MAV_TYPE_QUADROTOR, M.MAV_AUTOPILOT_GENERIC,
        M.MAV_MODE_FLAG_SAFETY_ARMED | M.MAV_MODE_FLAG_STABILIZE_ENABLED,
        0, M.MAV_STATE_ACTIVE)


def rc_channels(mav, boot_ms, switch_us):
    mav.rc_channels_send(boot_ms, 14, 1440, 1500, 1000, 1500, 1900, switch_us,
                         *([1500] * 8), *([65535] * 4), 200)


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    impostor = "--impostor" in sys.argv
    manual_after = next((float(a.split("=", 1)[1]) for a in sys.argv
                         if a.startswith("--manual-after=")), None)
    port, seconds = int(args[0]), float(args[1])
    switch_us = int(args[2]) if len(args) > 2 else 1900
    conn = mavutil.mavlink_connection(
        f"udpin:127.0.0.1:{port}", source_system=1, source_component=1, dialect="common"
    )
    mav = conn.mav
    rc = M.MAV_SYS_STATUS_SENSOR_RC_RECEIVER
    start = time.monotonic()
    next_send = start
    tick = 0
    overrides = 0
    companion_heartbeats = 0
    received = {}
    while time.monotonic() - start < seconds:
        msg = conn.recv_match(blocking=True, timeout=0.005)
        now = time.monotonic()
        if manual_after is not None and now - start >= manual_after:
            switch_us = 1000
        if msg is not None:
            key = f"{msg.get_type()} {msg.get_srcSystem()}/{msg.get_srcComponent()}"
            received[key] = received.get(key, 0) + 1
            kind = msg.get_type()
            if kind == "RC_CHANNELS_OVERRIDE":
                overrides += 1
            elif kind == "HEARTBEAT" and msg.get_srcComponent() == 191 \
                    and msg.type == M.MAV_TYPE_ONBOARD_CONTROLLER:
                companion_heartbeats += 1
        if now >= next_send:
            boot_ms = int((now - start) * 1000)
            mav.srcComponent = 1
            mav.attitude_send(boot_ms, 0.0, 0.0, 0.3, 0.0, 0.0, 0.0)
            rc_channels(mav, boot_ms, switch_us)
            if tick % 25 == 0:
                heartbeat(mav)
            if tick % 3 == 0:
                mav.sys_status_send(rc, rc, rc, 100, 11100, -1, -1, 0, 0, 0, 0, 0, 0)
            if impostor:
                mav.srcComponent = 154
                rc_channels(mav, boot_ms, 1900)
                heartbeat(mav)
                mav.srcComponent = 1
            tick += 1
            next_send += 0.04
    print(json.dumps({"companion_heartbeats": companion_heartbeats,
                      "overrides": overrides, "received": received}))


if __name__ == "__main__":
    main()
