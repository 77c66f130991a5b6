"""The Python codec against firmware-sim's golden frames (firmware-sim/tests/data/
plant-link-frames.json, written by its tests/plant_link_frames.rs): every message encodes to
the committed bytes and the committed bytes decode to the message, floats compared by bits."""

from __future__ import annotations

import re
import struct
from typing import Any

import pytest

from paths import load_golden
from margin_safe_rl import plant_link as pl

FRAMES = load_golden("plant-link-frames.json")["frames"]


def f32(bits: int) -> float:
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def f32s(bits: list[int]) -> tuple[float, ...]:
    return tuple(f32(b) for b in bits)


def bits(values: Any) -> list[int]:
    return [struct.unpack("<I", struct.pack("<f", v))[0] for v in values]


def build(direction: str, description: dict[str, Any]) -> Any:
    """The Python message a golden description stands for."""
    ((kind, fields),) = description.items()
    if direction == "to_plant":
        if kind == "Hello":
            return pl.HelloRequest()
        if kind == "Reset":
            return pl.ResetRequest(fields["seed"])
        if kind == "Step":
            return pl.StepRequest(f32s(fields["action"]))
        assert kind == "Close"
        return pl.CloseRequest()
    if kind == "Hello":
        agents = [
            pl.Agent(
                a["name"],
                *(f32s(a[k]) for k in ("observation_low", "observation_high")),
                *(f32s(a[k]) for k in ("action_low", "action_high")),
            )
            for a in fields["agents"]
        ]
        return pl.HelloReply(fields["name"], agents)
    if kind == "Reset":
        return pl.ResetReply(f32s(fields["observation"]))
    if kind == "Step":
        return pl.StepReply(
            observation=f32s(fields["observation"]),
            reward=f32(fields["reward"]),
            terminated=fields["terminated"],
            truncated=fields["truncated"],
            margin_touched=fields["margin_touched"],
            applied=f32s(fields["applied"]),
            success=fields["success"],
        )
    assert kind == "Error"
    return pl.ErrorReply(fields["message"])


def describe(message: Any) -> Any:
    """A message with its floats as bits, so NaN compares equal to itself."""
    out = {}
    for name, value in vars(message).items():
        if isinstance(value, tuple) and value and isinstance(value[0], pl.Agent):
            value = [describe(a) for a in value]
        elif isinstance(value, tuple):
            value = bits(value)
        elif isinstance(value, float):
            value = bits([value])
        out[name] = value
    return type(message).__name__, out


def test_the_golden_file_covers_every_message() -> None:
    kinds = {(f["direction"], next(iter(f["message"]))) for f in FRAMES}
    assert kinds == {
        *(("to_plant", k) for k in ("Hello", "Reset", "Step", "Close")),
        *(("from_plant", k) for k in ("Hello", "Reset", "Step", "Error")),
    }


@pytest.mark.parametrize("golden", FRAMES, ids=[f["what"] for f in FRAMES])
def test_encode_writes_rusts_bytes(golden: dict[str, Any]) -> None:
    message = build(golden["direction"], golden["message"])
    assert pl.encode(message).hex() == golden["frame"]


@pytest.mark.parametrize("golden", FRAMES, ids=[f["what"] for f in FRAMES])
def test_decode_reads_rusts_bytes(golden: dict[str, Any]) -> None:
    frame = bytes.fromhex(golden["frame"])
    assert frame[-1] == 0 and 0 not in frame[:-1]
    decode = pl.decode_request if golden["direction"] == "to_plant" else pl.decode_reply
    decoded = decode(frame[:-1])
    assert describe(decoded) == describe(build(golden["direction"], golden["message"]))


def test_a_changed_byte_is_a_crc_error() -> None:
    frame = bytearray(bytes.fromhex(FRAMES[1]["frame"])[:-1])
    frame[3] ^= 0x40
    with pytest.raises(pl.LinkError, match="CRC-32"):
        pl.decode_request(bytes(frame))


def test_another_version_is_refused() -> None:
    frame = pl.encode(pl.HelloRequest(), version=2)
    with pytest.raises(pl.LinkError, match="version 2; this side speaks version 1"):
        pl.decode_request(frame[:-1])


def test_a_reply_is_not_a_request() -> None:
    # A step answer read as a request: variant 2 is a step request, whose body then is wrong.
    frame = bytes.fromhex(next(f for f in FRAMES if f["what"] == "error")["frame"])
    with pytest.raises(pl.LinkError):
        pl.decode_request(frame[:-1])


@pytest.mark.parametrize("n", [0, 1, 253, 254, 255, 508, 509, 1000])
def test_cobs_round_trips_runs_of_any_length(n: int) -> None:
    for data in (bytes([7]) * n, bytes(n), bytes([0, 5]) * n):
        encoded = pl.cobs_encode(data)
        assert 0 not in encoded
        assert pl.cobs_decode(encoded) == data


def test_frame_reader_refuses_a_frame_too_long_and_reads_on() -> None:
    import io

    good = pl.encode(pl.CloseRequest())
    stream = io.BytesIO(b"\x01" * 300 + b"\x00" + good + b"\x00\x00" + b"\x05\x05")
    reader = pl.FrameReader(stream, limit=256)
    with pytest.raises(pl.LinkError, match="longer than 256"):
        reader.read()
    assert reader.read() == good[:-1]
    assert reader.read() is None  # a half frame before the end is no frame


def test_the_byte_by_byte_exchange_in_docs_reads_and_writes_back() -> None:
    """docs/own-plant.md's exchange with serve-plant: each frame decodes and encodes again to
    the same bytes, so the page and the Python codec agree."""
    from paths import REPO

    page = (REPO / "docs" / "own-plant.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| (host|plant) \| `([0-9a-f ]+)` \|", page, re.M)
    assert len(rows) >= 4
    for side, text in rows:
        frame = bytes.fromhex(text)
        decode = pl.decode_request if side == "host" else pl.decode_reply
        message = decode(frame[:-1])
        assert pl.encode(message) == frame, (side, text, message)
