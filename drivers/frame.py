"""Binary sample frame of the serial DAQ, and an incremental parser that resynchronises.

Layout (little-endian; documented in docs/drivers.md)::

    offset  size  field
    0       2     sync word 0xA5 0x5A
    2       1     version (1)
    3       1     channel count C (1..64)
    4       4     sequence counter (uint32, +1 per frame, wraps)
    8       8     index of the first sample since stream start (uint64)
    16      2     samples per channel N (0..4096; 0: a heartbeat, the stream is alive)
    18      2     header CRC: CRC-16/CCITT (binascii.crc_hqx, init 0xFFFF) of bytes 2..17
    20      4*N*C samples, float32 volts, sample-major (s0c0, s0c1, ..., s1c0, ...)
    end     4     CRC-32 (zlib.crc32) of bytes 2..end of samples

The header CRC lets the parser reject a false sync word in garbage without waiting for a
bogus frame length; the CRC-32 rejects corrupted payloads.
"""

from __future__ import annotations

import binascii
import struct
import zlib
from dataclasses import dataclass

import numpy as np

SYNC = b"\xa5\x5a"
VERSION = 1
HEADER = struct.Struct("<2sBBIQHH")
MAX_CHANNELS = 64
MAX_SAMPLES = 4096


@dataclass
class Frame:
    """One decoded frame."""

    seq: int
    first_sample: int
    volts: np.ndarray  # (N, C) float32


def encode_frame(seq: int, first_sample: int, volts: np.ndarray) -> bytes:
    """Return the bytes of one frame holding ``volts`` of shape (N, C)."""
    volts = np.ascontiguousarray(volts, dtype="<f4")
    n, c = volts.shape
    head = struct.pack("<BBIQH", VERSION, c, seq & 0xFFFFFFFF, first_sample, n)
    hcrc = binascii.crc_hqx(head, 0xFFFF)
    body = head + struct.pack("<H", hcrc) + volts.tobytes()
    return SYNC + body + struct.pack("<I", zlib.crc32(body))


def frame_length(n_channels: int, n_samples: int) -> int:
    """Bytes of a frame holding ``n_samples`` samples of ``n_channels`` channels."""
    return HEADER.size + 4 * n_channels * n_samples + 4


class FrameParser:
    """Feed bytes in, get whole valid frames out.

    Bytes that cannot start a valid frame are skipped one at a time and counted in
    ``garbage_bytes``; frames with a good header but a bad CRC-32 are counted in
    ``bad_frames`` and skipped.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self.garbage_bytes = 0
        self.bad_frames = 0

    def feed(self, data: bytes) -> list[Frame]:
        """Add received bytes; return the whole valid frames they complete.

        Parameters
        ----------
        data : bytes

        Returns
        -------
        list of Frame
        """
        self._buf += data
        frames: list[Frame] = []
        buf = self._buf
        pos = 0
        while True:
            start = buf.find(SYNC, pos)
            if start < 0:
                # keep a trailing 0xA5 that may be the first half of a sync word
                keep = 1 if buf.endswith(SYNC[:1]) else 0
                self.garbage_bytes += len(buf) - pos - keep
                pos = len(buf) - keep
                break
            self.garbage_bytes += start - pos
            pos = start
            if len(buf) - pos < HEADER.size:
                break
            _, ver, c, seq, first, n, hcrc = HEADER.unpack_from(buf, pos)
            if (ver != VERSION or not 1 <= c <= MAX_CHANNELS or not 0 <= n <= MAX_SAMPLES
                    or binascii.crc_hqx(bytes(buf[pos + 2:pos + 18]), 0xFFFF) != hcrc):
                self.garbage_bytes += 1
                pos += 1
                continue
            total = frame_length(c, n)
            if len(buf) - pos < total:
                break
            body = bytes(buf[pos + 2:pos + total - 4])
            (crc,) = struct.unpack_from("<I", buf, pos + total - 4)
            if zlib.crc32(body) != crc:
                self.bad_frames += 1
                self.garbage_bytes += 1
                pos += 1
                continue
            volts = np.frombuffer(body, dtype="<f4", offset=HEADER.size - 2).reshape(n, c)
            frames.append(Frame(seq, first, volts))
            pos += total
        del buf[:pos]
        return frames
