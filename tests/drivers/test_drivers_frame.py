"""Binary frame codec and resynchronising parser (serial DAQ)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.frame import SYNC, FrameParser, encode_frame, frame_length


def _frame(seq, n=4, c=3, first=None):
    volts = np.arange(n * c, dtype=np.float32).reshape(n, c) + seq
    return encode_frame(seq, seq * n if first is None else first, volts), volts


def test_round_trip():
    raw, volts = _frame(7)
    assert raw.startswith(SYNC) and len(raw) == frame_length(3, 4)
    (frame,) = FrameParser().feed(raw)
    assert frame.seq == 7 and frame.first_sample == 28
    np.testing.assert_array_equal(frame.volts, volts)


def test_resync_after_garbage_and_corruption():
    a, _ = _frame(0)
    b, _ = _frame(1)
    c, _ = _frame(2)
    bad = bytearray(b)
    bad[30] ^= 0x55
    p = FrameParser()
    frames = p.feed(b"\xa5\x5a\x01garbage\xa5" + a + bytes(bad) + b"\xa5\x5a" + c)
    assert [f.seq for f in frames] == [0, 2]
    assert p.bad_frames == 1 and p.garbage_bytes > 0


chunks = st.lists(st.one_of(st.integers(0, 20).map(lambda s: ("frame", s)),
                            st.binary(max_size=40).map(lambda b: ("junk", b))), max_size=25)


@settings(max_examples=150, deadline=None)
@given(chunks, st.lists(st.integers(1, 97), min_size=1, max_size=8))
def test_parser_finds_exactly_the_frames(parts, cuts):
    """Any mix of valid frames and junk, fed in arbitrary pieces: every frame comes out, in
    order, unchanged; nothing raises. (Junk could in principle contain a valid frame with
    both CRCs right; random junk of this size never does.)"""
    stream, expected = b"", []
    for kind, value in parts:
        if kind == "frame":
            raw, volts = _frame(value)
            stream += raw
            expected.append((value, volts))
        else:
            stream += value
    p, got, pos, i = FrameParser(), [], 0, 0
    while pos < len(stream):
        step = cuts[i % len(cuts)]
        got += p.feed(stream[pos:pos + step])
        pos, i = pos + step, i + 1
    assert [f.seq for f in got] == [s for s, _ in expected]
    for f, (_, volts) in zip(got, expected):
        np.testing.assert_array_equal(f.volts, volts)
