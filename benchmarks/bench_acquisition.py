"""Sustained acquisition through the emulators: serial pty streaming and CAN frame rate.

Serial: 8 channels x 25.6 kS/s, real-time paced, from a DAQ emulator in a child process
through a pseudo-terminal to the production `SerialDaq`. CAN: 8 channels (4 frames per sample
row) on a python-can ``virtual`` bus at >= 10,000 frames/s to the production `CanDaq`.
Both must lose zero samples. Baseline timed in the same run: the frame parser alone on
in-memory bytes (the host's decoding ceiling), printed as a ratio to the required rate.

    python benchmarks/bench_acquisition.py [--seconds 60]
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from analysis.models import Model  # noqa: E402
from drivers.base import Channel
from drivers.outputs import RandomOutput  # noqa: E402
from drivers.frame import FrameParser, encode_frame  # noqa: E402
from drivers.rig import SimRig  # noqa: E402

MODEL = ROOT / "examples" / "models" / "three-dof-paper.toml"
CHANNELS = ([Channel("F0", "force", 0, 0.01)]
            + [Channel(f"x{d}", "displacement", d, 1000.0) for d in range(3)]
            + [Channel(f"v{d}", "velocity", d, 10.0) for d in range(3)]
            + [Channel("a2", "acceleration", 2, 0.01)])


def _rig(fs: float) -> SimRig:
    rig = SimRig(Model.load(MODEL), fs, 0, shaker_gain=10.0, seed=1)
    rig.set_output(RandomOutput((5.0, min(2000.0, fs / 2.5)), 1))
    rig.set_level(0.5)
    rig.set_on(True, 0.01)
    return rig


def _serial_emulator(fs: float, conn, stop) -> None:
    from drivers.emulators import SerialDaqEmulator
    emu = SerialDaqEmulator(_rig(fs), CHANNELS, pace=1.0)
    emu.start()
    conn.send(emu.port)
    stop.wait()
    emu.close()


def parser_baseline(fs: float, seconds: float = 1.0) -> float:
    """Samples per second the frame parser decodes from memory (host ceiling)."""
    volts = np.random.default_rng(0).standard_normal((256, len(CHANNELS)))
    data = b"".join(encode_frame(k, 256 * k, volts) for k in range(int(fs * seconds) // 256))
    p = FrameParser()
    t = time.perf_counter()
    n = sum(len(f.volts) for f in p.feed(data))
    return n / (time.perf_counter() - t)


def bench_serial(seconds: float, fs: float = 25600.0) -> dict:
    from drivers.serial_daq import SerialDaq
    ctx = mp.get_context("fork")
    parent, child = ctx.Pipe()
    stop = ctx.Event()
    proc = ctx.Process(target=_serial_emulator, args=(fs, child, stop), daemon=True)
    proc.start()
    port = parent.recv()
    try:
        with SerialDaq(port, stall_timeout=1.0) as daq:
            daq.configure(fs, CHANNELS, frame_size=256)
            daq.start()
            t0 = time.monotonic()
            n = 0
            while time.monotonic() - t0 < seconds:
                n += len(daq.read(timeout=2.0).data)
            elapsed = time.monotonic() - t0
            stats = daq.stats
    finally:
        stop.set()
        proc.join(5)
    return {"samples_per_s": n / elapsed, "bytes_per_s": n * (4 * len(CHANNELS)) / elapsed,
            "lost_samples": stats.lost_samples, "lost_frames": stats.lost_frames,
            "bad_frames": stats.bad_frames, "garbage_bytes": stats.garbage_bytes}


def bench_can(seconds: float, fs: float = 3200.0) -> dict:
    from drivers.can_daq import CanDaq
    from drivers.emulators import CanDaqEmulator
    emu = CanDaqEmulator(_rig(fs), CHANNELS, "virtual", "bench-can", pace=1.0)
    emu.start()
    try:
        with CanDaq("virtual", "bench-can", stall_timeout=1.0) as daq:
            daq.configure(fs, CHANNELS, frame_size=64)
            daq.start()
            t0 = time.monotonic()
            n = 0
            while time.monotonic() - t0 < seconds:
                n += len(daq.read(timeout=2.0).data)
            elapsed = time.monotonic() - t0
            stats = daq.stats
    finally:
        emu.close()
    return {"frames_per_s": stats.frames / elapsed, "samples_per_s": n / elapsed,
            "lost_samples": stats.lost_samples, "lost_frames": stats.lost_frames,
            "duplicate_frames": stats.duplicate_frames}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    args = ap.parse_args()
    fs = 25600.0
    base = parser_baseline(fs)
    print(f"baseline: frame parser decodes {base:,.0f} samples/s of 8 channels "
          f"({base / fs:.1f} x the required {fs:,.0f} S/s)")
    s = bench_serial(args.seconds, fs)
    print(f"serial pty, 8 ch x {fs:,.0f} S/s for {args.seconds:g} s: achieved "
          f"{s['samples_per_s']:,.0f} S/s per channel ({s['samples_per_s'] / fs:.3f} x "
          f"required, {s['bytes_per_s'] / 1e6:.2f} MB/s payload), lost samples "
          f"{s['lost_samples']}, lost frames {s['lost_frames']}, bad frames {s['bad_frames']}")
    c = bench_can(args.seconds)
    print(f"CAN virtual bus, 8 ch (4 frames/row) for {args.seconds:g} s: achieved "
          f"{c['frames_per_s']:,.0f} frames/s ({c['frames_per_s'] / 10000:.2f} x the 10,000 "
          f"required), {c['samples_per_s']:,.0f} rows/s, lost samples {c['lost_samples']}, "
          f"lost frames {c['lost_frames']}")
    ok = (s["lost_samples"] == 0 and s["samples_per_s"] >= 0.99 * fs
          and c["lost_samples"] == 0 and c["frames_per_s"] >= 10000)
    print("PASS" if ok else "FAIL: rate below target or samples lost")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
