"""What LeRobot's Robot and Teleoperator interfaces ask of a device that lives in this process.

Nothing to calibrate or configure; "connected" is a flag that ``connect`` sets and ``disconnect``
clears. Mixed in before LeRobot's base class: ``class ForceMapSim(SimulatedDevice, Robot)``.
"""

from __future__ import annotations


class SimulatedDevice:
    _connected = False

    @property
    def is_connected(self) -> bool:
        return self._connected

    @property
    def is_calibrated(self) -> bool:
        return True

    def connect(self, calibrate: bool = True) -> None:
        self._connected = True

    def calibrate(self) -> None:
        """Nothing to calibrate in simulation."""

    def configure(self) -> None:
        """Nothing to configure in simulation."""

    def disconnect(self) -> None:
        self._connected = False
