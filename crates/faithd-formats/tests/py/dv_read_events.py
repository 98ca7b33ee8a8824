"""Reads an AEDAT 4 file with iniVation's dv-processing and reports what it holds.

usage: dv_read_events.py IN.aedat4 [EXPECTED_COUNT]
Prints one JSON line: count, first and last event as [t, x, y, p], checksum, and the
resolution. With EXPECTED_COUNT, also compares every event with the known list and
exits 1 on the first difference.
"""

import json
import sys

from known_events import checksum, import_dv, known_event

dv = import_dv()
path = sys.argv[1]
recording = dv.io.MonoCameraRecording(path)
if not recording.isEventStreamAvailable():
    print("no event stream in " + path, file=sys.stderr)
    sys.exit(1)
events = []
while recording.isRunning():
    batch = recording.getNextEventBatch()
    if batch is None:
        continue
    for event in batch:
        events.append((int(event.timestamp()), int(event.x()), int(event.y()), int(bool(event.polarity()))))
if len(sys.argv) > 2:
    expected_count = int(sys.argv[2])
    if len(events) != expected_count:
        print(f"expected {expected_count} events, read {len(events)}", file=sys.stderr)
        sys.exit(1)
    for i, event in enumerate(events):
        if event != known_event(i):
            print(f"event {i}: read {event}, expected {known_event(i)}", file=sys.stderr)
            sys.exit(1)
resolution = recording.getEventResolution()
print(
    json.dumps(
        {
            "count": len(events),
            "first": list(events[0]) if events else None,
            "last": list(events[-1]) if events else None,
            "checksum": checksum(events),
            "width": resolution[0] if resolution is not None else None,
            "height": resolution[1] if resolution is not None else None,
        }
    )
)
