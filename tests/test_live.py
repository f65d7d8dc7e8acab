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
#: The protocol's former name, which Foxglove Studio 1.48 and Lichtblick send.
LEGACY_SUBPROTOCOL = "foxglove.websocket.v1"
#: The topics of a planar run's live view.
TOPICS = {"/joint_state", "/task_state", "/margins", "/margins/cond", "/scene", "/scene/fixed", "/tf", "/tracking"}


def _start_live_run(scenario, links, duration, out, speed=3.0):
    """Start ``coordarm run SCENARIO --live --live-wait``; the process and the server's URL."""
    cmd = [sys.executable, "-m", "coordarm", "run", scenario, "--links", str(links), "--duration", str(duration),
           "--backend", "interpreted", "--live", "--port", "0", "--live-wait", "--live-speed", str(speed),
           "--no-figures", "--quiet", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = proc.stdout.readline()   # printed once the server listens; the run waits for a subscriber
    assert first.startswith("live "), first + proc.stderr.read()
    return proc, first.split()[1]


def _subscribe_to_all(ws, topics):
    """Read the advertisements until ``topics`` are all there, subscribe to every channel; ``(channels, subs)``."""
    channels = {}
    while not topics <= {c["topic"] for c in channels.values()}:
        msg = json.loads(ws.recv(timeout=60))
        if msg["op"] == "advertise":
            channels.update({c["id"]: c for c in msg["channels"]})
    subs = {i: cid for i, cid in enumerate(channels)}
    ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": i, "channelId": cid} for i, cid in subs.items()]}))
    return channels, subs


def _watch_live_run(scenario, links, duration, out, subprotocol=SUBPROTOCOL, topics=TOPICS):
    """Run ``coordarm run SCENARIO --live`` and subscribe to every channel with a real WebSocket client.

    Returns the advertised channels (by id), the received messages by topic as (log time, bytes),
    the number of time messages, the subprotocol the server chose and the run's standard error.
    """
    proc, url = _start_live_run(scenario, links, duration, out)
    try:
        received, times = {}, 0
        with connect(url, subprotocols=[subprotocol], open_timeout=60, close_timeout=5) as ws:
            chosen = ws.subprotocol
            channels, subs = _subscribe_to_all(ws, topics)
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
        stderr = proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return channels, received, times, chosen, stderr


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
    for topic in received:
        for log_time, data in received[topic]:
            assert logged[(topic, log_time)] == data, (topic, log_time)


def _advertised_fields(channels, topic):
    """``{field: length}`` (0 = scalar) of the ros2msg schema advertised for ``topic``."""
    channel = next(c for c in channels.values() if c["topic"] == topic)
    assert channel["schemaEncoding"] == "ros2msg", channel
    return {name: int(n) if n else 0 for n, name in re.findall(r"float64(?:\[(\d+)\])? (\w+)", channel["schema"])}


def test_a_websocket_client_receives_joint_state_scene_and_frames_while_the_log_is_written(tmp_path):
    out = tmp_path / "live.mcap"
    channels, received, times, chosen, stderr = _watch_live_run("hole", 5, 1.5, out)
    _check_the_live_messages_are_the_logs(channels, received, times, out)
    assert chosen == SUBPROTOCOL and "Callback failed" not in stderr, stderr
    assert TOPICS <= set(received)   # every channel of the log, cond too


def test_a_client_sending_the_former_subprotocol_name_gets_the_whole_run_and_disconnects_cleanly(tmp_path):
    """Foxglove Studio 1.48 and Lichtblick offer only ``foxglove.websocket.v1``: the server accepts it (and says
    so in the handshake), serves every channel of the log (``/margins/cond`` too), and the client's
    disconnect prints nothing."""
    out = tmp_path / "legacy.mcap"
    channels, received, times, chosen, stderr = _watch_live_run("hole", 5, 1.5, out, subprotocol=LEGACY_SUBPROTOCOL)
    assert chosen == LEGACY_SUBPROTOCOL
    _check_the_live_messages_are_the_logs(channels, received, times, out)
    assert TOPICS <= set(received) and len(received["/margins/cond"]) >= 2   # 1 Hz (the default) over 1.5 s: t = 0, 1
    assert "Callback failed" not in stderr and "Error" not in stderr, stderr


def test_a_viewer_subscribing_to_the_fixed_scene_late_gets_it_at_once(tmp_path):
    """``/scene/fixed`` (the walls) goes out once; a client that subscribes to it while the run goes on gets it
    again, as the log holds it, stamped with the run's time then; subscribers from the start get it once."""
    out = tmp_path / "late.mcap"
    proc, url = _start_live_run("hole", 5, 3.0, out, speed=1.0)
    try:
        with connect(url, subprotocols=[SUBPROTOCOL], open_timeout=60, close_timeout=5) as ws:
            channels = {}
            while not {"/scene", "/scene/fixed"} <= {c["topic"] for c in channels.values()}:
                msg = json.loads(ws.recv(timeout=60))
                if msg["op"] == "advertise":
                    channels.update({c["id"]: c for c in msg["channels"]})
            ids = {c["topic"]: cid for cid, c in channels.items()}
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 0, "channelId": ids["/scene"]}]}))
            scenes, fixed = [], []
            while len(scenes) < 5:                       # the run is on: 5 scenes (0.2 s of it) seen
                data = ws.recv(timeout=60)
                if isinstance(data, bytes) and data[0] == MESSAGE_DATA:
                    sub, log_time = struct.unpack_from("<IQ", data, 1)
                    assert sub == 0
                    scenes.append(log_time)
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": ids["/scene/fixed"]}]}))
            while not fixed:
                data = ws.recv(timeout=60)
                if isinstance(data, bytes) and data[0] == MESSAGE_DATA:
                    sub, log_time = struct.unpack_from("<IQ", data, 1)
                    (fixed if sub == 1 else scenes).append((log_time, bytes(data[13:])) if sub == 1 else log_time)
        assert proc.wait(timeout=120) == 0, proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    with open(out, "rb") as f:
        (logged,) = [(m.log_time, m.data) for _, _, m in make_reader(f).iter_messages(topics=["/scene/fixed"])]
    (log_time, data), = fixed
    from coordarm.simulation.scenario import load_scenario
    walls = len(load_scenario("hole").obstacles)
    assert data == logged[1] and len(json.loads(data)["entities"][0]["lines"]) == walls > 0     # the hole's walls
    assert logged[0] == scenes[0] < scenes[4] <= log_time          # the first scene's time in the log; now, live


def test_a_live_spatial_run_serves_the_spatial_channels_and_its_3d_scene(tmp_path):
    links = 6
    out = tmp_path / "live3d.mcap"
    channels, received, times, _, _ = _watch_live_run("line3d", links, 0.6, out,
                                                      topics={"/joint_state", "/scene", "/tf", "/tracking"})
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
    # the scene is the 3-D one: a cylinder per link, a sphere per joint (m+1) and the target
    entity = json.loads(received["/scene"][-1][1])["entities"][0]
    assert len(entity["cylinders"]) == links and len(entity["spheres"]) == links + 2
    frames = json.loads(received["/tf"][-1][1])["transforms"]
    assert [f["child_frame_id"] for f in frames] == ["base", "tip"]      # the default --log-frames ends


def test_a_live_rail_run_serves_the_rail_coordinates_as_the_log_does(tmp_path):
    """A rail robot's ``q`` and ``u`` hold ``d`` and its rate first (m + 1 entries), live as in the log."""
    links = 80     # the preset's (fewer links start outside the rail's limits)
    out = tmp_path / "rail.mcap"
    channels, received, times, _, stderr = _watch_live_run("pipe", links, 0.3, out)
    _check_the_live_messages_are_the_logs(channels, received, times, out)
    assert _advertised_fields(channels, "/joint_state") == {"t": 0, "q": links + 1, "u": links + 1}
    assert "sigma" in _advertised_fields(channels, "/task_state")
    assert "rail_margin" in _advertised_fields(channels, "/margins")
    _, data = received["/joint_state"][0]
    assert len(data) == 4 + 8 * (1 + 2 * (links + 1)) and "Traceback" not in stderr, stderr


def test_a_client_that_stops_reading_never_slows_the_run(tmp_path):
    """A real client subscribes to every channel, then reads nothing (a tiny receive buffer, so the server
    feels it at once): the run still ends at its paced time, and the client missed messages (the server
    dropped them for it instead of waiting)."""
    import socket
    import time

    links, duration, speed = 24, 12.0, 6.0
    proc, url = _start_live_run("hole", links, duration, tmp_path / "stall.mcap", speed=speed)
    try:
        host, port = url.removeprefix("ws://").split(":")
        sock = socket.socket()
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        sock.connect((host, int(port)))
        with connect(url, sock=sock, subprotocols=[LEGACY_SUBPROTOCOL], open_timeout=60, close_timeout=1,
                     max_queue=1) as ws:
            channels, subs = _subscribe_to_all(ws, TOPICS)
            start = time.monotonic()
            code = proc.wait(timeout=120)       # stall: read nothing until the run has ended
            elapsed = time.monotonic() - start
            got = 0
            try:
                while True:
                    data = ws.recv(timeout=5)
                    got += isinstance(data, bytes) and data[0] == MESSAGE_DATA
            except Exception:
                pass
        assert code == 0, proc.stderr.read()
        # paced: 1 s for the subscriptions to settle, duration / speed of simulated time, plus start-up and room
        # for a loaded machine; a server that waited for the client would hold the run until the bridge drops
        # the client (STALL_TIMEOUT, 20 s without progress)
        assert elapsed < 1.0 + duration / speed + 10.0, elapsed
        with open(tmp_path / "stall.mcap", "rb") as f:
            logged = {}
            for _, ch, _ in make_reader(f).iter_messages():
                logged[ch.topic] = logged.get(ch.topic, 0) + 1
        # the live view sends the per-step channels at 50 Hz (the log has every step: 1000 Hz), the rest as logged
        sent = sum(n / 20 if topic in ("/joint_state", "/task_state", "/margins") else n for topic, n in logged.items())
        print(f"stalled client: run took {elapsed:.2f} s, got {got} messages, about {sent:.0f} messages sent")
        assert got < sent, (got, sent)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_live_wait_returns_only_once_the_subscriptions_have_settled():
    """A viewer subscribes panel by panel: the wait ends ``settle`` seconds after the last subscription, not at
    the first one (a real client, in two steps 0.6 s apart)."""
    import threading
    import time

    from coordarm.simulation.live import LiveView
    from coordarm.simulation.scenario import load_scenario

    scenario = load_scenario("hole").with_overrides(links=5, duration=0.1)
    with LiveView(scenario, port=0) as view:
        def client():
            with connect(view.url, subprotocols=[LEGACY_SUBPROTOCOL], open_timeout=30) as ws:
                channels = {}
                while len(channels) < 7:
                    msg = json.loads(ws.recv(timeout=30))
                    if msg["op"] == "advertise":
                        channels.update({c["id"]: c for c in msg["channels"]})
                ids = sorted(channels)
                ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 0, "channelId": ids[0]}]}))
                time.sleep(0.6)
                ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": ids[1]}]}))
                time.sleep(2.0)

        thread = threading.Thread(target=client)
        start = time.monotonic()
        thread.start()
        assert view.wait_for_client(timeout=30, settle=1.0)
        waited = time.monotonic() - start
        thread.join()
    assert waited >= 1.6 - 0.05, waited


def test_the_bridge_renames_only_a_request_offering_the_former_name_alone():
    from coordarm.simulation.ws_bridge import offered_subprotocols, rewrite_answer, rewrite_request

    head = ("GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nSec-WebSocket-Key: abc==\r\n"
            "Sec-WebSocket-Protocol: {}\r\n\r\n")
    legacy = head.format("foxglove.websocket.v1").encode()
    sent, restore = rewrite_request(legacy)
    assert sent == head.format("foxglove.sdk.v1").encode() and restore == "foxglove.websocket.v1"
    for offer in ("foxglove.sdk.v1", "foxglove.websocket.v1, foxglove.sdk.v1", "other"):
        request = head.format(offer).encode()
        assert rewrite_request(request) == (request, None)
    two_lines = (b"GET / HTTP/1.1\r\nsec-websocket-protocol: a\r\nSec-WebSocket-Protocol: b, c\r\n\r\n")
    assert offered_subprotocols(two_lines) == ["a", "b", "c"]
    answer = b"HTTP/1.1 101 Switching Protocols\r\nSec-WebSocket-Accept: xyz=\r\nSec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n"
    assert rewrite_answer(answer, "foxglove.websocket.v1") == answer.replace(b"foxglove.sdk.v1", b"foxglove.websocket.v1")
    assert rewrite_answer(answer, None) == answer


def test_a_port_in_use_is_one_error_naming_the_port(tmp_path):
    import socket

    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        res = subprocess.run([sys.executable, "-m", "coordarm", "run", "hole", "--links", "5", "--duration", "0.1",
                              "--live", "--port", str(port), "--no-figures", "--quiet", "--out",
                              str(tmp_path / "x.mcap")], capture_output=True, text=True, timeout=120)
    assert res.returncode == 2 and f"--port {port}: cannot start the live server" in res.stderr, res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
