"""Fixed-width JSON numbers filled with numpy, checked against Python's own formatting and json.loads."""
import json

import numpy as np
import pytest

from coordarm.simulation.json_fill import LIMIT, JsonTemplate, int_text, text_width


def test_int_text_equals_python_right_aligned_formatting_at_every_digit_count(rng):
    edges = [0, 1, -1, 9, -9, 10, -10]
    for k in range(2, 18):
        edges += [10 ** k - 1, 10 ** k, -(10 ** k - 1), -(10 ** k)]
    values = np.array(edges + list(rng.integers(-LIMIT + 1, LIMIT, 2000)) + list(rng.integers(-999, 1000, 500)))
    width = text_width(values)
    assert width == 19                                   # 18 digits and a sign
    text = int_text(values, width)
    assert [row.tobytes().decode() for row in text] == [f"{v:>{width}d}" for v in values.tolist()]


def test_int_text_equals_python_formatting_at_every_width(rng):
    for width in range(1, 20):                           # every number of four-digit groups, signs, edges
        top = 10 ** min(width, 18) - 1                   # the widest unsigned value of this width
        values = [0, top, 10 ** (width - 1) if width > 1 else 1, top // 7]
        if width > 1:
            values += [-(10 ** (width - 1) - 1), -1, -(top // 10)]
        values += list(rng.integers(-(10 ** (width - 1) - 1) if width > 1 else 0, top, 300, endpoint=True))
        text = int_text(np.array(values), width)
        assert text.shape == (len(values), width)
        assert [row.tobytes().decode() for row in text] == [f"{v:>{width}d}" for v in values], width


def test_a_filled_template_parses_to_its_integers_and_each_kind_is_as_wide_as_its_widest_value(rng):
    t = JsonTemplate(kinds=2).text('{"a":[')
    for i in range(5):
        t.text("," if i else "").number(0)
    t.text('],"b":{"x":').number(1).text('e-9,"y":').number(1).text("e-9}}")
    values = np.column_stack([rng.integers(-5000, 5000, (50, 5)), rng.integers(0, 10 ** 12, (50, 2))])
    texts = t.fill(values)
    for row, text in zip(values, texts):
        doc = json.loads(text)
        assert doc["a"] == row[:5].tolist()
        assert [doc["b"]["x"], doc["b"]["y"]] == [float(f"{v}e-9") for v in row[5:].tolist()]
    widest = len(str(np.abs(values[:, :5]).max())) + 1, len(str(values[:, 5:].max()))
    assert len(texts[0]) == len('{"a":[,,,,],"b":{"x":e-9,"y":e-9}}') + 5 * widest[0] + 2 * widest[1]


def test_a_value_too_large_for_a_slot_or_a_wrong_shape_is_refused():
    t = JsonTemplate().text("[").number().text("]")
    with pytest.raises(ValueError, match="too large"):
        t.fill(np.array([[LIMIT]]))
    with pytest.raises(ValueError, match="shape"):
        t.fill(np.zeros((3, 2), int))


def test_the_compiled_digits_equal_python_formatting_and_the_numpy_fill(rng, monkeypatch):
    """Every width 1..19, signs, zeros and the edges of each digit count, in slots of two kinds between
    literals: the C kernel's messages are Python's right-aligned formatting, and the numpy path's bytes."""
    import coordarm.simulation.json_fill as json_fill
    if json_fill.digits_kernel() is None:
        pytest.skip("no working C compiler")
    edges = [0, 1, -1, 9, -9]
    for k in range(1, 18):
        edges += [10 ** k - 1, 10 ** k, -(10 ** k - 1), -(10 ** k)]
    big = np.array(edges + list(rng.integers(-LIMIT + 1, LIMIT, 300)))
    small = rng.integers(0, 10 ** rng.integers(1, 12, len(big)))
    t = JsonTemplate(kinds=2).text("[").number(0).text(",").number(1).text(', "x": ').number(0).text("]")
    values = np.column_stack([big, small, big[::-1]])
    compiled = t.fill(values)
    wb, ws = text_width(values[:, [0, 2]]), text_width(values[:, 1])
    assert compiled == [f"[{a:>{wb}d},{b:>{ws}d}, \"x\": {c:>{wb}d}]".encode() for a, b, c in values.tolist()]
    batches = [rng.integers(-top, top + 1, (rows, 3)) for top in (0, 1, 9, 99999) for rows in (1, 4)]
    with_kernel = [t.fill(b) for b in batches]                # narrow batches, one and several rows
    monkeypatch.setattr(json_fill, "digits_kernel", lambda: None)
    assert t.fill(values) == compiled
    assert [t.fill(b) for b in batches] == with_kernel


def test_each_kind_is_as_wide_as_text_width_of_all_its_values(rng):
    """Kinds of negative, mixed, non-negative and zero values, interleaved: every message is Python's
    right-aligned formatting at the width text_width gives all of the kind's values; no rows, no messages."""
    kinds = np.arange(12) % 4
    t = JsonTemplate(kinds=4).text("[")
    for i, k in enumerate(kinds):
        t.text("," if i else "").number(int(k))
    t.text("]")
    for _ in range(20):
        values = np.zeros((7, 12), np.int64)
        values[:, kinds == 0] = -rng.integers(1, 10 ** int(rng.integers(1, 15)), (7, 3))
        values[:, kinds == 1] = rng.integers(-10 ** 6, 10 ** 4, (7, 3))
        values[:, kinds == 2] = rng.integers(0, 10 ** 9, (7, 3))
        width = [text_width(values[:, kinds == k]) for k in range(4)]
        want = ["[" + ",".join(f"{v:>{width[k]}d}" for v, k in zip(row, kinds)) + "]" for row in values.tolist()]
        assert [x.decode() for x in t.fill(values)] == want
    assert t.fill(np.zeros((0, 12), np.int64)) == []


def test_a_template_extended_after_a_fill_fills_as_one_built_whole():
    def begun() -> JsonTemplate:
        return JsonTemplate(kinds=2).text('{"a":').number(0).text(',"b":').number(1)
    grown = begun()
    assert grown.fill(np.array([[3, -12], [40, 7]])) == [b'{"a": 3,"b":-12', b'{"a":40,"b":  7']
    grown.text(',"c":').number(0).text("}")
    values = np.array([[3, -12, 5], [40, 7, 1]])           # the widths of the first fill again
    whole = begun().text(',"c":').number(0).text("}")
    assert grown.fill(values) == whole.fill(values) == [b'{"a": 3,"b":-12,"c": 5}', b'{"a":40,"b":  7,"c": 1}']


def test_slots_showing_earlier_columns_are_the_values_repeated_with_the_kernel_and_with_numpy(rng, monkeypatch):
    """A template whose slots show columns twice (out of order) fills as the same template with every slot a
    column of its own, given the values repeated; the widths come from the columns; a bad column is an error."""
    import coordarm.simulation.json_fill as json_fill
    shown = [0, 1, 2, 1, 0, 3, 2, 3]                 # the column each slot shows
    kinds = [0, 1, 0, 1]                              # each column's kind
    reused, plain = JsonTemplate(kinds=2).text("["), JsonTemplate(kinds=2).text("[")
    for i, c in enumerate(shown):
        reused.text("," if i else "").number(kinds[c], c if c in shown[:i] else None)
        plain.text("," if i else "").number(kinds[c])
    reused.text("]")
    plain.text("]")
    assert (reused.slots, reused.columns, plain.columns) == (8, 4, 8)
    # the new columns in the order they appear: 0, 1, 2, 3 (slots 0, 1, 2, 5)
    values = rng.integers(-10 ** 7, 10 ** 7, (9, 4))
    want = plain.fill(values[:, shown])
    assert reused.fill(values) == want
    monkeypatch.setattr(json_fill, "digits_kernel", lambda: None)
    assert reused.fill(values) == want
    with pytest.raises(ValueError, match="expected shape"):
        reused.fill(values[:, :3])
    with pytest.raises(ValueError, match="column 1: not an existing column of kind 0"):
        JsonTemplate(kinds=2).number(0).number(1).number(0, 1)
    with pytest.raises(ValueError, match="column 2: not an existing column"):
        JsonTemplate(kinds=2).number(0).number(1).number(0, 2)


def test_messages_as_views_are_the_bytes_read_only(rng):
    t = JsonTemplate(kinds=1).text('{"a":').number(0).text(',"b":').number(0).text("}")
    values = rng.integers(-10 ** 9, 10 ** 9, (6, 2))
    views = t.fill(values, views=True)
    assert all(isinstance(v, memoryview) and v.readonly for v in views)
    assert [bytes(v) for v in views] == t.fill(values)
    assert t.fill(values[:0], views=True) == []
