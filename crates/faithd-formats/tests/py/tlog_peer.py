"""pymavlink's side of the .tlog interop test.

read PATH:  prints one JSON line per message pymavlink's mavutil finds in PATH
            (type, timestamp in microseconds, time_boot_ms, rollspeed).
write PATH N: writes N ATTITUDE messages as a ground station does (8-byte big-endian
            microsecond timestamp, then the packed MAVLink 2 frame).
"""

import json
import os
import struct
import sys

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink2  # noqa: E402


def read(path):
    log = mavutil.mavlink_connection(path, dialect="common")
    while True:
        msg = log.recv_msg()
        if msg is None:
            break
        if msg.get_type() == "BAD_DATA":
            print(json.dumps({"type": "BAD_DATA"}))
            continue
        print(json.dumps({
            "type": msg.get_type(),
            "t_us": round(msg._timestamp * 1e6),
            "time_boot_ms": getattr(msg, "time_boot_ms", None),
            "rollspeed": getattr(msg, "rollspeed", None),
            "seq": msg.get_seq(),
        }))


def write(path, n):
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    with open(path, "wb") as f:
        for k in range(n):
            msg = mavlink2.MAVLink_attitude_message(k * 20, 0.0, 0.0, 0.0, k * 0.01, 0.0, 0.0)
            frame = msg.pack(mav)
            f.write(struct.pack(">Q", 1_700_000_000_000_000 + k * 20_000))
            f.write(frame)


if __name__ == "__main__":
    if sys.argv[1] == "read":
        read(sys.argv[2])
    else:
        write(sys.argv[2], int(sys.argv[3]))
