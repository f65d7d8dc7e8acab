"""Each preset's log read by independent readers: ``mcap_ros2``, the plain ``mcap`` reader, ``jsonschema``."""
import copy
import json
from collections import Counter

import jsonschema
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2._dynamic import generate_dynamic
from mcap_ros2.decoder import DecoderFactory

from coordarm.analysis.replay import load
from coordarm.simulation.log_schemas import PER_STEP, numeric_channels
from coordarm.simulation.mcap_writer import RunLogger
from coordarm.simulation.run import simulate
from coordarm.simulation.scenario import Scenario, load_scenario, presets

LINKS, DURATION = 5, 0.4


def held_span(scenario):
    """The scenario with a rail's commanded span (sized for its own link count) held instead."""
    spec = copy.deepcopy(scenario.spec)
    spec["control"].pop("span", None)
    return Scenario.from_dict(spec, scenario.source)


@pytest.fixture(scope="module", params=[p for p in presets() if not load_scenario(p).universal])
def preset_log(request, tmp_path_factory):
    scenario = held_span(load_scenario(request.param)).with_overrides(links=LINKS, duration=DURATION)
    ctrl = scenario.controller()
    path = tmp_path_factory.mktemp("readers") / f"{request.param}.mcap"
    with RunLogger(path, scenario, ctrl, chunk_size=8 * 1024, cond_rate=20.0) as log:
        simulate(ctrl, scenario.start(ctrl), scenario.duration, scenario.step, scenario.t0,
                 backend="interpreted", chunk=61, on_chunk=log.on_chunk)
    return path


def test_mcap_ros2_decodes_the_numeric_channels_bit_for_bit_like_replay_load(preset_log):
    rep = load(preset_log)
    specs = numeric_channels(LINKS, True) if rep.scenario.chain().rail else numeric_channels(LINKS)
    with open(preset_log, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        decoded = {}
        for _, channel, _, msg in reader.iter_decoded_messages(topics=[specs[k].topic for k in (*PER_STEP, "cond")]):
            decoded.setdefault(channel.topic, []).append(msg)
    for key in PER_STEP:
        msgs = decoded[specs[key].topic]
        assert len(msgs) == len(rep.t)
        for name, n in specs[key].fields:
            ours = getattr(rep, name)
            theirs = np.array([getattr(m, name) for m in msgs], dtype=np.float64).reshape(ours.shape)
            assert theirs.tobytes() == np.ascontiguousarray(ours).tobytes(), f"{specs[key].topic}.{name}"
    cond = decoded["/margins/cond"]
    assert np.array([m.t for m in cond]).tobytes() == rep.cond_t.tobytes()
    assert np.array([m.cond for m in cond]).tobytes() == rep.cond.tobytes()


def test_message_counts_of_the_summary_match_a_plain_pass_over_the_messages(preset_log):
    rep = load(preset_log)
    with open(preset_log, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        stats = {summary.channels[cid].topic: n for cid, n in summary.statistics.channel_message_counts.items()}
        counted = Counter(channel.topic for _, channel, _ in reader.iter_messages())
    assert stats == dict(counted)
    assert stats["/joint_state"] == stats["/task_state"] == stats["/margins"] == len(rep.t)
    assert stats["/margins/cond"] == len(rep.cond)
    assert stats["/scene"] == stats["/tf"] == stats["/tracking"] > 0
    assert summary.statistics.message_count == sum(stats.values()) == rep.messages


def test_every_schema_parses_with_its_declared_encoding(preset_log):
    with open(preset_log, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        encodings = Counter()
        for schema in summary.schemas.values():
            encodings[schema.encoding] += 1
            if schema.encoding == "ros2msg":
                assert generate_dynamic(schema.name, schema.data.decode())  # the ROS 2 .msg parser of mcap_ros2
            elif schema.encoding == "jsonschema":
                jsonschema.Draft202012Validator.check_schema(json.loads(schema.data))
            else:
                pytest.fail(f"unexpected schema encoding {schema.encoding!r}")
        for channel in summary.channels.values():
            expected = {"ros2msg": "cdr", "jsonschema": "json"}[summary.schemas[channel.schema_id].encoding]
            assert channel.message_encoding == expected, channel.topic
    assert encodings == {"ros2msg": 5, "jsonschema": 2}     # SceneUpdate (/scene, /scene/fixed), FrameTransforms


def test_every_json_message_of_each_preset_validates_against_its_channels_schema(preset_log):
    with open(preset_log, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        validators = {cid: jsonschema.Draft202012Validator(json.loads(summary.schemas[ch.schema_id].data))
                      for cid, ch in summary.channels.items() if ch.message_encoding == "json"}
        seen = Counter()
        for _, channel, message in reader.iter_messages(topics=[summary.channels[c].topic for c in validators]):
            validators[channel.id].validate(json.loads(message.data))
            seen[channel.topic] += 1
    assert set(seen) == {"/scene", "/scene/fixed", "/tf"} and seen["/scene"] == seen["/tf"] > 0 and seen["/scene/fixed"] == 1
