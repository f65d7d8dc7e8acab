"""``coordarm run --live``: a real WebSocket client subscribes to the live server and gets the run."""
import json
import re
import struct
import subprocess
import sys

import jsonschema
from mcap.reader import make_reader
from websockets.sync.client import connect

from coordarm.simulation.log_schemas import foxglove_schema

#: The Foxglove WebSocket protocol as foxglove-sdk 0.30 serves it: subprotocol, opcodes of binary messages.
SUBPROTOCOL, MESSAGE_DATA, TIME = "foxglove.sdk.v1", 0x01, 0x02


def _watch_live_run(scenario, links, duration, out):
    """Run ``coordarm run SCENARIO --live`` and subscribe to every channel with a real WebSocket client.

    Returns the advertised channels (by id), the received messages by topic as (log time, bytes)
    and the number of time messages.
    """
    cmd = [sys.executable, "-m", "coordarm", "run", scenario, "--links", str(links), "--duration", str(duration),
           "--backend", "interpreted", "--live", "--port", "0", "--live-wait", "--live-speed", "3",
           "--no-figures", "--quiet", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = proc.stdout.readline()   # printed once the server listens; the run waits for a subscriber
        assert first.startswith("live "), first + proc.stderr.read()
        url = first.split()[1]
        channels, received, times = {}, {}, 0
        with connect(url, subprotocols=[SUBPROTOCOL], open_timeout=60, close_timeout=5) as ws:
            while not {"/joint_state", "/scene", "/tf", "/tracking"} <= {c["topic"] for c in channels.values()}:
                msg = json.loads(ws.recv(timeout=60))
                if msg["op"] == "advertise":
                    channels.update({c["id"]: c for c in msg["channels"]})
            subs = {i: cid for i, cid in enumerate(channels)}
            ws.send(json.dumps({"op": "subscribe",
                                "subscriptions": [{"id": i, "channelId": cid} for i, cid in subs.items()]}))
            while True:   # until the run ends and the server closes the connection
                try:
                    data = ws.recv(timeout=120)
                except Exception:   # ConnectionClosed: the server stopped at the end of the run
                    break
                if isinstance(data, str):
                    continue
                if data[0] == TIME:
                    times += 1
                elif data[0] == MESSAGE_DATA:
                    sub, log_time = struct.unpack_from("<IQ", data, 1)
                    topic = channels[subs[sub]]["topic"]
                    received.setdefault(topic, []).append((log_time, bytes(data[13:])))
        assert proc.wait(timeout=300) == 0, proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return channels, received, times


def _check_the_live_messages_are_the_logs(channels, received, times, out):
    """Scene, frames and joint state arrived, the scenes are valid SceneUpdates, every message is the log's."""
    assert channels[next(c for c in channels if channels[c]["topic"] == "/scene")]["schemaEncoding"] == "jsonschema"
    assert received.get("/joint_state") and received.get("/scene") and received.get("/tf") and times > 0
    validator = jsonschema.Draft202012Validator(foxglove_schema("foxglove.SceneUpdate"))
    for _, data in received["/scene"]:
        validator.validate(json.loads(data))
    # the live messages are the log's messages: same log time, same bytes
    with open(out, "rb") as f:
        logged = {(ch.topic, m.log_time): m.data for _, ch, m in make_reader(f).iter_messages()}
    for topic in ("/joint_state", "/scene", "/tf", "/tracking"):
        for log_time, data in received[topic]:
            assert logged[(topic, log_time)] == data, (topic, log_time)


def _advertised_fields(channels, topic):
    """``{field: length}`` (0 = scalar) of the ros2msg schema advertised for ``topic``."""
    channel = next(c for c in channels.values() if c["topic"] == topic)
    assert channel["schemaEncoding"] == "ros2msg", channel
    return {name: int(n) if n else 0 for n, name in re.findall(r"float64(?:\[(\d+)\])? (\w+)", channel["schema"])}


def test_a_websocket_client_receives_joint_state_scene_and_frames_while_the_log_is_written(tmp_path):
    out = tmp_path / "live.mcap"
    channels, received, times = _watch_live_run("hole", 5, 1.5, out)
    _check_the_live_messages_are_the_logs(channels, received, times, out)


def test_a_live_spatial_run_serves_the_spatial_channels_and_its_3d_scene(tmp_path):
    links = 6
    out = tmp_path / "live3d.mcap"
    channels, received, times = _watch_live_run("line3d", links, 0.6, out)
    _check_the_live_messages_are_the_logs(channels, received, times, out)
    # the advertised schemas are the spatial ones: 2m joint coordinates, 2(m-1) deviations, roll, spatial margins
    assert _advertised_fields(channels, "/joint_state") == {"t": 0, "q": 2 * links, "u": 2 * links}
    task = _advertised_fields(channels, "/task_state")
    assert task["e"] == 2 * (links - 1) and {"s", "v_star", "roll", "roll_star"} <= set(task)
    margins = _advertised_fields(channels, "/margins")
    assert margins["link_margins"] == links - 1 and margins["joint_margins"] == links and "end_margin" in margins
    assert {"target_z", "roll", "roll_target"} <= set(_advertised_fields(channels, "/tracking"))
    # a joint-state message holds the 2m angles (CDR: 4-byte header, then float64 t, q, u)
    _, data = received["/joint_state"][0]
    assert len(data) == 4 + 8 * (1 + 4 * links)
    # the scene is the 3-D one: a cylinder per link, a sphere per joint (m+1) and the target, a frame per link
    entity = json.loads(received["/scene"][-1][1])["entities"][0]
    assert len(entity["cylinders"]) == links and len(entity["spheres"]) == links + 2
    frames = json.loads(received["/tf"][-1][1])["transforms"]
    assert [f["child_frame_id"] for f in frames] == [f"link{j}" for j in range(1, links + 1)]
