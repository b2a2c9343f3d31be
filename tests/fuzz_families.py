"""The fuzz and fault suite of issue 26 (tests/nlid_lab/test_fuzz_suite.py, the table of
docs/reliability-inputs.md by tools/fuzz_table.py): five families of damaged or malformed
inputs, each case run through the command that reads it and sorted into one `Outcome`.

Every case knows whether its input is damaged (it breaks a documented rule, or it is not the
file it was: cut, bytes replaced). The oracle is the family's own (`fuzz_inputs` mutations
and their documented ranges; a cut that leaves an identical document is not damage).
Cases are drawn by hypothesis (derandomized, bounded), so a run is repeatable and a case
is found again by its index.
"""

from __future__ import annotations

import copy
import json
import tomllib
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import HealthCheck, given, seed as hypothesis_seed, settings, strategies as st

from fuzz_inputs import (CAMPAIGN, MODEL, TimeLimit, bad_arrays, campaign_number_invalid,
                         model_number_invalid, mutations, run_cli, toml_text)

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


class Outcome(StrEnum):
    """What a command made of one input."""

    ACCEPTED = "accepted correctly"
    REFUSED = "exit 2, one line"
    INTERNAL = "internal error"
    CRASH = "crash or hang"
    SILENT = "silent acceptance"


BAD = (Outcome.INTERNAL, Outcome.CRASH, Outcome.SILENT)


@dataclass
class Result:
    """The outcome of one case and what the command said."""

    outcome: Outcome
    said: str
    what: str = ""


def classify(code: int, err: str, damaged: bool) -> Outcome:
    """The outcome of a command that exited ``code`` with ``err`` on stderr."""
    lines = [ln for ln in err.splitlines() if ln.strip() and "compiling numeric" not in ln]
    if "Traceback" in err or code not in (0, 2):
        return Outcome.INTERNAL
    if code == 2:
        return Outcome.REFUSED if len(lines) == 1 else Outcome.INTERNAL
    return Outcome.SILENT if damaged else Outcome.ACCEPTED


def run_classified(argv: list[str], damaged: bool, seconds: float = 60.0) -> Result:
    """Run ``nlid-lab argv`` in this process and classify it (a hang is a crash)."""
    try:
        code, err, _ = run_cli(argv, seconds)
    except TimeLimit:
        return Result(Outcome.CRASH, "no answer")
    except Exception as exc:  # noqa: BLE001 - escaped the CLI's own handler
        return Result(Outcome.INTERNAL, repr(exc))
    return Result(classify(code, err, damaged), f"exit {code}: {err.strip()[-300:]}")


# --- damage to a text file ------------------------------------------------------------------
@st.composite
def text_damage(draw, text: str) -> tuple[bytes, str, Callable[[str], Any] | None]:
    """``text`` with one structural damage: cut, a byte that is not UTF-8, an array nested
    thousands deep. Returns the bytes, the description, and whether it is damaged (a cut
    whose document parses the same, or is invalid TOML anyway, is judged by the parser)."""
    raw = text.encode()
    kind = draw(st.sampled_from(["cut", "byte", "deep", "duplicate"]))
    if kind == "duplicate":          # a key written twice: TOML forbids it
        lines = [ln for ln in text.splitlines(keepends=True) if " = " in ln]
        line = draw(st.sampled_from(lines))
        at = draw(st.integers(0, len(lines)))
        out = "".join(lines[:at] + [line] + lines[at:])
        return out.encode(), f"key {line.split(' = ')[0]} written twice", True
    if kind == "cut":
        at = draw(st.integers(1, len(raw) - 1))
        end = " (a line end)" if b"\n" in raw[at - 1:at + 1] else ""
        return raw[:at], f"cut at byte {at} of {len(raw)}{end}", None
    if kind == "byte":
        at = draw(st.integers(0, len(raw) - 1))
        return raw[:at] + b"\xff" + raw[at + 1:], f"byte {at} = 0xFF", True
    depth = draw(st.sampled_from([40, 1000, 5000]))
    at = raw.index(b"= [") + 2
    return raw[:at] + b"[" * depth + raw[at:].replace(b"]", b"]" * (depth + 1), 1), \
        f"an array nested {depth} deeper", True


def cut_damaged(cut: bytes, whole: str) -> bool:
    """Whether a cut TOML file is damage a reader can see: another document than the whole
    one (or none), cut inside a line. A cut at a line's end leaves a shorter valid document
    (whole lines lost: for a model, maybe its last elements) that nothing in the text tells
    from a file written that way: not counted as damage (docs/reliability-inputs.md)."""
    at_line_end = cut.endswith(b"\n") or whole.encode()[len(cut):len(cut) + 1] == b"\n"
    if at_line_end:
        return False
    try:
        return tomllib.loads(cut.decode()) != tomllib.loads(whole)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError):
        return True


def write_damaged(data: st.DataObject, doc: dict, path: Path) -> tuple[str, bool]:
    """Write ``doc`` as TOML text to ``path`` with damage drawn from `text_damage`; what was
    done and whether a reader must see the damage (a cut: `cut_damaged`)."""
    whole = toml_text(doc)
    raw, what, damaged = data.draw(text_damage(whole))
    damaged = cut_damaged(raw, whole) if damaged is None else damaged
    path.write_bytes(raw)
    return what, damaged


# --- family 1: model files ------------------------------------------------------------------
def model_case(data: st.DataObject, folder: Path) -> Result:
    """A mutated or damaged model file through ``simulate``."""
    drive = folder / "drive.npz"
    if not drive.exists():
        rng = np.random.default_rng(0)
        np.savez(drive, fs=1024.0, force=rng.normal(size=(512, 1)), force_dofs=[1])
    path, out = folder / "m.toml", folder / "out.npz"
    out.unlink(missing_ok=True)
    if data.draw(st.booleans()):
        doc, what, damaged = data.draw(mutations(MODEL, model_number_invalid))
        path.write_text(toml_text(doc))
    else:
        what, damaged = write_damaged(data, MODEL, path)
    result = run_classified(["simulate", str(path), "--drive", str(drive), "--out", str(out)],
                            damaged)
    result.what = what
    return result


# --- family 2: campaign files ---------------------------------------------------------------
FAULT_VALUES = [float("nan"), float("inf"), -1, 2.5, True, 10**9, 0, 5, "x", [1]]


def fault_value_invalid(key: str, value: Any) -> bool:
    """The rule of docs/campaign-format.md for an ``[emulator] faults`` entry."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return True
    if key == "stall_seconds":
        return not value >= 0          # NaN and negatives; inf: for good
    return not (isinstance(value, int) and value >= 0) or (
        key == "garbage_bytes" and value > 1 << 16)


def campaign_case(data: st.DataObject, folder: Path) -> Result:
    """A mutated or damaged campaign file through ``campaign check``."""
    path = folder / "c.toml"
    kind = data.draw(st.sampled_from(["mutation", "fault", "damage"]))
    if kind == "mutation":
        doc, what, damaged = data.draw(mutations(CAMPAIGN, campaign_number_invalid))
        path.write_text(toml_text(doc))
    elif kind == "fault":
        doc = copy.deepcopy(CAMPAIGN)
        key = data.draw(st.sampled_from(["stall_at", "stall_seconds", "disconnect_at",
                                         "drop_every", "garbage_bytes", "seed"]))
        value = data.draw(st.sampled_from(FAULT_VALUES))
        doc["emulator"] = {"faults": {"stall_at": 10, key: value}}
        damaged, what = fault_value_invalid(key, value), f"faults.{key} = {value!r}"
        path.write_text(toml_text(doc))
    else:
        what, damaged = write_damaged(data, CAMPAIGN, path)
    result = run_classified(["campaign", "check", str(path)], damaged, 30.0)
    result.what = what
    return result


# --- family 3: recordings (NPZ, CSV, MAT) ---------------------------------------------------
def _recording(folder: Path) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(1)
    return {"fs": np.float64(1024.0), "force_dofs": np.array([0]),
            "force": rng.normal(size=(1024, 1)),
            "response": 1e-5 * rng.normal(size=(1024, 2)), "force_rms": np.float64(1.0)}


def csv_cut_damaged(text: str, at: int) -> bool:
    """A CSV cut at byte ``at`` is damaged unless the cut falls at a line's end (whole
    lines, or only the last newline, are gone: a shorter recording)."""
    return not (text[at - 1] == "\n" or text[at:at + 1] == "\n")


def recording_case(data: st.DataObject, folder: Path) -> Result:
    """A mutated, cut or damaged NPZ, CSV or MAT recording through ``import``."""
    from nlid_lab import formats as rio
    from scipy.io import savemat

    keys = _recording(folder)
    out = folder / "run.h5"
    out.unlink(missing_ok=True)
    fmt = data.draw(st.sampled_from(["npz", "csv", "mat", "csv dialect", "npz objects",
                                     "mat v7.3"]))
    if fmt in ("csv dialect", "npz objects", "mat v7.3"):
        return _new_recording_case(data, folder, fmt, keys, out)
    argv = ["import", str(folder / f"r.{fmt}"), "--out", str(out)]
    if fmt == "npz":
        key = data.draw(st.sampled_from(sorted(keys)))
        change = data.draw(st.sampled_from(sorted(bad_arrays(keys[key]))))
        keys[key], damaged = bad_arrays(keys[key])[change]
        if key == "force_dofs" and change == "transposed":
            keys[key], damaged = keys[key][None, :], True    # [[0]]: issue 26
        np.savez(folder / "r.npz", **keys)
        what = f"npz {key} {change}"
    elif fmt == "csv":
        path = folder / "r.csv"
        rio.write_csv(path, rio.recording_from_keys(keys, path))
        text = path.read_text()
        if data.draw(st.booleans()):
            at = data.draw(st.integers(len(text) // 2, len(text) - 1))
            damaged = csv_cut_damaged(text, at)
            path.write_text(text[:at])
            what = f"csv cut at {at} of {len(text)}: ...{text[at - 30:at]!r}"
        else:
            lines = text.splitlines(keepends=True)
            row = data.draw(st.integers(len(lines) - 1000, len(lines) - 1))
            cells = lines[row].rstrip("\n").split(",")
            cells[data.draw(st.integers(0, len(cells) - 1))] = data.draw(
                st.sampled_from(["abc", "nan", "inf", "1e300", "", "1+2j", "0x10"]))
            lines[row] = ",".join(cells) + "\n"
            path.write_text("".join(lines))
            damaged, what = True, f"csv row {row} = {lines[row]!r}"
    else:
        mat = {"Force": keys["force"][:, 0], "Acc": keys["response"].T, "Fs": 1024.0}
        name = data.draw(st.sampled_from(sorted(mat)))
        change = data.draw(st.sampled_from(["nan", "text", "empty", "cut", "huge"]))
        damaged, what = True, f"mat {name} {change}"
        if change == "cut":
            savemat(folder / "r.mat", mat)
            raw = (folder / "r.mat").read_bytes()
            at = data.draw(st.integers(1, len(raw) - 1))
            (folder / "r.mat").write_bytes(raw[:at])
            what = f"mat cut at {at} of {len(raw)}"
        else:
            mat[name] = bad_arrays(np.atleast_1d(mat[name]))[change][0]
            savemat(folder / "r.mat", mat)
        argv += ["--map", "force=Force", "response=Acc", "fs=Fs", "force_dofs=0"]
    result = run_classified(argv, damaged)
    result.what = what
    return result


MAT_MAP = ["--map", "force=Force", "response=Acc", "fs=Fs", "force_dofs=0"]
MATLAB_73_HEADER = (b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Fri Nov 27 "
                    b"00:00:00 2026 HDF5 schema 1.00 .").ljust(116) + b"\x00" * 8 + b"\x00\x02IM"


def _same_as_stored(out: Path, keys: dict) -> bool:
    """Whether the run ``out`` holds the recording ``keys`` (to the CSV's printed digits)."""
    from nlid_lab.store import open_run
    rec = open_run(out).recordings()[0]
    return (rec.fs == float(keys["fs"]) and rec.force.shape == keys["force"].shape
            and rec.response.shape == keys["response"].shape
            and np.allclose(rec.force, keys["force"], rtol=1e-9, atol=0)
            and np.allclose(rec.response, keys["response"], rtol=1e-9, atol=0))


def _new_recording_case(data: st.DataObject, folder: Path, fmt: str, keys: dict,
                        out: Path) -> Result:
    """Inputs beyond the first round: a CSV written with a byte-order mark, CRLF line ends,
    semicolons or decimal commas (the same numbers: accepted only if read as written);
    an NPZ holding an object (pickled) array; a MATLAB v7.3 (HDF5) file, whole or cut."""
    from nlid_lab import formats as rio
    import h5py

    if fmt == "csv dialect":
        path = folder / "r.csv"
        rio.write_csv(path, rio.recording_from_keys(keys, path))
        text = path.read_text()
        dialect = data.draw(st.sampled_from(["bom", "crlf", "semicolons", "decimal commas",
                                             "tabs"]))
        text = {"bom": "\ufeff" + text, "crlf": text.replace("\n", "\r\n"),
                "semicolons": text.replace(",", ";"), "tabs": text.replace(",", "\t"),
                "decimal commas": text.replace(",", ";").replace(".", ",")}[dialect]
        path.write_bytes(text.encode())
        result = run_classified(["import", str(path), "--out", str(out)], False)
        what = f"csv with {dialect}"
    elif fmt == "npz objects":
        key = data.draw(st.sampled_from(sorted(keys)))
        keys[key] = np.array([np.asarray(keys[key]), None], dtype=object)
        np.savez(folder / "r.npz", **keys)
        result = run_classified(["import", str(folder / "r.npz"), "--out", str(out)], True)
        what = f"npz {key} an object array"
    else:
        path = folder / "r.mat"
        with h5py.File(path, "w", userblock_size=512) as f:
            f["Force"], f["Acc"], f["Fs"] = keys["force"][:, 0], keys["response"], 1024.0
        with open(path, "r+b") as f:
            f.write(MATLAB_73_HEADER)
        raw = path.read_bytes()
        at = data.draw(st.sampled_from([None, None, 600, 4096, len(raw) // 2, len(raw) - 1]))
        if at is not None:
            path.write_bytes(raw[:at])
        result = run_classified(["import", str(path), "--out", str(out)] + MAT_MAP,
                                at is not None)
        what = "mat v7.3" + (f" cut at {at} of {len(raw)}" if at else "")
    if result.outcome is Outcome.ACCEPTED and not _same_as_stored(out, keys):
        result = Result(Outcome.SILENT, result.said + "; stored other numbers")
    result.what = what
    return result


# --- family 4: serial streams ---------------------------------------------------------------
def stream_case(data: st.DataObject, folder: Path) -> Result:
    """A stream of DAQ frames, damaged by flipped bits, lost or inserted bytes, fed to the
    parser in random chunks. Every frame it returns must be one that was sent, intact, and
    every frame that arrived intact must be returned: accepted correctly when all were,
    refused when damaged frames were dropped (the DAQ counts them by sequence number).
    Silent: a frame that was not sent, or an intact frame lost."""
    from drivers.frame import FrameParser, encode_frame

    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    n_ch, n = int(rng.integers(1, 9)), int(rng.integers(1, 65))
    sent = [encode_frame(k, k * n, rng.normal(size=(n, n_ch)).astype(np.float32))
            for k in range(20)]
    stream = bytearray(b"".join(sent))
    edits = data.draw(st.lists(st.tuples(st.sampled_from(["flip", "drop", "insert"]),
                                         st.integers(0, len(stream) - 1)), max_size=5))
    what = f"{n_ch} ch x {n} samples, edits {edits}"
    for edit, at in edits:
        at = min(at, len(stream) - 1)
        if edit == "flip":
            stream[at] ^= 1 << int(rng.integers(0, 8))
        elif edit == "drop":
            del stream[at]
        else:
            stream[at:at] = rng.integers(0, 256, int(rng.integers(1, 40)), np.uint8).tobytes()
    parser, got = FrameParser(), []
    try:
        pos = 0
        while pos < len(stream):
            step = int(rng.integers(1, 300))
            got += parser.feed(bytes(stream[pos:pos + step]))
            pos += step
    except Exception as exc:  # noqa: BLE001 - the parser must never raise on bytes
        return Result(Outcome.INTERNAL, repr(exc), what)
    said = f"{len(got)} of {len(sent)} frames, {parser.bad_frames} bad, " \
        f"{parser.garbage_bytes} garbage bytes"
    for frame in got:
        ref = sent[frame.seq] if 0 <= frame.seq < len(sent) else None
        if ref is None or encode_frame(frame.seq, frame.first_sample, frame.volts) != ref:
            return Result(Outcome.SILENT, said + f"; frame {frame.seq} was not sent", what)
    intact = sum(f in bytes(stream) for f in sent)
    if len(got) < intact:   # a frame that arrived whole was lost (the DAQ counts the rest
        return Result(Outcome.SILENT, said + f"; {intact} intact", what)  # by sequence)
    return Result(Outcome.REFUSED if len(got) < len(sent) else Outcome.ACCEPTED, said, what)


# --- family 5: device-fault campaigns -------------------------------------------------------
def fault_campaign_case(data: st.DataObject, folder: Path) -> Result:
    """A short serial or CAN campaign on the emulators with injected faults, through
    ``campaign run``. Accepted correctly: complete, every stored block whole, every loss
    counted in the run; refused: a stall or disconnect stops it (exit 1, one line, run
    ``aborted``, data kept) — the device's failure, said; silent: losses not counted."""
    from nlid_lab.store import open_run

    backend = data.draw(st.sampled_from(["serial", "can"]))
    faults = {k: data.draw(st.sampled_from([0, 0, 7, 40, 200]))
              for k in ("drop_every", "duplicate_every", "corrupt_every", "garbage_every")}
    stop = data.draw(st.sampled_from([None, None, "stall_at", "disconnect_at"]))
    if backend == "can":
        faults.pop("corrupt_every")     # a CAN frame has no payload CRC of ours to fail
    if stop:
        faults[stop] = 300
    doc = tomllib.loads((EXAMPLES / "campaign-serial-random.toml").read_text())
    doc["plant"]["model"] = str(EXAMPLES / "models" / "sdof-cubic-quaddamp.toml")
    doc["random"].update(levels=[5.0], averages=2, block_size=1024)
    doc["emulator"] = {"faults": faults}
    doc["daq"]["url"] = ("serial-emu://?pace=16" if backend == "serial"
                         else f"can-emu://virtual/fz{data.draw(st.integers(0, 10**9))}?pace=16")
    path, out = folder / "c.toml", folder / "run.h5"
    path.write_text(toml_text(doc))
    out.unlink(missing_ok=True)
    what = f"{backend} {faults}"
    try:
        code, err, _ = run_cli(["campaign", "run", str(path), "--out", str(out), "-q"], 120)
    except TimeLimit:
        return Result(Outcome.CRASH, "no answer", what)
    said = f"exit {code}: {err.strip()[-300:]}"
    lines = [ln for ln in err.splitlines() if ln.strip()]
    if "Traceback" in err or code not in (0, 1):
        return Result(Outcome.INTERNAL, said, what)
    run = open_run(out) if out.exists() else None
    if code == 1:   # the device failed: one line, the run kept and marked
        ok = len(lines) == 1 and run is not None and run.status == "aborted"
        return Result(Outcome.REFUSED if ok else Outcome.INTERNAL, said, what)
    # frames the DAQ saw missing (by sequence number: tests of the stream family) must be
    # losses of the run; faults configured past the frames a stream reached never happen
    seen = sum(e["lost_frames"] for e in (x.get("data", x) for x in run.log
                                          if x.get("kind") == "daq-stats"))
    whole = all(lv.n_samples == 2 * 1024 for lv in run.levels)
    if not whole or (seen and run.losses["frames"] == 0):
        return Result(Outcome.SILENT, said + f"; losses {run.losses}, DAQ lost {seen}", what)
    return Result(Outcome.ACCEPTED, said + f"; DAQ lost {seen} frames", what)


# --- family 6: damaged run files -----------------------------------------------------------
RUN_BLOCKS, RUN_BLOCK = 6, 512


def _run_file(folder: Path) -> tuple[Path, np.ndarray]:
    """A small complete run (one level of `RUN_BLOCKS` blocks), written once per folder, and
    its force samples."""
    from nlid_lab.store import RunWriter

    path = folder / "whole.h5"
    force = np.random.default_rng(2).normal(size=(RUN_BLOCKS * RUN_BLOCK, 1))
    if not path.exists():
        with RunWriter(folder / "whole.tmp.h5", fs=1024.0, excitation="random",
                       force_dofs=[0], n_dof=2) as w:
            lv = w.level(0, 1.0)
            for b in np.split(force, RUN_BLOCKS):
                lv.append_block(b, 1e-5 * b @ np.ones((1, 2)))
            lv.complete()
        (folder / "whole.tmp.h5").rename(path)
    return path, force


def run_file_case(data: st.DataObject, folder: Path) -> Result:
    """A run file cut at a 4 kB boundary, or with bytes overwritten (one flipped bit, or 64
    bytes of 0xFF), through ``export``. A cut file is damaged. Otherwise accepted correctly
    when the exported samples are the written ones but for the blocks the command named as
    left out; silent when other numbers come out unannounced."""
    import re

    whole, force = _run_file(folder)
    raw = bytearray(whole.read_bytes())
    path, out = folder / "run.h5", folder / "out.npz"
    out.unlink(missing_ok=True)
    kind = data.draw(st.sampled_from(["cut", "bit", "0xFF x 64"]))
    if kind == "cut":
        at = 4096 * data.draw(st.integers(1, (len(raw) - 1) // 4096))
        raw, what = raw[:at], f"cut at {at} of {len(raw)}"
    else:
        at = data.draw(st.integers(0, len(raw) - 1))
        if kind == "bit":
            raw[at] ^= 1 << data.draw(st.integers(0, 7))
        else:
            raw[at:at + 64] = b"\xff" * len(raw[at:at + 64])
        what = f"{kind} at byte {at} of {len(raw)}"
    path.write_bytes(bytes(raw))
    result = run_classified(["export", str(path), "--out", str(out)], kind == "cut")
    result.what = what
    if result.outcome is not Outcome.ACCEPTED:
        return result
    err = result.said
    dropped = {int(b) for b in re.findall(r"level 0 block (\d+)", err)}
    kept = np.concatenate([b for i, b in enumerate(np.split(force, RUN_BLOCKS))
                           if i not in dropped])
    got = np.load(out)["force"]
    if got.shape != kept.shape or not np.array_equal(got, kept):
        return Result(Outcome.SILENT, err + "; exported other samples", what)
    return result


FAMILIES: dict[str, Callable[[st.DataObject, Path], Result]] = {
    "model files": model_case, "campaign files": campaign_case,
    "recordings (NPZ, CSV, MAT)": recording_case, "serial streams": stream_case,
    "device-fault campaigns": fault_campaign_case, "run files (HDF5)": run_file_case}

#: cases per family: a few in the fast suite, the table's counts in the slow one
FAST = {"model files": 30, "campaign files": 30, "recordings (NPZ, CSV, MAT)": 30,
        "serial streams": 200, "device-fault campaigns": 2, "run files (HDF5)": 20}
TABLE = {"model files": 300, "campaign files": 300, "recordings (NPZ, CSV, MAT)": 300,
         "serial streams": 3000, "device-fault campaigns": 30, "run files (HDF5)": 200}


@dataclass
class Tally:
    """Outcome counts of a family, and the cases that ended badly (index, outcome, input,
    what the command said)."""

    counts: Counter
    bad: list[tuple[int, str, str, str]]


def run_family(name: str, n: int, folder: Path, skip: int = 0,
               report: Callable[[int, Result], None] | None = None,
               seed: int | None = None) -> Tally:
    """Draw ``n`` cases of family ``name`` (the first ``skip`` drawn, not run) and classify
    each; ``report(index, outcome)`` hears of every case as it ends. Without ``seed`` the
    draws are derandomized (the same cases on every run); a ``seed`` draws other cases,
    the same again for the same seed."""
    tally = Tally(Counter(), [])
    index = [0]
    case = FAMILIES[name]

    @settings(max_examples=n, deadline=None, database=None, derandomize=seed is None,
              suppress_health_check=list(HealthCheck))
    @given(data=st.data())
    def one(data: st.DataObject) -> None:
        i = index[0]
        index[0] += 1
        if i < skip:
            return
        result = case(data, folder)
        tally.counts[result.outcome] += 1
        if result.outcome in BAD:
            tally.bad.append((i, result.outcome.value, result.what, result.said))
        if report is not None:
            report(i, result)

    (one if seed is None else hypothesis_seed(seed)(one))()
    return tally


def as_json(tally: Tally) -> str:
    """A tally as one JSON line."""
    return json.dumps({"counts": {k.value: v for k, v in tally.counts.items()},
                       "bad": tally.bad})
