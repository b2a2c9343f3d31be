"""Print the outcome table of the fuzz and fault suite (docs/reliability-inputs.md).

Each family runs in a child process that reports every case as it ends, so that a crash
(the process killed by a signal) is counted against its case and the family resumes after
it in a fresh child. Cases are those of tests/fuzz_families.py (derandomized hypothesis
draws: the same on every run).

    python tools/fuzz_table.py [--scale 1.0] [--family NAME] [--seed N]

``--seed N`` draws other cases than the derandomized default (the same again for the same N).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from fuzz_families import FAMILIES, TABLE, Outcome  # noqa: E402

CHILD = """
import json, sys
from pathlib import Path
sys.path[:0] = [{root!r}, {tests!r}]
from fuzz_families import run_family
def report(i, r):
    print(json.dumps([i, r.outcome.value, r.what, r.said]), flush=True)
run_family({name!r}, {n}, Path({folder!r}), skip={skip}, report=report, seed={seed!r})
"""


def run(name: str, n: int, seed: int | None = None) -> tuple[Counter, list]:
    """Outcome counts of family ``name`` over ``n`` cases, and its bad cases."""
    counts, bad, skip = Counter(), [], 0
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen"}
    while skip < n:
        with tempfile.TemporaryDirectory() as folder:
            code = CHILD.format(root=str(ROOT), tests=str(ROOT / "tests"), name=name, n=n,
                                folder=folder, skip=skip, seed=seed)
            proc = subprocess.run([sys.executable, "-c", code], capture_output=True,
                                  text=True, env=env)
        done = [json.loads(ln) for ln in proc.stdout.splitlines() if ln.startswith("[")]
        for i, outcome, what, said in done:
            counts[outcome] += 1
            if outcome == Outcome.ACCEPTED and "(a line end)" in what:
                counts["line-end cuts accepted"] += 1
            if outcome not in (Outcome.ACCEPTED, Outcome.REFUSED):
                bad.append((i, outcome, what, said))
        skip = (done[-1][0] + 1) if done else skip
        if proc.returncode != 0:      # killed (or failed) on case `skip`: a crash
            counts[Outcome.CRASH] += 1
            bad.append((skip, Outcome.CRASH.value, "", proc.stderr.strip()[-300:]))
            skip += 1
        elif len(done) + skip < n and not done:
            break
    return counts, bad


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0, help="fraction of the table's counts")
    ap.add_argument("--family", choices=sorted(FAMILIES))
    ap.add_argument("--seed", type=int, help="draw other cases (default: derandomized)")
    args = ap.parse_args()
    names = [args.family] if args.family else list(FAMILIES)
    head = ["family", "inputs tried"] + [o.value for o in Outcome]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for name in names:
        n = max(1, round(TABLE[name] * args.scale))
        counts, bad = run(name, n, args.seed)
        print("| " + " | ".join([name, str(sum(counts[o.value] for o in Outcome))]
                                + [str(counts[o.value]) for o in Outcome]) + " |", flush=True)
        if counts["line-end cuts accepted"]:
            print(f"    {name}: {counts['line-end cuts accepted']} of the accepted inputs are "
                  "files cut at a line end (undetectable)", file=sys.stderr)
        for case in bad:
            print(f"    {name} case {case[0]}: {case[1]}: {case[2]} -> {case[3]}",
                  file=sys.stderr)


if __name__ == "__main__":
    main()
