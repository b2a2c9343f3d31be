"""How much work a simulation asks of the plant, bounded before it starts.

The simulated plant integrates with ``oversample`` substeps per output sample, chosen from the
model's fastest time scale (`analysis.plant.auto_oversample`); a substep costs about the DOFs
plus the elements. A stiff model or a long drive can ask for hours: `simulate` and
`campaign run` say so before starting instead of hanging.
"""

from __future__ import annotations

from analysis.models import Model

MAX_WORK = 1e9  # substeps x (DOFs + elements): a few minutes of the plant at most


def work(model: Model, fs: float, n_samples: int, oversample: int | None = None
         ) -> tuple[float, float]:
    """Plant substeps for ``n_samples`` output samples at ``fs``, and their work."""
    from analysis.plant import auto_oversample   # the plant's kernels load on use
    substeps = float(oversample or auto_oversample(model, fs)) * n_samples
    return substeps, substeps * (model.n_dof + len(model.elements))


def excess(model: Model, fs: float, n_samples: int, oversample: int | None = None
           ) -> str | None:
    """Why simulating ``n_samples`` is beyond `MAX_WORK`, or None."""
    substeps, total = work(model, fs, n_samples, oversample)
    if total <= MAX_WORK:
        return None
    return (f"simulating {n_samples} samples at fs = {fs:g} Hz takes {substeps:.3g} plant "
            f"substeps of a {model.n_dof}-DOF model with {len(model.elements)} elements, more "
            f"than the bound {MAX_WORK:g} substeps x (DOFs + elements)")
