"""The plant link in Python: the reference implementation, one file, standard library only.

A plant (an environment) runs as a process that speaks framed messages on its standard input
and output; the host (host-trainer, ``firmware-sim run``, :class:`PlantClient` here) sends a
request and reads one answer. This file holds the whole protocol, so it can be copied into a
project that wants nothing else:

- the codec: postcard's encoding of the messages (varints, little-endian ``f32``, enums as a
  variant index), the envelope ``{version, body}``, its CRC-32 (ISO-HDLC, ``zlib.crc32``)
  appended little-endian, COBS, and the ``0x00`` delimiter; byte for byte what firmware-sim's
  ``plant_link::messages`` writes (golden frames in ``firmware-sim/tests/data`` prove it);
- :class:`FrameReader`: frames out of a byte stream, at most :data:`MAX_FRAME` bytes each;
- :func:`serve`: the plant's side for any object with ``hello``/``reset``/``step``;
- :class:`GymnasiumPlant`: any Gymnasium environment with ``Box`` spaces as such an object;
- :class:`PlantClient`: the host's side, a plant process driven request by request;
- the command line: ``python3 -m margin_safe_rl.plant_link serve Pendulum-v1``.

The conversation (protocol version 1):

=========================  ==============================================================
host sends                 plant answers
=========================  ==============================================================
``HelloRequest``           ``HelloReply``: its name and the boxes of its one agent
``ResetRequest(seed)``     ``ResetReply(observation)``
``StepRequest(action)``    ``StepReply``: observation, reward, flags, margin, applied action
``CloseRequest``           nothing: the plant exits (it also exits when its input ends)
=========================  ==============================================================

Any request may be answered with ``ErrorReply(message)``. numpy is optional: values may be
numpy arrays, and only :class:`GymnasiumPlant` needs numpy (Gymnasium brings it).

>>> frame = encode(ResetRequest(seed=7))
>>> frame.hex()
'0901020107f5c8031d00'
>>> decode_request(frame[:-1])
ResetRequest(seed=7)
"""

from __future__ import annotations

import argparse
import math
import os
import select
import struct
import subprocess
import sys
import time
import zlib
from dataclasses import dataclass
from typing import IO, Any, Iterable, Optional, Protocol, Sequence, Union

__all__ = [
    "VERSION",
    "MAX_FRAME",
    "LinkError",
    "PlantError",
    "HelloRequest",
    "ResetRequest",
    "StepRequest",
    "CloseRequest",
    "Agent",
    "HelloReply",
    "ResetReply",
    "StepReply",
    "ErrorReply",
    "ToPlant",
    "FromPlant",
    "cobs_encode",
    "cobs_decode",
    "frame_body",
    "unframe",
    "encode",
    "decode_request",
    "decode_reply",
    "FrameReader",
    "Plant",
    "serve",
    "GymnasiumPlant",
    "UnsupportedEnv",
    "PlantClient",
    "main",
]

#: The plant protocol's version, carried by every frame (firmware-sim's ``messages::VERSION``).
VERSION = 1
#: The longest frame either side accepts, delimiter included (firmware-sim's ``MAX_FRAME``).
MAX_FRAME = 1 << 20

Values = tuple[float, ...]


class LinkError(Exception):
    """A frame that cannot be written or read: too long, garbled, another version, malformed."""


class PlantError(Exception):
    """The other side of the link failed: it said so (an error answer), exited, or hung.

    A plant's ``hello``/``reset``/``step`` may raise it too: :func:`serve` answers with its
    message as an :class:`ErrorReply`.
    """


# --- the messages ------------------------------------------------------------------------------
# Dataclasses mirroring firmware-sim's `ToPlant` and `FromPlant`; the variant indices on the wire
# are the order of the Rust enums' variants, written in each class's `_TAG`. Values are stored
# as tuples of floats whatever sequence they are given as, so messages compare and hash.


def _values(xs: Iterable[Any]) -> Values:
    """Any sequence of numbers (a list, a numpy array) as a tuple of floats."""
    return tuple(float(x) for x in xs)


@dataclass(frozen=True)
class HelloRequest:
    """Say who you are: answered by :class:`HelloReply`."""

    _TAG = 0


@dataclass(frozen=True)
class ResetRequest:
    """Start an episode; the same seed must give the same start."""

    seed: int
    _TAG = 1


@dataclass(frozen=True)
class StepRequest:
    """Apply one action (one value per action dimension)."""

    action: Sequence[float]
    _TAG = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "action", _values(self.action))


@dataclass(frozen=True)
class CloseRequest:
    """The host is done: the plant exits without answering."""

    _TAG = 3


@dataclass(frozen=True)
class Agent:
    """One agent's boxes: ``low[i] <= x[i] <= high[i]`` (observation bounds may be infinite)."""

    name: str
    observation_low: Sequence[float]
    observation_high: Sequence[float]
    action_low: Sequence[float]
    action_high: Sequence[float]

    def __post_init__(self) -> None:
        for name in ("observation_low", "observation_high", "action_low", "action_high"):
            object.__setattr__(self, name, _values(getattr(self, name)))


@dataclass(frozen=True)
class HelloReply:
    """Who the plant is: its name and its agents (exactly one in this protocol version)."""

    name: str
    agents: Sequence[Agent]
    _TAG = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "agents", tuple(self.agents))


@dataclass(frozen=True)
class ResetReply:
    """The first observation of an episode."""

    observation: Sequence[float]
    _TAG = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "observation", _values(self.observation))


@dataclass(frozen=True)
class StepReply:
    """What one action did, as Gymnasium's ``step`` says it, with the margin made explicit.

    ``applied`` is the motion the plant carried out in action units (the clipped action for a
    Gymnasium plant); ``success`` is the plant's own verdict on the episode so far, if any.
    """

    observation: Sequence[float]
    reward: float
    terminated: bool
    truncated: bool
    margin_touched: bool
    applied: Sequence[float]
    success: Optional[bool] = None
    _TAG = 2

    def __post_init__(self) -> None:
        object.__setattr__(self, "observation", _values(self.observation))
        object.__setattr__(self, "applied", _values(self.applied))
        object.__setattr__(self, "reward", float(self.reward))


@dataclass(frozen=True)
class ErrorReply:
    """The plant cannot answer the request: one line saying why."""

    message: str
    _TAG = 3


ToPlant = Union[HelloRequest, ResetRequest, StepRequest, CloseRequest]
FromPlant = Union[HelloReply, ResetReply, StepReply, ErrorReply]


# --- postcard ----------------------------------------------------------------------------------
# Only what these messages use: unsigned LEB128 varints (u16, u64, lengths, variant indices),
# f32 as 4 little-endian bytes, bool as one byte, Option as a 0/1 tag.


class _Writer:
    def __init__(self) -> None:
        self.out = bytearray()

    def varint(self, n: int) -> None:
        if n < 0:
            raise LinkError(f"a negative number {n} where an unsigned integer goes")
        while n >= 0x80:
            self.out.append((n & 0x7F) | 0x80)
            n >>= 7
        self.out.append(n)

    def f32(self, x: float) -> None:
        try:
            self.out += struct.pack("<f", x)
        except OverflowError:
            # Beyond f32's range: infinity, as Rust's `as f32` rounds it.
            self.out += struct.pack("<f", math.copysign(math.inf, x))

    def f32s(self, xs: Sequence[float]) -> None:
        self.varint(len(xs))
        for x in xs:
            self.f32(x)

    def boolean(self, b: bool) -> None:
        self.out.append(1 if b else 0)

    def string(self, s: str) -> None:
        raw = s.encode("utf-8")
        self.varint(len(raw))
        self.out += raw


class _Reader:
    def __init__(self, data: bytes) -> None:
        self.data = data
        self.pos = 0

    def take(self, n: int) -> bytes:
        if n > len(self.data) - self.pos:
            raise LinkError(f"a frame holding no message of protocol version {VERSION} (cut short)")
        chunk = self.data[self.pos : self.pos + n]
        self.pos += n
        return chunk

    def varint(self, bits: int) -> int:
        """An unsigned varint of at most ``bits`` bits (postcard refuses anything wider)."""
        n, shift = 0, 0
        while True:
            byte = self.take(1)[0]
            n |= (byte & 0x7F) << shift
            if not byte & 0x80:
                break
            shift += 7
            if shift >= bits + 7:
                raise LinkError(f"a varint longer than a u{bits}")
        if n >> bits:
            raise LinkError(f"a varint larger than a u{bits}")
        return n

    def length(self, item_size: int) -> int:
        # A length must fit the bytes left: a garbled length cannot make us allocate.
        n = self.varint(64)
        if n * item_size > len(self.data) - self.pos:
            raise LinkError(f"a length of {n} beyond the end of the frame")
        return n

    def f32(self) -> float:
        return float(struct.unpack("<f", self.take(4))[0])

    def f32s(self) -> Values:
        n = self.length(4)
        return struct.unpack(f"<{n}f", self.take(4 * n))

    def boolean(self) -> bool:
        b = self.take(1)[0]
        if b > 1:
            raise LinkError(f"a bool of {b}, expected 0 or 1")
        return b == 1

    def string(self) -> str:
        raw = self.take(self.length(1))
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as e:
            raise LinkError(f"a string that is not UTF-8 ({e})") from None

    def end(self) -> None:
        # The message must fill the body: a shorter reading is another message misread.
        if self.pos != len(self.data):
            raise LinkError(
                f"a frame holding no message of plant protocol version {VERSION} "
                f"({len(self.data) - self.pos} bytes left over)"
            )


def _write_message(message: Union[ToPlant, FromPlant]) -> bytes:
    w = _Writer()
    w.varint(message._TAG)
    if isinstance(message, ResetRequest):
        w.varint(message.seed)
        if message.seed >> 64:
            raise LinkError(f"a seed of {message.seed}, expected 0 to 2^64 - 1")
    elif isinstance(message, StepRequest):
        w.f32s(message.action)
    elif isinstance(message, HelloReply):
        w.string(message.name)
        w.varint(len(message.agents))
        for agent in message.agents:
            w.string(agent.name)
            for values in (agent.observation_low, agent.observation_high):
                w.f32s(values)
            for values in (agent.action_low, agent.action_high):
                w.f32s(values)
    elif isinstance(message, ResetReply):
        w.f32s(message.observation)
    elif isinstance(message, StepReply):
        w.f32s(message.observation)
        w.f32(message.reward)
        for flag in (message.terminated, message.truncated, message.margin_touched):
            w.boolean(flag)
        w.f32s(message.applied)
        if message.success is None:
            w.out.append(0)
        else:
            w.out.append(1)
            w.boolean(message.success)
    elif isinstance(message, ErrorReply):
        w.string(message.message)
    elif not isinstance(message, (HelloRequest, CloseRequest)):
        raise TypeError(f"not a plant link message: {message!r}")
    return bytes(w.out)


def _read_request(r: _Reader) -> ToPlant:
    tag = r.varint(32)
    if tag == 0:
        return HelloRequest()
    if tag == 1:
        return ResetRequest(seed=r.varint(64))
    if tag == 2:
        return StepRequest(action=r.f32s())
    if tag == 3:
        return CloseRequest()
    raise LinkError(f"a request of variant {tag}, expected 0 to 3 (hello, reset, step, close)")


def _read_agent(r: _Reader) -> Agent:
    name = r.string()
    return Agent(name, r.f32s(), r.f32s(), r.f32s(), r.f32s())


def _read_reply(r: _Reader) -> FromPlant:
    tag = r.varint(32)
    if tag == 0:
        name = r.string()
        return HelloReply(name, tuple(_read_agent(r) for _ in range(r.length(1))))
    if tag == 1:
        return ResetReply(observation=r.f32s())
    if tag == 2:
        observation, reward = r.f32s(), r.f32()
        terminated, truncated, margin_touched = r.boolean(), r.boolean(), r.boolean()
        applied = r.f32s()
        option = r.take(1)[0]
        if option > 1:
            raise LinkError(f"an Option tag of {option}, expected 0 or 1")
        success = r.boolean() if option else None
        return StepReply(
            observation, reward, terminated, truncated, margin_touched, applied, success
        )
    if tag == 3:
        return ErrorReply(message=r.string())
    raise LinkError(f"an answer of variant {tag}, expected 0 to 3 (hello, reset, step, error)")


# --- frames ------------------------------------------------------------------------------------


def cobs_encode(data: bytes) -> bytes:
    """COBS as postcard's ``Cobs`` flavor writes it (no delimiter): every block ends with a code,
    a final one after a full 254-byte run included.

    >>> cobs_encode(b"\\x11\\x00\\x22").hex()
    '02110222'
    """
    out = bytearray(b"\x00")
    code_at, code = 0, 1
    for byte in data:
        if byte == 0:
            out[code_at] = code
            code_at, code = len(out), 1
            out.append(0)
            continue
        out.append(byte)
        code += 1
        if code == 0xFF:
            out[code_at] = code
            code_at, code = len(out), 1
            out.append(0)
    out[code_at] = code
    return bytes(out)


def cobs_decode(frame: bytes) -> bytes:
    """Undoes :func:`cobs_encode` on the bytes before the delimiter.

    >>> cobs_decode(bytes.fromhex("02110222")).hex()
    '110022'
    """
    out = bytearray()
    i, n = 0, len(frame)
    while i < n:
        code = frame[i]
        if code == 0 or i + code > n:
            raise LinkError("a garbled frame (invalid COBS)")
        out += frame[i + 1 : i + code]
        i += code
        if code != 0xFF and i < n:
            out.append(0)
    return bytes(out)


def frame_body(body: bytes, version: int = VERSION) -> bytes:
    """Frames a message's postcard bytes: the envelope ``{version, body}``, its CRC-32
    little-endian, COBS and the ``0x00`` delimiter (hil-protocol's ``frame_body``)."""
    w = _Writer()
    w.varint(version)
    w.varint(len(body))
    envelope = bytes(w.out) + body
    return cobs_encode(envelope + zlib.crc32(envelope).to_bytes(4, "little")) + b"\x00"


def unframe(frame: bytes) -> tuple[int, bytes]:
    """Undoes :func:`frame_body` on the bytes before the delimiter: the version and the body,
    whatever the version. Raises :class:`LinkError` on bad COBS, CRC or length."""
    if len(frame) >= MAX_FRAME:
        raise LinkError(f"a frame longer than {MAX_FRAME} bytes")
    data = cobs_decode(frame)
    if len(data) < 4:
        raise LinkError("a truncated frame")
    envelope, crc = data[:-4], int.from_bytes(data[-4:], "little")
    if zlib.crc32(envelope) != crc:
        raise LinkError("a garbled frame (CRC-32 mismatch)")
    r = _Reader(envelope)
    version = r.varint(16)
    body = r.take(r.length(1))
    r.end()
    return version, body


def encode(message: Union[ToPlant, FromPlant], version: int = VERSION) -> bytes:
    """One message as a frame, its ``0x00`` delimiter included.

    >>> encode(CloseRequest()).hex()
    '08010103ded3917e00'
    """
    frame = frame_body(_write_message(message), version)
    if len(frame) > MAX_FRAME:
        raise LinkError(f"a frame longer than {MAX_FRAME} bytes")
    return frame


def _decode(frame: bytes, read: Any) -> Any:
    version, body = unframe(frame)
    if version != VERSION:
        raise LinkError(
            f"a frame of plant protocol version {version}; this side speaks version {VERSION}"
        )
    r = _Reader(body)
    message = read(r)
    r.end()
    return message


def decode_request(frame: bytes) -> ToPlant:
    """The request in one frame (the bytes before the delimiter)."""
    return _decode(frame, _read_request)  # type: ignore[no-any-return]


def decode_reply(frame: bytes) -> FromPlant:
    """The answer in one frame (the bytes before the delimiter)."""
    return _decode(frame, _read_reply)  # type: ignore[no-any-return]


class FrameReader:
    """Frames out of a binary stream: the bytes before each ``0x00`` (empty frames skipped).

    A frame longer than ``limit`` is read to its delimiter and refused with :class:`LinkError`,
    so memory stays bounded and the next frame reads normally. With ``timeout`` (seconds, for
    a pipe or socket with a file descriptor) a read that waits longer raises ``TimeoutError``.
    """

    def __init__(self, stream: IO[bytes], limit: int = MAX_FRAME) -> None:
        self._stream = stream
        self._read = getattr(stream, "read1", stream.read)
        self._limit = limit
        self._buf = bytearray()

    def read(self, timeout: Optional[float] = None) -> Optional[bytes]:
        """The next frame, or ``None`` at the end of the stream (a half frame is no frame)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        too_long = False
        while True:
            at = self._buf.find(0)
            if at >= 0:
                frame = bytes(self._buf[:at])
                del self._buf[: at + 1]
                if too_long or len(frame) >= self._limit:
                    raise LinkError(f"a frame longer than {self._limit} bytes")
                if frame:
                    return frame
                continue
            if len(self._buf) >= self._limit:
                too_long = True
                self._buf.clear()
            if deadline is not None:
                left = deadline - time.monotonic()
                if left <= 0 or not select.select([self._stream], [], [], left)[0]:
                    raise TimeoutError(f"no frame within {timeout} s")
            chunk = self._read(1 << 16)
            if not chunk:
                return None
            self._buf += chunk


# --- the plant's side --------------------------------------------------------------------------


class Plant(Protocol):
    """What :func:`serve` serves: a plant of one agent. Raise :class:`PlantError` to answer a
    request with an error."""

    def hello(self) -> HelloReply:
        """The plant's name and boxes."""

    def reset(self, seed: int) -> Sequence[float]:
        """Starts an episode from ``seed``; the first observation."""

    def step(self, action: Sequence[float]) -> StepReply:
        """Applies one action (of the hello's size: :func:`serve` checks)."""


def _log(message: str) -> None:
    print(f"margin_safe_rl.plant_link: {message}", file=sys.stderr, flush=True)


def _answer(plant: Plant, action_size: int, request: ToPlant) -> FromPlant:
    if isinstance(request, HelloRequest):
        return plant.hello()
    if isinstance(request, ResetRequest):
        return ResetReply(plant.reset(request.seed))
    assert isinstance(request, StepRequest)
    if len(request.action) != action_size:
        return ErrorReply(f"an action of {len(request.action)} values, expected {action_size}")
    return plant.step(request.action)


def serve(plant: Plant, stdin: IO[bytes], stdout: IO[bytes]) -> None:
    """Answers requests from ``stdin`` on ``stdout`` until a close request or the end of
    ``stdin``. An undecodable frame, an action of the wrong size or an exception in the plant
    is answered with :class:`ErrorReply` (and logged on stderr), never a traceback on the link.

    >>> import io
    >>> class Still:
    ...     def hello(self):
    ...         return HelloReply("still", [Agent("agent", [-1.0], [1.0], [-1.0], [1.0])])
    ...     def reset(self, seed):
    ...         return [0.0]
    ...     def step(self, action):
    ...         return StepReply([0.0], 0.0, False, False, False, action)
    >>> out = io.BytesIO()
    >>> serve(Still(), io.BytesIO(encode(StepRequest([1, 2])) + encode(CloseRequest())), out)
    >>> decode_reply(out.getvalue()[:-1])
    ErrorReply(message='an action of 2 values, expected 1')
    """
    reader = FrameReader(stdin)
    action_size = len(plant.hello().agents[0].action_low)
    while True:
        try:
            frame = reader.read()
            if frame is None:
                return
            request = decode_request(frame)
        except LinkError as e:
            answer: FromPlant = ErrorReply(f"the Python plant could not read the request: {e}")
        else:
            if isinstance(request, CloseRequest):
                return
            try:
                answer = _answer(plant, action_size, request)
            except PlantError as e:
                answer = ErrorReply(str(e))
            except Exception as e:  # noqa: BLE001 - the host gets one line, never a traceback
                answer = ErrorReply(f"{type(e).__name__}: {e}")
        if isinstance(answer, ErrorReply):
            _log(answer.message)
        stdout.write(encode(answer))
        stdout.flush()


class UnsupportedEnv(Exception):
    """An environment the link cannot serve (a space that is not a ``Box``)."""


class GymnasiumPlant:
    """Any Gymnasium environment with ``Box`` spaces as a :class:`Plant`.

    Observations and rewards go as ``float32``, spaces flattened. An action outside the
    action box is clipped to it: ``margin_touched`` says it had to be, ``applied`` is the
    clipped action. ``success`` is ``info["is_success"]`` where the environment gives it as a
    bool, else ``None``.
    """

    def __init__(self, env: Any, name: str) -> None:
        import numpy as np
        from gymnasium import spaces

        for role, space in (("observation", env.observation_space), ("action", env.action_space)):
            if not isinstance(space, spaces.Box):
                raise UnsupportedEnv(
                    f"{name}'s {role} space is {space}; the plant link serves Box spaces only"
                )
        self._np = np
        self.env = env
        self._name = name
        self._action_space = env.action_space
        # Actions are clipped to the box the hello declares, in float32: an action on its edge
        # is inside it, whatever the environment's own dtype rounds its bounds to.
        declared = lambda x: np.asarray(x, dtype=np.float32).astype(np.float64)  # noqa: E731
        self._low, self._high = declared(env.action_space.low), declared(env.action_space.high)

    def hello(self) -> HelloReply:
        o, a = self.env.observation_space, self.env.action_space
        flat = self._float32s
        agent = Agent("agent", flat(o.low), flat(o.high), flat(a.low), flat(a.high))
        return HelloReply(self._name, (agent,))

    def _float32s(self, values: Any) -> list[float]:
        return list(self._np.asarray(values, dtype=self._np.float32).ravel().tolist())

    def reset(self, seed: int) -> Sequence[float]:
        observation, _info = self.env.reset(seed=seed)
        return self._float32s(observation)

    def step(self, action: Sequence[float]) -> StepReply:
        np = self._np
        wanted = np.asarray(action, dtype=np.float64).reshape(self._action_space.shape)
        clipped = np.clip(wanted, self._low, self._high)
        space = self._action_space
        # The float32 edge may lie a rounding beyond a float64 bound: that is no margin.
        inside = np.clip(clipped, space.low, space.high).astype(space.dtype)
        observation, reward, terminated, truncated, info = self.env.step(inside)
        success = info.get("is_success") if isinstance(info, dict) else None
        return StepReply(
            observation=self._float32s(observation),
            reward=float(np.float32(reward)),
            terminated=bool(terminated),
            truncated=bool(truncated),
            margin_touched=bool(np.any(clipped != wanted)),
            applied=self._float32s(clipped),
            success=bool(success) if isinstance(success, (bool, np.bool_)) else None,
        )


# --- the host's side ---------------------------------------------------------------------------


def _finite(x: float) -> float:
    return x if math.isfinite(x) else 0.0


class PlantClient:
    """A plant process driven over the link: started, asked for its hello, then one request
    and one answer at a time, each awaited for at most ``timeout`` seconds (``start_timeout``
    for the hello). Any failure (the plant exits, hangs, answers an error or garbage) raises
    :class:`PlantError` with one line naming the plant.
    """

    def __init__(
        self,
        argv: Sequence[str],
        timeout: float = 10.0,
        start_timeout: float = 60.0,
        environ: Optional[dict[str, str]] = None,
    ) -> None:
        self.argv = list(argv)
        self.timeout = timeout
        try:
            self._process = subprocess.Popen(
                self.argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, bufsize=0, env=environ
            )
        except OSError as e:
            raise PlantError(f"plant {self._command()!r}: cannot start: {e}") from None
        assert self._process.stdout is not None
        self._frames = FrameReader(self._process.stdout)
        try:
            answer = self.request(HelloRequest(), start_timeout)
            if not isinstance(answer, HelloReply):
                raise self._error(f"answered the hello with {type(answer).__name__}")
            if len(answer.agents) != 1:
                raise self._error(f"its hello declares {len(answer.agents)} agents, expected 1")
        except PlantError:
            self.close()
            raise
        self.hello: HelloReply = answer

    def _command(self) -> str:
        return " ".join(self.argv)

    def _error(self, message: str) -> PlantError:
        return PlantError(f"plant {self._command()!r}: {message}")

    def _exit_reason(self) -> str:
        try:
            status = self._process.wait(timeout=2)
        except subprocess.TimeoutExpired:
            return "it closed its output"
        return f"it exited with status {status}"

    def request(self, message: ToPlant, timeout: Optional[float] = None) -> FromPlant:
        """Sends one request and returns its answer (an :class:`ErrorReply` raises)."""
        assert self._process.stdin is not None
        name = type(message).__name__
        try:
            self._process.stdin.write(encode(message))
            self._process.stdin.flush()
        except (BrokenPipeError, ValueError):
            why = self._exit_reason()
            raise self._error(f"{name}: {why} before the request was sent") from None
        wait = self.timeout if timeout is None else timeout
        try:
            frame = self._frames.read(wait)
        except TimeoutError:
            raise self._error(f"{name}: no answer within {wait} s") from None
        except LinkError as e:
            raise self._error(f"{name}: sent {e}") from None
        if frame is None:
            raise self._error(f"{name}: {self._exit_reason()} before answering")
        try:
            answer = decode_reply(frame)
        except LinkError as e:
            raise self._error(f"{name}: sent {e}") from None
        if isinstance(answer, ErrorReply):
            raise self._error(f"{name}: the plant says: {answer.message}")
        return answer

    def _checked(self, what: str, values: Sequence[float], size: int) -> Sequence[float]:
        if len(values) != size:
            raise self._error(f"an {what} of {len(values)} values, expected {size}")
        return values

    def reset(self, seed: int) -> Sequence[float]:
        """Starts an episode; the first observation."""
        answer = self.request(ResetRequest(seed))
        if not isinstance(answer, ResetReply):
            raise self._error(f"answered a reset with {type(answer).__name__}")
        size = len(self.hello.agents[0].observation_low)
        return self._checked("observation", answer.observation, size)

    def step(self, action: Iterable[float]) -> StepReply:
        """Applies one action (non-finite values sent as 0, as firmware-sim's host does)."""
        answer = self.request(StepRequest([_finite(float(a)) for a in action]))
        if not isinstance(answer, StepReply):
            raise self._error(f"answered a step with {type(answer).__name__}")
        self._checked("observation", answer.observation, len(self.hello.agents[0].observation_low))
        return answer

    def close(self, wait: float = 1.0) -> Optional[int]:
        """Sends a close request, waits up to ``wait`` seconds, then kills; the exit status."""
        process = self._process
        if process.poll() is None and process.stdin is not None:
            try:
                process.stdin.write(encode(CloseRequest()))
                process.stdin.close()
            except (BrokenPipeError, ValueError):
                pass
        try:
            return process.wait(timeout=wait)
        except subprocess.TimeoutExpired:
            process.kill()
            return process.wait()
        finally:
            if process.stdout is not None:
                process.stdout.close()


# --- the command line --------------------------------------------------------------------------


def _serve_gymnasium(args: argparse.Namespace) -> int:
    # Frames own the real stdout; anything else written there (a library's banner, a print in
    # the environment, C code) goes to stderr instead of corrupting the link.
    frames_out = os.fdopen(os.dup(sys.stdout.fileno()), "wb", buffering=0)
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    sys.stdout = sys.stderr
    try:
        import gymnasium
    except ImportError:
        _log("cannot import gymnasium: pip install gymnasium")
        return 2
    kwargs = {} if args.max_episode_steps is None else {"max_episode_steps": args.max_episode_steps}
    try:
        env = gymnasium.make(args.env_id, **kwargs)
        plant = GymnasiumPlant(env, args.env_id)
    except UnsupportedEnv as e:
        _log(str(e))
        return 2
    except Exception as e:  # noqa: BLE001 - one line, as every CLI error here
        _log(f"cannot make {args.env_id}: {type(e).__name__}: {e}")
        return 2
    try:
        serve(plant, sys.stdin.buffer, frames_out)
    except BrokenPipeError:
        _log("the host closed the link")
        return 1
    finally:
        env.close()
    return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``python3 -m margin_safe_rl.plant_link serve ENV_ID [--max-episode-steps N]``."""
    parser = argparse.ArgumentParser(
        prog="python3 -m margin_safe_rl.plant_link",
        description="Serve a Gymnasium environment as a plant over the plant link "
        "(frames on stdin/stdout, log on stderr).",
    )
    commands = parser.add_subparsers(dest="command", required=True)
    serve_cmd = commands.add_parser("serve", help="serve a Gymnasium environment (Box spaces)")
    serve_cmd.add_argument("env_id", help="a registered id, e.g. Pendulum-v1 or module:Env-v0")
    serve_cmd.add_argument(
        "--max-episode-steps", type=int, default=None, help="override the time limit"
    )
    args = parser.parse_args(argv)
    return _serve_gymnasium(args)


if __name__ == "__main__":
    sys.exit(main())
