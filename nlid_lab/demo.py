"""The built-in demo: a random test of the paper's SDOF system at several force levels.

Steps (one function each, run in order by `run_demo`): load the model, run a random campaign
on the simulated rig (`sim://` shaker and DAQ, level control, every block written as it
arrives) into one HDF5 run file, overlay the H1 FRF of every level (the paper's fig 3.5), estimate the nonlinear
coefficients by reverse path from all levels pooled (paper section 3.3.1: true vs estimated,
95 % intervals, multiple coherence, modes of the underlying linear system; JSON next to the
run and stored in it), and write the HTML report of the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from analysis.detection import Detection, detect
from analysis.errors import InputError
from analysis.models import Element, Model
from analysis.spectral import level_frf

from . import methods, store
from .campaign import parse_campaign, run_campaign
from .methods import ReversePathOptions, reverse_path_estimate, reverse_path_table
from .progress import CampaignProgress
from .reports import load_run, write_report
from .outputs import atomic_dir, atomic_path, write_json

if TYPE_CHECKING:
    from analysis.documents import JsonObject

    from .methods import ReversePathEstimate

MODEL_FILE = Path(__file__).resolve().parents[1] / "examples" / "models" \
    / "sdof-cubic-quaddamp.toml"


@dataclass
class DemoConfig:
    """What the demo does; the defaults run in a few seconds.

    The levels span the nonlinearity: at 0.5 N rms the cubic spring adds well under 0.1 % to
    the stiffness; at 30 N rms the resonance has moved up by several hertz and lost about
    half its height.
    """

    out: Path
    levels: tuple[float, ...] = (0.5, 5.0, 15.0, 30.0)
    fs: float = 1024.0
    duration: float = 128.0
    band: tuple[float, float] = (5.0, 200.0)
    nperseg: int = 8192
    # reverse path needs a resolution well below the resonance's half-power bandwidth
    # (0.8 Hz): 32 s segments (0.03 Hz) cut the leakage bias of the damping estimate from
    # about 0.4 % (8 s segments) to 0.2 %; shorter records use a quarter of their length
    estimate_nperseg: int = 32768
    # the plant's automatic choice (2 substeps at 1024 Hz) is sized for the linear system; at
    # 30 N rms the cubic spring stiffens it and 8 substeps keep the response error ~2e-5
    oversample: int = 8
    noise_std: float = 0.0
    seed: int = 1
    model_file: Path = MODEL_FILE


def step_model(cfg: DemoConfig) -> Model:
    """Load the demo model (examples/models/sdof-cubic-quaddamp.toml)."""
    if not cfg.model_file.exists():
        raise InputError(f"demo model {cfg.model_file} not found; run the demo from a source "
                         "checkout of nlid-lab")
    return Model.load(cfg.model_file)


def _campaign_document(cfg: DemoConfig) -> JsonObject:
    """The demo's random campaign on the in-process simulated rig (`sim://`), as a campaign
    file holds it (`parse_campaign` reads it: the campaign file's own edge)."""
    block = 4096
    return {
        "name": "demo", "kind": "random",
        "plant": {"model": str(cfg.model_file), "seed": cfg.seed, "shaker_gain": 20.0,
                  "noise_std": cfg.noise_std, "oversample": cfg.oversample},
        "shaker": {"url": "sim://", "gain_guess": 20.0},
        "daq": {"url": "sim://", "fs": cfg.fs, "response_kind": "displacement"},
        "channel": [{"name": "F0", "quantity": "force", "dof": 0},
                    {"name": "x0", "quantity": "displacement", "dof": 0}],
        "random": {"levels": list(cfg.levels), "band": list(cfg.band), "block_size": block,
                   "averages": max(1, int(round(cfg.duration * cfg.fs / block)))},
    }


def step_simulate(cfg: DemoConfig, model: Model) -> Path:
    """Run the random campaign on the simulated rig: every level into one HDF5 run file."""

    cfg.out.mkdir(parents=True, exist_ok=True)
    path = cfg.out / "sdof-random.h5"
    path.unlink(missing_ok=True)
    run_campaign(parse_campaign(_campaign_document(cfg), cfg.model_file.parent), path,
                 observer=CampaignProgress())
    return path


@dataclass(frozen=True)
class LevelPeak:
    """One level's resonance as the FRF overlay shows it: the largest |H1| in the band."""

    level_rms: float
    peak_hz: float
    peak_m_per_n: float

    def to_json(self) -> JsonObject:
        """``level_rms``, ``peak_hz``, ``peak_m_per_n``."""
        return {"level_rms": self.level_rms, "peak_hz": self.peak_hz,
                "peak_m_per_n": self.peak_m_per_n}


@dataclass(frozen=True)
class DemoSummary:
    """What the demo did and where its files are (`run_demo`; ``demo --json``).

    Attributes
    ----------
    model, run, frf_png, estimate_json, report_html : Path
        The model file, the run file, the FRF overlay, the estimate's JSON and the report.
    levels : tuple of LevelPeak
        Resonance of each level.
    detection : Detection
        The model-free detection on the stored levels.
    estimate : ReversePathEstimate
        Reverse path on all levels pooled.
    """

    model: Path
    run: Path
    frf_png: Path
    levels: tuple[LevelPeak, ...]
    detection: Detection
    estimate_json: Path
    estimate: ReversePathEstimate
    report_html: Path

    def to_json(self) -> JsonObject:
        """The ``demo --json`` summary: paths, levels, detection, and the estimate's
        ``elements``, ``multiple_coherence`` and ``modal``."""
        est = self.estimate.to_json()
        return {"model": str(self.model), "run": str(self.run), "frf_png": str(self.frf_png),
                "levels": [p.to_json() for p in self.levels],
                "detection": self.detection.to_json(),
                "estimate_json": str(self.estimate_json),
                "estimate": {k: est[k] for k in ("elements", "multiple_coherence", "modal")},
                "report_html": str(self.report_html)}


def step_frf(cfg: DemoConfig, run_path: Path, model: Model) -> tuple[Path, list[LevelPeak]]:
    """H1 FRF of each level, overlaid with the underlying linear FRF, as a PNG."""
    import matplotlib             # the figure backend is chosen here, on use
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt   # after the backend is chosen

    run = store.open_run(run_path)
    fig, ax = plt.subplots(figsize=(8, 5))
    peaks = []
    for i, rec in enumerate(run.recordings()):
        frf = level_frf(rec, i, nperseg=min(cfg.nperseg, rec.force.shape[0] // 4))
        keep = (frf.freqs >= cfg.band[0]) & (frf.freqs <= cfg.band[1])
        freqs, h1 = frf.freqs[keep], np.abs(frf.H[keep, 0, 0])
        peak = freqs[np.argmax(h1)]
        peaks.append(LevelPeak(rec.level, float(peak), float(h1.max())))
        ax.semilogy(freqs, h1, label=f"{rec.level:g} N rms (peak {peak:.1f} Hz)")
    lin = np.abs(model.linear_frf(freqs, [0])[:, 0, 0])
    ax.semilogy(freqs, lin, "k--", lw=1, label="underlying linear")
    fn = float(model.natural_frequencies()[0])
    ax.set_xlim(max(cfg.band[0], fn / 2), min(cfg.band[1], 2 * fn))
    ax.set(xlabel="frequency [Hz]", ylabel="|H1| [m/N]",
           title=f"{model.name}: FRF per force level (paper fig 3.5)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    png = cfg.out / "frf-levels.png"
    with atomic_path(png) as tmp:
        fig.savefig(tmp, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return png, peaks


def step_detect(run_path: Path) -> Detection:
    """Is it nonlinear? The model-free test of ``nlid-lab detect`` on the stored levels."""

    result = detect(store.open_run(run_path).recordings())
    (t,) = result.tests
    print(f"demo: detection (model-free, `nlid-lab detect`): the FRF changes with level beyond "
          f"its noise on {100 * t.share_flagged:.0f} % of the lines (a linear structure: "
          f"~1 %) -> {result.verdict}")
    return result


def step_estimate(cfg: DemoConfig, run_path: Path, model: Model
                  ) -> tuple[Path, ReversePathEstimate]:
    """Reverse path on all levels pooled, as ``nlid-lab analyze reverse-path`` would do it.

    The candidate is the demo model with every element parameter omitted. The result is
    written as JSON next to the run and stored in the run as ``analyze-reverse-path``.
    """

    candidate = model.with_elements([Element(el.kind, el.w.copy(), {})
                                     for el in model.elements])
    recs = store.open_run(run_path).recordings()
    nperseg = min(cfg.estimate_nperseg, min(r.force.shape[0] for r in recs) // 4)
    est = reverse_path_estimate(recs, candidate, ReversePathOptions(nperseg=nperseg))
    out = est.to_json()
    print(reverse_path_table(est.result, est.modal, reference=model))
    path = cfg.out / "reverse-path.json"
    write_json(out, str(path))
    store.save_result(run_path, "analyze-reverse-path", out)
    return path, est


def step_report(cfg: DemoConfig, run_path: Path) -> Path:
    """HTML report of the run (FRFs, coherence, reverse-path figures, stored estimates)."""

    run = load_run(run_path)
    with atomic_dir(cfg.out / "report") as tmp:     # figures and page whole, or none
        write_report(run, tmp, estimators=methods)
    return cfg.out / "report" / "index.html"


def run_demo(cfg: DemoConfig) -> DemoSummary:
    """Run every step, print what was done and where the files are; returns the summary."""
    model = step_model(cfg)
    print(f"demo: random test of '{model.name}' ({cfg.model_file.name}), force on DOF 0, "
          f"band {cfg.band[0]:g}-{cfg.band[1]:g} Hz, levels {', '.join(map(str, cfg.levels))} "
          f"N rms, {cfg.duration:g} s each at {cfg.fs:g} Hz")
    run_path = step_simulate(cfg, model)
    print(f"demo: stored {len(cfg.levels)} levels in run {run_path}")
    png, peaks = step_frf(cfg, run_path, model)
    for p in peaks:
        print(f"demo:   {p.level_rms:g} N rms: resonance at {p.peak_hz:.2f} Hz, "
              f"|H1| peak {p.peak_m_per_n:.3g} m/N")
    print(f"demo: FRF overlay per level -> {png}")
    detection = step_detect(run_path)
    print("demo: reverse path on all levels pooled (paper section 3.3.1)")
    est_path, est = step_estimate(cfg, run_path, model)
    print(f"demo: estimate -> {est_path} (also stored in the run as 'analyze-reverse-path')")
    html = step_report(cfg, run_path)
    print(f"demo: report -> {html}")
    return DemoSummary(cfg.model_file, run_path, png, tuple(peaks), detection, est_path, est,
                       html)
