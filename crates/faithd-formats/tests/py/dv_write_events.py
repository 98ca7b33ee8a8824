"""Writes the known events to an AEDAT 4 file with iniVation's dv-processing.

usage: dv_write_events.py OUT.aedat4 COMPRESSION COUNT
COMPRESSION is a dv.CompressionType name (NONE, LZ4, LZ4_HIGH, ZSTD, ZSTD_HIGH).
Events go out in batches of 500 so the file holds several packets.
"""

import sys

from known_events import import_dv, known_event

dv = import_dv()
path, compression_name, count = sys.argv[1], sys.argv[2], int(sys.argv[3])
config = dv.io.MonoCameraWriter.EventOnlyConfig("DVS240_interop", (240, 180))
config.compression = dv.CompressionType.__members__[compression_name]
writer = dv.io.MonoCameraWriter(path, config)
for start in range(0, count, 500):
    store = dv.EventStore()
    for i in range(start, min(start + 500, count)):
        t, x, y, p = known_event(i)
        store.push_back(t, x, y, bool(p))
    writer.writeEvents(store)
del writer  # closing writes the packet index
