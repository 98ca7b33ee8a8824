"""An independent MAVLink peer playing iNav for faithd's tests: pymavlink on UDP.

Listens on 127.0.0.1:PORT, answers whoever talks to it (faithd) with HEARTBEAT
(armed), ATTITUDE and RC_CHANNELS (switch in AUTO) at 50 Hz, records every
RC_CHANNELS_OVERRIDE and HEARTBEAT it receives, and after SECONDS prints one JSON
object with what it saw.
"""

import json
import os
import sys
import time

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402


def main():
    port = int(sys.argv[1])
    seconds = float(sys.argv[2])
    switch_us = int(sys.argv[3]) if len(sys.argv) > 3 else 1900
    conn = mavutil.mavlink_connection(
        f"udpin:127.0.0.1:{port}", source_system=1, source_component=1, dialect="common"
    )
    mav = conn.mav
    start = time.monotonic()
    next_send = start
    tick = 0
    overrides = []
    companion_heartbeats = 0
    while time.monotonic() - start < seconds:
        msg = conn.recv_match(blocking=True, timeout=0.005)
        now = time.monotonic()
        if msg is not None:
            kind = msg.get_type()
            if kind == "RC_CHANNELS_OVERRIDE":
                overrides.append({"t_s": now - start, "chan1_raw": msg.chan1_raw,
                                  "chan2_raw": msg.chan2_raw,
                                  "target_system": msg.target_system})
            elif kind == "HEARTBEAT" and msg.get_srcComponent() == 191 \
                    and msg.type == mavutil.mavlink.MAV_TYPE_ONBOARD_CONTROLLER:
                companion_heartbeats += 1
        if now >= next_send:
            boot_ms = int((now - start) * 1000)
            mav.attitude_send(boot_ms, 0.0, 0.0, 0.3, 0.0, 0.0, 0.0)
            mav.rc_channels_send(boot_ms, 8, 1500, 1500, 1400, 1500, 1900, switch_us,
                                 1000, 1000, *([65535] * 10), 200)
            if tick % 10 == 0:
                mav.heartbeat_send(
                    mavutil.mavlink.MAV_TYPE_QUADROTOR,
                    mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                    mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED
                    | mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                    0, mavutil.mavlink.MAV_STATE_ACTIVE)
            tick += 1
            next_send += 0.02
    print(json.dumps({"companion_heartbeats": companion_heartbeats,
                      "overrides": overrides}))


if __name__ == "__main__":
    main()
