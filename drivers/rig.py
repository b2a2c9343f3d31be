"""`SimRig`: the simulated test rig shared by the sim backend and the device emulators.

One rig is one loop through the structure: the shaker side sets the drive waveform, level and
output state; the DAQ side advances time and reads force and responses. Time advances only
when the DAQ side asks for samples, so a rig driven with the same commands and seed produces
the same sample stream whatever the frame size or transport (sim, serial, CAN).

The response channels are anti-aliased like a DAQ's (`analysis.plant._plant`, Sensor sampling): the
folded images of the held drive are removed with the drive's next ``HOLD_IMAGE_LOOKAHEAD``
samples, generated ahead with the commands in force (exact unless a command changes the drive
within that lookahead, where the small image term follows the predicted drive).
"""

from __future__ import annotations

import copy
import threading
import time
from dataclasses import dataclass

import numpy as np

from analysis.plant import Plant, hold_image_response
from analysis.models import Model
from analysis.recordings import HOLD_IMAGE_LOOKAHEAD, RESPONSE_KINDS

from .base import Channel
from .errors import DriverConfigError
from .outputs import Output, Player, check_output

WARM_VOLTS = (0.1, 1.0, 3.0)  # drive rms of the warm-up, V (`SimRig._warm_up`)


@dataclass
class RigSamples:
    """Samples of one `SimRig.advance` call."""

    first_sample: int
    force: np.ndarray          # (n, n_in), N
    displacement: np.ndarray   # (n, n_dof)
    velocity: np.ndarray
    acceleration: np.ndarray
    response: np.ndarray       # plant response (noise included), (n, n_dof)
    response_kind: str

    def channel(self, ch: Channel, force_dofs: list[int]) -> np.ndarray:
        """Values (physical units) seen by one channel."""
        if ch.quantity == "force":
            if ch.dof not in force_dofs:
                raise DriverConfigError(f"channel '{ch.name}': no shaker at DOF {ch.dof}; "
                                        f"force DOFs are {force_dofs}")
            return self.force[:, force_dofs.index(ch.dof)]
        if ch.dof >= self.displacement.shape[1]:
            raise DriverConfigError(f"channel '{ch.name}': DOF {ch.dof} outside the model's "
                                    f"0..{self.displacement.shape[1] - 1}")
        src = self.response if ch.quantity == self.response_kind else getattr(self, ch.quantity)
        return src[:, ch.dof]

    def values(self, channels: list[Channel], force_dofs: list[int]) -> np.ndarray:
        """(n, n_channels) values in physical units."""
        return np.column_stack([self.channel(c, force_dofs) for c in channels])

    def volts(self, channels: list[Channel], force_dofs: list[int]) -> np.ndarray:
        """(n, n_channels) sensor voltages."""
        return self.values(channels, force_dofs) * [c.sensitivity for c in channels]


class SimRig:
    """Simulated shaker + structure + sensors.

    Parameters
    ----------
    model : Model
        Complete structural model (every element parameter known).
    fs : float
        Sample rate, Hz.
    force_dof : int
        DOF the shaker drives.
    shaker_gain : float
        Force per drive volt, N/V (an ideal shaker: no force drop-out).
    noise_std, response_kind, seed, oversample
        Passed to `analysis.plant.Plant`; ``seed`` also seeds the random drive.
    """

    def __init__(self, model: Model, fs: float, force_dof: int = 0, *,
                 shaker_gain: float = 1.0, noise_std: float = 0.0,
                 response_kind: str = "displacement", seed: int | None = None,
                 oversample: int | None = None) -> None:
        model.require_complete("the simulated rig")
        if not 0 <= force_dof < model.n_dof:
            raise DriverConfigError(f"force DOF {force_dof} outside the model's "
                                    f"0..{model.n_dof - 1}")
        if not shaker_gain > 0:
            raise DriverConfigError(f"shaker_gain must be > 0 N/V, got {shaker_gain}")
        self.model = model
        self.fs = float(fs)
        self.force_dofs = [int(force_dof)]
        self.shaker_gain = float(shaker_gain)
        self.response_kind = response_kind
        self.seed = seed
        self.plant = Plant(model, self.fs, self.force_dofs, oversample=oversample,
                           noise_std=noise_std, response_kind=response_kind, seed=seed)
        self.lock = threading.RLock()
        self._output: Output | None = None
        self._player: Player | None = None
        self._last: dict[type, Player] = {}   # the last player of each output type
        self._level = 0.0
        self._on = False
        self._envelope = 0.0
        self._ramp_per_sample = 1.0
        self.sample_index = 0
        self.zero_commanded_at: float | None = None
        self._past_force = np.zeros((HOLD_IMAGE_LOOKAHEAD, 1))   # before the start: at rest
        self._warm_up()
        self.sample_index = 0
        self._past_force = np.zeros((HOLD_IMAGE_LOOKAHEAD, 1))

    def _warm_up(self) -> None:
        """Load the integrator, discretise it for the substeps drives up to `WARM_VOLTS` ask
        and build the hold-image filters now, not mid-stream: each costs 20-130 ms on a
        loaded machine with the GIL held, long enough for an emulated DAQ to look stalled
        and a watchdog to go unfed. Kernels stay cached; the state is reset."""
        rng = np.random.default_rng(0)
        for volts in WARM_VOLTS:
            self.plant.run(volts * self.shaker_gain * rng.standard_normal((256, 1)))
        self.plant.reset()
        self.advance(4)
        self.plant.reset()

    # --- shaker side ---------------------------------------------------------------------
    def set_output(self, output: Output) -> None:
        """Set the waveform the shaker drives (takes effect at once, state carried).

        Raises
        ------
        DriverConfigError
            An output this sample rate cannot produce.
        """
        check_output(output, self.fs)
        player = output.player(self.fs, self.seed)     # its samples made outside the lock
        with self.lock:      # the last player stands still while the new one takes it over
            player.resume(self._last.get(type(output)))
            self._output, self._player = output, player
            self._last[type(output)] = player

    def set_level(self, level: float) -> None:
        """Set the drive level, V."""
        with self.lock:
            self._level = float(level)

    def set_on(self, on: bool, ramp_time: float) -> None:
        """Switch the output; the envelope ramps linearly over ``ramp_time`` seconds."""
        with self.lock:
            if on and self._output is None:
                raise DriverConfigError("no waveform configured; configure the shaker first")
            self._on = bool(on)
            self._ramp_per_sample = 1.0 / max(ramp_time * self.fs, 1.0)
            if not on:
                self.zero_commanded_at = time.monotonic()

    @property
    def level(self) -> float:
        """The drive level, V."""
        return self._level

    @property
    def drive_is_zero(self) -> bool:
        """Whether the output is off and its ramp has reached zero."""
        with self.lock:
            return not self._on and self._envelope == 0.0

    def check_channels(self, channels: list[Channel]) -> None:
        """Raise `DriverConfigError` if a channel measures something the rig lacks."""
        for ch in channels:
            if ch.quantity == "force" and ch.dof not in self.force_dofs:
                raise DriverConfigError(f"channel '{ch.name}': no shaker at DOF {ch.dof}; "
                                        f"the shaker drives DOF {self.force_dofs[0]}")
            if ch.dof >= self.model.n_dof:
                raise DriverConfigError(f"channel '{ch.name}': DOF {ch.dof} outside the "
                                        f"model's 0..{self.model.n_dof - 1}")

    # --- DAQ side ------------------------------------------------------------------------
    def advance(self, n: int) -> RigSamples:
        """Run the loop for ``n`` samples and return what the sensors see."""
        with self.lock:
            first = self.sample_index
            drive = self._drive(n)
            force = (self.shaker_gain * drive)[:, None]
            out = self.plant.run(force)
            ahead = (self.shaker_gain * self._peek(HOLD_IMAGE_LOOKAHEAD))[:, None]
            context = np.concatenate([self._past_force, force, ahead])
            self._past_force = context[-2 * HOLD_IMAGE_LOOKAHEAD:-HOLD_IMAGE_LOOKAHEAD]
            self.sample_index += n
        fs, gains = self.fs, self.plant.image_gains
        kinds = {k: getattr(out, k) - hold_image_response(context, fs, k, gains)
                 for k in RESPONSE_KINDS}
        response = out.response - hold_image_response(context, fs, self.response_kind, gains)
        return RigSamples(first, force, kinds["displacement"], kinds["velocity"],
                          kinds["acceleration"], response, self.response_kind)

    def _peek(self, n: int) -> np.ndarray:
        """The next ``n`` drive samples if no command changes them; the drive state is kept."""
        envelope, player = self._envelope, self._player
        self._player = copy.copy(player)
        wave = self._drive(n)
        self._envelope, self._player = envelope, player
        return wave

    def _drive(self, n: int) -> np.ndarray:
        env = self._envelope_samples(n)
        if self._player is None or not np.any(env):
            if self._player is not None:
                self._player.idle(n)
            return np.zeros(n)
        return self._level * env * self._player.play(n)

    def _envelope_samples(self, n: int) -> np.ndarray:
        step = self._ramp_per_sample if self._on else -self._ramp_per_sample
        env = np.clip(self._envelope + step * np.arange(1, n + 1), 0.0, 1.0)
        self._envelope = float(env[-1])
        return env
