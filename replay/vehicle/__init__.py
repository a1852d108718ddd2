"""The aircraft of the replay engine: parameters and presets, the 6-DOF model, trim.

- :mod:`replay.vehicle.params` — :class:`VehicleParams` (frozen, validated) and its packed layout;
- :mod:`replay.vehicle.presets` — ``aerosonde`` (default), ``solar-uav``, ``cessna172``,
  ``small-uas`` and :func:`load_vehicle` for names and YAML vehicle files;
- :mod:`replay.vehicle.dynamics` — the 12-state equations of motion in numpy (the reference) and
  :class:`Aircraft`, the system object stepping the compiled RK4 (:mod:`replay.vehicle._kernels`);
- :mod:`replay.vehicle.trim` — steady-flight trim (Beard & McLain ch. 5);
- :mod:`replay.vehicle.multirotor` — a multirotor: :class:`MultirotorParams`, the ``quadrotor``
  preset (:func:`multirotor_preset`), its 16-state model in numpy (the compiled twin:
  :mod:`replay.vehicle._mr_kernels`); its stack is :mod:`replay.multirotor_stack`.

The autopilot that flies it lives in :mod:`replay.autopilot`.
"""

from replay.vehicle._kernels import rk4, step_n
from replay.vehicle.dynamics import DT, Aircraft, air_data, derivatives, rk4_step
from replay.vehicle.params import G, VehicleParams
from replay.vehicle.presets import DEFAULT_VEHICLE, PRESETS, load_vehicle, preset
from replay.vehicle.trim import Trim, trim, trim_range

__all__ = [
    "DEFAULT_VEHICLE",
    "DT",
    "PRESETS",
    "Aircraft",
    "G",
    "Trim",
    "VehicleParams",
    "air_data",
    "derivatives",
    "load_vehicle",
    "preset",
    "rk4",
    "rk4_step",
    "step_n",
    "trim",
    "trim_range",
]
