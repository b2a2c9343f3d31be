"""The CAN DAQ protocol as described by the shipped DBC file ``nlid_daq.dbc``.

Host -> DAQ ``HOST_Control`` (0x100) starts/stops streaming; DAQ -> host ``DAQ_Status``
(0x101) confirms; sample data travel in ``DAQ_Samples<g>`` (0x200 + g): a 16-bit per-sample
counter and two signed 24-bit channels (volts), one frame per group per sample.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import cantools

DBC_PATH = Path(__file__).with_name("nlid_daq.dbc")
CONTROL_ID = 0x100
STATUS_ID = 0x101
SAMPLES_ID = 0x200
MAX_GROUPS = 8
COUNTER_MOD = 1 << 16
STATE_IDLE, STATE_STREAMING, STATE_ERROR = 0, 1, 2


@lru_cache(maxsize=1)
def database() -> cantools.database.can.Database:
    """The protocol's cantools database (loaded once)."""
    return cantools.database.load_file(str(DBC_PATH))


def n_groups(n_channels: int) -> int:
    """Sample messages per scan: two channels per CAN message."""
    return (n_channels + 1) // 2


def volt_scale() -> float:
    """Volts per count of a sample signal (from the DBC)."""
    return database().get_message_by_frame_id(SAMPLES_ID).get_signal_by_name("Ch0").scale


def full_scale_counts() -> int:
    """Largest positive count of a sample signal (from the DBC)."""
    sig = database().get_message_by_frame_id(SAMPLES_ID).get_signal_by_name("Ch0")
    return (1 << (sig.length - 1)) - 1
