"""A ground station for faithd's tests: pymavlink on UDP, listening as QGroundControl
and Mission Planner do (127.0.0.1:PORT; faithd's `[ground] endpoint` sends to it).

For SECONDS it records everything that arrives, by message type and sender, with
the time of arrival: faithd's HEARTBEAT, STATUSTEXT and NAMED_VALUE_FLOAT, and the
autopilot telemetry faithd forwards. Once it has heard faithd it behaves as a ground
station that tries to fly the vehicle: its own HEARTBEAT (a GCS, system 255,
component 190) once a second, and RC_CHANNELS_OVERRIDE (roll hard right) and
COMMAND_LONG (disarm, forced) to the vehicle every 200 ms, none of which may reach
the autopilot. Prints one JSON object: per "TYPE SYS/COMP" the count and the rate
(messages per second between the first and the last), every STATUSTEXT, the
NAMED_VALUE_FLOAT values and rates by name, what it sent, and `capture`: the same as a ground
station's message list and MAVLink inspector would show it, as text.

    pymavlink_ground.py PORT SECONDS
"""

import json
import math
import os
import sys
import time

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402

M = mavutil.mavlink
SEVERITY = {v: k.replace("MAV_SEVERITY_", "") for k, v in vars(M).items()
            if k.startswith("MAV_SEVERITY_") and isinstance(v, int)}
MAV_TYPE = {v: k.replace("MAV_TYPE_", "") for k, v in vars(M).items()
            if k.startswith("MAV_TYPE_") and isinstance(v, int)}
MAV_AUTOPILOT = {v: k.replace("MAV_AUTOPILOT_", "") for k, v in vars(M).items()
                 if k.startswith("MAV_AUTOPILOT_") and isinstance(v, int)}


def main():
    port, seconds = int(sys.argv[1]), float(sys.argv[2])
    conn = mavutil.mavlink_connection(
        f"udpin:127.0.0.1:{port}", source_system=255, source_component=190,
        dialect="common")
    start = time.monotonic()
    seen = {}        # "TYPE SYS/COMP" -> [count, first_s, last_s]
    last = {}        # "TYPE SYS/COMP" -> the last message (for the inspector view)
    texts = []       # every STATUSTEXT: time, sender, severity, text
    values = {}      # NAMED_VALUE_FLOAT name -> [[time, value], ...]
    heartbeats = {}  # "SYS/COMP" -> {type, autopilot}
    sent = {"RC_CHANNELS_OVERRIDE": 0, "COMMAND_LONG": 0, "HEARTBEAT": 0}
    heard_faithd = False
    next_hb = next_cmd = start
    while time.monotonic() - start < seconds:
        msg = conn.recv_match(blocking=True, timeout=0.01)
        now = time.monotonic()
        t = now - start
        if msg is not None:
            kind = msg.get_type()
            sender = f"{msg.get_srcSystem()}/{msg.get_srcComponent()}"
            key = f"{kind} {sender}"
            entry = seen.setdefault(key, [0, t, t])
            entry[0] += 1
            entry[2] = t
            last[key] = msg
            if kind == "STATUSTEXT":
                texts.append({"t_s": round(t, 3), "from": sender,
                              "severity": SEVERITY.get(msg.severity, str(msg.severity)),
                              "text": msg.text})
            elif kind == "NAMED_VALUE_FLOAT":
                # NaN (no value this period) as null: JSON has no NaN.
                value = None if math.isnan(msg.value) else msg.value
                values.setdefault(msg.name, []).append([round(t, 3), value])
            elif kind == "HEARTBEAT":
                heartbeats[sender] = {"type": MAV_TYPE.get(msg.type, str(msg.type)),
                                      "autopilot": MAV_AUTOPILOT.get(msg.autopilot,
                                                                     str(msg.autopilot))}
                if sender == "1/191":
                    heard_faithd = True
        # Only once faithd has spoken does udpin know where to answer.
        if heard_faithd and now >= next_hb:
            conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0,
                                    M.MAV_STATE_ACTIVE)
            sent["HEARTBEAT"] += 1
            next_hb += 1.0
        if heard_faithd and now >= next_cmd:
            conn.mav.rc_channels_override_send(1, 1, 2000, 1500, 1500, 1500,
                                               0, 0, 0, 0)
            conn.mav.command_long_send(1, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                       0, 21196, 0, 0, 0, 0, 0)
            sent["RC_CHANNELS_OVERRIDE"] += 1
            sent["COMMAND_LONG"] += 1
            next_cmd += 0.2
    rates = {k: {"count": c, "rate_hz": (c - 1) / (b - a) if c > 1 and b > a else 0.0}
             for k, (c, a, b) in seen.items()}
    values_hz = {n: (len(v) - 1) / (v[-1][0] - v[0][0]) if len(v) > 1 and v[-1][0] > v[0][0]
                 else 0.0 for n, v in values.items()}
    print(json.dumps({"seen": rates, "statustext": texts, "values": values,
                      "values_hz": values_hz,
                      "heartbeats": heartbeats, "sent": sent,
                      "capture": capture(rates, texts, values, heartbeats, last)}))


def show(v):
    return "nan" if v is None else f"{v:.4g}"


def capture(rates, texts, values, heartbeats, last):
    """What a ground station shows: its message list, then its MAVLink inspector."""
    lines = ["Messages (STATUSTEXT, as the ground station lists them):"]
    for t in texts:
        lines.append(f"  {t['t_s']:6.2f} s  {t['from']:7} {t['severity']:8} {t['text']}")
    lines.append("")
    lines.append("MAVLink inspector (sender, message, rate, last value):")
    for key in sorted(rates, key=lambda k: (k.split()[1], k.split()[0])):
        kind, sender = key.split()
        r = rates[key]
        msg = last[key]
        if kind == "HEARTBEAT":
            hb = heartbeats[sender]
            detail = f"type {hb['type']}, autopilot {hb['autopilot']}"
        elif kind == "NAMED_VALUE_FLOAT":
            detail = ", ".join(f"{n} {show(v[-1][1])}" for n, v in values.items())
        elif kind == "STATUSTEXT":
            detail = f"\"{msg.text}\""
        elif kind == "ATTITUDE":
            detail = f"roll {msg.roll:.3f} rad, yaw {msg.yaw:.3f} rad"
        elif kind == "RC_CHANNELS":
            detail = f"ch1 {msg.chan1_raw}, ch6 {msg.chan6_raw} us"
        else:
            detail = ""
        lines.append(f"  {sender:7} {kind:18} {r['rate_hz']:5.1f} Hz  {detail}".rstrip())
    rolls = [t["t_s"] for t in texts if t["text"].startswith("faithd: roll")]
    if rolls:
        lines.append("")
        lines.append("NAMED_VALUE_FLOAT from 1/191 as plotted, around the first roll "
                     f"({rolls[0]:.2f} s):")
        names = list(values)
        lines.append("  " + "".join(f"{n:>11}" for n in ["t_s"] + names))
        for i, (t, _) in enumerate(values[names[0]]):
            if rolls[0] - 1.0 <= t <= rolls[0] + 0.6:
                row = [show(values[n][i][1]) if i < len(values[n]) else "" for n in names]
                lines.append("  " + "".join(f"{c:>11}" for c in [f"{t:.2f}"] + row))
    return "\n".join(lines)


if __name__ == "__main__":
    main()
