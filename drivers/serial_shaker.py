"""``serial://`` shaker controller speaking the SCPI-style command set of docs/drivers.md."""

from __future__ import annotations

from .base import Output, RandomOutput, SignalGenerator, SineOutput, check_output
from .errors import CommsError
from .serial_link import SerialLink


class SerialShaker(SignalGenerator):
    """Shaker controller on a serial port.

    Parameters
    ----------
    port : str
        Device path or pyserial URL.
    baud : int
        Baud rate (ignored by pseudo-terminals).
    ramp_time : float
        Seconds over which `stop` ramps the drive down.
    """

    def __init__(self, port: str, baud: int = 115200, *, ramp_time: float = 0.05) -> None:
        self.link = SerialLink(port, baud, what="shaker")
        self.ramp_time = ramp_time
        self.idn = self.link.command("*IDN?", 1.0)

    def configure(self, output: Output, level: float, *, timeout: float = 1.0) -> None:
        self._require("new", "configured", "stopped", action="configure")
        check_output(output)
        level = self.check_level(level)
        if isinstance(output, RandomOutput):
            cmds = [f"SOUR:RAND:SEED {int(output.seed)}"] if output.seed is not None else []
            cmds += [f"SOUR:RAND:BAND {output.band[0]:.9g},{output.band[1]:.9g}",
                     "SOUR:FUNC RAND"]
        else:
            assert isinstance(output, SineOutput)
            cmds = ["SOUR:FUNC SIN", f"SOUR:FREQ {output.freq:.12g}"]
        cmds += [f"SOUR:RAMP {self.ramp_time:.6g}", f"SOUR:VOLT {level:.12g}"]
        for cmd in cmds:
            self.link.command(cmd, timeout)
        self._state = "configured"

    def set_level(self, level: float, *, timeout: float = 1.0) -> None:
        self._require("configured", "running", "stopped", action="set the level")
        self.link.command(f"SOUR:VOLT {self.check_level(level):.12g}", timeout)

    def set_frequency(self, freq: float, *, timeout: float = 1.0) -> None:
        """Change the sine frequency without stopping (phase-continuous)."""
        self._require("configured", "running", "stopped", action="set the frequency")
        check_output(SineOutput(freq))
        self.link.command(f"SOUR:FREQ {freq:.12g}", timeout)

    def start(self, *, timeout: float = 1.0) -> None:
        self._require("configured", "stopped", action="start")
        self.link.command("OUTP ON", timeout)
        self._state = "running"

    def stop(self, *, timeout: float = 1.0) -> None:
        if self._state == "running":
            self.link.command("OUTP OFF", timeout)
            self._state = "stopped"

    def emergency_stop(self, *, timeout: float = 0.1) -> None:
        self.link.command("ABOR", timeout)
        if self._state == "running":
            self._state = "stopped"

    def close(self) -> None:
        if self._state == "closed":
            return
        try:
            self.stop(timeout=0.5)
        except CommsError:
            pass
        finally:
            self.link.close()
            self._state = "closed"
