"""Drive-zero latency of a campaign on the emulators (issue 26 item 5), for the realtime test
(tests/nlid_lab/campaign/test_drive_zero.py) and benchmarks/bench_drive_zero.py.

A random campaign with default settings runs on the serial shaker emulator and a serial
(pseudo-terminal) or CAN (python-can ``virtual`` bus) DAQ emulator; once the drive is on, one
fault is injected: the DAQ stream stalls or disconnects, or the shaker link is cut (every
byte lost) or the controller hangs. The latency is from the fault to the drive at zero: the
first time the rig is switched off after the fault (the host's emergency stop, or the
controller's own link watchdog) plus the controller's emergency ramp (`ESTOP_RAMP`).
"""

from __future__ import annotations

import contextlib
import copy
import subprocess
import sys
import threading
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drivers.emulators._serial_emu import ESTOP_RAMP
from drivers.errors import CommsError
from nlid_lab.campaign import parse_campaign, run_campaign

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
BACKENDS = ("serial", "can")
FAULTS = ("daq-stall", "daq-disconnect", "shaker-cut", "shaker-stall")
#: DAQ frame of the DAQ faults: ~0.8 s into the stream at the emulators' default pace (8x
#: serial, 4x CAN); CAN counts one frame per sample row
DAQ_FAULT_FRAME = {"serial": 200, "can": 3200}
SHAKER_FAULT_AFTER = 0.5  # s after the output went on


@dataclass(frozen=True)
class Latency:
    """One measurement: what failed and how long until the drive was zero."""

    backend: str
    fault: str
    seconds: float          # fault -> drive at zero, s
    error: str              # what the campaign ended with
    #: shaker faults: fault -> the controller's trip deadline + its ramp, s: when a controller
    #: on its own clock zeroes the drive (the emulated one shares this busy process and may
    #: act late); None for DAQ faults
    deadline_seconds: float | None = None


def campaign_doc(backend: str, name: str, **changes: dict[str, Any]) -> dict:
    """The serial random example with ``backend``'s DAQ, one level, many averages (the fault
    comes long before it ends), default timing settings; ``changes`` update its tables."""
    doc = tomllib.loads((EXAMPLES / "campaign-serial-random.toml").read_text())
    doc = copy.deepcopy(doc)
    doc["daq"].pop("comms_timeout", None)       # the example's room for a busy machine:
    doc["shaker"].pop("watchdog", None)         # the defaults are what is measured
    if backend == "can":
        doc["daq"]["url"] = f"can-emu://virtual/{name}"
    doc["random"].update(levels=[20.0], averages=40)
    for key, value in changes.items():
        doc[key] = {**doc.get(key, {}), **value}
    return doc


def _watch_off(rig) -> list[float]:
    """Times the rig's output is switched off from now on."""
    offs: list[float] = []
    switch = rig.set_on

    def set_on(on: bool, ramp_time: float) -> None:
        switch(on, ramp_time)
        if not on:
            offs.append(time.monotonic())
    rig.set_on = set_on
    return offs


def _shaker_fault(bench, fault: str, when: list[float]) -> None:
    """Cut or hang the shaker link `SHAKER_FAULT_AFTER` s after the output went on."""
    emu = bench.shaker_emulator

    def inject() -> None:
        deadline = time.monotonic() + 60
        while not any(line == "OUTP ON" for _, line in list(emu.log)):
            if time.monotonic() > deadline:
                return
            time.sleep(0.002)
        time.sleep(SHAKER_FAULT_AFTER)
        when.append(time.monotonic())
        setattr(emu, "unplugged" if fault == "shaker-cut" else "stall", True)
    threading.Thread(target=inject, daemon=True).start()


class FalseTrip(AssertionError):
    """The campaign stopped before the fault: the defaults tripped at normal pacing."""


def measure(backend: str, fault: str, out: Path, **changes: dict[str, Any]) -> Latency:
    """Run the campaign into ``out`` with one ``fault`` and measure the drive-zero latency.

    Raises
    ------
    FalseTrip
        The campaign stopped before the fault was injected.
    """
    faults = {}
    if fault.startswith("daq-"):
        key = "stall_at" if fault == "daq-stall" else "disconnect_at"
        faults = {"emulator": {"faults": {key: DAQ_FAULT_FRAME[backend]}}}
    doc = campaign_doc(backend, f"dz-{out.stem}", **faults, **changes)
    benches, offs, when = [], [], []

    def on_bench(bench) -> None:
        benches.append(bench)
        offs.append(_watch_off(bench.rig))
        if fault.startswith("shaker-"):
            _shaker_fault(bench, fault, when)

    try:
        run_campaign(parse_campaign(doc, EXAMPLES), out, on_bench=on_bench)
        error = "completed"
    except CommsError as exc:
        error = f"{type(exc).__name__}: {exc}"
    bench = benches[0]
    t_fault = bench.daq_emulator.faults.fault_at if fault.startswith("daq-") else \
        (when[0] if when else None)
    tripped = [due for due, _ in bench.shaker_emulator.trips]
    if t_fault is None or any(t < t_fault for t in tripped):
        raise FalseTrip(f"{backend} {fault}: stopped before the fault ({error})")
    zero = next((t for t in offs[0] if t >= t_fault), None)
    if zero is None:
        raise AssertionError(f"{backend} {fault}: the drive was never zeroed ({error})")
    due = next((d for d in tripped if d >= t_fault), None) if fault.startswith("shaker-") \
        else None
    return Latency(backend, fault, zero + ESTOP_RAMP - t_fault, error,
                   None if due is None else due + ESTOP_RAMP - t_fault)


def normal_run(backend: str, out: Path, pace: float | None = None) -> tuple[str, int]:
    """A short campaign with default settings, no fault: its status (``complete`` unless a
    timeout tripped) and the shaker watchdog's trips."""
    url = {"serial": "serial-emu://", "can": f"can-emu://virtual/nr-{out.stem}"}[backend]
    if pace is not None:
        url += f"?pace={pace:g}"
    # 0.5 s blocks at 1024 Hz, each spanning six watchdog periods (80 ms) and 16 DAQ frames;
    # the level control accepts 25 % (what is checked is the timing, not the level): a settle
    # block, a measured one and an average per level, and the moments a trip is likeliest
    # (start, level change, end), about 3 s at real-time pace
    doc = campaign_doc(backend, out.stem, daq={"url": url},
                       random={"averages": 1, "block_size": 512, "levels": [5.0, 20.0],
                               "tolerance": 0.25})
    benches = []
    try:
        status = run_campaign(parse_campaign(doc, EXAMPLES), out,
                              on_bench=benches.append).status
    except CommsError as exc:
        status = f"{type(exc).__name__}: {exc}"
    return status, len(benches[0].shaker_emulator.trips)


#: run by ``python -I -S -c``: nothing to import, so it spins within milliseconds of its start
_SPIN = "import os\nos.write(1, b'up')\nwhile True:\n    pass\n"


@contextlib.contextmanager
def cpu_load(processes: int):
    """``processes`` child processes spinning on the CPU while the block runs (synthetic load
    on top of whatever else the machine does), each spinning before the block starts. Bare
    interpreters: a child importing this module (multiprocessing's spawn) spent seconds of a
    loaded machine importing, so the first campaigns ran before the load, and the block's end
    waited for the imports to finish."""
    procs = [subprocess.Popen([sys.executable, "-I", "-S", "-c", _SPIN], stdout=subprocess.PIPE)
             for _ in range(processes)]
    try:
        for p in procs:
            if p.stdout.read(2) != b"up":
                raise RuntimeError("a CPU load process did not start")
        yield
    finally:
        for p in procs:
            p.kill()
            p.wait()
            p.stdout.close()


def false_trips(backend: str, runs: int, folder: Path, load: int) -> list[str]:
    """How ``runs`` healthy campaigns (`normal_run`, default settings) ended under ``load``
    spinning processes: the outcome of each that a timeout or the watchdog stopped."""
    bad = []
    with cpu_load(load):
        for k in range(runs):
            status, trips = normal_run(backend, folder / f"load-{backend}-{k}.h5")
            if (status, trips) != ("complete", 0):
                bad.append(f"{status} ({trips} watchdog trips)")
    return bad
