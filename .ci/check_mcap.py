"""Open a firefleet recording with the Python mcap reader: every channel has a schema,
every message is JSON, the Foxglove scene is there, and the metadata record names the
build and the site file."""
import json
import sys
from collections import Counter

from mcap.reader import make_reader

with open(sys.argv[1], "rb") as f:
    reader = make_reader(f)
    summary = reader.get_summary()
    assert summary is not None, "no summary section: the file was not finished"
    missing = [c.topic for c in summary.channels.values() if c.schema_id not in summary.schemas]
    assert not missing, f"channels without a schema: {missing}"
    counts = Counter()
    for schema, channel, message in reader.iter_messages():
        json.loads(message.data)
        counts[schema.name] += 1
    described = [m for m in reader.iter_metadata() if m.name == "firefleet"]
    assert described, "no firefleet metadata record"
    for key in ("firefleet_version", "protocol_version", "site", "site_file"):
        assert described[0].metadata.get(key), f"metadata without {key}"
for name in ("foxglove.SceneUpdate", "firefleet.UnitState", "firefleet.Task", "firefleet.SimTruth", "firefleet.BtTransitions", "foxglove.Log", "firefleet.DtsZone", "firefleet.Vent", "firefleet.ScadaLink"):
    assert counts[name] > 0, f"no {name} messages"
print(f"mcap ok: {len(summary.channels)} channels, {sum(counts.values())} messages")
for name, n in sorted(counts.items()):
    print(f"  {name:28} {n}")
