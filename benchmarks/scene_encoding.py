"""What one ``/scene`` message costs to encode: coordarm's JSON templates against json.dumps and protobuf.

The 64-link ``line`` run's first 2 s; the scene rows of one block (every 50th step, 40 scenes):

* ``SceneBuilder.messages``: what the log does, the ``/scene``, ``/tf`` and ``/tracking`` of each row,
  geometry included (numbers written into :class:`~coordarm.simulation.json_fill.JsonTemplate`);
* ``json.dumps`` of the very same scenes (parsed back into dicts first, so only the encoding is timed);
* foxglove-sdk's protobuf ``SceneUpdate`` (``foxglove.messages``) built from those dicts and encoded: the
  cost of the other encoding Foxglove reads, the numbers given.

Prints the median time per block [ms] and the bytes of one scene. Run:
``python benchmarks/scene_encoding.py [--repeats 20]``; results in RESULTS.md ("Where a logged run's time goes").
"""
import argparse
import json
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402

from coordarm.simulation.mcap_writer import log_time_ns  # noqa: E402
from coordarm.simulation.run import simulate  # noqa: E402
from coordarm.simulation.scenario import load_scenario  # noqa: E402
from coordarm.simulation.scene_kind import scene_builder  # noqa: E402

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--repeats", type=int, default=20)
repeats = ap.parse_args().repeats
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    import foxglove.messages as fm

sc = load_scenario("line").with_overrides(64, 2.0, None)
ctrl = sc.controller()
parts = []
simulate(ctrl, sc.start(ctrl), sc.duration, sc.step, sc.t0, backend="compiled", progress=False, on_chunk=parts.append)
builder = scene_builder(ctrl, sc.obstacles, None, "ends")
part = parts[0]
builder.advance(part)
ks = np.arange(0, len(part.t), 50)
ns = log_time_ns(part.t[ks], 0.0)
scenes = [data for key, _, data in builder.messages(part, ks, ns) if key == "scene"]
docs = [json.loads(s) for s in scenes]
LINE_TYPES = (fm.LinePrimitiveLineType.LineStrip, fm.LinePrimitiveLineType.LineLoop, fm.LinePrimitiveLineType.LineList)


def protobuf(doc: dict) -> bytes:
    """The scene ``doc`` as a protobuf ``foxglove.SceneUpdate``."""
    e = doc["entities"][0]

    def pose(d):
        return fm.Pose(position=fm.Vector3(**d["position"]), orientation=fm.Quaternion(**d["orientation"]))

    spheres = [fm.SpherePrimitive(pose=pose(s["pose"]), size=fm.Vector3(**s["size"]), color=fm.Color(**s["color"]))
               for s in e["spheres"]]
    lines = [fm.LinePrimitive(type=LINE_TYPES[li["type"]], pose=pose(li["pose"]), thickness=li["thickness"],
                              scale_invariant=li["scale_invariant"], points=[fm.Point3(**p) for p in li["points"]],
                              color=fm.Color(**li["color"]), colors=[fm.Color(**c) for c in li["colors"]], indices=[])
             for li in e["lines"]]
    entity = fm.SceneEntity(timestamp=fm.Timestamp(**e["timestamp"]), frame_id=e["frame_id"], id=e["id"],
                            lifetime=fm.Duration(**e["lifetime"]), frame_locked=False, spheres=spheres, lines=lines)
    return fm.SceneUpdate(entities=[entity]).encode()


def timed(fn) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1e3 * float(np.median(times))


print(f"{len(ks)} scenes of {ctrl.chain.m} links per block")
print("| encoding | per block [ms] | one scene [bytes] |")
print("|---|---|---|")
print(f"| JSON templates (`SceneBuilder.messages`: scene, tf and tracking, geometry included) | "
      f"{timed(lambda: builder.messages(part, ks, ns)):.2f} | {len(scenes[0])} |")
print(f"| `json.dumps` of the same scenes | {timed(lambda: [json.dumps(d, separators=(',', ':')) for d in docs]):.2f} | "
      f"{len(json.dumps(docs[0], separators=(',', ':')))} |")
print(f"| protobuf (foxglove-sdk `SceneUpdate`, built from the numbers, encoded) | "
      f"{timed(lambda: [protobuf(d) for d in docs]):.2f} | {len(protobuf(docs[0]))} |")
