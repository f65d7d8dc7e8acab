"""``coordarm run --live``: a real WebSocket client subscribes to the live server and gets the run."""
import json
import struct
import subprocess
import sys

import jsonschema
from mcap.reader import make_reader
from websockets.sync.client import connect

from coordarm.simulation.log_schemas import foxglove_schema

#: The Foxglove WebSocket protocol as foxglove-sdk 0.30 serves it: subprotocol, opcodes of binary messages.
SUBPROTOCOL, MESSAGE_DATA, TIME = "foxglove.sdk.v1", 0x01, 0x02


def test_a_websocket_client_receives_joint_state_scene_and_frames_while_the_log_is_written(tmp_path):
    out = tmp_path / "live.mcap"
    cmd = [sys.executable, "-m", "coordarm", "run", "hole", "--links", "5", "--duration", "1.5",
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
